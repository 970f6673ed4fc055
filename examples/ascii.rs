/*!
 * Modbus ASCII (feature `ascii`) at 9600 bps 7E1, the serial-line spec's default character
 * format for ASCII: frames of hex characters from `:` to CR LF, checked by their LRC,
 * for masters, PLC ports and modem links that speak only ASCII.
 *
 * Wiring:
 * - pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND;
 * - LEDs with 220 Ω resistors to GND on pins 2, 3, 4, 5;
 * - push buttons or switches from pins 6, 7, 8, 9 to GND (internal pull-ups);
 * - potentiometers (10 kΩ) between 5 V and GND, wipers on A0 and A1.
 *
 * Serial line: slave id 1, 9600 bps, 7 data bits, even parity, 1 stop bit (7E1), ASCII;
 * a frame inside which the line stays silent for 1 s is dropped.
 *
 * | reference   | address | meaning                                                     |
 * |-------------|---------|-------------------------------------------------------------|
 * | 00001–00004 | 0–3     | LEDs on pins 2–5                                            |
 * | 10001–10004 | 0–3     | switches on pins 6–9, 1 while closed                        |
 * | 30001–30002 | 0–1     | A0, A1: 0–1023 for 0–5 V                                    |
 * | 30003–30009 | 2–8     | the slave's counters: frames, LRC errors, parity/framing    |
 * |             |         | errors, overruns and overlong frames, malformed (bad hex,   |
 * |             |         | odd count, too short, timeout), exceptions, replies         |
 * | 40001–40008 | 0–7     | setpoints kept for the master                               |
 *
 * QModMaster can't poll it (libmodbus speaks RTU and TCP, not ASCII). In a master's terms:
 * Read Coils (0x01) from 0, 4 coils; Read Discrete Inputs (0x02) 0, 4; Read Input
 * Registers (0x04) 0, 9; Read Holding Registers (0x03) 0, 8.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Adc, Pins};
use avr_modbus::{Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::ascii(1, 9600, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// The table above.
    struct Registers { 1..=4, 10001..=10004, 30001..=30009, 40001..=40008 }
}

avr_modbus::slave!(SLAVE: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let (pins, mut adc) = match (Pins::new(dp.PORTB, dp.PORTC, dp.PORTD), Adc::new(dp.ADC)) {
        (Ok(pins), Ok(adc)) => (pins, adc),
        (Err(error), _) | (_, Err(error)) => board::halt(error),
    };
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, Registers::new()) {
        board::halt(error);
    }

    let mut leds = [pins.d2.into_output(), pins.d3.into_output(), pins.d4.into_output(), pins.d5.into_output()];
    let switches = [
        pins.d6.into_pull_up_input(),
        pins.d7.into_pull_up_input(),
        pins.d8.into_pull_up_input(),
        pins.d9.into_pull_up_input(),
    ];
    let _pots = [pins.a0.into_floating_input(), pins.a1.into_floating_input()];

    loop {
        for (input, switch) in (10001..).zip(switches.iter()) {
            let _ = SLAVE.set(input, u16::from(!switch.is_high()));
        }
        for (register, channel) in (30001..).zip(0..2) {
            let _ = SLAVE.set(register, adc.read(channel));
        }
        let c = SLAVE.counters();
        let counters = [c.frames, c.crc_errors, c.uart_errors, c.overruns, c.malformed, c.exceptions, c.replies];
        for (register, value) in (30003..).zip(counters) {
            let _ = SLAVE.set(register, value);
        }
        for (coil, led) in (1..).zip(leds.iter_mut()) {
            led.set(SLAVE.get(coil).unwrap_or(0) != 0);
        }
    }
}
