/*!
 * The way not to serve one map on two ports, kept as the control of `tcp_rtu`'s tests and
 * its size: two maps, one per port, and a main loop that copies values from one to the
 * other. A TCP master's write reaches the serial side only when the loop copies it, word by
 * word, so that a serial master can read a 32-bit pair half old, half new (the simulator's
 * hammer, `tests/sim_shared_model.rs`, sees it); `tcp_rtu` serves one model on both ports
 * (`shared_model!`) and never shows a torn pair.
 *
 * Wiring: the shield on an Uno; pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485
 * transceiver (its driver enable off pin 13, which is the shield's SCK: use another pin).
 *
 * Network: 192.168.1.177/24, port 502. Serial line: slave id 1, 19200 8E1. On each, the
 * references of `sixteen_each`; the main loop copies the TCP masters' holding registers
 * 40001–40002 to the serial side's 40001–40002, one word at a time, with 2 ms of other work
 * after each.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use avr_modbus::{Config, Parity, StopBits};
use panic_halt as _;

const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]);
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

avr_modbus::tcp_server!(SERVER: Registers, W5100);
avr_modbus::slave!(SLAVE: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    if let Err(error) = SERVER.start(NETWORK, dp.SPI, &*dp.TC0, Registers::new()) {
        board::halt(error);
    }
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, Registers::new()) {
        board::halt(error);
    }
    loop {
        for i in 0..2 {
            if let Ok(value) = SERVER.get(40001 + i) {
                let _ = SLAVE.set(40001 + i, value);
            }
            // The rest of the loop's work: 2 ms.
            avr_device::asm::delay_cycles(32_000);
        }
    }
}
