/*!
 * A slave whose main loop does nothing but read and write its values, as fast as it can:
 * `get`, `set`, `get_wide` and `set_wide` (and `millis`) at every turn. Each call holds
 * interrupts off for a few cycles; this firmware meets the slave's interrupts with those
 * windows at every point of a request, so that `make bench` can show what they cost the
 * reply (its "Main loop calling the slave as fast as it can" series).
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board, GND to GND.
 *
 * Serial line: slave id 1, 19200 bps, 8E1.
 *
 * | references  | addresses | meaning                                                  |
 * |-------------|-----------|----------------------------------------------------------|
 * | 30001       | 0         | turns of the main loop (`set`)                           |
 * | 30002–30003 | 1–2       | u32, high word first: `millis()` (`set_wide`)            |
 * | 30004       | 3         | copy of 40001 (`get`, then `set`)                        |
 * | 30005–30006 | 4–5       | f32, high word first: copy of 40002–40003 (`get_wide`, then `set_wide` of its bits) |
 * | 40001       | 0         | free for the master                                      |
 * | 40002–40003 | 1–2       | f32, high word first: free for the master                |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 30001–30006 | Read Input Registers (0x04)                        | 0             | 6      |
 * | 40001–40003 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 3      |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use core::hint::black_box;

use avr_modbus::{board, millis, Config, Parity, StopBits, WordOrder};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const ABCD: WordOrder = WordOrder::HighFirst;

avr_modbus::register_map! {
    /// The loop's values and the master's.
    struct Registers {
        30001,
        30002..=30003 as u32,
        30004,
        30005..=30006 as f32,
        40001,
        40002..=40003 as f32,
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

    let mut turns: u16 = 0;
    loop {
        turns = turns.wrapping_add(1);
        set(30001, turns);
        set_wide(30002, millis());
        set(30004, get(40001));
        set_wide(30005, get_wide(40002).to_bits());
        black_box(with());
    }
}

// Each call in a function of its own, kept out of line, so that `make bench` names the
// window each holds interrupts off by the function it is in; the references pass through
// `black_box`, as a loop over a table of them would have them, not constants the compiler
// folds into the call.

#[inline(never)]
fn set(reference: u32, value: u16) {
    let _ = SLAVE.set(black_box(reference), value);
}

#[inline(never)]
fn get(reference: u32) -> u16 {
    SLAVE.get(black_box(reference)).unwrap_or(0)
}

#[inline(never)]
fn set_wide(first: u32, value: u32) {
    let _ = SLAVE.set_wide(black_box(first), value, ABCD);
}

#[inline(never)]
fn get_wide(first: u32) -> f32 {
    SLAVE.get_wide(black_box(first), ABCD).unwrap_or(0.0)
}

#[inline(never)]
fn with() -> u16 {
    // The shortest closure that reaches the map: what `with` costs around its closure.
    SLAVE.with(|map| map.master_writes()).unwrap_or(0)
}
