/*!
 * One device on two ports: the contract's map served at once on an Arduino Ethernet Shield
 * (W5100) by the TCP server and on the serial line (USART0, pins 0/1) by the RTU slave,
 * one model without copies (`shared_model!`). A write on either port is seen on both at
 * once, whole. The TCP server polls the chip from Timer0's overflow with interrupts
 * enabled and holds them off only while a request runs against the model, so the slave's
 * interrupts keep their timing: `make bench` compares this firmware's USART receive
 * interrupt and reply with `sixteen_each`'s while masters poll both.
 *
 * Wiring: the shield on an Uno; pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485
 * transceiver (its driver enable off pin 13, which is the shield's SCK: use another pin).
 *
 * Network: 192.168.1.177/24, port 502. Serial line: slave id 1, 19200 8E1. On both, the
 * references of `sixteen_each`; the main loop keeps input register 30001 at the number of
 * master writes so far, and 30002 at the last writer: 0 for none yet, 1 for the serial line,
 * 2 for a TCP client.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use avr_modbus::{Config, Parity, Port, StopBits};
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

avr_modbus::shared_model!(MODEL: Registers);
avr_modbus::tcp_server!(SERVER: MODEL, W5100);
avr_modbus::slave!(SLAVE: MODEL);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    if let Err(error) = SERVER.start(NETWORK, dp.SPI, &*dp.TC0, MODEL) {
        board::halt(error);
    }
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, MODEL) {
        board::halt(error);
    }
    loop {
        let _ = MODEL.set(30001, MODEL.master_writes());
        if let Some(write) = MODEL.take_write() {
            let _ = MODEL.set(30002, if let Port::Serial(_) = write.by { 1 } else { 2 });
        }
    }
}
