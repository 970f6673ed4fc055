//! Event sequences as the AVR layer feeds them to the slave: bytes, UART errors, the gap
//! and end deadlines, whole requests byte by byte, processing and the end of a reply;
//! checked against the reference receiver of Serial Line §2.5.1.1 and the model.
//!
//! Input: two bytes of salt (the bank's starting values; the high byte picks the
//! identification FC 43 reports), then events, each an opcode byte (its low three bits) and
//! what that event needs: 0–2 a byte, 3 the gap deadline, 4 T3.5, 5 a UART error, 6 the
//! reply sent, 7 a request (length byte, then the PDU; address and CRC added).
#![no_main]

#[path = "../../tests/common/mod.rs"]
mod common;
#[path = "../../tests/model/mod.rs"]
mod model;

use avr_modbus::internal::UartError;
use libfuzzer_sys::fuzz_target;
use model::Event;

fn events(mut data: &[u8]) -> Vec<Event> {
    let mut events = Vec::new();
    let mut next = || {
        let (&byte, rest) = data.split_first()?;
        data = rest;
        Some(byte)
    };
    while let Some(op) = next() {
        let event = match op & 0b111 {
            0..=2 => Event::Byte(next().unwrap_or(op)),
            3 => Event::Gap,
            4 => Event::End,
            5 => Event::Error([UartError::Parity, UartError::Framing, UartError::Overrun][usize::from(op >> 3) % 3]),
            6 => Event::ReplySent,
            _ => {
                let len = usize::from(next().unwrap_or(0));
                let mut frame = vec![if op & 0x80 != 0 { 0 } else { model::ID }];
                frame.extend((0..len).map_while(|_| next()));
                Event::Request(model::with_crc(&frame))
            }
        };
        events.push(event);
    }
    events
}

fuzz_target!(|data: &[u8]| {
    let Some((salt, rest)) = data.split_first_chunk::<2>() else { return };
    let (mut bank, mut reference) = model::fixture(u16::from_le_bytes(*salt));
    let mut slave = model::slave();
    if let Err(message) = model::run_events(&mut slave, &mut bank, &mut reference, &events(rest)) {
        panic!("{message}");
    }
});
