/*!
 * The size contract of `sixteen_each`, with the map built at run time: a `Bank` and four
 * `add_range` calls instead of `register_map!`, as a firmware that picks its map from a
 * jumper, a DIP switch or the EEPROM builds it. Sixteen of each bit table, eight input
 * registers, sixteen holding registers, and a main loop that does nothing. `make bench`
 * prints its flash and RAM beside `sixteen_each` and the libraries' figures.
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

use avr_modbus::{bit_bytes, board, Bank, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// The contract's map, built at run time: 4 runs, 24 registers (8 input, 16 holding),
/// 32 bits (16 coils, 16 discrete inputs).
type Registers = Bank<4, 24, { bit_bytes(32) }>;

avr_modbus::slave!(SLAVE: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let mut bank = Registers::new();
    // An error (an address added twice, no room left) adds nothing and is reported; the
    // ranges after it are still tried.
    let added = bank
        .add_range(1, 16)
        .and(bank.add_range(10001, 16))
        .and(bank.add_range(30001, 8))
        .and(bank.add_range(40001, 16));
    if let Err(error) = added.and_then(|()| SLAVE.start(CONFIG, dp.USART0, dp.TC0, bank)) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
