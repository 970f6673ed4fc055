//! The settings record in EEPROM: one [`Config`] with a sequence number, sealed with
//! CRC-16/MODBUS (Modbus over Serial Line v1.02 §6.2.2), and the single record of earlier
//! firmware (format 1), still read.
//!
//! Format 2, [`RECORD_LEN`] bytes, written by this crate into one of two slots (see
//! [`super::slots`]):
//!
//! | byte | content                                     |
//! |-----:|---------------------------------------------|
//! | 0    | [`MAGIC`], written last                     |
//! | 1    | sequence number (wrapping), the newer wins  |
//! | 2    | slave id                                    |
//! | 3–6  | baud rate, `u32` little-endian (at most 1 000 000: byte 6 is 0); with feature `reply-delay` byte 6 is the reply delay in milliseconds instead (0: the byte earlier firmware writes) |
//! | 7    | parity code (0 none, 1 odd, 2 even)         |
//! | 8    | stop bits (1 or 2), and with feature `ascii` the transmission mode code in the high nibble (0 RTU: the byte RTU firmware writes) |
//! | 9–10 | CRC-16/MODBUS of bytes 0–8, low byte first  |
//!
//! Format 1, [`LEGACY_LEN`] bytes: [`LEGACY_MAGIC`], then bytes 2–8 above (no sequence
//! number), then the CRC of bytes 0–7. Only read.
//!
//! A blank (0xFF) or damaged record (wrong magic or CRC), or one with settings
//! [`Config::try_new`] refuses, decodes to `None`. Decoding takes well under a millisecond
//! on the Uno (see [`LineSettings::to_config`]).

use super::block::{parity_code, parity_from_code, stop_bits_count, stop_bits_from_count, LineSettings};
use crate::link::config::Config;
use crate::link::crc::Crc16;

/// Length of a record, in bytes.
pub const RECORD_LEN: usize = 11;

/// First byte of a record: format 2 ('N', the letter after format 1's 'M'). A blank
/// EEPROM reads 0xFF.
pub const MAGIC: u8 = 0x4E;

/// Length of a format-1 record, in bytes.
pub const LEGACY_LEN: usize = 10;

/// First byte of a format-1 record ('M' for Modbus).
pub const LEGACY_MAGIC: u8 = 0x4D;

/// A decoded record: the settings and the sequence number they were stored with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    /// Counts stores, wrapping: of two records, the one one to 127 ahead is the newer.
    pub sequence: u8,
    /// The settings.
    pub config: Config,
}

/// The slave id, baud rate, parity and stop bits (and the mode, feature `ascii`) as
/// stored: 7 bytes.
fn encode_settings(config: &Config) -> [u8; 7] {
    let [b0, b1, b2, b3] = config.baud().to_le_bytes();
    #[cfg(feature = "reply-delay")]
    let b3 = b3 | LineSettings::of(config).reply_delay_ms;
    #[allow(unused_mut)]
    let mut stop = stop_bits_count(config.stop_bits());
    #[cfg(feature = "ascii")]
    {
        stop |= (config.mode() as u8) << 4;
    }
    [config.slave_id().get(), b0, b1, b2, b3, parity_code(config.parity()), stop]
}

/// The configuration of 7 stored bytes, `None` when [`Config::try_new`] refuses it.
fn decode_settings(bytes: [u8; 7]) -> Option<Config> {
    #[allow(unused_mut)]
    let [id, b0, b1, b2, mut b3, parity, stop] = bytes;
    // With feature `reply-delay` the baud rate's high byte (always 0) holds the delay;
    // without, a delay there makes a rate no USART makes: a record this firmware can't run.
    #[cfg(feature = "reply-delay")]
    let reply_delay_ms = core::mem::replace(&mut b3, 0);
    // Without feature `ascii` a mode in the high nibble makes an unknown stop count: a
    // record this firmware can't run.
    #[cfg(feature = "ascii")]
    let (stop, mode) = (stop & 0x0F, super::block::mode_from_code(u16::from(stop >> 4))?);
    LineSettings {
        slave_id: id,
        baud: u32::from_le_bytes([b0, b1, b2, b3]),
        parity: parity_from_code(u16::from(parity))?,
        stop_bits: stop_bits_from_count(u16::from(stop))?,
        #[cfg(feature = "ascii")]
        mode,
        #[cfg(feature = "reply-delay")]
        reply_delay_ms,
    }
    .to_config()
}

/// The record of `config` stored as number `sequence`.
pub fn encode(config: &Config, sequence: u8) -> [u8; RECORD_LEN] {
    let [id, b0, b1, b2, b3, parity, stop] = encode_settings(config);
    let mut record = [MAGIC, sequence, id, b0, b1, b2, b3, parity, stop, 0, 0];
    let [lo, hi] = Crc16::new().update_slice(record.get(..RECORD_LEN - 2).unwrap_or(&[])).to_wire();
    record[RECORD_LEN - 2] = lo;
    record[RECORD_LEN - 1] = hi;
    record
}

/// The record in `bytes`; `None` when blank, damaged or unrunnable.
pub fn decode(bytes: &[u8; RECORD_LEN]) -> Option<Record> {
    let [magic, sequence, id, b0, b1, b2, b3, parity, stop, _, _] = *bytes;
    if magic != MAGIC || !Crc16::new().update_slice(bytes).is_residue_ok() {
        return None;
    }
    let config = decode_settings([id, b0, b1, b2, b3, parity, stop])?;
    Some(Record { sequence, config })
}

/// The configuration in a format-1 record; `None` when blank, damaged or unrunnable.
pub fn decode_legacy(bytes: &[u8; LEGACY_LEN]) -> Option<Config> {
    let [magic, id, b0, b1, b2, b3, parity, stop, _, _] = *bytes;
    if magic != LEGACY_MAGIC || !Crc16::new().update_slice(bytes).is_residue_ok() {
        return None;
    }
    decode_settings([id, b0, b1, b2, b3, parity, stop])
}
