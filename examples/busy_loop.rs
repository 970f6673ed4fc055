/*!
 * A slave whose application blocks for 500 ms at a time and still answers every request
 * on time: reception, dispatch and transmission all run in interrupts.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND.
 *
 * Serial line: slave id 1, 19200 bps, 8E1.
 *
 * | reference | address | meaning                                                 |
 * |-----------|---------|---------------------------------------------------------|
 * | 30001     | 0       | passes through the main loop (one every 500 ms)         |
 * | 40001     | 0       | free for the master                                     |
 * | 40002     | 1       | free for the master                                     |
 * | 40003     | 2       | free for the master                                     |
 * | 40004     | 3       | copy of 40001, made once per pass of the main loop      |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 30001       | Read Input Registers (0x04)                        | 0             | 1      |
 * | 40001–40004 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 4      |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::{board, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// 500 ms at 16 MHz.
const BLOCK_CYCLES: u32 = 8_000_000;

avr_modbus::register_map! {
    /// The pass counter and four holding registers.
    struct Registers { 30001, 40001..=40004 }
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

    let mut passes: u16 = 0;
    loop {
        passes = passes.wrapping_add(1);
        let _ = SLAVE.set(30001, passes);
        let _ = SLAVE.set(40004, SLAVE.get(40001).unwrap_or(0));
        // The application is busy: no call into the slave for half a second.
        avr_device::asm::delay_cycles(BLOCK_CYCLES);
    }
}
