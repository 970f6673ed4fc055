//! Timer0's part in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature `ascii`):
//! no silences, but the inter-character timeout counted in turns of the timer, and the end
//! of a frame brought out of the receive interrupt once its last character has left the
//! line.

use super::{FrameTimer, Passed, Unit, TCNT0, TIFR0};
use crate::link::timing::Deadline;

/// The compare interrupt's part in ASCII framing: it comes once a turn (1.024 ms, 2.048 ms
/// at 8 MHz) and counts the turns since the last character against the inter-character
/// timeout, and it brings the end of a frame (or of one a `:` dropped) out of the receive
/// interrupt once the character that ended it has left the line (`end`: from its receive
/// flag to its end).
#[derive(Clone, Copy)]
pub(super) struct AsciiTimer {
    pub(super) on: bool,
    /// The timeout in turns, 0 for none.
    pub(super) timeout: u16,
    /// Turns since the last character (up to the timeout).
    pub(super) idle: u16,
    /// A frame's outcome is due: reported at the compare match `end` sets.
    pub(super) end_due: bool,
    /// From a character's receive flag to its end on the line.
    pub(super) end: Deadline,
    /// Matches of the compare value still to let pass before the outcome is reported.
    pub(super) end_turns: u8,
}

impl AsciiTimer {
    /// RTU framing: what the deadlines hold before a role starts.
    pub(super) const OFF: AsciiTimer =
        AsciiTimer { on: false, timeout: 0, idle: 0, end_due: false, end: Deadline { low: 0, turns: 0 }, end_turns: 0 };

    /// A compare interrupt (once a turn, or brought forward by [`FrameTimer::end_now`]).
    #[inline(always)]
    pub(super) fn on_compare(&mut self) -> Passed {
        if self.end_due {
            if self.end_turns != 0 {
                self.end_turns -= 1;
                return Passed::Nothing;
            }
            self.end_due = false;
            return Passed::End;
        }
        if self.timeout != 0 && self.idle < self.timeout {
            self.idle += 1;
            if self.idle == self.timeout {
                return Passed::Gap;
            }
        }
        Passed::Nothing
    }
}

impl<U: Unit> FrameTimer<U> {
    /// ASCII framing (feature `ascii`) with an inter-character timeout of `timeout` turns
    /// (0: none), or RTU; `end`: from a character's receive flag to its end on the line.
    /// Interrupts must be disabled.
    fn set_ascii(&mut self, on: bool, timeout: u16, end: Deadline) {
        // SAFETY: called with interrupts disabled (the slave's start and its settings switch).
        unsafe {
            U::deadlines().with(|d| d.ascii = AsciiTimer { on, timeout, idle: 0, end_due: false, end, end_turns: 0 })
        }
    }

    /// The framing `config` asks for (feature `ascii`): ASCII's timeout and character end
    /// from it, or RTU. Returns true for ASCII. Both roles start (and the slave switches
    /// settings) through here. Interrupts must be disabled.
    pub(crate) fn set_mode(&mut self, config: &crate::link::config::Line) -> bool {
        let ascii = config.mode() != crate::link::config::Mode::Rtu;
        self.set_ascii(ascii, config.char_timeout_turns(), config.char_end());
        ascii
    }

    /// ASCII: a frame's outcome is due (its LF came, or a `:` dropped it): the compare
    /// interrupt reports [`Passed::End`] once the character just received has left the line
    /// (its receive flag came half a bit before its end, or one and a half with two stop
    /// bits), within two ticks after that, so that a reply never starts under its stop bits.
    /// A compare flag already set is noted, as [`Deadlines::set`] notes it. Only from the
    /// receive interrupt.
    #[inline(always)]
    pub(crate) fn end_now(&mut self) {
        // SAFETY: called from the receive interrupt handler, with interrupts disabled.
        unsafe {
            U::deadlines().with(|d| {
                U::OCR.write(TCNT0.read().wrapping_add(d.ascii.end.low));
                d.stale = TIFR0.read();
                d.ascii.end_turns = d.ascii.end.turns;
                d.ascii.end_due = true;
            })
        }
    }
}
