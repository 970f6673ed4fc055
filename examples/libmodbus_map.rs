/*!
 * libmodbus's unit-test map (libmodbus 3.1.6, `tests/unit-test.h` and the initial values of
 * `tests/unit-test-server.c`) served over Modbus TCP on an Arduino Ethernet Shield (W5100),
 * so that libmodbus's own `unit-test-client tcp` can run against the crate's server
 * (`tools/virtual-uno/tests/interop_tcp.rs`, `make interop`).
 *
 * Network: 192.168.1.178/24, MAC DE:AD:BE:EF:FE:02, port 502, every unit id answered.
 *
 * | reference   | address       | libmodbus's name           | initial value           |
 * |-------------|---------------|----------------------------|-------------------------|
 * | 00305–00341 | 0x130–0x154   | UT_BITS_ADDRESS, 0x25      | 0                       |
 * | 10453–10474 | 0x1C4–0x1D9   | UT_INPUT_BITS_ADDRESS, 0x16 | UT_INPUT_BITS_TAB: AC DB 35, LSB first |
 * | 30265       | 0x108         | UT_INPUT_REGISTERS_ADDRESS, 1 | 0x000A               |
 * | 40353–40384 | 0x160–0x17F   | UT_REGISTERS_ADDRESS, UT_REGISTERS_NB_MAX 0x20 | 0    |
 *
 * The client also uses FC 22 (Mask Write Register) and FC 23 (Read/Write Multiple
 * Registers), feature `extra-fc`, and FC 17 (Report Server ID), feature `diagnostics`: `make
 * chips` builds it with both. Its FC 17 checks want 10 bytes after the byte count (server id,
 * run indicator, 8 bytes of description): the description below has 8. Without the features
 * those requests get exception 01.
 *
 * The special registers 0x170–0x173 and the two-register read, where libmodbus's own server
 * misbehaves on purpose (an exception, a wrong transaction id, a 500 ms sleep, a reply sent a
 * byte every 5 ms, one register short) are plain registers here.
 */
#![no_std]
#![no_main]

use avr_modbus::board;
use avr_modbus::tcp::{Network, W5100};
use panic_halt as _;

const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x02], [192, 168, 1, 178])
    // With every socket taken, the connection idle 2 s makes room for a newcomer (default 10 s).
    .evict_after(2);

include!("libmodbus/unit_test.rs");

avr_modbus::tcp_server!(SERVER: UnitTest, W5100);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    let mut map = UnitTest::new();
    set_unit_test_values(&mut map);
    // FC 17's description: 8 bytes, so that the reply's byte count is the 10 the client checks.
    #[cfg(feature = "diagnostics")]
    map.set_device_info(b"UnoW5100");
    if let Err(error) = SERVER.start(NETWORK, dp.SPI, dp.TC0, map) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
