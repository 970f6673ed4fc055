/*!
 * The smallest useful slave: four holding registers, nothing else.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board (or an RS-485
 * transceiver with DE/RE tied high for listen-only testing), GND to GND.
 *
 * Serial line: slave id 1, 19200 bps, 8 data bits, even parity, 1 stop bit (8E1).
 *
 * | reference | address | meaning                                       |
 * |-----------|---------|-----------------------------------------------|
 * | 40001     | 0       | setpoint, written by the master               |
 * | 40002     | 1       | copy of 40001 made by the main loop           |
 * | 40003     | 2       | count of master writes seen by the main loop  |
 * | 40004     | 3       | free for the master                           |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 40001–40004 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 4      |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::{board, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// Four holding registers.
    struct Registers { 40001..=40004 }
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

    let mut seen = 0;
    loop {
        let writes = SLAVE.master_writes();
        if writes != seen {
            seen = writes;
            let setpoint = SLAVE.get(40001).unwrap_or(0);
            let _ = SLAVE.set(40002, setpoint);
            let _ = SLAVE.set(40003, writes);
        }
    }
}
