/*!
 * A Modbus TCP server on an Arduino Ethernet Shield (W5100) with the size contract's map:
 * sixteen coils, sixteen discrete inputs, eight input registers, sixteen holding registers.
 * The main loop blocks for a second at a time, as Arduino's `delay(1000)` does (a busy wait
 * on `millis()`), and counts the seconds into 30001: masters are answered all the same. The chip is the one the build is
 * for (`-C target-cpu`: the Uno's, the Mega's, the Leonardo's); `make firmware` builds it
 * for the W5100 (the shield R3), the W5500 (Ethernet Shield 2, the modules), each polled
 * and with the INT line on pin 2 (this repository's `AVR_MODBUS_EXAMPLE_SHIELD`).
 *
 * Wiring: the shield on an Uno (or a Mega: its SPI comes through the ICSP header); the
 * shield's chip select is pin 10, its SD card's pin 4 (leave that high, or unplugged); pins
 * 11-13 are the SPI on the Uno, so an RS-485 driver-enable pin must go elsewhere. A W5500
 * module instead: its MOSI, MISO, SCK to pins 11, 12, 13 (the Mega: 51, 50, 52), its CS to
 * pin 10, 3.3 V and GND, and `W5500` below.
 *
 * Network: 192.168.1.177/24, MAC DE:AD:BE:EF:FE:01, port 502, every unit id answered; with
 * every socket taken, a connection idle 2 s is closed for a newcomer. Built with feature
 * `udp`: Modbus UDP on port 502 as well, on the chip's socket 3 (TCP on sockets 0-2).
 *
 * | reference   | address | meaning                                          |
 * |-------------|---------|--------------------------------------------------|
 * | 00001–00016 | 0–15    | coils, written by the master                     |
 * | 10001–10016 | 0–15    | discrete inputs (0)                              |
 * | 30001       | 0       | seconds the main loop has counted                |
 * | 30002       | 1       | requests answered so far                         |
 * | 30003–30008 | 2–7     | input registers (0)                              |
 * | 40001–40016 | 0–15    | holding registers, written by the master         |
 *
 * From the host: `mbpoll -m tcp -a 1 -r 1 -c 16 192.168.1.177` (or, on the virtual shield,
 * `make serve EXAMPLE=tcp_server SHIELD=w5100` and the port it prints).
 */
#![no_std]
#![no_main]
// Only the INT line's handler is the firmware's own (`tcp_server!(…, pin2_int)`).
#![cfg_attr(any(example_shield = "w5100-int", example_shield = "w5500-int"), feature(abi_avr_interrupt))]

use avr_modbus::tcp::Network;
use avr_modbus::{board, millis};
use panic_halt as _;

// The chip's peripherals, as the build's `-C target-cpu` chose the chip (build.rs).
#[cfg(avr_chip = "atmega1280")]
use avr_device::atmega1280 as pac;
#[cfg(avr_chip = "atmega168")]
use avr_device::atmega168 as pac;
#[cfg(avr_chip = "atmega2560")]
use avr_device::atmega2560 as pac;
#[cfg(avr_chip = "atmega328p")]
use avr_device::atmega328p as pac;
#[cfg(avr_chip = "atmega32u4")]
use avr_device::atmega32u4 as pac;

#[cfg(not(feature = "udp"))]
const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177])
    // With every socket taken, the connection idle 2 s makes room for a newcomer (default 10 s).
    .evict_after(2);
// With feature `udp`, Modbus UDP on port 502 too, on socket 3 (TCP on sockets 0-2).
#[cfg(feature = "udp")]
const NETWORK: Network =
    Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).evict_after(2).sockets(3).udp(3);

avr_modbus::register_map! {
    /// The contract's map: 16 coils, 16 discrete inputs, 8 input and 16 holding registers.
    struct Registers {
        1..=16,
        10001..=10016,
        30001..=30008,
        40001..=40016,
    }
}

#[cfg(not(any(example_shield = "w5500", example_shield = "w5100-int", example_shield = "w5500-int")))]
avr_modbus::tcp_server!(SERVER: Registers, avr_modbus::tcp::W5100);
#[cfg(example_shield = "w5500")]
avr_modbus::tcp_server!(SERVER: Registers, avr_modbus::tcp::W5500);
#[cfg(example_shield = "w5100-int")]
avr_modbus::tcp_server!(SERVER: Registers, avr_modbus::tcp::W5100, pin2_int);
#[cfg(example_shield = "w5500-int")]
avr_modbus::tcp_server!(SERVER: Registers, avr_modbus::tcp::W5500, pin2_int);

/// Arduino's `delay(ms)`: a busy wait on the millisecond clock.
fn delay(ms: u32) {
    let start = millis();
    while millis().wrapping_sub(start) < ms {}
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    if let Err(error) = SERVER.start(NETWORK, dp.SPI, dp.TC0, Registers::new()) {
        board::halt(error);
    }
    let mut seconds: u16 = 0;
    loop {
        delay(1000);
        seconds = seconds.wrapping_add(1);
        let counters = SERVER.counters();
        let _ = SERVER.set(30001, seconds);
        let _ = SERVER.set(30002, counters.requests);
    }
}
