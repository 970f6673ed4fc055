//! Whole frames through the slave (`Engine::handle_frame`), one after another, against
//! the reference model: replies (FC 43 / MEI 14 included), end of frame, counters,
//! listen-only mode and the bank.
//!
//! Input: two bytes of salt for the bank's starting values (the high byte picks the
//! identification FC 43 reports, `tests/model/device_id.rs`), then frames, each a length
//! byte `n` (255 means 300 bytes, past the 256-byte limit), a mode byte and up to `n`
//! bytes. Mode bit 0: append a correct CRC; bit 1: address this slave; bit 2: broadcast.
#![no_main]

#[path = "../../tests/common/mod.rs"]
mod common;
#[path = "../../tests/model/mod.rs"]
mod model;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((salt, mut rest)) = data.split_first_chunk::<2>() else { return };
    let (mut bank, mut reference) = model::fixture(u16::from_le_bytes(*salt));
    let mut slave = model::slave();
    while let Some((&[len, mode], tail)) = rest.split_first_chunk::<2>() {
        let n = if len == 255 { 300 } else { usize::from(len) };
        let (bytes, tail) = tail.split_at(n.min(tail.len()));
        rest = tail;
        let mut frame = bytes.to_vec();
        if let Some(address) = frame.first_mut() {
            if mode & 0b010 != 0 {
                *address = model::ID;
            } else if mode & 0b100 != 0 {
                *address = 0;
            }
        }
        if mode & 0b001 != 0 {
            frame = model::with_crc(&frame);
        }
        if let Err(message) = model::exchange(&mut slave, &mut bank, &mut reference, &frame) {
            panic!("{message}");
        }
    }
});
