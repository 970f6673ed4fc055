//! The values both register maps keep (the build-time `register_map!` and the run-time
//! `Bank`, each holding a [`Values`]), in the layout of `words`; beside them the
//! [`Device`] data FC 7, 17 and 43 report.

use crate::error::Error;
use crate::protocol::reference::Table;
use crate::protocol::Exception;
use crate::slave::device::Device;
use crate::slave::words::*;

/// The values of a register map: what [`crate::register_map!`] wraps, and what a
/// [`crate::Bank`] keeps beside its runs.
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct Values<const WORDS: usize, const BIT_BYTES: usize> {
    words: [Word; WORDS],
    bits: [u8; BIT_BYTES],
    master_writes: u16,
    device: Device,
}

impl<const WORDS: usize, const BIT_BYTES: usize> Default for Values<WORDS, BIT_BYTES> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const WORDS: usize, const BIT_BYTES: usize> Values<WORDS, BIT_BYTES> {
    /// Every value 0.
    pub const fn new() -> Self {
        Values { words: [[0; 2]; WORDS], bits: [0; BIT_BYTES], master_writes: 0, device: Device::new() }
    }

    /// The value at storage index `i` of the bits (`bits`: 0 or 1) or the registers, 0
    /// past the end.
    #[inline(always)]
    fn value(&self, bits: bool, i: usize) -> u16 {
        if bits {
            u16::from(bit(&self.bits, i))
        } else {
            word(&self.words, i)
        }
    }

    /// Sets the value at storage index `i` of the bits (on when `value` is not 0) or the
    /// registers; nothing past the end.
    #[inline(always)]
    fn put(&mut self, bits: bool, i: usize, value: u16) {
        if bits {
            set_bit(&mut self.bits, i, value != 0);
        } else {
            set_word(&mut self.words, i, value);
        }
    }

    /// The value at storage index `at` of `table`'s kind.
    #[inline(always)]
    pub fn get(&self, table: Table, at: Option<usize>) -> Result<u16, Error> {
        Ok(self.value(table.is_bits(), at.ok_or(Error::NotFound)?))
    }

    /// Sets the value at storage index `at` of `table`'s kind.
    #[inline(always)]
    pub fn set(&mut self, table: Table, at: Option<usize>, value: u16) -> Result<(), Error> {
        self.put(table.is_bits(), at.ok_or(Error::NotFound)?, value);
        Ok(())
    }

    /// What is kept at `place` ([`Place::Word`] or [`Place::Bit`]; 0 otherwise): a
    /// register's two bytes as one little-endian `u16`, or a bit's byte. For the
    /// application's calls, with interrupts disabled: loads only, [`Place::value`] does the
    /// rest.
    #[inline(always)]
    pub fn load(&self, place: Place) -> u16 {
        match place {
            Place::Word(i) => self.words.get(usize::from(i)).map_or(0, |&word| u16::from_le_bytes(word)),
            Place::Bit(i, _) => self.bits.get(usize::from(i)).map_or(0, |&byte| u16::from(byte)),
            Place::Ask | Place::Missing => 0,
        }
    }

    /// Writes `stored` ([`Place::stored`]) at `place`: stores only, for the application's
    /// calls, with interrupts disabled.
    #[inline(always)]
    pub fn store(&mut self, place: Place, stored: u16) {
        match place {
            Place::Word(i) => {
                if let Some(word) = self.words.get_mut(usize::from(i)) {
                    *word = stored.to_le_bytes();
                }
            }
            Place::Bit(i, mask) => {
                if let Some(byte) = self.bits.get_mut(usize::from(i)) {
                    *byte = (*byte & !mask) | stored as u8;
                }
            }
            Place::Ask | Place::Missing => {}
        }
    }

    /// Makes room for `n` values at storage index `at` of the bits (`bits`) or the
    /// registers, of which `used` are in use (`used + n` fit): the values from `at` on
    /// move `n` up, and the `n` from `at` read 0. What a [`crate::Bank`] does when it adds
    /// addresses below others of their kind, at start-up: two copies out of a copy of that
    /// storage on the stack (its bytes of bits, or two bytes a register), with the copies the
    /// requests use; the `n` zeros come from past the used values.
    pub(crate) fn open(&mut self, bits: bool, at: usize, used: usize, n: usize) {
        if at >= used {
            return;
        }
        let moved = used - at;
        if bits {
            let old = self.bits;
            copy_bits(&old, at, &mut self.bits, at + n, moved as u16);
            copy_bits(&old, used, &mut self.bits, at, n as u16);
        } else {
            let old = self.words;
            if let (Some(to), Some(from)) = (self.words.get_mut(at + n..used + n), old.get(at..used)) {
                to.copy_from_slice(from);
            }
            if let (Some(to), Some(from)) = (self.words.get_mut(at..at + n), old.get(used..used + n)) {
                to.copy_from_slice(from);
            }
        }
    }

