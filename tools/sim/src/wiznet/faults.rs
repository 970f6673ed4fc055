//! Faults a test (or a virtual board's command) plays on the chip while the board runs: the
//! link pulled and back, and a chip that hangs and comes back. (A reset while the board runs,
//! a brown-out or the shield's reset line, is [`W5x00::reset`].)
//!
//! While the link is down nothing reaches the chip (a SYN, data, a FIN or an RST from a peer
//! is not delivered: [`W5x00::connect`] finds no socket, [`W5x00::deliver`] takes nothing)
//! and nothing the chip sends arrives: each connection up when the link went is as if its
//! peer vanished ([`W5x00::peer_vanish`]), its data or FIN timing out after the chip's
//! retransmissions, and stays so after the link's return (its peer gave up meanwhile).
//! The W5500's PHYCFGR bit 0 reads the link; the W5100 has no such bit.
//!
//! A hung chip answers every SPI byte with the same value (0x00 or 0xFF, as a chip that
//! drives MISO no more or holds it) and takes no write; nothing reaches it from the network
//! either (as with the link down), but its connections are kept as they were.

use super::W5x00;

impl W5x00 {
    /// The link goes down (`false`: a cable pulled, a switch rebooting) or comes back up.
    pub fn set_link(&mut self, up: bool) {
        if self.link && !up {
            for n in 0..self.sockets.len() {
                self.peer_vanish(n);
            }
        }
        self.link = up;
    }

    /// Whether the link is up.
    pub fn link_up(&self) -> bool {
        self.link
    }

    /// The chip hangs: MISO reads `miso` (0x00 or 0xFF) for every byte, writes are ignored,
    /// until [`W5x00::unhang`].
    pub fn hang(&mut self, miso: u8) {
        self.hung = Some(miso);
    }

    /// The chip answers again, its registers and sockets as they were when it hung (the
    /// frame under way forgotten: the next one starts at the next chip select).
    pub fn unhang(&mut self) {
        self.hung = None;
        self.frame = Default::default();
    }

    /// Whether what a peer sends reaches the chip: the link up and the chip not hung.
    pub(crate) fn reachable(&self) -> bool {
        self.link && self.hung.is_none()
    }

    /// The value MISO is stuck at while the chip hangs.
    pub fn hung(&self) -> Option<u8> {
        self.hung
    }
}
