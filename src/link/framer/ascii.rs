//! ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature `ascii`): a frame is `:`,
//! the address, the PDU and the LRC as pairs of hex characters, then CR LF.
//!
//! The receiver shares the [`Framer`]'s buffer and states, and stores the decoded bytes
//! (address, PDU, LRC) as the RTU receiver stores the bytes of a frame, so the engine
//! handles both alike. What differs is the events: a frame starts at `:` wherever it comes
//! (a new `:` drops the frame in progress), ends at the LF after its CR, and is dropped
//! when the line stays silent for the inter-character timeout (1 s by default) inside it.
//!
//! | state | ASCII meaning |
//! |-------|---------------|
//! | `Idle` | outside a frame: everything but `:` is ignored |
//! | `Receiving` | after `:`: hex pairs, then CR ([`Ascii::after_cr`]), then LF |
//! | `Broken` | the frame went wrong (why: `Framer::error`); the rest is ignored until LF, `:` or the timeout |
//! | `Waiting` | LF came: the frame is complete and checked (`Framer::error`), for [`Framer::on_end_deadline`] |
//! | `Busy` | handed out, as for RTU |
//!
//! A frame's outcome is reported once, by [`Framer::on_end_deadline`], which the caller
//! calls when [`Framer::on_char`] returns true (at the LF that ends a frame, good or
//! broken, and at a `:` that drops a frame in progress) and after the timeout
//! ([`Framer::on_gap_deadline`]). Checks at the LF, in this order: a frame broken before
//! (a character that is not a hex digit, an odd number of them, anything but LF after CR:
//! [`FrameError::Encoding`]; more than 513 characters or bytes past 256:
//! [`FrameError::TooLong`]; a damaged character), fewer than 3 bytes
//! ([`FrameError::TooShort`]), a wrong LRC ([`FrameError::BadCrc`], the serial checksum).

use super::{FrameError, Framer, State};

/// Start of a frame.
pub const COLON: u8 = b':';
/// First character of a frame's end.
pub const CR: u8 = b'\r';
/// Last character of a frame.
pub const LF: u8 = b'\n';

/// The most characters a frame has: `:`, 255 bytes (address, 253 bytes of PDU, LRC) as
/// 510 hex characters, CR, LF.
pub const MAX_CHARS: u16 = 513;

/// The most bytes a frame has: address, PDU and LRC.
const MAX_BYTES: usize = 255;

/// The LRC of `bytes`, §2.5.2.2: the two's complement of their 8-bit sum. A frame whose
/// bytes, LRC included, sum to 0 checks.
pub fn lrc(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |sum, &b| sum.wrapping_add(b)).wrapping_neg()
}

/// The value of a hex digit, upper or lower case; `None` for any other character.
pub const fn hex_value(c: u8) -> Option<u8> {
    let digit = c.wrapping_sub(b'0');
    if digit < 10 {
        return Some(digit);
    }
    // Lower case is upper case with bit 5 set.
    let letter = (c | 0x20).wrapping_sub(b'a');
    if letter < 6 {
        Some(letter + 10)
    } else {
        None
    }
}

/// The upper-case hex digit of `nibble` (0–15): arithmetic, where a table would be copied
/// to RAM.
pub const fn hex_digit(nibble: u8) -> u8 {
    let nibble = nibble & 0x0F;
    if nibble < 10 {
        b'0' + nibble
    } else {
        b'A' + nibble - 10
    }
}

/// Characters of the ASCII frame of `bytes` bytes (address, PDU, LRC): `:`, two hex
/// digits a byte, CR, LF.
pub const fn encoded_len(bytes: usize) -> usize {
    1 + 2 * bytes + 2
}

/// Character `i` of the ASCII frame of `frame` (address, PDU, LRC): `:`, the bytes' hex
/// digits (high nibble first, upper case), CR, LF; 0 past the end.
pub fn encoded_char(frame: &[u8], i: usize) -> u8 {
    let digits = 2 * frame.len();
    match i {
        0 => COLON,
        i if i <= digits => {
            let byte = frame.get((i - 1) / 2).copied().unwrap_or(0);
            hex_digit(if i % 2 == 1 { byte >> 4 } else { byte })
        }
        i if i == digits + 1 => CR,
        i if i == digits + 2 => LF,
        _ => 0,
    }
}

/// What the ASCII receiver keeps beside the [`Framer`]'s own fields.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ascii {
    /// The line runs ASCII frames: the framer's events follow this module.
    pub on: bool,
    /// A hex digit waits for its pair (its value), `None` between pairs.
    high: Option<u8>,
    /// The 8-bit sum of the bytes so far, LRC included once it came: 0 for a good frame.
    sum: u8,
    /// Characters of the frame so far, `:` included.
    chars: u16,
    /// CR came: only LF may follow.
    after_cr: bool,
    /// A frame dropped by a `:` that started the next one, to report.
    abandoned: Option<FrameError>,
}

impl Ascii {
    /// ASCII framing off: RTU.
    pub const OFF: Ascii = Ascii { on: false, high: None, sum: 0, chars: 0, after_cr: false, abandoned: None };
}

impl<const N: usize, const WHOLE: bool> Framer<N, WHOLE> {
    /// Switches between RTU and ASCII framing (from the next frame on). ASCII needs no
    /// silence before its first frame: the receiver listens at once.
    pub fn set_ascii(&mut self, on: bool) {
        self.ascii = Ascii { on, ..Ascii::OFF };
        if on {
            self.state = State::Idle;
        }
    }

