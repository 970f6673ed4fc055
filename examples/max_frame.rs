/*!
 * The largest frames Modbus allows: 125 holding registers, so that FC 3 × 125 (a
 * 255-byte reply) and FC 16 × 123 (a 255-byte request) are answered normally. Used by
 * `make bench` to time the slave's worst cases.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND;
 * optionally a jumper from pin 12 to GND.
 *
 * Serial line: slave id 1, 8E1; 19200 bps, or 115200 bps with pin 12 jumpered to GND at
 * start-up.
 *
 * | reference   | address | meaning                               |
 * |-------------|---------|---------------------------------------|
 * | 40001–40125 | 0–124   | holding registers kept for the master |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 40001–40125 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 125 (123 to write) |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pins};
use avr_modbus::{Config, Error, Parity, StopBits};
use panic_halt as _;

const SLOW: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const FAST: Config = Config::new(1, 115_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// 125 holding registers: the longest read.
    struct Registers { 40001..=40125 }
}

avr_modbus::slave!(SLAVE: Registers);

fn start(dp: avr_device::atmega328p::Peripherals) -> Result<(), Error> {
    let pins = Pins::new(dp.PORTB, dp.PORTC, dp.PORTD)?;
    let jumper = pins.d12.into_pull_up_input();
    // Let the pull-up charge the pin before reading it.
    avr_device::asm::delay_cycles(1_000);
    let config = if jumper.is_high() { SLOW } else { FAST };

    SLAVE.start(config, dp.USART0, dp.TC0, Registers::new())
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
