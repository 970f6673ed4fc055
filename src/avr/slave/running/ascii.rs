//! The slave's interrupts in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature
//! `ascii`): every character goes to the framer, which finds the frame's `:` and CR LF;
//! Timer0's compare unit brings a frame's end out of the receive interrupt once its LF has
//! left the line, or drops a frame the inter-character timeout broke off. The reply (begun
//! with `:` where the RTU one begins with the address) goes out in hex, its LRC and CR LF
//! last.

use embedded_hal::digital::OutputPin;

use super::Running;
use crate::avr::timer::Passed;
use crate::link::framer::ascii::encoded_char;
use crate::slave::model::DataModel;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Running<M, DE, LED, N, U> {
    /// Timer0 compare B in ASCII framing: what `passed`, a frame's end (true), or the
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

    /// USART data register empty in ASCII framing: the reply's next character.
    #[inline(always)]
    pub(super) fn on_ascii_udre(&mut self) {
        let next = self.tx_next;
        self.usart.write(encoded_char(self.engine.reply(), usize::from(next)));
        self.tx_next = next + 1;
        if self.tx_next == self.tx_len {
            self.usart.last_written();
        }
    }
}
