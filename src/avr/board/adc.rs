//! The 10-bit ADC on A0–A5, ATmega328P datasheet §24: AVCC reference, clk/128
//! (125 kHz), one blocking conversion of about 104 µs per read.

use core::ops::Deref;

use super::super::reg::{self, claim, ADCH, ADCL, ADCSRA, ADMUX};
use crate::error::Error;

const REFS_AVCC: u8 = 0b01 << 6;
const ADEN: u8 = 1 << 7;
const ADSC: u8 = 1 << 6;
const ADPS_128: u8 = 0b111;

/// The ADC, reading one channel at a time.
pub struct Adc(());

impl Adc {
    /// Takes the ADC from the application's PAC (`dp.ADC`) and enables it with AVCC (5 V
    /// on the Uno) as reference.
    pub fn new<P: Deref>(adc: P) -> Result<Self, Error>
    where
        P::Target: Sized,
    {
        claim::<_, { reg::ADC.1 }>(adc, reg::ADC.0)?;
        ADCSRA.write(ADEN | ADPS_128);
        Ok(Adc(()))
    }

    /// Converts channel 0–5 (A0–A5; higher channels are masked to 0–7): 0–1023 for
    /// 0 V–AVCC. Interrupts keep running while it waits.
    pub fn read(&mut self, channel: u8) -> u16 {
        ADMUX.write(REFS_AVCC | (channel & 0x07));
        ADCSRA.write(ADEN | ADSC | ADPS_128);
        while ADCSRA.read() & ADSC != 0 {}
        // ADCL first: reading it locks ADCH until ADCH is read.
        let low = ADCL.read();
        u16::from_le_bytes([low, ADCH.read()])
    }
}
