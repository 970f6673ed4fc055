/*!
 * An Uno as Modbus master polling a PLC: input registers 0–4 (30001–30005) of slave 1,
 * one at a time with FC 04, every 100 ms, over RS-485. Nothing in the loop waits: the
 * request goes out and the reply comes back in interrupts while the loop runs on.
 *
 * Wiring: Uno pin 1 (TX) to a MAX485 module's DI, pin 0 (RX) to its RO, pin 13 to DE and
 * /RE joined (high while the Uno sends; the board's LED "L" shows it), A/B to the PLC's
 * RS-485 terminals, GND to GND. An LED with a resistor on pin 8 to GND: errors.
 *
 * Serial line: 19200 bps, 8 data bits, even parity, 1 stop bit (8E1); the PLC is slave 1.
 *
 * What it does with the answers: `VALUES` holds the five registers last read. A timeout,
 * a damaged reply or an exception lights the LED on pin 8 for half a second; the master's
 * counters (`MASTER.counters()`) tell which.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::master::{Request, Timeouts};
use avr_modbus::{millis, Line, NoPin, Parity, SlaveId, StopBits};
use panic_halt as _;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);
const PLC: SlaveId = SlaveId::new(1);
const REGISTERS: u16 = 5;

// A reply to one register is 7 bytes, the request 8: 16-byte buffers.
avr_modbus::master!(MASTER: 16, Pin, NoPin);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let pins = match Pins::new(dp.PORTB, dp.PORTC, dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let driver_enable = pins.d13.into_output();
    let mut error_led = pins.d8.into_output();
    if let Err(error) = MASTER.start_with_pins(LINE, dp.USART0, dp.TC0, driver_enable, NoPin) {
        board::halt(error);
    }
    MASTER.set_timeouts(Timeouts { response_ms: 200, turnaround_ms: 100, retries: 1 });

    let mut values = [0u16; REGISTERS as usize];
    let mut next = 0;
    let mut asked = 0;
    let mut last_poll = 0;
    let mut error_since = None;
    loop {
        let now = millis();
        if let Some(outcome) = MASTER.poll(|outcome| outcome.map(|reply| reply.register(0))) {
            match outcome {
                Ok(Some(value)) => {
                    if let Some(slot) = values.get_mut(asked) {
                        *slot = value;
                    }
                }
                Ok(None) | Err(_) => error_since = Some(now),
            }
        }
        if now.wrapping_sub(last_poll) >= 100 && !MASTER.is_busy() {
            last_poll = now;
            asked = next;
            let request = Request::ReadInputRegisters { address: asked as u16, quantity: 1 };
            if MASTER.send(PLC, &request).is_err() {
                error_since = Some(now);
            }
            next = (next + 1) % REGISTERS as usize;
        }
        let lit = matches!(error_since, Some(since) if now.wrapping_sub(since) < 500);
        error_led.set(lit);
        // The application's own work goes here, with `values`.
        core::hint::black_box(&values);
    }
}
