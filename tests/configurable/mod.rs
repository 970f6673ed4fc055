//! The release `configurable` firmware on a simulated board with a master of its own,
//! and the settings records as the documentation lays them out: shared by
//! `sim_configurable` and `sim_settings_reset`.
//!
//! The simulated master sends at whatever rate the firmware's USART runs (see `uno-sim`),
//! so the line settings are checked in USART0's registers and in the reply's character
//! times. Start-up with a stored record computes the configuration at run time (≈3 ms),
//! longer than `sim::Rtu` allows for booting, hence [`Board`].
#![allow(dead_code)]

use crate::sim::{collect_reply, crc16, firmware, read_request, us_to_cycles, with_crc, Exchange, Line};
use uno_sim::{Parity, Uno};

pub const FIRMWARE: &str = "configurable";
/// The recovery jumper's pin.
pub const JUMPER: u8 = 12;
/// The settings slots' place in EEPROM.
pub const SLOTS_AT: usize = 0;
/// Length of a slot, and of the record in it.
pub const SLOT_LEN: usize = 11;
/// The settings block: 40101, protocol address 100.
pub const BLOCK: u16 = 100;

/// 9600 bps, 8N2.
pub const B9600_8N2: Line = Line { baud: 9600, parity: Parity::None, stop_bits: 2, data_bits: 8 };

fn parity_code(parity: Parity) -> u8 {
    match parity {
        Parity::None => 0,
        Parity::Odd => 1,
        Parity::Even => 2,
    }
}

/// The record for `id` and `line` stored as number `sequence`, built from the layout
/// documented in `src/slave/settings/record.rs`: magic 0x4E, sequence number, id, baud (u32
/// LE), parity code, stop bits, CRC.
pub fn record(sequence: u8, id: u8, line: Line) -> Vec<u8> {
    let mut bytes = vec![0x4E, sequence, id];
    bytes.extend_from_slice(&line.baud.to_le_bytes());
    bytes.extend_from_slice(&[parity_code(line.parity), line.stop_bits]);
    with_crc(&bytes)
}

