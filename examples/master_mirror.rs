/*!
 * A master that reports what it gets: it runs one request of every function code against
 * slave 1, and after each writes the outcome to slave 2 with FC 16, so that a test (or a
 * person with two slaves and a bus monitor) can see on the line what the master took.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to an RS-485 transceiver (DE/RE on pin 2) or a MAX3232,
 * two slaves on the line: 1, the one polled; 2, the one told.
 *
 * Serial line: 19200 bps, 8E1. Response timeout 100 ms, broadcast turnaround 20 ms, one retry.
 *
 * The steps, to slave 1 (protocol addresses), and the report each gets at slave 2's holding
 * registers from 16 × step: the status (0 answered, 0x01–0xFF the exception code, 0x100 timeout,
 * 0x200 bad reply), then what was read (registers, or bits packed into one register, LSB first):
 *
 * | step | request to slave 1                                | read      |
 * |------|---------------------------------------------------|-----------|
 * | 0    | FC 3, holding registers 0–3                        | 4 values  |
 * | 1    | FC 1, coils 0–9                                    | 10 bits   |
 * | 2    | FC 5, coil 3 on                                    |           |
 * | 3    | FC 16, holding registers 10–11 = 0x1234, 0x5678    |           |
 * | 4    | FC 4, input registers 0–2                          | 3 values  |
 * | 5    | FC 2, discrete inputs 0–7                          | 8 bits    |
 * | 6    | FC 6, holding register 12 = 0xBEEF                 |           |
 * | 7    | FC 15, coils 4–7 = on, off, on, on                 |           |
 * | 8    | FC 23, write 13 = 7, then read 10–13               | 4 values  |
 * | 9    | FC 3, holding registers 0–125: refused before sending (status 0x300) |  |
 * | 10   | FC 3, holding register 9999 (absent: exception 02 expected) |  |
 * | 11   | broadcast (slave 0) FC 6, holding register 14 = 0x0B0B |       |
 * | 12   | raw FC 0x41 with a byte of data (no slave has it: exception 01 expected) |  |
 * | 13   | raw FC 3 of 0 registers (exception 03 expected)   |           |
 * | 14   | FC 3, holding registers 16–19: two f32, high word first then low word first | each × 2, high word first (4 registers) |
 *
 * After the last step: the master's counters at slave 2's registers 240–249 (requests,
 * CRC errors, UART errors, overruns, malformed, replies, exceptions, timeouts, retries,
 * unexpected), then again from step 0 with the pass count at register 250.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::master::{Failure, Reply, Request, Timeouts};
use avr_modbus::{board, Error, FunctionCode, Line, Parity, SlaveId, StopBits, WordOrder};
use panic_halt as _;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);
const POLLED: SlaveId = SlaveId::new(1);
const TOLD: SlaveId = SlaveId::new(2);
const STEPS: u16 = 15;
/// A user-defined function code (65), which no slave here answers but with exception 01.
const VENDOR: FunctionCode = FunctionCode::custom(0x41);

avr_modbus::master!(MASTER: 64);

/// What a step's report says: status, then up to 4 values read.
type Report = ([u16; 5], usize);

/// Step `step`'s request and whom it goes to (`None`: every slave, a broadcast).
fn request(step: u16) -> (Option<SlaveId>, Request<'static>) {
    const COILS: [bool; 4] = [true, false, true, true];
    const PAIR: [u16; 2] = [0x1234, 0x5678];
    const SEVEN: [u16; 1] = [7];
    let request = match step {
        0 => Request::ReadHoldingRegisters { address: 0, quantity: 4 },
        1 => Request::ReadCoils { address: 0, quantity: 10 },
        2 => Request::WriteSingleCoil { address: 3, value: true },
        3 => Request::WriteMultipleRegisters { address: 10, values: &PAIR },
        4 => Request::ReadInputRegisters { address: 0, quantity: 3 },
        5 => Request::ReadDiscreteInputs { address: 0, quantity: 8 },
        6 => Request::WriteSingleRegister { address: 12, value: 0xBEEF },
        7 => Request::WriteMultipleCoils { address: 4, values: &COILS },
        8 => Request::ReadWriteMultipleRegisters {
            read_address: 10,
            read_quantity: 4,
            write_address: 13,
            values: &SEVEN,
        },
        9 => Request::ReadHoldingRegisters { address: 0, quantity: 126 },
        10 => Request::ReadHoldingRegisters { address: 9999, quantity: 1 },
        11 => return (None, Request::WriteSingleRegister { address: 14, value: 0x0B0B }),
        12 => Request::Raw { function: VENDOR, data: &[0x00] },
        // What the master refuses to build as FC 3 (a quantity of 0), sent raw.
        13 => Request::Raw { function: FunctionCode::ReadHoldingRegisters, data: &[0, 0, 0, 0] },
        _ => Request::ReadHoldingRegisters { address: 16, quantity: 4 },
    };
    (Some(POLLED), request)
}

/// Starts `request` to `slave`, or to every slave.
fn send(slave: Option<SlaveId>, request: &Request<'_>) -> Result<(), Error> {
    match slave {
        Some(slave) => MASTER.send(slave, request),
        None => MASTER.broadcast(request),
    }
}

/// How a step's reply is reported.
#[derive(Clone, Copy, PartialEq)]
enum Read {
    /// The registers as read.
    Registers,
    /// Bits, packed into one register.
    Bits,
    /// Two f32, high word first then low word first, each doubled and reported high word
    /// first.
    Floats,
}

/// The report of an outcome.
fn report(outcome: Result<Reply<'_>, Failure>, read: Read) -> Report {
    let mut values = [0u16; 5];
    let mut len = 1;
    let bits = read == Read::Bits;
    match outcome {
        Ok(reply) if read == Read::Floats => {
            let first = reply.wide::<f32>(0, WordOrder::HighFirst).unwrap_or(f32::NAN) * 2.0;
            let second = reply.wide::<f32>(2, WordOrder::LowFirst).unwrap_or(f32::NAN) * 2.0;
            let [a, b] = WordOrder::HighFirst.split(first);
            let [c, d] = WordOrder::HighFirst.split(second);
            values[1..].copy_from_slice(&[a, b, c, d]);
            len = 5;
        }
        Ok(reply) if bits => {
            values[1] =
                (0..reply.len().min(16)).fold(0, |packed, i| packed | u16::from(reply.bit(i) == Some(true)) << i);
            len = 2;
        }
        Ok(reply) => {
            for (slot, value) in values[1..].iter_mut().zip(reply.registers()) {
                *slot = value;
                len += 1;
            }
        }
        Err(Failure::Exception(code)) => values[0] = u16::from(code.code()),
        Err(Failure::Timeout) => values[0] = 0x100,
        Err(Failure::BadReply) => values[0] = 0x200,
    }
    (values, len)
}

/// Sends `request` and waits for its outcome (this firmware has nothing else to do).
fn ask<R>(slave: SlaveId, request: &Request<'_>, f: impl FnOnce(Result<Reply<'_>, Failure>) -> R) -> Option<R> {
    while MASTER.send(slave, request).is_err() {}
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

    let mut pass = 0u16;
    loop {
        for step in 0..STEPS {
            let (slave, request) = request(step);
            let read = match request {
                Request::ReadCoils { .. } | Request::ReadDiscreteInputs { .. } => Read::Bits,
                _ if step == 14 => Read::Floats,
                _ => Read::Registers,
            };
            let (values, len) = match send(slave, &request) {
                Ok(()) => MASTER.wait_blocking(|outcome| report(outcome, read)).unwrap_or(([0x400, 0, 0, 0, 0], 1)),
                Err(_) => ([0x300, 0, 0, 0, 0], 1),
            };
            let told =
                Request::WriteMultipleRegisters { address: 16 * step, values: values.get(..len).unwrap_or(&values) };
            ask(TOLD, &told, |_| ());
        }
        let c = MASTER.counters();
        pass = pass.wrapping_add(1);
        let counters = [
            c.requests,
            c.crc_errors,
            c.uart_errors,
            c.overruns,
            c.malformed,
            c.replies,
            c.exceptions,
            c.timeouts,
            c.retries,
            c.unexpected,
            pass,
        ];
        ask(TOLD, &Request::WriteMultipleRegisters { address: 240, values: &counters }, |_| ());
    }
}
