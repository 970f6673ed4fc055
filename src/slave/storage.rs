//! The value storage both register maps share (the build-time `register_map!` and the
//! run-time `Bank`, each holding a [`Values`]): registers as two bytes, coils and discrete
//! inputs packed 8 to a byte, LSB first, and the copies between them and the PDU,
//! Application Protocol v1.1b3 §6.1–6.12.
//!
//! A register is kept as it travels, big-endian ([`Word`]): FC 3, 4, 6 and 16 copy bytes,
//! and only the application's `get` and `set` convert.

use crate::error::Error;
use crate::protocol::reference::Table;
use crate::slave::model::Access;
use crate::slave::pdu::device_id::Identification;
use crate::slave::pdu::Exception;

/// A register's value, big-endian (high byte first), as on the wire.
pub(crate) type Word = [u8; 2];

/// `value` with its bytes swapped: [`u16::swap_bytes`], but as three instructions on the
/// AVR, where the backend writes a byte swap out as seven. A big-endian pair of bytes
/// loaded or stored side by side becomes one 16-bit access and a swap.
#[inline(always)]
#[cfg_attr(target_arch = "avr", allow(unsafe_code))]
fn swap(value: u16) -> u16 {
    #[cfg(target_arch = "avr")]
    {
        let mut value = value;
        // SAFETY: three exclusive-ors within the register pair: no memory, no stack.
        unsafe {
            core::arch::asm!(
                "eor {0:l}, {0:h}",
                "eor {0:h}, {0:l}",
                "eor {0:l}, {0:h}",
                inout(reg_pair) value,
                options(pure, nomem, nostack),
            )
        };
        value
    }
    #[cfg(not(target_arch = "avr"))]
    value.swap_bytes()
}

/// [`u16::from_be_bytes`] with the swap of [`swap`].
#[inline(always)]
pub(crate) fn from_be(hi: u8, lo: u8) -> u16 {
    swap(u16::from_le_bytes([hi, lo]))
}

/// [`u16::to_be_bytes`] with the swap of [`swap`].
#[inline(always)]
pub(crate) fn to_be(value: u16) -> Word {
    swap(value).to_le_bytes()
}

/// The value of a register kept as a [`Word`], 0 past the end.
#[inline(always)]
pub(crate) fn word(words: &[Word], i: usize) -> u16 {
    words.get(i).map_or(0, |&[hi, lo]| from_be(hi, lo))
}

/// Sets the register `i` kept as a [`Word`].
#[inline(always)]
pub(crate) fn set_word(words: &mut [Word], i: usize, value: u16) {
    if let Some(slot) = words.get_mut(i) {
        *slot = to_be(value);
    }
}

/// Bit `i` of the packed bits.
#[inline(always)]
pub(crate) fn bit(bits: &[u8], i: usize) -> bool {
    bits.get(i / 8).is_some_and(|byte| byte & (1 << (i % 8)) != 0)
}

/// Sets bit `i` of the packed bits.
#[inline(always)]
pub(crate) fn set_bit(bits: &mut [u8], i: usize, on: bool) {
    let mask = 1 << (i % 8);
    if let Some(byte) = bits.get_mut(i / 8) {
        if on {
            *byte |= mask;
        } else {
            *byte &= !mask;
        }
    }
}

/// A position in packed bits: the byte, and the bit's mask in it. Stepping on shifts the
/// mask (the AVR has no barrel shifter, so `1 << (i % 8)` would be a loop per bit).
#[derive(Clone, Copy)]
struct BitCursor {
    byte: usize,
    mask: u8,
}

impl BitCursor {
    #[inline(always)]
    fn at(i: usize) -> Self {
        BitCursor { byte: i / 8, mask: 1 << (i % 8) }
    }

    #[inline(always)]
    fn get(self, bits: &[u8]) -> bool {
        bits.get(self.byte).is_some_and(|byte| byte & self.mask != 0)
    }

