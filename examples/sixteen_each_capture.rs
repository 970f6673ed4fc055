/*!
 * The size contract (`sixteen_each.rs`) on the Uno's pins 8 and 9 instead of its USART:
 * Timer1's input capture receives on pin 8 and its compare unit A sends on pin 9 (feature
 * `capture-line`), so pins 0/1 and the USB serial stay free for the application. `make
 * bench` prints its flash and RAM beside the USART's.
 *
 * Wiring: Uno pins 8 (RX) and 9 (TX) to the TTL side of a MAX3232 board (or an RS-485
 * transceiver's RO and DI), GND to GND. Timer1 is the line's: no Servo, no tone(), no PWM
 * on pins 9 and 10 (pin 10 still works as a plain output, an Ethernet shield's select).
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

avr_modbus::slave!(SLAVE on TIMER1: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = SLAVE.start(CONFIG, dp.TC1, dp.TC0, Registers::new()) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
