//! The 10-bit ADC on A0–A5, ATmega328P datasheet §24: AVCC reference, clk/128
//! (125 kHz), one blocking conversion of about 104 µs per read.

use avr_device::atmega328p::ADC;

const REFS_AVCC: u8 = 0b01 << 6;
const ADEN: u8 = 1 << 7;
const ADSC: u8 = 1 << 6;
const ADPS_128: u8 = 0b111;

/// The ADC, reading one channel at a time.
pub struct Adc {
    regs: ADC,
}

impl Adc {
    /// Enables the ADC with AVCC (5 V on the Uno) as reference.
    pub fn new(regs: ADC) -> Self {
        // SAFETY: enable bit and prescaler bits of ADCSRA.
        regs.adcsra().write(|w| unsafe { w.bits(ADEN | ADPS_128) });
        Adc { regs }
    }

    /// Converts channel 0–5 (A0–A5; higher channels are masked to 0–7): 0–1023 for
    /// 0 V–AVCC. Interrupts keep running while it waits.
    pub fn read(&mut self, channel: u8) -> u16 {
        // SAFETY: reference selection and a channel number in ADMUX; start bit in ADCSRA.
        unsafe {
            self.regs.admux().write(|w| w.bits(REFS_AVCC | (channel & 0x07)));
            self.regs.adcsra().write(|w| w.bits(ADEN | ADSC | ADPS_128));
        }
        while self.regs.adcsra().read().bits() & ADSC != 0 {}
        self.regs.adc().read().bits()
    }
}
