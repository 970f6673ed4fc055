/*!
 * The size contract over Modbus TCP: `sixteen_each`'s map (sixteen coils, sixteen discrete
 * inputs, eight input registers, sixteen holding registers) served on an Arduino Ethernet
 * Shield (W5100), polled, and a main loop that does nothing. `make bench` prints its flash
 * and RAM beside the Arduino Ethernet library's and the Arduino Modbus TCP libraries'.
 *
 * Wiring: the shield on an Uno (chip select pin 10, SPI on the ICSP header).
 *
 * Network: 192.168.1.177/24, MAC DE:AD:BE:EF:FE:01, port 502, every unit id answered; the
 * references as in `sixteen_each`. Built with feature `dhcp` (`make tcp-firmware`'s
 * `atmega328p-tcp-dhcp`, the measure of DHCP's cost), the address comes from a DHCP server
 * instead (host name `sixteen-each`, the client on socket 3, the server on 0-2), and
 * 192.168.1.177 is the fallback after 30 s without a lease.
 */
#![no_std]
#![no_main]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use panic_halt as _;

#[cfg(not(feature = "dhcp"))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]);
#[cfg(feature = "dhcp")]
const NETWORK: Network =
    Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).dhcp(3, "sixteen-each").fallback_after(30);

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
