//! The pseudo-terminal standing in for the Uno's serial port, and the optional symlink to it.
//!
//! The master opens the slave side (`/dev/pts/N`) like any serial port and sets its baud rate
//! and frame format there; this side keeps the slave open too, so the line settings can be read
//! at any time and the pty survives masters coming and going.

use std::fs::File;
use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::path::{Path, PathBuf};

use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::pty::openpty;
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
use nix::unistd::ttyname;

use crate::line::Settings;

/// Our end of the pty pair.
pub struct Pty {
    master: File,
    slave: OwnedFd,
    path: PathBuf,
}

impl Pty {
    /// Opens a pty pair in raw mode; our (master) end does not block.
    pub fn open() -> io::Result<Pty> {
        let pair = openpty(None, None)?;
        let mut termios = tcgetattr(&pair.slave)?;
        cfmakeraw(&mut termios);
        tcsetattr(&pair.slave, SetArg::TCSANOW, &termios)?;
        let flags = OFlag::from_bits_retain(fcntl(&pair.master, FcntlArg::F_GETFL)?);
        fcntl(&pair.master, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK))?;
        let path = ttyname(&pair.slave)?;
        Ok(Pty { master: File::from(pair.master), slave: pair.slave, path })
    }

    /// The device a master opens, e.g. `/dev/pts/3`.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// For `poll`: readable when the master has written something.
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.master.as_fd()
    }

    /// The baud rate and frame format the master last set.
    pub fn master_settings(&self) -> io::Result<Settings> {
        Ok(Settings::from_cflag(tcgetattr(&self.slave)?.control_flags))
    }

    /// Reads what the master sent (empty if nothing is waiting).
    pub fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match nix::unistd::read(&self.master, buf) {
            Ok(n) => Ok(n),
            Err(Errno::EAGAIN) => Ok(0),
            Err(e) => Err(e.into()),
        }
    }

    /// Passes bytes to the master; returns how many the pty took (it holds about 4 KiB that
    /// nobody reads).
    pub fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        match nix::unistd::write(&self.master, bytes) {
            Ok(n) => Ok(n),
            Err(Errno::EAGAIN) => Ok(0),
            Err(e) => Err(e.into()),
        }
    }
}

/// A symlink to the pty, removed when dropped (if it still points there).
pub struct Link {
    path: PathBuf,
    target: PathBuf,
}

impl Link {
    /// Creates `path` -> `target`, replacing an old symlink (not a file) of that name.
    pub fn create(path: &Path, target: &Path) -> io::Result<Link> {
        if path.symlink_metadata().is_ok_and(|m| m.file_type().is_symlink()) {
            std::fs::remove_file(path)?;
        }
        std::os::unix::fs::symlink(target, path)?;
        Ok(Link { path: path.to_owned(), target: target.to_owned() })
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        if std::fs::read_link(&self.path).is_ok_and(|t| t == self.target) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}
