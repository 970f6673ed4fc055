//! The chip's and the link's health, from the WIZnet datasheets' register maps (W5500:
//! PHYCFGR bit 0 the link, Sn_IMR 0xFF after a reset; W5100: IMR 0 after a reset): once a
//! second a TCP role reads back one register its set-up wrote ([`Chip::SETTING`]), and on the
//! W5500 the link.
//!
//! A chip that browned out or was reset by the shield's reset line comes back with its
//! defaults (IP 0.0.0.0, sockets closed, that register at its reset value); a hung chip
//! answers nothing (MISO reads 0x00 or 0xFF, neither of which is the value set). Either way
//! it is set up again (`Wiznet::init`: reset, identity, addresses) and its sockets opened
//! again, without a reset of the board; a chip that does not answer is tried again each
//! second, and not served meanwhile. When the link goes, the chip is set up again too: its
//! reset closes every connection (their masters are gone with the link), and the sockets
//! listen again, ready for the link's return.

use super::network::Network;
use super::server::{Server, Sockets};
use super::wiznet::{Block, Bus, Chip, Wiznet};

/// What the health check asks of a chip.
pub trait Watch {
    /// True when the chip answers as itself and still holds the settings the firmware gave
    /// it.
    fn configured(&mut self) -> bool;
    /// True while the link is up (always on a chip that cannot tell, the W5100).
    fn link(&mut self) -> bool;
    /// Resets the chip and sets it up with `network`'s addresses; false when it does not
    /// answer as itself.
    fn restart(&mut self, network: &Network) -> bool;
}

impl<C: Chip, B: Bus> Watch for Wiznet<C, B> {
    /// One read: the register `init` set ([`Chip::SETTING`]), which neither a reset chip nor
    /// a hung one reads as set.
    fn configured(&mut self) -> bool {
        let (block, register, value) = C::SETTING;
        self.get(block, register) == value
    }

    fn link(&mut self) -> bool {
        C::LINK.map_or(true, |register| self.get(Block::COMMON, register) & 1 != 0)
    }

    fn restart(&mut self, network: &Network) -> bool {
        // Bounded waits only (`Wiznet::init`): this runs in the poll's interrupt.
        self.init(network)
    }
}

/// What the check found, and what the role does next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// All well: serve.
    Serve,
    /// The chip was set up again (it lost its settings, or the link went): every socket is
    /// closed, to be opened again.
    Reopen,
    /// The chip does not answer: not served until the next check.
    Wait,
}

/// The chip's and the link's state as the last check saw them, and what happened so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Health {
    /// The chip lost its settings and could not be set up again yet.
    lost: bool,
    /// The link was down at the last check.
    down: bool,
    /// The chip set up again after it lost its settings or stopped answering, and the times
    /// the link went down (each wrapping).
    counts: [u16; 2],
}

/// Where each count is in [`Health::counts`].
const RESTARTS: usize = 0;
const LOSSES: usize = 1;

impl Health {
    /// Before the first check: the chip set up, the link taken to be up.
    pub const fn new() -> Self {
        Health { lost: false, down: false, counts: [0; 2] }
    }

    /// The check, once a second: the chip set up again when it lost its settings (counted
    /// as a reset) or when the link went (counted as a loss): the reset closes every socket,
    /// and with them the connections of masters that are gone.
    pub fn check<W: Watch>(&mut self, chip: &mut W, network: &Network) -> Verdict {
        let why = if self.lost || !chip.configured() {
            RESTARTS
        } else {
            // The link is read only from a chip that answers (a hung one reads 0x00 or 0xFF).
            let was_down = self.down;
            self.down = !chip.link();
            if !self.down || was_down {
                return Verdict::Serve;
            }
            LOSSES
        };
        self.lost = !chip.restart(network);
        if self.lost {
            // Counted once it answers again.
            return Verdict::Wait;
        }
        self.counts[why] = self.counts[why].wrapping_add(1);
        Verdict::Reopen
    }

    /// True while the chip answers and (W5500) its link is up, as of the last check.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    pub fn link_up(&self) -> bool {
        !self.lost && !self.down
    }

    /// True while the chip is not served: it lost its settings and does not answer yet.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// Times the chip was set up again (wrapping).
    pub fn restarts(&self) -> u16 {
        self.counts[RESTARTS]
    }

    /// Times the link went down (wrapping).
    pub fn losses(&self) -> u16 {
        self.counts[LOSSES]
    }
}

impl<const B: usize> Server<B> {
    /// The once-a-second health check ([`Health::check`]), before the poll with `second`:
    /// when the chip was set up again (it lost its settings, or the link went), its sockets
    /// are closed, and that poll, which looks at every socket, opens each again (an answer
    /// still to come for one of their connections finds it gone). False while the chip does
    /// not answer: it is not served then.
    pub fn check<S: Sockets + Watch>(&mut self, chip: &mut S, net: &Network) -> bool {
        self.health.check(chip, net) != Verdict::Wait
    }
}

#[cfg(test)]
mod tests;
