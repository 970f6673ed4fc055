//! The link layer both roles share, Modbus over Serial Line v1.02 §2.5: the line's
//! configuration, the character times and Timer0's arithmetic, the RTU framer (frames by
//! silence, CRC-16) and ASCII framing (frames by `:` and CR LF, LRC). The slave
//! (`crate::slave`) and the master (`crate::master`) sit above it; the AVR layer
//! (`crate::avr`) drives it from the USART's and Timer0's interrupts.

pub(crate) mod config;
pub(crate) mod crc;
pub(crate) mod framer;
pub(crate) mod framing;
pub(crate) mod timing;

use framer::UartError;

/// What a role's protocol state takes from the line, the same for the slave and the
/// master: characters of RTU frames and their damage, or with feature `ascii` the
/// characters of ASCII frames. The AVR layer's receive interrupt hands each one over
/// through this, whichever role it serves.
#[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
pub(crate) trait Receive {
    /// A character of an RTU frame arrived.
    fn on_byte(&mut self, byte: u8);
    /// A damaged character arrived (parity, framing, overrun).
    fn on_error(&mut self, error: UartError);
    /// The framing the line runs, which says which of the two next calls a character takes.
    fn framing(&self) -> framing::Framing;
    /// A character of an ASCII frame arrived: true when the frame's outcome is due, once
    /// the character has left the line.
    #[cfg(feature = "ascii")]
    fn on_char(&mut self, c: u8) -> bool;
}

/// One more in the counter at `at` of a role's `counts` (their order is the role's counters'
/// fields; a damaged frame's place is [`framer::FrameError::counter`] in both), wrapping at
/// 65535. Not inlined: a call where an inlined increment of a counter at a fixed address
/// takes twice the flash, and both roles count from a dozen places.
#[inline(never)]
pub(crate) fn bump(counts: &mut [u16], at: u8) {
    if let Some(count) = counts.get_mut(usize::from(at)) {
        *count = count.wrapping_add(1);
    }
}
