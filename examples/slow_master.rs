/*!
 * A slave for a slow master: it answers 3 ms after the request's T3.5 of silence instead of
 * at once (feature `reply-delay`), for a PC behind a USB–RS-485 adapter that switches
 * direction by itself, or a master whose transceiver turns around slowly.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to an RS-485 transceiver (DE/RE on pin 2) or a
 * MAX3232 board, GND to GND.
 *
 * Serial line: slave id 1, 19200 bps, 8E1; holding registers 40001–40004.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::{Config, NoPin, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One).with_reply_delay(3_000);

avr_modbus::register_map! {
    /// Four holding registers.
    struct Registers { 40001..=40004 }
}

avr_modbus::slave!(SLAVE: Registers, Pin, NoPin);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let pins = match Pins::new(dp.PORTB, dp.PORTC, dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let driver_enable = pins.d2.into_output();
    if let Err(error) = SLAVE.start_with_pins(CONFIG, dp.USART0, dp.TC0, Registers::new(), driver_enable, NoPin) {
        board::halt(error);
    }
    loop {
        core::hint::spin_loop();
    }
}
