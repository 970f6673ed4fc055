//! The master in ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature `ascii`): the
//! request sealed with its LRC and sent as `:`, hex pairs, CR LF; replies received by the
//! receiver the slave uses ([`crate::link::framer::ascii`]) and checked as RTU replies are.
//!
//! ASCII frames carry their own delimiters, and there is no T3.5 to wait for: the master
//! sends when its receiver is outside a frame. That is at once after power-up (as the
//! slave listens at once), once its own request has left the wire, once a frame's LF has
//! left the line (the receive flag comes before the stop bits end: the AVR layer reports
//! the frame when they have), or once the inter-character timeout has dropped a frame
//! that broke off. Characters outside a frame (noise before a `:`) delay nothing.

use super::Engine;

impl<const N: usize> Engine<N> {
    /// Switches between RTU and ASCII framing; call it before the first request.
    pub fn set_ascii(&mut self, on: bool) {
        self.framer.set_ascii(on);
    }

    /// An ASCII character arrived. Returns true when a frame's outcome is due: the caller
    /// calls [`Engine::on_end_deadline`] once the character has left the line (at the LF
    /// that ends a frame, and at a `:` that drops the frame in progress). Characters while
    /// the request goes out are its echo, ignored.
    #[inline(always)]
    pub fn on_char(&mut self, c: u8) -> bool {
        self.hears() && self.framer.on_char(c)
    }

    /// The inter-character timeout passed (ASCII): a frame in progress is dropped and
    /// reported, and a request due goes out.
    pub fn on_char_timeout(&mut self) -> super::Action {
        self.framer.on_gap_deadline();
        self.on_end_deadline()
    }

    /// The line is free for a request: the receiver is outside a frame.
    #[inline(always)]
    pub(super) fn ascii_line_free(&self) -> bool {
        !self.framer.is_in_frame()
    }
}
