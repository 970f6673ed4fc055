/*!
 * The smallest useful master: every 100 ms, holding registers 40001–40010 (addresses 0–9)
 * of slave 1 with FC 03; the values land in `VALUES`. The Arduino masters' benchmark sketch
 * in its read-only form (`make bench` sets its size beside theirs).
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485 transceiver (DE/RE
 * tied to the TX-enable of your choice; see plc_poller for a driver-enable pin), GND to GND.
 *
 * Serial line: 19200 bps, 8E1; response timeout 1000 ms, one retry (the defaults).
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::master::Request;
use avr_modbus::{board, millis, Line, Parity, SlaveId, StopBits};
use panic_halt as _;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);

// FC 3 × 10 is answered in 25 bytes.
avr_modbus::master!(MASTER: 25);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = MASTER.start(LINE, dp.USART0, dp.TC0) {
        board::halt(error);
    }
    let mut values = [0u16; 10];
    let mut last = 0;
    loop {
        MASTER.poll(|outcome| {
            if let Ok(reply) = outcome {
                for (slot, value) in values.iter_mut().zip(reply.registers()) {
                    *slot = value;
                }
            }
        });
        let now = millis();
        if now.wrapping_sub(last) >= 100 {
            last = now;
            let _ = ask();
        }
        core::hint::black_box(&values);
    }
}

/// Asks slave 1 for holding registers 0–9. Out of line: `make bench` times the request's
/// first start bit from this function's entry, the moment the application asks.
#[inline(never)]
fn ask() -> Result<(), avr_modbus::Error> {
    MASTER.send(SlaveId::new(1), &Request::ReadHoldingRegisters { address: 0, quantity: 10 })
}
