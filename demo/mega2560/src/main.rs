/*!
 * `make demo BOARD=mega2560`'s firmware: an Arduino Mega 2560 answering Modbus RTU on its
 * USB serial port (USART0, pins 0/1), slave 1 at 19200 8E1, as a user's avr-hal template
 * project would. The board's LED "L" (pin 13) is lit while the slave answers.
 *
 * | reference   | meaning                                  |
 * |-------------|------------------------------------------|
 * | 00001–00008 | coils, written by the master             |
 * | 10001–10008 | discrete inputs (0)                      |
 * | 30001       | seconds since start-up                   |
 * | 30002       | 2560, the chip                           |
 * | 40001–40010 | holding registers; 40001 starts at 1234  |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_device::atmega2560 as pac;
use avr_modbus::{board, millis, Config, Error, NoPin, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// What the master sees.
    struct Registers { 1..=8, 10001..=10008, 30001..=30002, 40001..=40010 }
}

// Pins 0/1: USART0, the Mega's USB serial port.
avr_modbus::slave!(SLAVE: Registers, NoPin, board::Pin);

fn registers() -> Result<Registers, Error> {
    let mut bank = Registers::new();
    bank.set(30002, 2560)?;
    bank.set(40001, 1234)?;
    Ok(bank)
}

#[avr_device::entry]
fn main() -> ! {
    let dp = pac::Peripherals::take().unwrap();
    let started = board::led(dp.PORTB)
        .and_then(|led| Ok((led, registers()?)))
        .and_then(|(led, bank)| SLAVE.start_with_pins(CONFIG, dp.USART0, dp.TC0, bank, NoPin, led));
    if let Err(error) = started {
        board::halt(error);
    }
    loop {
        SLAVE.set(30001, (millis() / 1000) as u16).ok();
    }
}
