//! A board's USART off the line, on a pty of its own (`usartN=pty:PATH`): a Mega gateway's
//! other side, where an outside master (mbpoll, QModMaster) polls it while the board works
//! the line. Timed as the virtual Uno's port is (`wire`): bytes from the pty reach the
//! USART one character time apart, bytes from it reach the pty once their stop bit ends.

use crate::line::Settings;
use crate::pty::{Link, Pty};
use crate::wire::{LineReport, Wire};

/// The pty, its link and the wire to the USART.
pub struct Side {
    /// The USART.
    pub usart: u8,
    /// The pty.
    pub pty: Pty,
    /// The symlink's path.
    pub link_path: std::path::PathBuf,
    _link: Link,
    wire: Wire,
    /// The USART's settings last reported.
    pub serial: Option<Settings>,
}

impl Side {
    /// USART`usart` on `pty`.
    pub fn new(usart: u8, pty: Pty, link_path: std::path::PathBuf, link: Link) -> Side {
        Side { usart, pty, link_path, _link: link, wire: Wire::new(usart), serial: None }
    }

    /// Bytes the outside program wrote: scheduled towards the USART. Returns what its line
    /// settings mean against the firmware's, when that changed.
    pub fn received(&mut self, uno: &mut uno_sim::Uno, bytes: &[u8]) -> Result<Option<LineReport>, String> {
        let master = self.pty.master_settings().map_err(|e| format!("reading the pty's settings: {e}"))?;
        self.wire.receive(uno, bytes, master).map_err(|e| e.to_string())
    }

    /// What the USART has finished sending, to the pty.
    pub fn transmit(&mut self, uno: &mut uno_sim::Uno) -> Result<(), String> {
        self.wire.transmit(uno, &mut self.pty).map_err(|e| format!("writing the pty: {e}"))
    }

    /// Bytes from the pty to the USART and back so far.
    pub fn counts(&self) -> (u64, u64) {
        self.wire.counts()
    }
}
