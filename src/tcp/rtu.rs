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

/// Each function code's frame up to FC 24 (0x18), by code: an even entry is the frame's
/// length, an odd one the place of its byte count plus one, 0 a code with no length to read
/// (FC 43, 0x2B, the one past 24 with a length, is 7 bytes).
#[cfg_attr(target_arch = "avr", allow(unsafe_code), link_section = ".progmem.data")]
static FRAMES: [u8; 25] = [
    0, 8, 8, 8, 8, 8, 8, 4, 8, 0, 0, 4, 4, 0, 0, //   0-14: FC 1-6, 8; 7, 11, 12
    7, 7, // 15, 16: byte count at 6
    4, 0, 0, // 17-19: FC 17
    3, 3, // 20, 21: byte count at 2
    10, 11, 6, // 22: 10 bytes; 23: byte count at 10; 24: 6 bytes
];

/// [`FRAMES`]'s entry for `code` (0 past it).
fn entry(code: u8) -> u8 {
    let Some(entry) = FRAMES.get(usize::from(code)) else { return 0 };
    #[cfg(target_arch = "avr")]
    {
        let byte: u8;
        #[allow(unsafe_code)]
        // SAFETY: `lpm` reads a byte of program memory, where `FRAMES` is (its link
        // section), at `entry`, inside it; it touches nothing else.
        unsafe {
            core::arch::asm!(
                "lpm {byte}, Z",
                byte = out(reg) byte,
                in("Z") entry as *const u8,
                options(pure, readonly, nostack, preserves_flags),
            );
        }
        byte
    }
    #[cfg(not(target_arch = "avr"))]
    *entry
}

/// The length of the frame starting with `head` (its first bytes received; FC 23's byte
/// count, the 11th byte, is the furthest it looks),
/// from its function code and, for codes with data, its byte count; `received` bytes are
/// there in all. `None` while `head` is too short to tell; a length outside 4–256 is no
/// frame.
pub(crate) fn frame_len(head: &[u8], received: u16) -> Option<u16> {
    let code = *head.get(1)?;
    if code == 0x2B {
        return Some(7);
    }
    let entry = entry(code);
    if entry == 0 {
        return Some(received);
    }
    if entry & 1 == 0 {
        return Some(u16::from(entry));
    }
    // The frame: up to its byte count, the count, the data counted, 2 bytes of CRC.
    let count_at = entry - 1;
    head.get(usize::from(count_at)).map(|&n| u16::from(count_at) + 3 + u16::from(n))
}

#[cfg(test)]
mod tests;
