//! The master's interrupts in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature
//! `ascii`): as the slave's ASCII receiver, every character goes to the shared framer, and
//! Timer0's compare unit brings a frame's end out of the receive interrupt once its last
//! character has left the line, or drops a frame the inter-character timeout broke off.
//! Between those, the compare interrupt comes once a turn for the response timeout.

use embedded_hal::digital::OutputPin;

use super::super::clock;
use super::super::timer::Passed;
use super::Running;

impl<DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Running<DE, LED, N, U> {
    /// Timer0 compare A in ASCII framing: a frame's end (its LF, or the `:` that dropped
    /// it, has left the line), the inter-character timeout, or a turn with neither, when
    /// the response timeout and the turnaround delay are checked.
    #[inline(always)]
    pub(super) fn on_ascii_compare(&mut self) {
        let action = match self.timer.on_compare() {
            Passed::Gap => self.engine.on_char_timeout(),
            Passed::End => self.engine.on_end_deadline(),
            Passed::Nothing if self.engine.is_timing() => self.engine.on_tick(clock::millis()),
            Passed::Nothing => return,
            // The slave's reply delay, on compare B: the master sets none on compare A.
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => return,
        };
        self.act(action);
    }
}
