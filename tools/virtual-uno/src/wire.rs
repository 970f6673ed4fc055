//! The serial wire between the pty and the simulated USART (USART0 on the Uno), in simulated time.
//!
//! Master to Uno: each byte's stop bit ends one character time after the previous byte's, or
//! after the byte reached us if that is later (the simulated USART flags it half a bit before,
//! one and a half bits with two stop bits, as the chip's does); a master whose line settings
//! differ from the firmware's delivers its bytes with the framing or parity error a real UART
//! would see.
//! Uno to master: a byte goes to the pty once its stop bit has ended.

use std::collections::VecDeque;
use std::io;

use uno_sim::{Error, TxByte, Uno};

use crate::line::{receive_error, Settings};
use crate::pty::Pty;

/// State of both directions.
#[derive(Default)]
pub struct Wire {
    /// End cycle of the last byte scheduled towards the Uno.
    last_rx_end: u64,
    /// Firmware bytes not yet due on the pty.
    tx: VecDeque<TxByte>,
    /// The last (master, firmware) pair reported, to report each change once.
    reported: Option<(Settings, Option<Settings>)>,
    rx_count: u64,
    tx_count: u64,
}

impl Wire {
    /// Schedules bytes the master just wrote, sent with `master` settings.
    pub fn receive(&mut self, uno: &mut Uno, bytes: &[u8], master: Settings) -> Result<(), Error> {
        let firmware = uno.serial_config();
        let error = firmware.as_ref().and_then(|fw| receive_error(&master, fw));
        let fw_settings = firmware.as_ref().map(Settings::of_firmware);
        if self.reported != Some((master, fw_settings)) {
            self.reported = Some((master, fw_settings));
            match (fw_settings, error) {
                (None, _) => eprintln!(
                    "virtual-uno: the master sends at {master}, but the firmware's USART{} is off",
                    uno.usart()
                ),
                (Some(fw), Some(e)) => eprintln!(
                    "virtual-uno: line settings differ: master {master}, firmware {fw}; its bytes arrive with {} errors",
                    match e {
                        uno_sim::LineError::Framing => "framing",
                        uno_sim::LineError::Parity => "parity",
                    }
                ),
                (Some(fw), None) => println!("line: master {master} matches the firmware ({fw})"),
            }
        }
        // On a matching line the firmware's own character time is the wire's; otherwise the master's.
        let char_cycles = match (&firmware, error) {
            (Some(fw), None) => fw.char_cycles(),
            _ => master.char_cycles().max(1),
        };
        // The USART flags a byte before its end: never before now, however short the master's
        // characters are beside the firmware's bits.
        let lead = uno.rx_flag_lead().unwrap_or(0);
        for &byte in bytes {
            let end = (self.last_rx_end.max(uno.now()) + char_cycles).max(uno.now() + lead);
            match error {
                None => uno.send_byte(byte, end)?,
                Some(e) => uno.send_byte_with_error(byte, end, e)?,
            }
            self.last_rx_end = end;
        }
        self.rx_count += bytes.len() as u64;
        Ok(())
    }

    /// Writes every firmware byte whose stop bit has ended to the pty. Bytes nobody reads are
    /// dropped once the pty's buffer is full, as a wire would lose them.
    pub fn transmit(&mut self, uno: &mut Uno, pty: &mut Pty) -> io::Result<()> {
        self.tx.extend(uno.take_tx());
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
