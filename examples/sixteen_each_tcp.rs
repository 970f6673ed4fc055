/*!
 * The size contract over Modbus TCP: `sixteen_each`'s map (sixteen coils, sixteen discrete
 * inputs, eight input registers, sixteen holding registers) served on an Arduino Ethernet
 * Shield (W5100), polled, and a main loop that does nothing. `make bench` prints its flash
 * and RAM beside the Arduino Ethernet library's and the Arduino Modbus TCP libraries'.
 *
 * Wiring: the shield on an Uno (chip select pin 10, SPI on the ICSP header).
 *
 * Network: 192.168.1.177/24, MAC DE:AD:BE:EF:FE:01, port 502, every unit id answered; the
 * references as in `sixteen_each`. With feature `rtu-over-tcp`, socket 3 serves RTU over TCP
 * on port 5020; with feature `udp`, socket 3 serves Modbus UDP on port 502 (TCP then on
 * sockets 0-2); with both, socket 2 RTU over TCP and socket 3 UDP (each feature's size,
 * measured used).
 */
#![no_std]
#![no_main]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use panic_halt as _;

#[cfg(not(any(feature = "rtu-over-tcp", feature = "udp")))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]);
#[cfg(all(feature = "rtu-over-tcp", not(feature = "udp")))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).sockets(4).rtu_over_tcp(5020, 0b1000);
#[cfg(all(feature = "udp", not(feature = "rtu-over-tcp")))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).sockets(3).udp(3);
#[cfg(all(feature = "udp", feature = "rtu-over-tcp"))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).sockets(3).rtu_over_tcp(5020, 0b0100).udp(3);

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

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    if let Err(error) = SERVER.start(NETWORK, dp.SPI, dp.TC0, Registers::new()) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
