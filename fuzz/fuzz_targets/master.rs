//! Line events as the AVR layer feeds them to the master: requests started, bytes, UART
//! errors, the gap and end deadlines, the clock, the end of the request on the wire. The
//! master must never panic, never take a reply that does not answer its request, and keep
//! its counters consistent.
//!
//! Input: events, each an opcode byte (its low three bits) and what that event needs:
//! 0–2 a byte, 3 the gap deadline, 4 T3.5, 5 a UART error, 6 the request sent (the clock
//! byte after it), 7 a request (function selector, slave, address, quantity) or the clock
//! moving on (high bit set: milliseconds in the next byte, × 8).
#![no_main]

use avr_modbus::internal::UartError;
use avr_modbus::master::internal::Engine;
use avr_modbus::master::{Request, Timeouts};
use libfuzzer_sys::fuzz_target;

/// The frame a good answer to `request` (address to CRC) must be, judged apart from the
/// crate: its PDU after the function code, as `Reply::data` hands it.
fn answers(request: &[u8], data: &[u8]) -> bool {
    let quantity = usize::from(u16::from_be_bytes([request[4], request[5]]));
    match request[1] {
        1 | 2 => data.len() == 1 + quantity.div_ceil(8) && usize::from(data[0]) == quantity.div_ceil(8),
        3 | 4 | 0x17 => data.len() == 1 + 2 * quantity && usize::from(data[0]) == 2 * quantity,
        _ => data.len() == 4 && data == &request[2..6],
    }
}

fuzz_target!(|data: &[u8]| {
    let mut master: Engine<64> = Engine::new();
    master.set_timeouts(Timeouts { response_ms: 50, turnaround_ms: 10, retries: 1 });
    let mut now = 0u32;
    let mut input = data.iter().copied();
    let values = [0x1234u16, 0xFFFF, 0];
    let coils = [true, false, true];
    while let Some(op) = input.next() {
        match op & 0b111 {
            0..=2 => master.on_byte(input.next().unwrap_or(op)),
            3 => master.on_gap_deadline(),
            4 => {
                master.on_end_deadline();
            }
            5 => master.on_error([UartError::Parity, UartError::Framing, UartError::Overrun][usize::from(op >> 3) % 3]),
            6 => master.on_sent(now),
            _ if op & 0x80 != 0 => {
                now = now.wrapping_add(u32::from(input.next().unwrap_or(1)) * 8);
                master.on_tick(now);
            }
            _ => {
                let selector = input.next().unwrap_or(0);
                let slave = input.next().unwrap_or(1) % 4;
                let address = u16::from(input.next().unwrap_or(0));
                let quantity = u16::from(input.next().unwrap_or(1) % 40);
                let request = match selector % 9 {
                    0 => Request::ReadCoils { address, quantity },
                    1 => Request::ReadDiscreteInputs { address, quantity },
                    2 => Request::ReadHoldingRegisters { address, quantity },
                    3 => Request::ReadInputRegisters { address, quantity },
                    4 => Request::WriteSingleCoil { address, value: quantity & 1 == 1 },
                    5 => Request::WriteSingleRegister { address, value: quantity },
                    6 => Request::WriteMultipleCoils { address, values: &coils },
                    7 => Request::WriteMultipleRegisters { address, values: &values },
                    _ => Request::ReadWriteMultipleRegisters {
                        read_address: address,
                        read_quantity: quantity,
                        write_address: 0,
                        values: &values[..1],
                    },
                };
                let _ = master.start(slave, &request);
            }
        }
        if let Some(Ok(reply)) = master.outcome() {
            let request = master.request();
            if request[0] != 0 {
                assert!(answers(request, reply.data()), "took {:02X?} for {:02X?}", reply.data(), request);
                assert_eq!(reply.function().code(), request[1]);
            }
        }
        let c = master.counters();
        assert!(c.replies <= c.requests && c.exceptions <= c.replies && c.retries <= c.requests, "{c:?}");
    }
});
