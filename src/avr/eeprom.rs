//! The 1 KiB data EEPROM, ATmega328P datasheet §8.4 (EEPROM data memory) and §8.6.3
//! (EECR): byte reads, and byte writes (erase and write, ≈3.4 ms each) that skip a byte
//! already holding the value, to spare time and wear (100 000 cycles per cell).
//!
//! Writes wait for the previous one with interrupts enabled; only the two-instruction
//! EEMPE/EEPE sequence, which must complete within four clock cycles, runs with them
//! disabled. Call the writing methods from the main loop, never from an interrupt.
//!
//! With `eeprom-settings`, the line settings live in two record slots there (`settings`).

use core::ops::Deref;

use super::chip::CHIP;
use super::reg::{self, claim, EEARH, EEARL, EECR, EEDR};
use crate::error::Error;

#[cfg(all(feature = "eeprom-settings", feature = "tcp"))]
mod network;
#[cfg(feature = "eeprom-settings")]
mod settings;

const EERE: u8 = 1 << 0;
const EEPE: u8 = 1 << 1;
const EEMPE: u8 = 1 << 2;

/// The EEPROM.
pub struct Eeprom(());

impl Eeprom {
    /// Size of the chip's EEPROM, in bytes: 1024 on the ATmega328P and ATmega32U4, 512 on
    /// the ATmega168, 4096 on the ATmega2560 and ATmega1280.
    pub const SIZE: u16 = CHIP.eeprom_size;

    /// Takes the EEPROM from the application's PAC (`dp.EEPROM`).
    pub fn new<P: Deref>(eeprom: P) -> Result<Self, Error>
    where
        P::Target: Sized,
    {
        claim::<_, { reg::EEPROM.1 }>(eeprom, reg::EEPROM.0)?;
        Ok(Eeprom(()))
    }

    /// True while a write is in progress.
    pub fn is_busy(&self) -> bool {
        EECR.read() & EEPE != 0
    }

    fn wait(&self) {
        while self.is_busy() {}
    }

    fn select(&self, address: u16) {
        self.wait();
        let [high, low] = address.to_be_bytes();
        EEARH.write(high);
        EEARL.write(low);
    }

    /// The byte at `address`; `None` past the end. Waits for a write in progress.
    pub fn read(&self, address: u16) -> Option<u8> {
        if address >= Self::SIZE {
            return None;
        }
        self.select(address);
        // EERE starts a read; EEPE and EEMPE stay clear, so nothing is written.
        EECR.write(EERE);
        Some(EEDR.read())
    }

    /// Fills `out` from `address` on; false (and `out` untouched) if it would pass the end.
    pub fn read_slice(&self, address: u16, out: &mut [u8]) -> bool {
        if usize::from(address) + out.len() > usize::from(Self::SIZE) {
            return false;
        }
        for (a, byte) in (address..).zip(out.iter_mut()) {
            *byte = self.read(a).unwrap_or(0xFF);
        }
        true
    }

    /// Writes `byte` at `address` unless it already holds it. Returns true when a write was
    /// started (it completes ≈3.4 ms later, on its own); false when the byte was already
    /// there or `address` is past the end.
    pub fn update(&mut self, address: u16, byte: u8) -> bool {
        if self.read(address).map_or(true, |current| current == byte) {
            return false;
        }
        EEDR.write(byte);
        // The datasheet's write sequence: EEMPE alone (EEPM = 00, erase and write; EERIE
        // off), then EEPE within four cycles, which the disabled interrupts guarantee (two
        // `out` instructions).
        reg::free(|| {
            EECR.write(EEMPE);
            EECR.write(EEMPE | EEPE);
        });
        true
    }

    /// Writes `bytes` from `address` on, skipping bytes that already hold their value.
    /// Returns how many bytes were written (0 if the range passes the end).
    pub fn update_slice(&mut self, address: u16, bytes: &[u8]) -> usize {
        if usize::from(address) + bytes.len() > usize::from(Self::SIZE) {
            return 0;
        }
        (address..).zip(bytes).filter(|&(a, &byte)| self.update(a, byte)).count()
    }
}