    #[inline(always)]
    fn set(self, bits: &mut [u8], on: bool) {
        if let Some(byte) = bits.get_mut(self.byte) {
            if on {
                *byte |= self.mask;
            } else {
                *byte &= !self.mask;
            }
        }
    }

    #[inline(always)]
    fn step(&mut self) {
        self.mask = self.mask.rotate_left(1);
        if self.mask == 1 {
            self.byte += 1;
        }
    }
}

/// Copies `qty` bits from index `from` in `src` to index `to` in `dst`: one copy in flash
/// for reads and writes, the masks worked out in it once.
#[inline(never)]
fn copy_bits(src: &[u8], from: usize, dst: &mut [u8], to: usize, qty: u16) {
    let (mut from, mut to) = (BitCursor::at(from), BitCursor::at(to));
    for _ in 0..qty {
        to.set(dst, from.get(src));
        from.step();
        to.step();
    }
}

/// FC 1 / 2's data: `qty` bits from index `first`, packed LSB first into `out`, the unused
/// high bits of the last byte zero.
#[inline(always)]
pub(crate) fn read_bits(bits: &[u8], first: usize, qty: u16, out: &mut [u8]) {
    out.fill(0);
    copy_bits(bits, first, out, 0, qty);
}

/// FC 5 / 15: `qty` bits from index `first`, from `packed` LSB first.
#[inline(always)]
pub(crate) fn write_bits(bits: &mut [u8], first: usize, qty: u16, packed: &[u8]) {
    copy_bits(packed, 0, bits, first, qty);
}

/// FC 3 / 4's data: `out.len() / 2` registers from index `first`, big-endian.
#[inline(always)]
pub(crate) fn read_words(words: &[Word], first: usize, out: &mut [u8]) {
    for (pair, value) in out.chunks_exact_mut(2).zip(words.get(first..).unwrap_or(&[])) {
        pair.copy_from_slice(value);
    }
}

/// FC 6 / 16: registers from index `first`, from `values` big-endian.
#[inline(always)]
pub(crate) fn write_words(words: &mut [Word], first: usize, values: &[u8]) {
    for (slot, pair) in words.get_mut(first..).unwrap_or(&mut []).iter_mut().zip(values.chunks_exact(2)) {
        slot.copy_from_slice(pair);
    }
}

/// FC 1, 2, 5 and 15: `qty` bits between the packed `bits` (from index `first`) and `data`
/// (packed from its bit 0). A read fills `data`, the unused high bits of its last byte zero.
#[inline(always)]
pub(crate) fn transfer_bits(bits: &mut [u8], first: usize, qty: u16, data: &mut [u8], access: Access) {
    match access {
        Access::Read => read_bits(bits, first, qty, data),
        Access::Write => write_bits(bits, first, qty, data),
    }
}

/// FC 3, 4, 6 and 16: the registers of `data` (big-endian pairs) between `words` (from
/// index `first`) and `data`.
#[inline(always)]
pub(crate) fn transfer_words(words: &mut [Word], first: usize, data: &mut [u8], access: Access) {
    let pairs = words.get_mut(first..).unwrap_or(&mut []).iter_mut().zip(data.chunks_exact_mut(2));
    // One loop each way: a reply of 125 registers is copied while its first byte is on the
    // wire, and a choice per register would lengthen the silence after it.
    match access {
        Access::Read => pairs.for_each(|(slot, pair)| pair.copy_from_slice(slot)),
        Access::Write => pairs.for_each(|(slot, pair)| slot.copy_from_slice(pair)),
    }
}

/// Where the application's `get` and `set` find a value in a [`Values`], worked out from
/// the reference before interrupts go off ([`crate::DataModel::place`]), so that only the
/// load or store runs with them disabled.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// The model keeps no [`Values`] of a layout fixed at build time: the application's
    /// calls ask [`crate::DataModel::value`] and [`crate::DataModel::set_value`].
    Ask,
    /// The model has no such value.
    Missing,
    /// Register `i` of the words.
    Word(u16),
    /// The bit `mask` of byte `i` of the packed bits.
    Bit(u16, u8),
}

