/*!
 * The size contract over Modbus TCP: `sixteen_each`'s map (sixteen coils, sixteen discrete
 * inputs, eight input registers, sixteen holding registers) served on an Arduino Ethernet
 * Shield (W5100), polled, and a main loop that does nothing. `make bench` prints its flash
 * and RAM beside the Arduino Ethernet library's and the Arduino Modbus TCP libraries'.
 *
 * Wiring: the shield on an Uno (chip select pin 10, SPI on the ICSP header).
 *
 * Network: 192.168.1.177/24, MAC DE:AD:BE:EF:FE:01, port 502, every unit id answered; the
 * references as in `sixteen_each`. With an optional feature, the sockets are shared: each
 * takes one from the top, so that built with one alone (`make tcp-firmware`, the measure of
 * its cost) it has socket 3 and MBAP the others: `udp` Modbus UDP on port 502, `dhcp` the
 * DHCP client (host name `sixteen-each`; 192.168.1.177 the fallback after 30 s without a
 * lease), `rtu-over-tcp` RTU over TCP on port 5020. With `write-protect`, an allow-list
 * whose readers may not write: 192.168.1.10 (and 127.0.0.1, the host's own clients of
 * `virtual-uno`) read and write, 192.168.1.20 (and 127.0.0.2) only read (their writes get
 * exception 01); nobody else connects.
 */
#![no_std]
#![no_main]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use panic_halt as _;

const NETWORK: Network = {
    let net = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]);
    #[cfg(any(feature = "udp", feature = "dhcp", feature = "rtu-over-tcp"))]
    let top: u8 = 4;
    #[cfg(feature = "udp")]
    let (net, top) = (net.sockets(top - 1).udp(top - 1), top - 1);
    #[cfg(feature = "dhcp")]
    let (net, top) = (net.sockets(top - 1).dhcp(top - 1, "sixteen-each").fallback_after(30), top - 1);
    #[cfg(feature = "rtu-over-tcp")]
    let net = net.sockets(top).rtu_over_tcp(5020, 1 << (top - 1));
    #[cfg(any(feature = "udp", feature = "dhcp", feature = "rtu-over-tcp"))]
    let _ = top;
    #[cfg(feature = "write-protect")]
    let net = net.allow(&[[192, 168, 1, 10], [127, 0, 0, 1]]).allow_reading(&[[192, 168, 1, 20], [127, 0, 0, 2]]);
    net
};

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
