/*!
 * libmodbus's unit-test map (libmodbus 3.1.6, `tests/unit-test.h` and the initial values of
 * `tests/unit-test-server.c`) served over Modbus RTU by slave 17, libmodbus's `SERVER_ID`:
 * the slave behind the TCP to RTU gateway ([`tcp_gateway.rs`](tcp_gateway.rs)) that
 * libmodbus's own `unit-test-client tcp` reaches through it
 * (`tools/virtual-uno/tests/interop_gateway.rs`, `make interop`). The same map as
 * [`libmodbus_map.rs`](libmodbus_map.rs), which serves it over TCP.
 *
 * Wiring: pins 0 (RX) and 1 (TX) to an RS-485 transceiver's RO and DI, its DE and /RE joined
 * on pin 10, A/B to the line. Serial line: 19200 bps, 8E1.
 *
 * | reference   | address       | libmodbus's name           | initial value           |
 * |-------------|---------------|----------------------------|-------------------------|
 * | 00305–00341 | 0x130–0x154   | UT_BITS_ADDRESS, 0x25      | 0                       |
 * | 10453–10474 | 0x1C4–0x1D9   | UT_INPUT_BITS_ADDRESS, 0x16 | UT_INPUT_BITS_TAB: AC DB 35, LSB first |
 * | 30265       | 0x108         | UT_INPUT_REGISTERS_ADDRESS, 1 | 0x000A               |
 * | 40353–40384 | 0x160–0x17F   | UT_REGISTERS_ADDRESS, UT_REGISTERS_NB_MAX 0x20 | 0    |
 *
 * The client also uses FC 22 and FC 23 (feature `extra-fc`) and FC 17 (feature
 * `diagnostics`, its description 8 bytes as the client's check wants): the example needs both.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::{Config, Parity, StopBits};
use panic_halt as _;

/// libmodbus's SERVER_ID, 19200 8E1.
const CONFIG: Config = Config::new(17, 19_200, Parity::Even, StopBits::One);

include!("libmodbus/unit_test.rs");

avr_modbus::slave!(SLAVE: UnitTest, Pin, Pin);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    let pins = match Pins::new(dp.PORTB, dp.PORTC, dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let mut map = UnitTest::new();
    set_unit_test_values(&mut map);
    map.set_device_info(b"UnoRS485");
    let driver_enable = pins.d10.into_output();
    let led = pins.d13.into_output();
    if let Err(error) = SLAVE.start_with_pins(CONFIG, dp.USART0, dp.TC0, map, driver_enable, led) {
        board::halt(error);
    }
    #[allow(clippy::empty_loop)]
    loop {}
}
