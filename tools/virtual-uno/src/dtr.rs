//! Auto-reset: a real Uno or Mega resets when a program opens its USB serial port (the
//! port's DTR line goes active and pulses RESET through a 100 nF capacitor). A pty has no
//! DTR, so the opens are watched instead, with inotify on the pty's device: the board
//! resets when the first program opens it, not when a second one opens it beside the first
//! (DTR is already active then) nor when the last one closes it.

use std::os::fd::{AsFd, BorrowedFd};
use std::path::Path;

use nix::sys::inotify::{AddWatchFlags, InitFlags, Inotify};

/// Opens of the pty by other programs.
pub struct Dtr {
    inotify: Inotify,
    open: u64,
}

impl Dtr {
    /// Watches `pty` (its `/dev/pts/N`). Our own descriptors are already open: not counted.
    pub fn watch(pty: &Path) -> nix::Result<Dtr> {
        let inotify = Inotify::init(InitFlags::IN_NONBLOCK | InitFlags::IN_CLOEXEC)?;
        let flags = AddWatchFlags::IN_OPEN | AddWatchFlags::IN_CLOSE_WRITE | AddWatchFlags::IN_CLOSE_NOWRITE;
        inotify.add_watch(pty, flags)?;
        Ok(Dtr { inotify, open: 0 })
    }

    /// For `poll`: readable when the pty was opened or closed.
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.inotify.as_fd()
    }

    /// Reads the opens and closes since the last call; true if DTR went active on the way
    /// (nobody had the port open, then somebody did).
    pub fn raised(&mut self) -> bool {
        let mut raised = false;
        while let Ok(events) = self.inotify.read_events() {
            if events.is_empty() {
                break;
            }
            for event in events {
                if event.mask.contains(AddWatchFlags::IN_OPEN) {
                    raised |= self.open == 0;
                    self.open += 1;
                } else {
                    self.open = self.open.saturating_sub(1);
                }
            }
        }
        raised
    }
}