/// The single record of earlier firmware (format 1) for `id` and `line`: magic 0x4D, id,
/// baud (u32 LE), parity code, stop bits, CRC.
pub fn legacy_record(id: u8, line: Line) -> Vec<u8> {
    let mut bytes = vec![0x4D, id];
    bytes.extend_from_slice(&line.baud.to_le_bytes());
    bytes.extend_from_slice(&[parity_code(line.parity), line.stop_bits]);
    let crc = crc16(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// Slot A's and slot B's bytes (each padded to a slot with 0xFF).
pub fn slots(a: &[u8], b: &[u8]) -> Vec<u8> {
    let mut bytes = vec![0xFF; 2 * SLOT_LEN];
    bytes[..a.len()].copy_from_slice(a);
    bytes[SLOT_LEN..SLOT_LEN + b.len()].copy_from_slice(b);
    bytes
}

/// The settings block's values for `id` and `line`.
pub fn block(id: u8, line: Line) -> [u16; 4] {
    [u16::from(id), (line.baud / 100) as u16, u16::from(parity_code(line.parity)), u16::from(line.stop_bits)]
}

/// FC 16 of the whole settings block to `id`.
pub fn write_block(id: u8, values: [u16; 4]) -> Vec<u8> {
    let mut frame = vec![
        id,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x64, // starting address lo: 40101
        0x00, // quantity hi
        0x04, // quantity lo: 4
        0x08, // byte count
    ];
    for value in values {
        frame.extend_from_slice(&value.to_be_bytes());
    }
    with_crc(&frame)
}

/// The simulated board with a master on its line.
pub struct Board {
    pub uno: Uno,
    /// The line the master uses (for its T3.5 waits).
    pub line: Line,
    /// The line has been idle since this cycle.
    pub quiet_since: u64,
}

/// Simulated time the firmware gets to start: the stored record's configuration takes
/// ≈3 ms to compute.
pub const BOOT_US: u64 = 10_000;

impl Board {
    /// Loads the firmware, lets `setup` prepare the board (EEPROM, pins), and starts it.
    pub fn boot(line: Line, setup: impl FnOnce(&mut Uno)) -> Board {
        let mut uno = Uno::load(firmware(FIRMWARE)).expect("firmware loads");
        setup(&mut uno);
        Board::start(uno, line)
    }

    /// Lets the firmware in `uno` start, with the master on `line`.
    pub fn start(mut uno: Uno, line: Line) -> Board {
        uno.run_until(us_to_cycles(BOOT_US)).expect("firmware runs");
        let quiet_since = uno.now();
        Board { uno, line, quiet_since }
    }

    /// Resets the board, keeping its EEPROM (and nothing else: the jumper is off), and
    /// starts it with the master on `line`.
    pub fn reset(mut self, line: Line) -> Board {
        self.uno.reset().expect("reset");
        Board::start(self.uno, line)
    }

    pub fn char_cycles(&self) -> u64 {
        self.uno.wire_char_cycles().expect("USART0 enabled")
    }

    /// Schedules `request` after T3.5 (and a little) of silence; returns its last
    /// character's end.
    pub fn send(&mut self, request: &[u8]) -> u64 {
        let start = (self.quiet_since + self.line.t35() + us_to_cycles(100)).max(self.uno.now());
        let end = self.uno.send_frame(request, start + self.char_cycles(), 0).expect("bytes scheduled");
        self.quiet_since = end;
        end
    }

    /// Sends `request` and collects the reply (empty: none within T3.5 + 10 characters).
    pub fn exchange(&mut self, request: &[u8]) -> Exchange {
        let request_end = self.send(request);
        let char_cycles = self.char_cycles();
        let reply = collect_reply(&mut self.uno, request_end, char_cycles, self.line.t35());
        if let Some(last) = reply.last() {
            self.quiet_since = self.quiet_since.max(last.end_cycle);
        }
        Exchange { request_end, reply }
    }

    pub fn ask(&mut self, request: &[u8]) -> Vec<u8> {
        self.exchange(request).bytes()
    }

    /// Reads `qty` registers of `function` from `start` at slave `id`; the values, or
    /// `None` when there was no normal reply.
    pub fn read(&mut self, id: u8, function: u8, start: u16, qty: u16) -> Option<Vec<u16>> {
        let reply = self.ask(&read_request(id, function, start, qty));
        let data = reply.get(3..reply.len().checked_sub(2)?)?;
        (reply.get(..3)? == [id, function, 2 * qty as u8] && reply == with_crc(&reply[..reply.len() - 2]))
            .then(|| data.chunks_exact(2).map(|pair| u16::from_be_bytes([pair[0], pair[1]])).collect())
    }

    /// Lets the main loop switch and store the settings: ≈3 ms to compute them, ≈3.4 ms
    /// per EEPROM byte on the chip, at most 12 (simavr finishes a write at once, but a
    /// test should not depend on that). The master then uses `line`.
    pub fn settle(&mut self, line: Line) {
        self.uno.run_for(us_to_cycles(60_000)).expect("firmware runs");
        self.quiet_since = self.uno.now();
        self.line = line;
    }

    /// The two settings slots.
    pub fn slots(&self) -> Vec<u8> {
        self.uno.read_eeprom(SLOTS_AT, 2 * SLOT_LEN).expect("EEPROM")
    }
}

/// USART0 runs `line`.
pub fn assert_usart_runs(uno: &Uno, line: Line) {
    let cfg = uno.serial_config().expect("USART0 enabled");
    assert!(cfg.rx_enabled && cfg.tx_enabled, "{cfg:?}");
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, line.parity, line.stop_bits), "{cfg:?}");
    assert!(cfg.baud_error(line.baud).abs() <= 0.025, "{} bps for {}", cfg.baud(), line.name());
}

/// `bytes` (address and PDU) as a Modbus ASCII frame (Serial Line v1.02 §2.5.2): `:`,
/// upper-case hex pairs with the LRC (the two's complement of the 8-bit sum), CR LF.
pub fn ascii_frame(bytes: &[u8]) -> Vec<u8> {
    let sum: u32 = bytes.iter().map(|&b| u32::from(b)).sum();
    let lrc = ((256 - sum % 256) % 256) as u8;
    let mut text = String::from(":");
    for b in bytes.iter().copied().chain([lrc]) {
        text.push_str(&format!("{b:02X}"));
    }
    text.push_str("\r\n");
    text.into_bytes()
}
