//! An ASCII line (feature `ascii`, Serial Line §2.5.2) as the AVR layer feeds it to the
//! slave in ASCII mode: characters, the inter-character timeout, damaged characters, the
//! end of a reply; checked against the model's reference ASCII receiver and, for each
//! whole frame, against its RTU twin in the model: executed exactly when the twin would
//! be, with the same reply (LRC for CRC) written out in hex; anything malformed silent and
//! counted.
//!
//! Input: two bytes of salt (the bank's starting values; the high byte picks the
//! identification FC 43 reports), then events, each an opcode byte (its low three bits) and
//! what that event needs: 0–1 any character (the next byte); 2 one of the characters
//! frames are made of, `0-9A-Fa-f:` CR LF (the opcode's high bits); 3 a byte as two hex
//! digits (opcode bit 3: lower case); 4 the timeout; 5 a damaged character; 6 the reply
//! sent; 7 a request (length byte, then the PDU; opcode bits 6–7 the address: this slave,
//! broadcast, another slave; bit 3 lower case, bit 5 no CR LF; bit 4 a wrong LRC, the
//! right one's bits flipped by the byte after the PDU).
#![no_main]

#[path = "../../tests/common/mod.rs"]
mod common;
#[path = "../../tests/model/mod.rs"]
mod model;

use avr_modbus::internal::UartError;
use libfuzzer_sys::fuzz_target;
use model::ascii::{lrc, request, run_ascii_events, AsciiEvent};

/// The characters ASCII frames are made of.
const FRAMING: &[u8] = b"0123456789ABCDEFabcdef:\r\n";

fn events(mut data: &[u8]) -> Vec<AsciiEvent> {
    let mut events = Vec::new();
    let mut next = || {
        let (&byte, rest) = data.split_first()?;
        data = rest;
        Some(byte)
    };
    while let Some(op) = next() {
        let lower = op & 0b1000 != 0;
        let event = match op & 0b111 {
            0 | 1 => AsciiEvent::Char(next().unwrap_or(op)),
            2 => AsciiEvent::Char(FRAMING[usize::from(op >> 3) % FRAMING.len()]),
            3 => {
                let text = format!("{:02X}", next().unwrap_or(op));
                AsciiEvent::Text(if lower { text.to_ascii_lowercase() } else { text }.into_bytes())
            }
            4 => AsciiEvent::Timeout,
            5 => {
                AsciiEvent::Error([UartError::Parity, UartError::Framing, UartError::Overrun][usize::from(op >> 3) % 3])
            }
            6 => AsciiEvent::ReplySent,
            _ => {
                let len = usize::from(next().unwrap_or(0));
                let address = [model::ID, 0, model::ID + 1, model::ID][usize::from(op >> 6)];
                let mut frame = vec![address];
                frame.extend((0..len).map_while(|_| next()));
                let mut text = request(&frame, lower);
                let n = text.len();
                if op & 0b1_0000 != 0 {
                    // The LRC's digits of another value: its bits flipped where the next
                    // byte has ones (at least one).
                    let wrong = format!("{:02X}", lrc(&frame) ^ next().unwrap_or(1).max(1));
                    text[n - 4..n - 2].copy_from_slice(wrong.as_bytes());
                }
                if op & 0b10_0000 != 0 {
                    text.truncate(n - 2);
                }
                AsciiEvent::Text(text)
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
    slave.set_ascii(true);
    if let Err(message) = run_ascii_events(&mut slave, &mut bank, &mut reference, &events(rest)) {
        panic!("{message}");
    }
});
