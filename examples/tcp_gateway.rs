/*!
 * A Modbus TCP to RTU gateway on an Uno: an Arduino Ethernet Shield (W5100) in front, an
 * RS-485 line behind. Every TCP master's request for units 1-247 goes to the slave of that
 * address on the line and its answer back to that master, with its transaction id; the
 * requests of all connections wait their turn for the line in the chip (none is dropped),
 * the connections take turns. Unit 0 is a broadcast (writes; no answer; a read gets 0A),
 * a request malformed for its function code gets the exception the slave would give (03,
 * 02) without reaching the line, a slave that does not answer gets exception 0B (and after
 * 3 such requests in a row is taken to be down: answered 0B at once, tried again each
 * second), 248-254 get 0A, and the gateway's own registers answer at unit 255 (0xFF).
 *
 * Wiring: the shield on the Uno (chip select pin 10, SPI on pins 11-13 through the ICSP
 * header, so pin 13 cannot be the transceiver's driver enable); pins 0 (RX) and 1 (TX) to
 * an RS-485 transceiver's RO and DI, its DE and /RE joined on pin 3, A/B to the line.
 *
 * Network: 192.168.1.177/24, port 502 (with feature `rtu-over-tcp`, socket 3 serves RTU over
 * TCP on port 5020 instead; with feature `udp`, socket 3 serves Modbus UDP on port 502, each
 * datagram's answer sent back to its sender, and TCP sockets 0-2; with both, socket 2 RTU
 * over TCP and socket 3 UDP). Line: 19200 8E1, a response timeout of 200 ms, one retry.
 *
 * | unit 255 (FC 3 or 4) | meaning                                                |
 * |----------------------|--------------------------------------------------------|
 * | 0                    | requests sent on the line                              |
 * | 1                    | answers passed back (the slaves' exceptions included)  |
 * | 2                    | of them, exceptions                                    |
 * | 3                    | 0A sent (unit not routed, a read to unit 0)            |
 * | 4                    | 0B sent (no answer, or the slave down)                 |
 * | 5                    | broadcasts                                             |
 * | 6                    | answers whose connection had closed                    |
 * | 7                    | malformed requests answered by the gateway             |
 * | 8                    | connections waiting for the line                       |
 * | 1000 + 4n ... + 3    | slave n: answers, misses, misses in a row, down (1/0)  |
 *
 * The main loop is the application's: here it does nothing.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::master::Timeouts;
use avr_modbus::tcp::Network;
#[cfg(not(any(example_shield = "w5500", example_shield = "w5500-int")))]
use avr_modbus::tcp::W5100;
use avr_modbus::{Line, Parity, StopBits};
use panic_halt as _;

#[cfg(not(any(feature = "rtu-over-tcp", feature = "udp")))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).evict_after(2);
#[cfg(all(feature = "rtu-over-tcp", not(feature = "udp")))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177])
    .evict_after(2)
    .sockets(4)
    .rtu_over_tcp(5020, 0b1000);
#[cfg(all(feature = "udp", not(feature = "rtu-over-tcp")))]
const NETWORK: Network =
    Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).evict_after(2).sockets(3).udp(3);
#[cfg(all(feature = "udp", feature = "rtu-over-tcp"))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177])
    .evict_after(2)
    .sockets(3)
    .rtu_over_tcp(5020, 0b0100)
    .udp(3);
const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);

// This repository builds it for each shield (`AVR_MODBUS_EXAMPLE_SHIELD`): the W5100 by
// default, the W5500, each also with the INT line on pin 2.
#[cfg(not(any(example_shield = "w5500", example_shield = "w5100-int", example_shield = "w5500-int")))]
avr_modbus::tcp_gateway!(GATEWAY: W5100, Pin);
#[cfg(example_shield = "w5500")]
avr_modbus::tcp_gateway!(GATEWAY: avr_modbus::tcp::W5500, Pin);
#[cfg(example_shield = "w5100-int")]
avr_modbus::tcp_gateway!(GATEWAY: W5100, Pin; pin2_int);
#[cfg(example_shield = "w5500-int")]
avr_modbus::tcp_gateway!(GATEWAY: avr_modbus::tcp::W5500, Pin; pin2_int);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    let pins = match Pins::new(&*dp.PORTB, &*dp.PORTC, &*dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let driver_enable = pins.d3.into_output();
    if let Err(error) =
        GATEWAY.start_with_pins(NETWORK, LINE, dp.SPI, dp.USART0, dp.TC0, avr_modbus::Pin10, driver_enable)
    {
        board::halt(error);
    }
    // The response timeout covers the longest answer on the line (FC 3 of 125 registers:
    // 255 bytes, 146 ms at 19200) and the slave's time to answer; 0B comes after two tries,
    // 400 ms, inside a TCP master's own timeout (mbpoll's is 1 s).
    GATEWAY.set_timeouts(Timeouts { response_ms: 200, turnaround_ms: 20, retries: 1 });
    #[allow(clippy::empty_loop)]
    loop {}
}
