//! A serial wire between a pty and one of the simulated chip's USARTs (USART0 on the Uno), in
//! simulated time.
//!
//! Master to chip: each byte's stop bit ends one character time after the previous byte's, or
//! after the byte reached us if that is later (the simulated USART flags it half a bit before,
//! one and a half bits with two stop bits, as the chip's does); a master whose line settings
//! differ from the firmware's delivers its bytes with the framing or parity error a real UART
//! would see.
//! Chip to master: a byte goes to the pty once its stop bit has ended.

use std::collections::VecDeque;
use std::fmt;
use std::io;

use uno_sim::{Error, LineError, TxByte, Uno};

use crate::line::{receive_error, Settings};
use crate::pty::Pty;

/// State of both directions of the wire on one USART.
pub struct Wire {
    /// The USART: the chip's wire or its second wire (`uno_sim::Options::second_usart`).
    usart: u8,
    /// End cycle of the last byte scheduled towards the chip.
    last_rx_end: u64,
    /// Firmware bytes not yet due on the pty.
    tx: VecDeque<TxByte>,
    /// The last (master, firmware) pair reported, to report each change once.
    reported: Option<(Settings, Option<Settings>)>,
    rx_count: u64,
    tx_count: u64,
}

/// What the master's line settings mean against the firmware's, told once per change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineReport {
    /// The firmware's USART is off: the master's bytes are lost.
    Off {
        /// The master's settings.
        master: Settings,
        /// The USART.
        usart: u8,
    },
    /// They differ: the bytes arrive with this error.
    Mismatch {
        /// The master's settings.
        master: Settings,
        /// The firmware's.
        firmware: Settings,
        /// What the firmware's USART flags on each byte.
        error: LineError,
    },
    /// They agree.
    Match {
        /// The master's settings.
        master: Settings,
        /// The firmware's.
        firmware: Settings,
    },
}

impl LineReport {
    /// Whether the master gets no answer because of it.
    pub fn is_trouble(&self) -> bool {
        !matches!(self, LineReport::Match { .. })
    }
}

impl fmt::Display for LineReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LineReport::Off { master, usart } => {
                write!(f, "the master sends at {master}, but the firmware's USART{usart} is off")
            }
            LineReport::Mismatch { master, firmware, error } => write!(
                f,
                "line settings differ: master {master}, firmware {firmware}; its bytes arrive with {} errors",
                match error {
                    LineError::Framing => "framing",
                    LineError::Parity => "parity",
                }
            ),
            LineReport::Match { master, firmware } => write!(f, "master {master} matches the firmware ({firmware})"),
        }
    }
}

impl Wire {
    /// The wire on USART`usart`, which must be the chip's wire or its second wire.
    pub fn new(usart: u8) -> Wire {
        Wire { usart, last_rx_end: 0, tx: VecDeque::new(), reported: None, rx_count: 0, tx_count: 0 }
    }

    /// Schedules bytes the master just wrote, sent with `master` settings. Returns what the
    /// settings mean, when that changed.
    pub fn receive(&mut self, uno: &mut Uno, bytes: &[u8], master: Settings) -> Result<Option<LineReport>, Error> {
        let usart = self.usart;
        let firmware = uno.serial_config_on(usart);
        let error = firmware.as_ref().and_then(|fw| receive_error(&master, fw));
        let fw_settings = firmware.as_ref().map(Settings::of_firmware);
        let mut report = None;
        if self.reported != Some((master, fw_settings)) {
            self.reported = Some((master, fw_settings));
            report = Some(match (fw_settings, error) {
                (None, _) => LineReport::Off { master, usart },
                (Some(firmware), Some(error)) => LineReport::Mismatch { master, firmware, error },
                (Some(firmware), None) => LineReport::Match { master, firmware },
            });
        }
        // On a matching line the firmware's own character time is the wire's; otherwise the master's.
        let char_cycles = match (&firmware, error) {
            (Some(fw), None) => fw.char_cycles(),
            _ => master.char_cycles().max(1),
        };
        // The USART flags a byte before its end: never before now, however short the master's
        // characters are beside the firmware's bits.
        let lead = uno.rx_flag_lead_on(usart).unwrap_or(0);
        for &byte in bytes {
            let end = (self.last_rx_end.max(uno.now()) + char_cycles).max(uno.now() + lead);
            match error {
                None => uno.send_byte_on(usart, byte, end)?,
                Some(e) => uno.send_byte_with_error_on(usart, byte, end, e)?,
            }
            self.last_rx_end = end;
        }
        self.rx_count += bytes.len() as u64;
        Ok(report)
    }

    /// Writes every firmware byte whose stop bit has ended to the pty. Bytes nobody reads are
    /// dropped once the pty's buffer is full, as a wire would lose them.
    pub fn transmit(&mut self, uno: &mut Uno, pty: &mut Pty) -> io::Result<()> {
        self.tx.extend(uno.take_tx_on(self.usart).map_err(io::Error::other)?);
        let now = uno.now();
        let due = self.tx.iter().take_while(|t| t.end_cycle <= now).count();
        if due > 0 {
            let bytes: Vec<u8> = self.tx.drain(..due).map(|t| t.byte).collect();
            pty.write(&bytes)?;
            self.tx_count += bytes.len() as u64;
        }
        Ok(())
    }

    /// Bytes received from the master and sent to it so far.
    pub fn counts(&self) -> (u64, u64) {
        (self.rx_count, self.tx_count)
    }
}
