/*!
 * The size contract the Arduino Modbus libraries are compared on: sixteen of each bit
 * table, eight input registers, sixteen holding registers, and a main loop that does
 * nothing. `make bench` prints its flash and RAM beside the libraries' figures.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board (or an RS-485
 * transceiver), GND to GND.
 *
 * Serial line: slave id 1, 19200 bps, 8 data bits, even parity, 1 stop bit (8E1).
 *
 * | reference   | address | meaning                                 |
 * |-------------|---------|-----------------------------------------|
 * | 00001–00016 | 0–15    | coils, written by the master            |
 * | 10001–10016 | 0–15    | discrete inputs (0 until the firmware sets them) |
 * | 30001–30008 | 0–7     | input registers (0 until the firmware sets them) |
 * | 40001–40016 | 0–15    | holding registers, written by the master |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 00001–00016 | Read Coils (0x01); write: 0x05, 0x0f               | 0             | 16     |
 * | 10001–10016 | Read Discrete Inputs (0x02)                        | 0             | 16     |
 * | 30001–30008 | Read Input Registers (0x04)                        | 0             | 8      |
 * | 40001–40016 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 16     |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::{board, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// The contract's map: 16 coils, 16 discrete inputs, 8 input and 16 holding registers.
    struct Registers {
        1..=16,
        10001..=10016,
        30001..=30008,
        40001..=40016,
    }
}

avr_modbus::slave!(SLAVE: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, Registers::new()) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
