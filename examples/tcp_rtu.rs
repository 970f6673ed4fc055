/*!
 * Modbus TCP and Modbus RTU in one firmware: the contract's map served on an Arduino
 * Ethernet Shield (W5100) and, a map of its own, on the serial line (USART0, pins 0/1) by
 * the RTU slave. The TCP server polls the chip from Timer0's overflow with interrupts
 * enabled, so the slave's interrupts keep their timing: `make bench` compares this
 * firmware's USART receive interrupt with `sixteen_each`'s while masters poll both.
 *
 * Wiring: the shield on an Uno; pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485
 * transceiver (its driver enable off pin 13, which is the shield's SCK: use another pin).
 *
 * Network: 192.168.1.177/24, port 502. Serial line: slave id 1, 19200 8E1. On each, the
 * references of `sixteen_each`; the main loop copies the TCP masters' holding registers
 * 40001–40004 to the serial side's input registers 30001–30004.
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
        for i in 0..4 {
            if let Ok(value) = SERVER.get(40001 + i) {
                let _ = SLAVE.set(30001 + i, value);
            }
        }
    }
}
