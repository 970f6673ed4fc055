/*!
 * The lab's control application on an Arduino: the master of the bench that
 * [`lab_lights`](lab_lights.rs) makes (run it on two boards, one as the button box, one as the
 * light tower). Every 50 ms it reads START and STOP (discrete inputs 10001–10002 of device 1)
 * and sets the tower's lamps (coils 00001–00004 of device 2): GREEN while running, RED while
 * stopped. START starts, STOP stops (STOP wins when both are pressed).
 *
 * Wiring: the three boards on one RS-485 bus: this Uno's pin 1 (TX) to its transceiver's DI,
 * pin 0 (RX) to RO, pin 2 to DE and /RE tied together, A/B to the bus, GND to GND. The
 * on-board LED (pin 13) is lit while a device does not answer.
 *
 * Serial line: 19200 bps, 8E1; response timeout 100 ms, one retry.
 *
 * | device | references  | read or written          |
 * |--------|-------------|--------------------------|
 * | 1      | 10001–10002 | START, STOP: read, FC 02 |
 * | 2      | 00001–00004 | RED, GREEN, YELLOW, BLUE: written, FC 15, when they change (and every second) |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::master::{Request, Timeouts};
use avr_modbus::{millis, FunctionCode, Line, NoPin, Parity, SlaveId, StopBits};
use panic_halt as _;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);
const BUTTON_BOX: SlaveId = SlaveId::new(1);
const LIGHT_TOWER: SlaveId = SlaveId::new(2);

avr_modbus::master!(MASTER: 16, Pin, NoPin);

/// What the loop is doing.
#[derive(Clone, Copy, PartialEq)]
enum Step {
    /// Reading the buttons.
    Buttons,
    /// Setting the lamps.
    Lamps,
}

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
    let mut alarm = pins.d13.into_output();
    if let Err(error) = MASTER.start_with_pins(LINE, dp.USART0, dp.TC0, driver_enable, NoPin) {
        board::halt(error);
    }
    MASTER.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 100, retries: 1 });

    let mut running = false;
    // The lamps as last written, and when: none yet.
    let mut shown: Option<bool> = None;
    let mut shown_at = 0u32;
    // What the last request was.
    let mut step = Step::Buttons;
    let mut last_read = 0u32;
    loop {
        let now = millis();
        // START and STOP when the buttons were read, nothing when the lamps were set.
        let outcome = MASTER.poll(|outcome| {
            outcome.map(|reply| {
                (reply.function() == FunctionCode::ReadDiscreteInputs)
                    .then(|| (reply.bit(0) == Some(true), reply.bit(1) == Some(true)))
            })
        });
        match outcome {
            Some(Ok(Some((start, stop)))) => {
                alarm.set_low();
                if stop {
                    running = false;
                } else if start {
                    running = true;
                }
            }
            Some(Ok(None)) => alarm.set_low(),
            Some(Err(_)) => {
                alarm.set_high();
                if step == Step::Lamps {
                    // The lamps may not show what they should: set them again.
                    shown = None;
                }
            }
            None => {}
        }
        if MASTER.is_busy() {
            continue;
        }
        let stale = shown != Some(running) || now.wrapping_sub(shown_at) >= 1000;
        // The lamps are set again after a failure, but never twice in a row: a silent tower
        // does not keep the buttons from being read.
        if stale && step != Step::Lamps {
            // RED, GREEN, YELLOW, BLUE.
            let lamps = [!running, running, false, false];
            if MASTER.send(LIGHT_TOWER, &Request::WriteMultipleCoils { address: 0, values: &lamps }).is_ok() {
                shown = Some(running);
                shown_at = now;
                step = Step::Lamps;
            }
        } else if now.wrapping_sub(last_read) >= 50 {
            last_read = now;
            if MASTER.send(BUTTON_BOX, &Request::ReadDiscreteInputs { address: 0, quantity: 2 }).is_ok() {
                step = Step::Buttons;
            }
        }
    }
}
