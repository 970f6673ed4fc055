//! Two slots for the settings record, so that a reset at any instant of a store (a power
//! cut, most likely) leaves the complete old settings or the complete new ones, never
//! neither: the device keeps answering on its bus, at its address, whatever happens.
//!
//! Slot A takes bytes 0–10, slot B bytes 11–21 ([`SLOTS_LEN`]), each holding one
//! [`Record`](super::Record) with a sequence number. Loading takes the newer valid record
//! (wrapping comparison: a sequence number one to 127 ahead is newer; if neither is, slot
//! A wins). A format-1 record left by earlier firmware at the start of slot A is read as
//! older than any format-2 record, so a device keeps its settings across the update.
//!
//! A store writes the slot that does *not* hold the newest valid record, numbered one
//! past it (0 after a format-1 record or none); slot A only when slot B holds the newest,
//! so a first store never touches a format-1 record. Its bytes go in this order:
//!
//! 1. if the slot's first byte is a magic ([`MAGIC`](super::MAGIC) or
//!    [`LEGACY_MAGIC`](super::LEGACY_MAGIC)), 0xFF over it: from here the slot is invalid,
//!    whatever mix of old and new bytes follows;
//! 2. bytes 1–10 of the new record, skipping those already right;
//! 3. the magic, last: the record becomes valid in one byte write.
//!
//! A reset before step 3 completes leaves the other slot, untouched, as the newest valid
//! record: the old settings. A byte torn by the reset reads anything; a torn magic byte
//! that happens to read [`MAGIC`](super::MAGIC) follows ten complete bytes, so it is the
//! whole new record. Settings equal to the newest record's are not stored again.
//!
//! Cost per store: the new record's changed bytes (sequence number and CRC, usually, and
//! the settings that changed) plus the magic twice, at most 12 writes of ≈3.4 ms.

use super::record::{self, Record, LEGACY_MAGIC, MAGIC, RECORD_LEN};
use crate::link::config::Config;

/// Bytes the two slots take: slot A, then slot B.
pub const SLOTS_LEN: usize = 2 * RECORD_LEN;

/// Most byte writes one store takes: invalidate the magic, ten bytes, the magic.
pub const MAX_WRITES: usize = RECORD_LEN + 1;

/// What the first byte of a slot is set to before its other bytes change: the erased
/// value, which no format uses as its magic.
const INVALID: u8 = 0xFF;

/// One of the two slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Bytes 0–10 (and a format-1 record's bytes 0–9).
    A,
    /// Bytes 11–21.
    B,
}

impl Slot {
    /// Offset of the slot's first byte from the slots' start.
    pub const fn offset(self) -> u16 {
        match self {
            Slot::A => 0,
            Slot::B => RECORD_LEN as u16,
        }
    }
}

/// The newest valid record in the slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Newest {
    /// The slot that holds it.
    pub slot: Slot,
    /// Its sequence number; `None` for a format-1 record (always in slot A).
    pub sequence: Option<u8>,
    /// The settings.
    pub config: Config,
}

/// One byte to write, at `offset` from the slots' start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Write {
    /// Offset from the slots' start, below [`SLOTS_LEN`].
    pub offset: u16,
    /// The value.
    pub byte: u8,
}

/// The byte writes of one store, in the order they must happen (each complete before the
/// next starts): an iterator of [`Write`]s, at most [`MAX_WRITES`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Writes {
    /// Offset of the slot written.
    offset: u16,
    /// Its bytes before the store.
    old: [u8; RECORD_LEN],
    /// The new record.
    new: [u8; RECORD_LEN],
    /// Next step: 0 invalidate the magic, 1–10 that byte, [`RECORD_LEN`] the magic.
    step: u8,
}

impl Writes {
    /// No writes.
    fn none() -> Writes {
        Writes { offset: 0, old: [INVALID; RECORD_LEN], new: [INVALID; RECORD_LEN], step: u8::MAX }
    }
}

impl Iterator for Writes {
    type Item = Write;

    fn next(&mut self) -> Option<Write> {
        while let Some(&was) = self.old.get(usize::from(self.step)) {
            let index = self.step;
            self.step += 1;
            let (offset, byte) = match index {
                0 if was == MAGIC || was == LEGACY_MAGIC => (self.offset, INVALID),
                0 => continue,
                _ => match self.new.get(usize::from(index)) {
                    Some(&byte) if byte != was => (self.offset + u16::from(index), byte),
                    _ => continue,
                },
            };
            return Some(Write { offset, byte });
        }
        if usize::from(self.step) == RECORD_LEN {
            self.step += 1;
            return Some(Write { offset: self.offset, byte: MAGIC });
        }
        None
    }
}

/// True when sequence number `a` is newer than `b`: one to 127 ahead, wrapping.
pub const fn is_newer(a: u8, b: u8) -> bool {
    matches!(a.wrapping_sub(b), 1..=127)
}

/// The two slots' bytes, as read from EEPROM.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slots {
    bytes: [u8; SLOTS_LEN],
}

impl Slots {
    /// The slots holding `bytes` (slot A first).
    pub const fn new(bytes: [u8; SLOTS_LEN]) -> Self {
        Slots { bytes }
    }

    /// The first `N` bytes of `slot`.
    fn read<const N: usize>(&self, slot: Slot) -> [u8; N] {
        let mut out = [INVALID; N];
        for (byte, &stored) in out.iter_mut().zip(self.bytes.iter().skip(usize::from(slot.offset()))) {
            *byte = stored;
        }
        out
    }

    /// The newest valid record; `None` when neither slot holds one.
    pub fn newest(&self) -> Option<Newest> {
        let found = |slot, record: Record| Newest { slot, sequence: Some(record.sequence), config: record.config };
        match (record::decode(&self.read(Slot::A)), record::decode(&self.read(Slot::B))) {
            (Some(a), Some(b)) if is_newer(b.sequence, a.sequence) => Some(found(Slot::B, b)),
            (Some(a), _) => Some(found(Slot::A, a)),
            (None, Some(b)) => Some(found(Slot::B, b)),
            (None, None) => {
                let config = record::decode_legacy(&self.read(Slot::A))?;
                Some(Newest { slot: Slot::A, sequence: None, config })
            }
        }
    }

    /// The settings of the newest valid record; `None` when there is none (start with the
    /// compiled-in default then).
    pub fn load(&self) -> Option<Config> {
        self.newest().map(|newest| newest.config)
    }

    /// The writes that store `config` (see the module documentation); none when the newest
    /// record already holds it.
    pub fn store(&self, config: &Config) -> Writes {
        let newest = self.newest();
        let (slot, sequence) = match newest {
            Some(newest) if newest.config == *config => return Writes::none(),
            Some(Newest { slot: Slot::B, sequence, .. }) => (Slot::A, sequence),
            Some(Newest { slot: Slot::A, sequence, .. }) => (Slot::B, sequence),
            None => (Slot::B, None),
        };
        let sequence = sequence.map_or(0, |newest| newest.wrapping_add(1));
        Writes { offset: slot.offset(), old: self.read(slot), new: record::encode(config, sequence), step: 0 }
    }
}
