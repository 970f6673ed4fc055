//! The slave's interrupts in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature
//! `ascii`): every character goes to the framer, which finds the frame's `:` and CR LF;
//! Timer0's compare unit brings a frame's end out of the receive interrupt once its LF has
//! left the line, or drops a frame the inter-character timeout broke off. The reply's
//! characters are the framing's (`crate::link::framing`).

use embedded_hal::digital::OutputPin;

use super::Running;
use crate::avr::timer::Passed;
use crate::slave::model::DataModel;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char>
    Running<M, DE, LED, N, U, C>
{
    /// Timer0's compare unit in ASCII framing: what `passed`, a frame's end (true), or the
    /// inter-character timeout, which has dropped the frame in progress and is reported as a
    /// frame's end is.
    #[inline(always)]
    pub(super) fn ascii_ended(&mut self, passed: Passed) -> bool {
        match passed {
            Passed::Nothing => false,
            Passed::Gap => true,
            Passed::End => true,
            // No reply delay in ASCII framing: none is ever set.
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => false,
        }
    }
}