    /// FC 1–6, 15 and 16: `qty` values of `table`'s kind from storage index `at` moved
    /// between the map and `data` (see [`crate::DataModel::transfer`]); a write counts as a
    /// master write.
    pub fn transfer(
        &mut self,
        access: Access,
        table: Table,
        at: Option<usize>,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        let i = at.ok_or(Exception::IllegalDataAddress)?;
        if table.is_bits() {
            transfer_bits(&mut self.bits, i, qty, data, access);
        } else {
            transfer_words(&mut self.words, i, data, access);
        }
        if access == Access::Write {
            self.master_writes = self.master_writes.wrapping_add(1);
        }
        Ok(())
    }

    /// FC 1 / 2: `qty` bits from storage index `at`, packed LSB first.
    pub fn read_bits(&self, at: Option<usize>, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        read_bits(&self.bits, at.ok_or(Exception::IllegalDataAddress)?, qty, out);
        Ok(())
    }

    /// FC 3 / 4: `out.len() / 2` registers from storage index `at`, big-endian.
    pub fn read_words(&self, at: Option<usize>, out: &mut [u8]) -> Result<(), Exception> {
        read_words(&self.words, at.ok_or(Exception::IllegalDataAddress)?, out);
        Ok(())
    }

    /// FC 5 / 15: `qty` coils from storage index `at`, packed LSB first.
    pub fn write_bits(&mut self, at: Option<usize>, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        write_bits(&mut self.bits, at.ok_or(Exception::IllegalDataAddress)?, qty, packed);
        self.master_writes = self.master_writes.wrapping_add(1);
        Ok(())
    }

    /// FC 6 / 16: registers from storage index `at`, big-endian.
    pub fn write_words(&mut self, at: Option<usize>, values: &[u8]) -> Result<(), Exception> {
        write_words(&mut self.words, at.ok_or(Exception::IllegalDataAddress)?, values);
        self.master_writes = self.master_writes.wrapping_add(1);
        Ok(())
    }

    /// Successful master writes so far, wrapping.
    #[inline(always)]
    pub fn master_writes(&self) -> u16 {
        self.master_writes
    }

    /// What FC 7, 17 and 43 report about the device.
    #[inline(always)]
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// What FC 7, 17 and 43 report, to set it.
    #[inline(always)]
    pub fn device_mut(&mut self) -> &mut Device {
        &mut self.device
    }
}

#[cfg(test)]
mod tests {
    use super::{Place, Values};
    use crate::protocol::reference::Table;

    #[test]
    fn a_value_stored_at_its_place_reads_back_and_travels_big_endian() {
        let mut values = Values::<3, 0>::new();
        let place = Place::of(Table::HoldingRegisters, Some(2));
        assert_eq!(place, Place::Word(2));
        values.store(place, place.stored(0x1234));
        assert_eq!(place.value(values.load(place)), 0x1234);
        assert_eq!(values.get(Table::HoldingRegisters, Some(2)), Ok(0x1234));
        let mut out = [0; 2];
        values.read_words(Some(2), &mut out).unwrap();
        assert_eq!(out, [0x12, 0x34]);
    }

    #[test]
    fn a_bit_stored_at_its_place_changes_that_bit_alone() {
        let mut values = Values::<0, 2>::new();
        let place = Place::of(Table::Coils, Some(9));
        assert_eq!(place, Place::Bit(1, 0b10));
        values.set(Table::Coils, Some(8), 1).unwrap();
        values.set(Table::Coils, Some(10), 1).unwrap();
        values.store(place, place.stored(7));
        assert_eq!(place.value(values.load(place)), 1);
        assert_eq!(values.load(place), 0b111);
        values.store(place, place.stored(0));
        assert_eq!(place.value(values.load(place)), 0);
        assert_eq!(values.load(place), 0b101);
    }

    #[test]
    fn a_missing_place_and_one_past_the_end_store_nothing_and_read_0() {
        let mut values = Values::<1, 1>::new();
        for place in [Place::Missing, Place::Ask, Place::Word(1), Place::Bit(1, 1)] {
            values.store(place, 0xFFFF);
            assert_eq!(values.load(place), 0);
        }
        assert_eq!(Place::of(Table::InputRegisters, None), Place::Missing);
        assert_eq!((values.load(Place::Word(0)), values.load(Place::Bit(0, 1))), (0, 0));
    }
}
