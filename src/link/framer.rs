//! RTU framing by silence, Modbus over Serial Line v1.02 §2.5.1.1 (the receiver's state
//! diagram, figure 14) and §2.5.1.2 (CRC).
//!
//! A pure state machine fed with what the USART and Timer0 report: a character, a
//! damaged character, the gap deadline (a character after it had a gap longer than T1.5),
//! the end deadline (T3.5 of silence). The caller restarts its timer on every character.
//! Bytes land in one buffer of `N` bytes (256 unless the data model needs fewer, see
//! [`crate::DataModel::FRAME`]) and nothing more happens per byte, which keeps the receive
//! interrupt short; the CRC is checked over the stored frame once it has ended, at the gap
//! deadline (which passes before T3.5), or at T3.5 if no gap deadline was reported.
//!
//! A frame longer than the buffer (up to the 256 bytes the spec allows) is still received
//! whole: the bytes past the buffer are counted and folded into a CRC of their own as they
//! arrive, which the check joins to the stored bytes' CRC ([`Crc16::join`]). The engine
//! then answers it from its first bytes as a 256-byte buffer would.

use crate::link::crc::Crc16;

#[cfg(feature = "ascii")]
pub mod ascii;

/// Largest RTU frame: address, PDU of up to 253 bytes, CRC.
pub const MAX_FRAME: usize = 256;
const _: () = assert!(MAX_FRAME == 256, "the framer counts stored bytes in a byte, modulo 256");
/// Shortest frame the framer hands on: address, function code, CRC.
pub const MIN_FRAME: usize = 4;
/// Smallest frame buffer: the longest fixed-size request and reply (FC 1–6: address,
/// 5-byte PDU, CRC), which also holds every header the engine reads.
pub const MIN_CAPACITY: usize = 8;

/// Why a frame was dropped in silence (never answered with an exception).
///
/// Half a value is the place of the counter it goes to among either role's counters (CRC
/// errors 1, UART errors 2, overruns 3, malformed frames 4): a shift, where choosing the
/// counter took a chain of comparisons. `Uart` is 4 as the receiver's `State::Broken` is,
/// so that the receive interrupt's error path loads the one value for both.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// Fewer than 4 bytes between two T3.5 silences.
    TooShort = 8,
    /// More than 256 bytes: the rest was discarded without being stored.
    TooLong = 7,
    /// The CRC did not check.
    BadCrc = 2,
    /// A character came after a silence longer than T1.5 but shorter than T3.5.
    Gap = 9,
    /// A character had a parity or framing error.
    Uart = 4,
    /// The USART lost a character (data overrun).
    Overrun = 6,
    /// ASCII framing (feature `ascii`): a character that is not a hex digit, an odd number
    /// of hex digits, or anything but LF after CR.
    #[cfg(feature = "ascii")]
    Encoding = 10,
}

impl FrameError {
    /// The place of the counter a frame dropped for this error goes to, the same among the
    /// slave's counters and the master's: half the value (CRC errors 1, UART errors 2,
    /// overruns 3, malformed frames 4); ASCII's encoding errors are malformed frames.
    pub(crate) const fn counter(self) -> u8 {
        #[cfg(feature = "ascii")]
        if matches!(self, FrameError::Encoding) {
            return 4;
        }
        self as u8 >> 1
    }
}

/// What the USART reported about a damaged character.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UartError {
    /// Wrong parity bit (UPE0).
    Parity,
    /// Missing stop bit (FE0).
    Framing,
    /// A character was lost before this one was read (DOR0).
    Overrun,
}

/// The receiver's state; `Receiving`, the one each character of a frame meets, is 0, which
/// the receive interrupt tests for in fewest instructions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Inside a frame.
    Receiving,
    /// After power-up: waiting for T3.5 of silence before accepting a frame.
    Initial,
    /// Silence reigns: the next character starts a frame.
    Idle,
    /// The gap deadline passed and the frame was checked (`Framer::error`): one more
    /// character breaks it.
    Waiting,
    /// The frame is broken (why: `Framer::error`); the rest is ignored until T3.5.
    Broken,
    /// A frame was handed out and its buffer is in use until [`Framer::release`].
    Busy,
}

