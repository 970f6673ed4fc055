//! 32-bit values in two consecutive 16-bit registers. The Application Protocol (v1.1b3 §4.2)
//! defines only 16-bit registers, sent big-endian; a `u32`, `i32` or `f32` (IEEE 754
//! single) takes two, in one of two word orders devices disagree on: [`WordOrder`].

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
