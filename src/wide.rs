//! 32-bit values in two consecutive 16-bit registers. The Application Protocol (v1.1b3 §4.2)
//! defines only 16-bit registers, sent big-endian; a `u32`, `i32` or `f32` (IEEE 754
//! single) takes two, in one of two word orders devices disagree on: [`WordOrder`].

use crate::error::Error;
use crate::protocol::reference::Reference;
use crate::slave::model::DataModel;

/// Which register of a pair holds the value's high 16 bits.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WordOrder {
    /// The first register holds the high word ("ABCD", big-endian throughout, as the
    /// Application Protocol sends each register): 1.0f32 = 0x3F80, 0x0000. The default.
    #[default]
    HighFirst,
    /// The first register holds the low word ("CDAB", word-swapped): 1.0f32 = 0x0000,
    /// 0x3F80. Many meters and PLCs send it so.
    LowFirst,
}

impl WordOrder {
    /// The two registers of `value`, in this order.
    pub fn split<T: Wide>(self, value: T) -> [u16; 2] {
        let bits = value.to_bits();
        let (high, low) = ((bits >> 16) as u16, bits as u16);
        match self {
            WordOrder::HighFirst => [high, low],
            WordOrder::LowFirst => [low, high],
        }
    }

    /// The value two registers hold in this order: the bits as they are, NaN and
    /// infinities included.
    pub fn join<T: Wide>(self, registers: [u16; 2]) -> T {
        let [first, second] = registers.map(u32::from);
        T::from_bits(match self {
            WordOrder::HighFirst => (first << 16) | second,
            WordOrder::LowFirst => (second << 16) | first,
        })
    }
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for u32 {}
    impl Sealed for i32 {}
    impl Sealed for f32 {}
}

/// A value two registers hold: `u32`, `i32` or `f32`, bit for bit.
pub trait Wide: Copy + sealed::Sealed {
    /// The value's 32 bits.
    fn to_bits(self) -> u32;
    /// The value of 32 bits.
    fn from_bits(bits: u32) -> Self;
}

impl Wide for u32 {
    fn to_bits(self) -> u32 {
        self
    }
    fn from_bits(bits: u32) -> Self {
        bits
    }
}

impl Wide for i32 {
    fn to_bits(self) -> u32 {
        self as u32
    }
    fn from_bits(bits: u32) -> Self {
        bits as i32
    }
}

impl Wide for f32 {
    fn to_bits(self) -> u32 {
        f32::to_bits(self)
    }
    fn from_bits(bits: u32) -> Self {
        f32::from_bits(bits)
    }
}

/// The pair of registers from `first`: two of one register table, the second at the next
/// address. A coil or discrete input, or a first register at 65535, is
/// [`Error::BadReference`].
pub(crate) fn pair(first: Reference) -> Result<(Reference, Reference), Error> {
    match first.address.checked_add(1) {
        Some(address) if !first.table.is_bits() => Ok((first, Reference { table: first.table, address })),
        _ => Err(Error::BadReference),
    }
}

/// The value the pair of registers from `first` holds in `model`, read together.
pub(crate) fn get<M: DataModel + ?Sized, T: Wide>(model: &M, first: Reference, order: WordOrder) -> Result<T, Error> {
    let (first, second) = pair(first)?;
    Ok(order.join([model.value(first)?, model.value(second)?]))
}

/// Sets the pair of registers from `first` in `model` to `value`: both, or neither when
/// one is missing.
pub(crate) fn set<M: DataModel + ?Sized, T: Wide>(
    model: &mut M,
    first: Reference,
    value: T,
    order: WordOrder,
) -> Result<(), Error> {
    let (first, second) = pair(first)?;
    model.value(second)?;
    let [a, b] = order.split(value);
    model.set_value(first, a)?;
    model.set_value(second, b)
}