impl Place {
    /// The place of storage index `at` of `table`'s kind (`None`: missing).
    #[inline(always)]
    pub fn of(table: Table, at: Option<usize>) -> Place {
        match at {
            None => Place::Missing,
            Some(i) if table.is_bits() => Place::Bit((i / 8) as u16, 1 << (i % 8)),
            Some(i) => Place::Word(i as u16),
        }
    }

    /// What [`Values::store`] writes for `value` here: a register's bytes as they are kept
    /// (big-endian, read as one little-endian `u16`), or for a bit the mask when `value`
    /// is not 0, else 0.
    #[inline(always)]
    pub fn stored(self, value: u16) -> u16 {
        match self {
            Place::Bit(_, mask) => u16::from(if value != 0 { mask } else { 0 }),
            _ => swap(value),
        }
    }

    /// The value from what [`Values::load`] read here.
    #[inline(always)]
    pub fn value(self, loaded: u16) -> u16 {
        match self {
            Place::Bit(_, mask) => u16::from(loaded as u8 & mask != 0),
            _ => swap(loaded),
        }
    }
}

/// The values of a register map: what [`crate::register_map!`] wraps, and what a
/// [`crate::Bank`] keeps beside its runs.
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct Values<const WORDS: usize, const BIT_BYTES: usize> {
    words: [Word; WORDS],
    bits: [u8; BIT_BYTES],
    master_writes: u16,
    #[cfg(feature = "diagnostics")]
    exception_status: u8,
    #[cfg(feature = "diagnostics")]
    device_info: &'static [u8],
    #[cfg(feature = "device-id")]
    identification: Option<&'static Identification>,
}

impl<const WORDS: usize, const BIT_BYTES: usize> Default for Values<WORDS, BIT_BYTES> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const WORDS: usize, const BIT_BYTES: usize> Values<WORDS, BIT_BYTES> {
    /// Every value 0.
    pub const fn new() -> Self {
        Values {
            words: [[0; 2]; WORDS],
            bits: [0; BIT_BYTES],
            master_writes: 0,
            #[cfg(feature = "diagnostics")]
            exception_status: 0,
            #[cfg(feature = "diagnostics")]
            device_info: &[],
            #[cfg(feature = "device-id")]
            identification: None,
        }
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

    /// FC 7's status bits (0 without feature `diagnostics`).
    #[inline(always)]
    pub fn exception_status(&self) -> u8 {
        #[cfg(feature = "diagnostics")]
        return self.exception_status;
        #[cfg(not(feature = "diagnostics"))]
        0
    }

    /// FC 17's device description (empty without feature `diagnostics`).
    #[inline(always)]
    pub fn device_info(&self) -> &[u8] {
        #[cfg(feature = "diagnostics")]
        return self.device_info;
        #[cfg(not(feature = "diagnostics"))]
        &[]
    }

    /// Sets FC 7's status bits (feature `diagnostics`).
    #[cfg(feature = "diagnostics")]
    pub fn set_exception_status(&mut self, bits: u8) {
        self.exception_status = bits;
    }

    /// Sets FC 17's device description (feature `diagnostics`).
    #[cfg(feature = "diagnostics")]
    pub fn set_device_info(&mut self, info: &'static [u8]) {
        self.device_info = info;
    }

    /// FC 43's objects (none without feature `device-id`).
    #[inline(always)]
    pub fn identification(&self) -> Option<&'static Identification> {
        #[cfg(feature = "device-id")]
        return self.identification;
        #[cfg(not(feature = "device-id"))]
        None
    }

    /// Sets FC 43's objects (feature `device-id`).
    #[cfg(feature = "device-id")]
    pub fn set_identification(&mut self, identification: &'static Identification) {
        self.identification = Some(identification);
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
