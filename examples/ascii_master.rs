/*!
 * A Modbus ASCII master (features `master` and `ascii`) at 9600 bps 7E1: it reads holding
 * registers 40001–40004 of slave 1, writes 0xBEEF to its register 40005, and after each
 * request reports the outcome and its counters to slave 2 with FC 16, so that a test (or a
 * person with two ASCII slaves and a terminal) sees on the line what the master took.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485 transceiver, GND to
 * GND; two ASCII slaves on the line: 1, the one polled; 2, the one told.
 *
 * Serial line: 9600 bps, 7 data bits, even parity, 1 stop bit (the spec's default for
 * ASCII); frames from `:` to CR LF with their LRC. Response timeout 100 ms, one retry.
 * No T3.5 in ASCII: a request goes out when no frame is on the line.
 *
 * The reports, at slave 2's holding registers from 16 × step (step 0: the read, step 1:
 * the write): the status (0 answered, 0x01–0xFF the exception code, 0x100 timeout, 0x200
 * bad reply), the four registers read (0 for the write), then the master's counters:
 * requests, replies, exceptions, timeouts, retries, LRC errors, malformed, unexpected.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::master::{Failure, Reply, Request, Timeouts};
use avr_modbus::{board, Line, Parity, SlaveId, StopBits};
use panic_halt as _;

const LINE: Line = Line::ascii(9600, Parity::Even, StopBits::One);
const POLLED: SlaveId = SlaveId::new(1);
const TOLD: SlaveId = SlaveId::new(2);

// The longest frame: the report, FC 16 of 13 registers (35 bytes).
avr_modbus::master!(MASTER: 40);

/// A report: status, four registers, eight counters.
type Report = [u16; 13];

/// The status and the registers read of an outcome.
fn outcome(outcome: Result<Reply<'_>, Failure>) -> Report {
    let mut report = [0u16; 13];
    match outcome {
        Ok(reply) => {
            for (slot, value) in report[1..5].iter_mut().zip(reply.registers()) {
                *slot = value;
            }
        }
        Err(Failure::Exception(code)) => report[0] = u16::from(code.code()),
        Err(Failure::Timeout) => report[0] = 0x100,
        Err(Failure::BadReply) => report[0] = 0x200,
    }
    report
}

/// Sends `request` to `slave` and waits for its outcome (this firmware has nothing else to
/// do); `None` when it could not be sent.
fn ask<R>(slave: SlaveId, request: &Request<'_>, f: impl FnOnce(Result<Reply<'_>, Failure>) -> R) -> Option<R> {
    MASTER.send(slave, request).ok()?;
    MASTER.wait_blocking(f)
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = MASTER.start(LINE, dp.USART0, dp.TC0) {
        board::halt(error);
    }
    MASTER.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 20, retries: 1 });

    loop {
        for step in 0..2u16 {
            let request = if step == 0 {
                Request::ReadHoldingRegisters { address: 0, quantity: 4 }
            } else {
                Request::WriteSingleRegister { address: 4, value: 0xBEEF }
            };
            let mut report = ask(POLLED, &request, outcome).unwrap_or([0x300; 13]);
            let c = MASTER.counters();
            report[5..].copy_from_slice(&[
                c.requests,
                c.replies,
                c.exceptions,
                c.timeouts,
                c.retries,
                c.crc_errors,
                c.malformed,
                c.unexpected,
            ]);
            ask(TOLD, &Request::WriteMultipleRegisters { address: 16 * step, values: &report }, |_| ());
        }
    }
}
