//! How a frame travels on the line, Modbus over Serial Line v1.02 §2.5: what the interrupt
//! code of both roles asks of the framing instead of branching on it. RTU (§2.5.1) sends a
//! frame's bytes as they are, its first the address; ASCII (§2.5.2, feature `ascii`) sends
//! `:`, two hex digits a byte, CR LF. A third framing (Modbus TCP's MBAP header) answers
//! the same questions. Without feature `ascii` there is one framing and every answer is
//! RTU's, known when the firmware is built.

use crate::link::crc::Crc16;
#[cfg(feature = "ascii")]
use crate::link::framer::ascii::{encoded_char, encoded_len, lrc, COLON};

/// The framing a role's line runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Framing {
    /// Binary bytes, frames delimited by silence, a CRC.
    Rtu,
    /// Hex characters from `:` to CR LF, an LRC (feature `ascii`).
    #[cfg(feature = "ascii")]
    Ascii,
}

#[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
impl Framing {
    /// Appends the frame's check to the `body` bytes (address and PDU) at the start of
    /// `buffer`: the CRC-16, low byte first, or the LRC. Returns the frame's length in
    /// bytes; the caller leaves room for the check (the CRC's two bytes whatever the
    /// framing: one bounds check).
    #[inline(always)]
    pub(crate) fn seal(self, buffer: &mut [u8], body: usize) -> usize {
        match self {
            Framing::Rtu => {
                if let Some((frame, crc)) = buffer.get_mut(..body + 2).and_then(<[u8]>::split_last_chunk_mut) {
                    *crc = Crc16::new().update_slice(frame).to_wire();
                }
                body + 2
            }
            #[cfg(feature = "ascii")]
            Framing::Ascii => {
                let sum = lrc(buffer.get(..body).unwrap_or_default());
                if let Some(slot) = buffer.get_mut(body) {
                    *slot = sum;
                }
                body + 1
            }
        }
    }

    /// The first character on the wire of a frame to or from `address`: the address itself,
    /// or `:`.
    #[inline(always)]
    pub(crate) fn first_char(self, address: u8) -> u8 {
        match self {
            Framing::Rtu => address,
            #[cfg(feature = "ascii")]
            Framing::Ascii => COLON,
        }
    }

    /// Characters on the wire for a frame of `bytes` bytes, its check included (0 for none).
    #[inline(always)]
    pub(crate) fn chars(self, bytes: usize) -> usize {
        match self {
            Framing::Rtu => bytes,
            #[cfg(feature = "ascii")]
            Framing::Ascii if bytes != 0 => encoded_len(bytes),
            #[cfg(feature = "ascii")]
            Framing::Ascii => 0,
        }
    }

    /// Character `i` on the wire of the frame of `len` bytes at the start of `buffer` (its
    /// bytes, check included), 0 past its end.
    #[inline(always)]
    pub(crate) fn char_at(self, buffer: &[u8], len: usize, i: usize) -> u8 {
        match self {
            // The length is the sender's to keep: RTU's characters are the buffer's bytes.
            Framing::Rtu => {
                let _ = len;
                buffer.get(i).copied().unwrap_or(0)
            }
            #[cfg(feature = "ascii")]
            Framing::Ascii => encoded_char(buffer.get(..len).unwrap_or_default(), i),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Framing;

    #[test]
    fn rtu_seals_with_the_crc_low_byte_first() {
        // Serial Line v1.02 §2.5.1.2's example: slave 0x11, FC 3 of 3 registers from 0x6B.
        let mut buffer = [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0, 0, 0xEE];
        assert_eq!(Framing::Rtu.seal(&mut buffer, 6), 8);
        assert_eq!(buffer, [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87, 0xEE]);
    }

    #[test]
    fn rtu_sends_the_bytes_as_they_are() {
        let frame = [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87];
        assert_eq!(Framing::Rtu.first_char(0x11), 0x11);
        assert_eq!(Framing::Rtu.chars(frame.len()), 8);
        let wire: Vec<u8> = (0..8).map(|i| Framing::Rtu.char_at(&frame, 8, i)).collect();
        assert_eq!(wire, frame);
        assert_eq!(Framing::Rtu.char_at(&frame, 8, 8), 0);
    }

    #[cfg(feature = "ascii")]
    #[test]
    fn ascii_seals_with_the_lrc() {
        let mut buffer = [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0, 0];
        assert_eq!(Framing::Ascii.seal(&mut buffer, 6), 7);
        assert_eq!(buffer[..7], [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x7E]);
    }

    #[cfg(feature = "ascii")]
    #[test]
    fn ascii_sends_a_colon_two_hex_digits_a_byte_and_cr_lf() {
        // Serial Line v1.02 §2.5.2.1's example: slave 0x11, FC 3 of 3 registers from 0x6B.
        let frame = [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x7E];
        assert_eq!(Framing::Ascii.first_char(0x11), b':');
        assert_eq!(Framing::Ascii.chars(frame.len()), 17);
        assert_eq!(Framing::Ascii.chars(0), 0);
        let wire: Vec<u8> = (0..17).map(|i| Framing::Ascii.char_at(&frame, 7, i)).collect();
        assert_eq!(wire, b":1103006B00037E\r\n");
    }
}
