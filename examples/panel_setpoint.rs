/*!
 * A setpoint that a local panel can hold (feature `write-protect`): holding register 40001
 * is the setpoint the master writes; while the panel's HOLD switch on pin 7 (to GND) is
 * closed, the panel keeps it and the slave refuses every write of the master (exception 01,
 * `SLAVE.set_read_only`), which still reads everything. Releasing the switch gives the
 * master its writes back. Coils 00001–00008 and holding registers 40001–40008.
 *
 * Wiring: the HOLD switch between pin 7 and GND (the pin's pull-up keeps it high, open);
 * the serial line on pins 0/1 (a USB adapter, or an RS-485 transceiver without DE).
 *
 * Serial line: 19200 bps, 8E1, slave id 1.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pins};
use avr_modbus::{bit_bytes, Bank, Config, Parity, StopBits};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// Two runs: coils 00001–00008, holding registers 40001–40008.
type Registers = Bank<2, 8, { bit_bytes(8) }>;

avr_modbus::slave!(SLAVE: Registers);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let pins = match Pins::new(dp.PORTB, dp.PORTC, dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let hold = pins.d7.into_pull_up_input();
    let mut bank = Registers::new();
    let added = bank.add_range(1, 8).and(bank.add_range(40001, 8));
    if let Err(error) = added.and_then(|()| SLAVE.start(CONFIG, dp.USART0, dp.TC0, bank)) {
        board::halt(error);
    }
    let mut held = false;
    loop {
        // The switch is read in the loop; the slave told only when it changes.
        let closed = !hold.is_high();
        if closed != held {
            held = closed;
            SLAVE.set_read_only(held);
        }
    }
}
