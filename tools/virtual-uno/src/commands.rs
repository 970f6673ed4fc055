//! Command lines for a virtual board: from stdin or from the
//! `--control` FIFO, read without blocking.

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

use nix::sys::stat::Mode;

/// Lines of commands from stdin or the control FIFO.
pub(crate) struct CommandSource {
    name: String,
    pub(crate) file: File,
    pending: Vec<u8>,
    /// False once the source closed or failed: it is not read again.
    pub(crate) open: bool,
}

impl CommandSource {
    /// Lines from `file`, named `name` in messages.
    pub(crate) fn new(name: &str, file: File) -> Self {
        CommandSource { name: name.to_owned(), file, pending: Vec::new(), open: true }
    }

    /// Reads what is available; returns complete lines. A closed stdin is simply not read again.
    pub(crate) fn read_lines(&mut self) -> Vec<String> {
        let mut buf = [0u8; 512];
        match self.file.read(&mut buf) {
            Ok(0) => self.open = false,
            Ok(n) => self.pending.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
            Err(e) => {
                eprintln!("{}: {e}; no longer read", self.name);
                self.open = false;
            }
        }
        let mut lines = Vec::new();
        while let Some(end) = self.pending.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.pending.drain(..=end).collect();
            lines.push(String::from_utf8_lossy(&line).into_owned());
        }
        lines
    }
}

/// The `--control` FIFO: created if missing (and then removed on exit), opened read-write so
/// that writers coming and going never make it report end of file.
pub(crate) struct ControlFifo {
    path: PathBuf,
    created: bool,
}

impl ControlFifo {
    pub(crate) fn open(path: &Path) -> Result<(ControlFifo, CommandSource), String> {
        let created = match path.metadata() {
            Ok(m) if m.file_type().is_fifo() => false,
            Ok(_) => return Err(format!("--control {}: exists and is not a FIFO", path.display())),
            Err(_) => {
                nix::unistd::mkfifo(path, Mode::from_bits_truncate(0o600))
                    .map_err(|e| format!("cannot create FIFO {}: {e}", path.display()))?;
                true
            }
        };
        let guard = ControlFifo { path: path.to_owned(), created };
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::libc::O_NONBLOCK)
            .open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let name = path.display().to_string();
        Ok((guard, CommandSource { name, file, pending: Vec::new(), open: true }))
    }
}

impl Drop for ControlFifo {
    fn drop(&mut self) {
        if self.created {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}
