/*!
 * Line settings from a DIP switch, read once at start-up, as many field devices do: three
 * switches pick one of eight presets, all computed at build time.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND; a
 * 3-way DIP switch from pins 10, 11, 12 to GND (closed = 1; pin 10 is the low bit).
 * Change the switches with the Uno powered off, or press reset afterwards.
 *
 * Built with feature `millis`: nothing here reads the clock, but it runs, so that
 * `tests/sim_clock.rs` checks `millis()` at every preset's rate.
 *
 * | 12 11 10 | preset        |   | 12 11 10 | preset        |
 * |----------|---------------|---|----------|---------------|
 * | 0  0  0  | 19200 8E1     |   | 1  0  0  | 115200 8N1    |
 * | 0  0  1  | 9600 8E1      |   | 1  0  1  | 9600 8N1      |
 * | 0  1  0  | 19200 8N2     |   | 1  1  0  | 115200 8E1    |
 * | 0  1  1  | 19200 8O1     |   | 1  1  1  | 1200 8E1      |
 *
 * Slave id 1. Registers:
 *
 * | reference   | address | meaning                                   |
 * |-------------|---------|-------------------------------------------|
 * | 00001–00016 | 0–15    | coils kept for the master                 |
 * | 10001–10003 | 0–2     | the DIP switch as read at start-up        |
 * | 30001       | 0       | preset number 0–7                         |
 * | 40001–40010 | 0–9     | holding registers kept for the master     |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 00001–00016 | Read Coils (0x01); write: 0x05, 0x0f               | 0             | 16     |
 * | 10001–10003 | Read Discrete Inputs (0x02)                        | 0             | 3      |
 * | 30001       | Read Input Registers (0x04)                        | 0             | 1      |
 * | 40001–40010 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 10     |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pins};
use avr_modbus::{Config, Error, Parity, StopBits};
use panic_halt as _;

const PRESETS: [Config; 8] = [
    Config::new(1, 19_200, Parity::Even, StopBits::One),
    Config::new(1, 9_600, Parity::Even, StopBits::One),
    Config::new(1, 19_200, Parity::None, StopBits::Two),
    Config::new(1, 19_200, Parity::Odd, StopBits::One),
    Config::new(1, 115_200, Parity::None, StopBits::One),
    Config::new(1, 9_600, Parity::None, StopBits::One),
    Config::new(1, 115_200, Parity::Even, StopBits::One),
    Config::new(1, 1_200, Parity::Even, StopBits::One),
];

avr_modbus::register_map! {
    /// The table above.
    struct Registers { 1..=16, 10001..=10003, 30001, 40001..=40010 }
}

avr_modbus::slave!(SLAVE: Registers);

fn start(dp: avr_device::atmega328p::Peripherals) -> Result<(), Error> {
    let pins = Pins::new(dp.PORTB, dp.PORTC, dp.PORTD)?;
    let switches = [pins.d10.into_pull_up_input(), pins.d11.into_pull_up_input(), pins.d12.into_pull_up_input()];
    // Let the pull-ups charge the pins before reading them.
    avr_device::asm::delay_cycles(1_000);
    let closed = switches.map(|s| !s.is_high());
    let preset = closed.iter().rev().fold(0usize, |n, &on| (n << 1) | usize::from(on));

    let mut bank = Registers::new();
    for (input, on) in (10001..).zip(closed) {
        bank.set(input, u16::from(on))?;
    }
    bank.set(30001, preset as u16)?;
    let config = PRESETS.get(preset).copied().unwrap_or(PRESETS[0]);
    SLAVE.start(config, dp.USART0, dp.TC0, bank)
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = start(dp) {
        board::halt(error);
    }
    loop {
        avr_device::asm::sleep();
    }
}
