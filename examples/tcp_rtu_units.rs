/*!
 * Two slave ids on two ports: two units, each with the contract's map, served at once as
 * slave ids 1 and 2 on the serial line (USART0, pins 0/1, 19200 8E1) and as unit ids 1
 * and 2 on an Arduino Ethernet Shield (W5100): one `shared_model!` of `Units`. A write to
 * id 2 on either port is read at id 2 on the other; id 1 keeps its own values. Each port
 * selects its own unit, even when a serial request comes in the middle of a TCP one
 * (`tests/sim_shared_model.rs`).
 *
 * Wiring: as `tcp_rtu`'s. Network: 192.168.1.177/24, port 502.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use avr_modbus::{Config, Parity, StopBits, Units};
use panic_halt as _;

const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]);
// The slave id is the units' (1 and 2): `Config`'s is not used with a `Units` model.
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

avr_modbus::shared_model!(MODEL: Units<Registers, 2> = Units::new(1, [Registers::new(), Registers::new()]));
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
    loop {}
}