    /// True while the receiver runs ASCII framing.
    pub fn is_ascii(&self) -> bool {
        self.ascii.on
    }

    /// True inside an ASCII frame: from its `:` until its outcome has been reported by
    /// [`Framer::on_end_deadline`] (a frame complete or broken but not yet reported is
    /// still in progress). Outside a frame the line carries nothing that is addressed to
    /// anyone: the master sends its requests then.
    pub fn is_in_frame(&self) -> bool {
        matches!(self.state, State::Receiving | State::Broken | State::Waiting)
    }

    /// An ASCII character arrived. Returns true when a frame's outcome is due: the caller
    /// then calls [`Framer::on_end_deadline`] (at the LF that ends a frame, and at a `:`
    /// that drops the frame in progress).
    pub fn on_char(&mut self, c: u8) -> bool {
        if c == COLON {
            return self.start_ascii();
        }
        match self.state {
            State::Receiving => {}
            State::Broken if c == LF => {
                // The broken frame ends here; its error stays for the report.
                self.state = State::Waiting;
                return true;
            }
            State::Initial | State::Idle | State::Waiting | State::Broken | State::Busy => return false,
        }
        self.ascii.chars += 1;
        if self.ascii.chars > MAX_CHARS {
            self.break_frame(FrameError::TooLong);
            return false;
        }
        if self.ascii.after_cr {
            if c == LF {
                self.end_ascii();
                return true;
            }
            self.break_frame(FrameError::Encoding);
            return false;
        }
        if c == CR {
            if self.ascii.high.is_some() {
                self.break_frame(FrameError::Encoding);
            } else {
                self.ascii.after_cr = true;
            }
            return false;
        }
        let Some(nibble) = hex_value(c) else {
            self.break_frame(FrameError::Encoding);
            return false;
        };
        match self.ascii.high.take() {
            None => self.ascii.high = Some(nibble),
            Some(high) => self.store_ascii((high << 4) | nibble),
        }
        false
    }

    /// `:`: a frame starts, whatever came before. A frame in progress is dropped (as too
    /// short, unless it broke before for a reason of its own), reported at once: returns
    /// true then.
    fn start_ascii(&mut self) -> bool {
        let dropped = match self.state {
            State::Receiving => Some(FrameError::TooShort),
            State::Broken => self.error,
            // A complete frame not yet handed out, or one in use: the master waits for the
            // reply, so this `:` is noise.
            State::Waiting | State::Busy => return false,
            State::Initial | State::Idle => None,
        };
        self.ascii = Ascii { on: true, chars: 1, abandoned: dropped, ..Ascii::OFF };
        self.len = 0;
        self.past = 0;
        self.error = None;
        self.state = State::Receiving;
        dropped.is_some()
    }

    /// A decoded byte: stored, or counted past a full buffer, and summed for the LRC; the
    /// 256th is one too many (a frame is 255 bytes at most, [`MAX_CHARS`]).
    fn store_ascii(&mut self, byte: u8) {
        if usize::from(self.len) + usize::from(self.past) == MAX_BYTES {
            self.break_frame(FrameError::TooLong);
            return;
        }
        self.ascii.sum = self.ascii.sum.wrapping_add(byte);
        match self.buf.get_mut(usize::from(self.len)) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => self.past += 1,
        }
    }

    /// LF after CR: the frame is complete, and checked now.
    fn end_ascii(&mut self) {
        self.error = if usize::from(self.len) + usize::from(self.past) < 3 {
            Some(FrameError::TooShort)
        } else if self.ascii.sum != 0 {
            Some(FrameError::BadCrc)
        } else {
            None
        };
        self.state = State::Waiting;
    }

    /// The inter-character timeout passed inside a frame: it is dropped, reported by
    /// [`Framer::on_end_deadline`] (the caller calls it next), for the fault that broke it
    /// before if one did (counted once, for its first fault, as an RTU frame is), else as a
    /// gap.
    pub(super) fn ascii_timeout(&mut self) {
        match self.state {
            State::Receiving => self.error = Some(FrameError::Gap),
            State::Broken => {}
            State::Initial | State::Idle | State::Waiting | State::Busy => return,
        }
        self.state = State::Waiting;
    }

    /// The length of the frame received, counted as an RTU frame's (see
    /// [`Framer::ascii_end`]).
    pub(super) fn ascii_frame_len(&self) -> usize {
        usize::from(self.len) + usize::from(self.past) + 1
    }

    /// The outcome [`Framer::on_end_deadline`] reports for ASCII: a frame a `:` dropped,
    /// else the frame that ended (LF, or the timeout), with its length counted as an RTU
    /// frame's (address, PDU and a two-byte check: one more than the bytes, which end with
    /// the one-byte LRC), so the engine reads the PDU at the same place.
    pub(super) fn ascii_end(&mut self) -> Option<Result<usize, FrameError>> {
        if let Some(error) = self.ascii.abandoned.take() {
            return Some(Err(error));
        }
        if self.state != State::Waiting {
            return None;
        }
        Some(match self.error {
            None => {
                self.state = State::Busy;
                Ok(self.ascii_frame_len())
            }
            Some(error) => {
                self.state = State::Idle;
                Err(error)
            }
        })
    }
}