/// The receiver of RTU frames; holds the one frame buffer, of `N` bytes (8 to 256).
/// `WHOLE`: a frame longer than the buffer is received whole, its CRC checked (the slave,
/// which answers such a request from its first bytes); without it such a frame is dropped
/// as too long once it overflows the buffer (the master, whose buffer holds the longest
/// reply to its request, so that a longer frame can be no answer).
///
/// In declaration order (`repr(C)`), the two fields that start other than zero first: the
/// rest of a new framer, and of the engine that holds it after its address, is one run of
/// zeros, which the slave's start writes in one go.
#[repr(C)]
#[derive(Clone, Debug)]
pub struct Framer<const N: usize = MAX_FRAME, const WHOLE: bool = true> {
    state: State,
    /// Why the frame is dropped (`Broken`), or the verdict of the checks at the gap
    /// deadline (`Waiting`: `None` for a good frame).
    error: Option<FrameError>,
    /// Bytes stored, modulo 256: inside a frame at least one byte is stored, so 0 there
    /// means all 256 ([`Framer::stored`]). One byte, so the receive interrupt stays short.
    len: u8,
    /// Bytes of the frame past the buffer (only when `N` < 256), 0 outside such a frame.
    past: u8,
    /// Their CRC, folded from [`Crc16::tail`] (which [`Framer::listen`] sets).
    tail: Crc16,
    buf: [u8; N],
    /// ASCII framing's own state (feature `ascii`), off for RTU.
    #[cfg(feature = "ascii")]
    ascii: ascii::Ascii,
}

impl<const N: usize, const WHOLE: bool> Default for Framer<N, WHOLE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const WHOLE: bool> Framer<N, WHOLE> {
    /// The framing the receiver runs: RTU, or ASCII (feature `ascii`).
    #[inline(always)]
    pub(crate) fn framing(&self) -> crate::link::framing::Framing {
        #[cfg(feature = "ascii")]
        if self.ascii.on {
            return crate::link::framing::Framing::Ascii;
        }
        crate::link::framing::Framing::Rtu
    }

    const CAPACITY: () = assert!(N >= MIN_CAPACITY && N <= MAX_FRAME, "a frame buffer holds 8 to 256 bytes");

    /// A framer just after power-up: it waits for T3.5 of silence (the caller starts its
    /// timer at start-up) before it accepts a frame.
    pub const fn new() -> Self {
        let () = Self::CAPACITY;
        Framer {
            buf: [0; N],
            len: 0,
            past: 0,
            tail: Crc16::tail(),
            state: State::Initial,
            error: None,
            #[cfg(feature = "ascii")]
            ascii: ascii::Ascii::OFF,
        }
    }

    /// A character arrived. Inside a frame it is only stored: this runs in the receive
    /// interrupt, once per character.
    #[inline(always)]
    pub fn on_byte(&mut self, byte: u8) {
        if self.state == State::Receiving {
            // One comparison either way: with 256 bytes every `len` is an index and 0 means
            // full; with fewer, the bounds check is the test for a full buffer.
            let len = self.len;
            let at = usize::from(len);
            let slot = if N == MAX_FRAME && at == 0 { None } else { self.buf.get_mut(at) };
            match slot {
                Some(slot) => {
                    *slot = byte;
                    self.len = len.wrapping_add(1);
                }
                None => self.past_buffer(byte),
            }
            return;
        }
        match self.state {
            State::Idle => {
                if let Some(first) = self.buf.first_mut() {
                    *first = byte;
                }
                self.len = 1;
                self.state = State::Receiving;
            }
            State::Waiting => self.break_frame(FrameError::Gap),
            State::Initial | State::Receiving | State::Broken | State::Busy => {}
        }
    }

    /// A character of a frame that fills the buffer: folded into the tail's CRC and
    /// counted, up to 256 bytes in all; one more makes the frame too long (without
    /// `WHOLE`, this one does).
    #[inline(always)]
    fn past_buffer(&mut self, byte: u8) {
        if N == MAX_FRAME || !WHOLE || usize::from(self.past) == MAX_FRAME - N {
            self.break_frame(FrameError::TooLong);
        } else {
            self.tail = self.tail.step(byte);
            self.past += 1;
        }
    }

    /// Bytes stored in the frame so far (inside a frame: 1 to `N`).
    fn stored(&self) -> usize {
        // Only a 256-byte buffer fills up to a count of 0.
        if N == MAX_FRAME && self.len == 0 {
            MAX_FRAME
        } else {
            usize::from(self.len)
        }
    }

    /// Bytes in the frame so far, stored or past the buffer (inside a frame: 1 to 256).
    fn received(&self) -> usize {
        self.stored() + usize::from(self.past)
    }

