//! The value storage both register maps share (the build-time `register_map!` and the
//! run-time `Bank`): registers as two bytes, coils and discrete inputs packed 8 to a byte, LSB
//! first, and the copies between them and the PDU, Application Protocol v1.1b3 §6.1–6.12.
//!
//! A register is kept as it travels, big-endian ([`Word`]): FC 3, 4, 6 and 16 copy bytes,
//! and only the application's `get` and `set` convert.

/// A register's value, big-endian (high byte first), as on the wire.
pub(crate) type Word = [u8; 2];

/// The value of a register kept as a [`Word`], 0 past the end.
#[inline(always)]
pub(crate) fn word(words: &[Word], i: usize) -> u16 {
    words.get(i).map_or(0, |&w| u16::from_be_bytes(w))
}

/// Sets the register `i` kept as a [`Word`].
#[inline(always)]
pub(crate) fn set_word(words: &mut [Word], i: usize, value: u16) {
    if let Some(slot) = words.get_mut(i) {
        *slot = value.to_be_bytes();
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

/// FC 1 / 2's data: `qty` bits from index `first`, packed LSB first into `out`, the unused
/// high bits of the last byte zero.
#[inline(always)]
pub(crate) fn read_bits(bits: &[u8], first: usize, qty: u16, out: &mut [u8]) {
    out.fill(0);
    for k in 0..usize::from(qty) {
        if let (true, Some(byte)) = (bit(bits, first + k), out.get_mut(k / 8)) {
            *byte |= 1 << (k % 8);
        }
    }
}

/// FC 5 / 15: `qty` bits from index `first`, from `packed` LSB first.
#[inline(always)]
pub(crate) fn write_bits(bits: &mut [u8], first: usize, qty: u16, packed: &[u8]) {
    for k in 0..usize::from(qty) {
        let byte = packed.get(k / 8).copied().unwrap_or(0);
        set_bit(bits, first + k, byte & (1 << (k % 8)) != 0);
    }
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
