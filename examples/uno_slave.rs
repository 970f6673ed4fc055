/*!
 * The classic Uno demo: LEDs follow coils, switches are discrete inputs, potentiometers
 * are input registers, setpoints live in holding registers.
 *
 * Wiring:
 * - pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND;
 * - LEDs with 220 Ω resistors to GND on pins 2, 3, 4, 5 (pin 13 is the on-board LED "L");
 * - push buttons or switches from pins 6, 7, 8, 9 to GND (internal pull-ups);
 * - potentiometers (10 kΩ) between 5 V and GND, wipers on A0, A1, A2.
 *
 * Serial line: slave id 1, 19200 bps, 8E1.
 *
 * | reference   | address | meaning                                                        |
 * |-------------|---------|----------------------------------------------------------------|
 * | 00001       | 0       | LED on pin 13: on/off; blinks if 40001 is non-zero             |
 * | 00002–00005 | 1–4     | LEDs on pins 2–5                                               |
 * | 10001–10004 | 0–3     | switches on pins 6–9, 1 while closed                           |
 * | 30001–30003 | 0–2     | A0–A2, 0–1023 for 0–5 V                                        |
 * | 30004       | 3       | seconds since start-up (wraps at 65535)                        |
 * | 30005       | 4       | 1 while A0 is above the threshold 40002                        |
 * | 30006–30012 | 5–11    | the slave's counters: frames, CRC errors, parity/framing errors, |
 * |             |         | overruns (lost or >256-byte), malformed, exceptions, replies   |
 * | 40001       | 0       | blink half-period of pin 13 in ms (0 = steady), default 500    |
 * | 40002       | 1       | A0 threshold for 30005, default 512                            |
 * | 40003–40010 | 2–9     | setpoints kept for the master                                  |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus_slave::avr::{Adc, ModbusSlave, Pins};
use avr_modbus_slave::{bit_bytes, Bank, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// Timer1 at clk/1024: one tick is 64 µs, 15625 ticks a second.
const TICKS_PER_SECOND: u16 = 15_625;

type UnoBank = Bank<4, 22, { bit_bytes(9) }>;

avr_modbus_slave::modbus_slave!(SLAVE: UnoBank);

/// Milliseconds to Timer1 ticks (×1000/64 = ×125/8), saturating at 4 s.
fn ms_to_ticks(ms: u16) -> u16 {
    ((u32::from(ms) * 125) >> 3).min(u32::from(u16::MAX)) as u16
}

#[avr_device::entry]
fn main() -> ! {
    // SAFETY: the only place that takes the peripherals, and it runs once.
    #[allow(unsafe_code)]
    let dp = unsafe { avr_device::atmega328p::Peripherals::steal() };
    let pins = Pins::new(dp.PORTB, dp.PORTC, dp.PORTD);
    let mut adc = Adc::new(dp.ADC);
    // Timer1 free-running at clk/1024 as the sketch's clock (Timer0 belongs to the slave).
    // SAFETY: clock-select bits CS12 and CS10 of TCCR1B; normal mode.
    #[allow(unsafe_code)]
    dp.TC1.tccr1b().write(|w| unsafe { w.bits(0b101) });
    let now = || dp.TC1.tcnt1().read().bits();

    let mut bank = UnoBank::new();
    let _ = bank.add_range(1, 5);
    let _ = bank.add_range(10001, 4);
    let _ = bank.add_range(30001, 12);
    let _ = bank.add_range(40001, 10);
    let _ = bank.set(40001, 500);
    let _ = bank.set(40002, 512);
    SLAVE.start(ModbusSlave::new(CONFIG, dp.USART0, dp.TC0, bank));
    // SAFETY: the slave is in its cell; its interrupt handlers may run from here on.
    #[allow(unsafe_code)]
    unsafe {
        avr_device::interrupt::enable()
    };

    let mut led13 = pins.d13.into_output();
    let mut leds = [pins.d2.into_output(), pins.d3.into_output(), pins.d4.into_output(), pins.d5.into_output()];
    let switches = [
        pins.d6.into_pull_up_input(),
        pins.d7.into_pull_up_input(),
        pins.d8.into_pull_up_input(),
        pins.d9.into_pull_up_input(),
    ];
    let _pots = [pins.a0.into_floating_input(), pins.a1.into_floating_input(), pins.a2.into_floating_input()];

    let (mut second_start, mut seconds) = (now(), 0u16);
    let (mut blink_start, mut blink_on) = (now(), true);
    loop {
        for (input, switch) in (10001..).zip(switches.iter()) {
            let _ = SLAVE.set(input, u16::from(!switch.is_high()));
        }
        for (register, channel) in (30001..).zip(0..3) {
            let _ = SLAVE.set(register, adc.read(channel));
        }
        let threshold = SLAVE.get(40002).unwrap_or(512);
        let _ = SLAVE.set(30005, u16::from(SLAVE.get(30001).unwrap_or(0) > threshold));

        let c = SLAVE.counters();
        let counters = [c.frames, c.crc_errors, c.uart_errors, c.overruns, c.malformed, c.exceptions, c.replies];
        for (register, value) in (30006..).zip(counters) {
            let _ = SLAVE.set(register, value);
        }

        if now().wrapping_sub(second_start) >= TICKS_PER_SECOND {
            second_start = second_start.wrapping_add(TICKS_PER_SECOND);
            seconds = seconds.wrapping_add(1);
            let _ = SLAVE.set(30004, seconds);
        }

        for (coil, led) in (2..).zip(leds.iter_mut()) {
            led.set(SLAVE.get(coil).unwrap_or(0) != 0);
        }
        let half_period = ms_to_ticks(SLAVE.get(40001).unwrap_or(0));
        if half_period == 0 {
            blink_on = true;
        } else if now().wrapping_sub(blink_start) >= half_period {
            blink_start = now();
            blink_on = !blink_on;
        }
        led13.set(SLAVE.get(1).unwrap_or(0) != 0 && blink_on);
    }
}
