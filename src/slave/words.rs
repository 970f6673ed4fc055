//! How the maps keep values (Application Protocol v1.1b3 §6.1–6.12): registers as two
//! bytes, coils and discrete inputs packed 8 to a byte, LSB first, the copies between them
//! and the PDU, and the place of one value for the application's `get` and `set`.
//!
//! A register is kept as it travels, big-endian ([`Word`]): FC 3, 4, 6 and 16 copy bytes,
//! and only the application's `get` and `set` convert.

use crate::protocol::reference::Table;

/// Which way a request moves values between the PDU and a [`crate::DataModel`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// FC 1–4: from the model into the reply.
    Read,
    /// FC 5, 6, 15 (0x0F) and 16 (0x10): from the request into the model.
    Write,
}

/// A register's value, big-endian (high byte first), as on the wire.
pub(crate) type Word = [u8; 2];

/// `value` with its bytes swapped: [`u16::swap_bytes`], but as three instructions on the
/// AVR, where the backend writes a byte swap out as seven. A big-endian pair of bytes
/// loaded or stored side by side becomes one 16-bit access and a swap.
#[inline(always)]
#[cfg_attr(target_arch = "avr", allow(unsafe_code))]
pub(crate) fn swap(value: u16) -> u16 {
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
pub(crate) fn copy_bits(src: &[u8], from: usize, dst: &mut [u8], to: usize, qty: u16) {
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
