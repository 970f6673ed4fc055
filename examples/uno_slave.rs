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
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 00001–00005 | Read Coils (0x01); write: 0x05, 0x0f               | 0             | 5      |
 * | 10001–10004 | Read Discrete Inputs (0x02)                        | 0             | 4      |
 * | 30001–30012 | Read Input Registers (0x04)                        | 0             | 12     |
 * | 40001–40010 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 10     |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Adc, Pins};
use avr_modbus::{millis, Config, Error, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// The table above.
    struct Registers { 1..=5, 10001..=10004, 30001..=30012, 40001..=40010 }
}

avr_modbus::slave!(SLAVE: Registers);

fn registers() -> Result<Registers, Error> {
    let mut bank = Registers::new();
    bank.set(40001, 500)?;
    bank.set(40002, 512)?;
    Ok(bank)
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let (pins, mut adc) = match (Pins::new(dp.PORTB, dp.PORTC, dp.PORTD), Adc::new(dp.ADC)) {
        (Ok(pins), Ok(adc)) => (pins, adc),
        (Err(error), _) | (_, Err(error)) => board::halt(error),
    };
    if let Err(error) = registers().and_then(|bank| SLAVE.start(CONFIG, dp.USART0, dp.TC0, bank)) {
        board::halt(error);
    }

    let mut led13 = pins.d13.into_output();
    let mut leds = [pins.d2.into_output(), pins.d3.into_output(), pins.d4.into_output(), pins.d5.into_output()];
    let switches = [
        pins.d6.into_pull_up_input(),
        pins.d7.into_pull_up_input(),
        pins.d8.into_pull_up_input(),
        pins.d9.into_pull_up_input(),
    ];
    let _pots = [pins.a0.into_floating_input(), pins.a1.into_floating_input(), pins.a2.into_floating_input()];

    let (mut blink_start, mut blink_on) = (millis(), true);
    // Whole seconds counted from millis() by subtraction: no 32-bit division (1.2 KB).
    let (mut second_start, mut uptime_s) = (0u32, 0u16);
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
        while millis().wrapping_sub(second_start) >= 1000 {
            second_start = second_start.wrapping_add(1000);
            uptime_s = uptime_s.wrapping_add(1);
        }
        let _ = SLAVE.set(30004, uptime_s);

        for (coil, led) in (2..).zip(leds.iter_mut()) {
            led.set(SLAVE.get(coil).unwrap_or(0) != 0);
        }
        let half_period = u32::from(SLAVE.get(40001).unwrap_or(0));
        if half_period == 0 {
            blink_on = true;
        } else if millis().wrapping_sub(blink_start) >= half_period {
            blink_start = millis();
            blink_on = !blink_on;
        }
        led13.set(SLAVE.get(1).unwrap_or(0) != 0 && blink_on);
    }
}