    /// The length [`Framer::on_end_deadline`] gave the frame it handed out, read again while
    /// the frame is in use (the framer changes nothing of it until [`Framer::release`]).
    pub(crate) fn frame_len(&self) -> usize {
        #[cfg(feature = "ascii")]
        if self.ascii.on {
            return self.ascii_frame_len();
        }
        self.received()
    }

    /// Silence: the next character starts a frame. Not inlined: several paths of the
    /// interrupts end here.
    #[inline(never)]
    fn listen(&mut self) {
        self.idle();
    }

    /// [`Framer::listen`]'s stores, written where they run.
    #[inline(always)]
    fn idle(&mut self) {
        self.state = State::Idle;
        // A 256-byte buffer holds every frame: nothing is past it, and both stay 0.
        if N < MAX_FRAME && WHOLE {
            self.past = 0;
            self.tail = Crc16::tail();
        }
    }

    fn break_frame(&mut self, error: FrameError) {
        self.state = State::Broken;
        self.error = Some(error);
    }

    /// A character arrived damaged: the frame it belongs to is dropped.
    pub fn on_error(&mut self, error: UartError) {
        // In ASCII, damage outside a frame is noise: frames start at `:`.
        #[cfg(feature = "ascii")]
        if self.ascii.on && self.state == State::Idle {
            return;
        }
        let reason = match error {
            UartError::Parity | UartError::Framing => FrameError::Uart,
            UartError::Overrun => FrameError::Overrun,
        };
        match self.state {
            State::Idle | State::Receiving | State::Waiting => self.break_frame(reason),
            State::Initial | State::Broken | State::Busy => {}
        }
    }

    /// The gap deadline passed since the last character: the frame has ended
    /// unless a character breaks it, so its length and CRC are checked now, well before
    /// T3.5.
    pub fn on_gap_deadline(&mut self) {
        #[cfg(feature = "ascii")]
        if self.ascii.on {
            return self.ascii_timeout();
        }
        if self.state == State::Receiving {
            self.error = if self.stored() < MIN_FRAME {
                Some(FrameError::TooShort)
            } else if !self.crc_checks() {
                Some(FrameError::BadCrc)
            } else {
                None
            };
            self.state = State::Waiting;
        }
    }

    /// Whether the frame, stored and past the buffer, ends with its correct CRC.
    fn crc_checks(&self) -> bool {
        let frame = self.buf.get(..self.stored()).unwrap_or(&self.buf);
        let crc = Crc16::new().update_slice(frame);
        if N < MAX_FRAME && WHOLE && self.past != 0 {
            crc.join(self.tail, u16::from(self.past)).is_residue_ok()
        } else {
            crc.is_residue_ok()
        }
    }

    /// T3.5 of silence passed since the last character. Returns the complete
    /// frame's length (with CRC) when one just ended with a good CRC, or why it was
    /// dropped; `None` when no frame was in progress.
    ///
    /// After `Some(Ok(_))` the buffer holds the frame, or its first `N` bytes when it is
    /// longer, and the framer ignores the line until [`Framer::release`].
    pub fn on_end_deadline(&mut self) -> Option<Result<usize, FrameError>> {
        #[cfg(feature = "ascii")]
        if self.ascii.on {
            return self.ascii_end();
        }
        // T3.5 comes after the gap deadline: if that was not reported (host tests,
        // `Engine::handle_frame`), it passes now. On the AVR it always was.
        self.on_gap_deadline();
        match self.state {
            State::Waiting | State::Broken => {}
            State::Initial => {
                self.listen();
                return None;
            }
            State::Receiving | State::Idle | State::Busy => return None,
        }
        Some(match self.error {
            None => {
                self.state = State::Busy;
                Ok(self.received())
            }
            Some(error) => {
                self.listen();
                Err(error)
            }
        })
    }

    /// The frame (or reply) buffer.
    pub fn buffer(&self) -> &[u8; N] {
        &self.buf
    }

    /// The frame (or reply) buffer, to write a reply in place.
    pub fn buffer_mut(&mut self) -> &mut [u8; N] {
        &mut self.buf
    }

    /// The reply (if any) is sent: listen for the next frame.
    #[inline(never)]
    pub fn release(&mut self) {
        if self.state == State::Busy {
            self.listen();
        }
    }

    /// [`Framer::release`] written where it runs: for the transmit-complete interrupt,
    /// which then calls nothing and saves only the registers it uses.
    #[inline(always)]
    pub(crate) fn release_here(&mut self) {
        if self.state == State::Busy {
            self.idle();
        }
    }

    /// True while a handed-out frame or its reply owns the buffer.
    pub fn is_busy(&self) -> bool {
        self.state == State::Busy
    }
}
