//! The slave's interrupts in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature
//! `ascii`): every character goes to the framer, which finds the frame's `:` and CR LF;
//! Timer0's compare unit brings a frame's end out of the receive interrupt once its LF has
//! left the line, or drops a frame the inter-character timeout broke off. The reply starts
//! with `:` from that interrupt and goes out in hex, its LRC and CR LF last.

use embedded_hal::digital::OutputPin;

use super::super::timer::Passed;
use super::Running;
use crate::link::framer::ascii::{encoded_char, encoded_len, COLON};
use crate::slave::engine::EndOfFrame;
use crate::slave::model::DataModel;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Running<M, DE, LED, N, U> {
    /// USART RX complete in ASCII framing: a character (or a damaged one) for the framer;
    /// its LF ends the frame once it has left the line.
    #[inline(always)]
    pub(super) fn on_ascii_rx(&mut self) {
        match self.usart.read() {
            Ok(c) => {
                if self.engine.on_char(c) {
                    self.timer.end_now();
                }
            }
            Err(e) => self.engine.on_error(e),
        }
    }

    /// Timer0 compare B in ASCII framing: a frame's end, or the inter-character timeout,
    /// which drops the frame in progress (reported as the frame's end is). A frame for this
    /// slave is answered from here, `:` first.
    #[inline(always)]
    pub(super) fn on_ascii_compare(&mut self) {
        match self.timer.on_compare() {
            Passed::Nothing => return,
            Passed::Gap => self.engine.on_gap_deadline(),
            Passed::End => {}
            // No reply delay in ASCII framing: none is ever set.
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => return,
        }
        if self.engine.on_end_deadline() == EndOfFrame::Reply {
            let _ = self.driver_enable.set_high();
            let _ = self.led.set_high();
            self.usart.write(COLON);
            self.tx_next = 1;
        }
        // Executes what `on_end_deadline` accepted and, for a reply, appends its LRC; the
        // rest of the reply's characters follow from the data-register-empty interrupt.
        let bytes = self.engine.process(&mut self.model);
        self.tx_len = if bytes == 0 { 0 } else { encoded_len(bytes) as u16 };
        if self.tx_len != 0 {
            self.usart.start_feeding();
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
