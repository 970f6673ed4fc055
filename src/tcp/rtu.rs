//! Modbus RTU over TCP's framing (feature `rtu-over-tcp`): the serial line's frame, Modbus
//! over Serial Line v1.02 §2.5.1 (address, PDU, CRC-16 low byte first), on a TCP stream with
//! no MBAP header and no silences.
//!
//! With no silence to end a frame, a request's length comes from its function code and its
//! length fields (Application Protocol v1.1b3 §6), as pymodbus's RTU framer finds it:
//!
//! | function codes | frame | bytes |
//! |---|---|---|
//! | 1–6, 8 | address, code, two 16-bit fields, CRC | 8 |
//! | 7, 11, 12, 17 | address, code, CRC | 4 |
//! | 15, 16 | address, code, start, quantity, byte count n at 6, n bytes, CRC | 9 + n |
//! | 20, 21 | address, code, byte count n at 2, n bytes, CRC | 5 + n |
//! | 22 | address, code, reference, AND and OR masks, CRC | 10 |
//! | 23 | address, code, read and write start and quantity, byte count n at 10, n bytes, CRC | 13 + n |
//! | 24 | address, code, FIFO pointer, CRC | 6 |
//! | 43 | address, code, MEI type 14, read code, object id, CRC | 7 |
//!
//! Any other code has no length to read: the frame is taken to be every byte received so
//! far (a master waits for its answer before it sends again, so that is the usual case),
//! and its CRC decides; a good one gets the server's exception 01, as over MBAP. A frame
//! longer than 256 bytes (Serial Line §2.5.1.1's limit) cannot be one.
//!
//! A bad CRC is what a damaged frame is on the serial line (§2.4): silence and a counter. The
//! stream is then out of step: where the next frame starts is unknown, so everything
//! received is discarded, and the stream starts again with the master's next request (sent
//! after its timeout, in a segment of its own).

/// The fewest bytes a frame has: address, function code, CRC.
pub(crate) const MIN_FRAME: u16 = 4;

/// The most bytes a frame has (Serial Line §2.5.1.1).
pub(crate) const MAX_FRAME: u16 = 256;

/// The length of the frame starting with `head` (its first bytes received; FC 23's byte
/// count, the 11th byte, is the furthest it looks),
/// from its function code and, for codes with data, its byte count; `received` bytes are
/// there in all. `None` while `head` is too short to tell; a length outside 4–256 is no
/// frame.
pub(crate) fn frame_len(head: &[u8], received: u16) -> Option<u16> {
    // The frame's length, or where its byte count is: the frame is then that place, the
    // count, the data counted and 2 bytes of CRC long.
    let count_at: u8 = match *head.get(1)? {
        0x01..=0x06 | 0x08 => return Some(8),
        0x07 | 0x0B | 0x0C | 0x11 => return Some(4),
        0x16 => return Some(10),
        0x18 => return Some(6),
        0x2B => return Some(7),
        0x0F | 0x10 => 6,
        0x14 | 0x15 => 2,
        0x17 => 10,
        _ => return Some(received),
    };
    head.get(usize::from(count_at)).map(|&n| u16::from(count_at) + 3 + u16::from(n))
}

#[cfg(test)]
mod tests;
