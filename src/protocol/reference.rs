//! The four tables of the Modbus data model, Application Protocol v1.1b3 §4.3–4.4, and
//! the classic 5-digit references (00001 coils, 10001 discrete inputs, 30001 input
//! registers, 40001 holding registers) that name their entries on the bench.

use crate::error::Error;

/// One of the four tables of the data model.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Table {
    /// Coils (0x): single bits, read/write (FC 1, 5, 15).
    Coils = 0,
    /// Discrete inputs (1x): single bits, read-only (FC 2).
    DiscreteInputs = 1,
    /// Input registers (3x): 16-bit words, read-only (FC 4).
    InputRegisters = 2,
    /// Holding registers (4x): 16-bit words, read/write (FC 3, 6, 16).
    HoldingRegisters = 3,
}

impl Table {
    /// True for the two single-bit tables.
    pub const fn is_bits(self) -> bool {
        matches!(self, Table::Coils | Table::DiscreteInputs)
    }
}

/// One entry of the data model: a table and a 0-based protocol address (0–65535).
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Reference {
    /// The table.
    pub table: Table,
    /// The 0-based address the master puts in the PDU.
    pub address: u16,
}

impl Reference {
    /// Coil at protocol `address` (classic 00001 is address 0).
    pub const fn coil(address: u16) -> Self {
        Reference { table: Table::Coils, address }
    }

    /// Discrete input at protocol `address` (classic 10001 is address 0).
    pub const fn discrete_input(address: u16) -> Self {
        Reference { table: Table::DiscreteInputs, address }
    }

    /// Input register at protocol `address` (classic 30001 is address 0).
    pub const fn input_register(address: u16) -> Self {
        Reference { table: Table::InputRegisters, address }
    }

    /// Holding register at protocol `address` (classic 40001 is address 0).
    pub const fn holding_register(address: u16) -> Self {
        Reference { table: Table::HoldingRegisters, address }
    }

    /// The entry a classic 5-digit reference names: 40001 is holding register 0,
    /// 30010 input register 9, 10001 discrete input 0, 1 (00001) coil 0.
    pub const fn classic(number: u32) -> Result<Self, Error> {
        // Range matches rather than `/ 10_000`: no division on the AVR.
        let (table, first) = match number {
            1..=9_999 => (Table::Coils, 1),
            10_001..=19_999 => (Table::DiscreteInputs, 10_001),
            30_001..=39_999 => (Table::InputRegisters, 30_001),
            40_001..=49_999 => (Table::HoldingRegisters, 40_001),
            _ => return Err(Error::BadReference),
        };
        Ok(Reference { table, address: (number - first) as u16 })
    }
}

/// Anything that names an entry of the data model: a [`Reference`], or a classic
/// reference number such as `40001` as a `u16`, `u32`, `i32` (a bare literal) or `usize`
/// (`30001 + i` with `i` an array index). A number that is no classic reference (0,
/// 20001, 50000, a negative one) is [`Error::BadReference`].
pub trait IntoReference {
    /// The entry, or [`Error::BadReference`].
    fn into_reference(self) -> Result<Reference, Error>;
}

impl IntoReference for Reference {
    fn into_reference(self) -> Result<Reference, Error> {
        Ok(self)
    }
}

impl IntoReference for u16 {
    fn into_reference(self) -> Result<Reference, Error> {
        Reference::classic(u32::from(self))
    }
}

impl IntoReference for u32 {
    fn into_reference(self) -> Result<Reference, Error> {
        Reference::classic(self)
    }
}

impl IntoReference for usize {
    fn into_reference(self) -> Result<Reference, Error> {
        match u32::try_from(self) {
            Ok(n) => Reference::classic(n),
            Err(_) => Err(Error::BadReference),
        }
    }
}

impl IntoReference for i32 {
    fn into_reference(self) -> Result<Reference, Error> {
        match u32::try_from(self) {
            Ok(n) => Reference::classic(n),
            Err(_) => Err(Error::BadReference),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classic_references_are_one_based_with_a_table_prefix() {
        assert_eq!(Reference::classic(1), Ok(Reference::coil(0)));
        assert_eq!(Reference::classic(9999), Ok(Reference::coil(9998)));
        assert_eq!(Reference::classic(10001), Ok(Reference::discrete_input(0)));
        assert_eq!(Reference::classic(30003), Ok(Reference::input_register(2)));
        assert_eq!(Reference::classic(40001), Ok(Reference::holding_register(0)));
        assert_eq!(Reference::classic(49999), Ok(Reference::holding_register(9998)));
    }

    #[test]
    fn classic_references_outside_the_four_ranges_are_refused() {
        for bad in [0, 10000, 20001, 29999, 30000, 40000, 50000, 65535, 400001] {
            assert_eq!(Reference::classic(bad), Err(Error::BadReference), "{bad}");
        }
        assert_eq!((-1i32).into_reference(), Err(Error::BadReference));
    }

    #[test]
    fn literals_of_any_integer_type_name_references() {
        assert_eq!(40001.into_reference(), Ok(Reference::holding_register(0)));
        assert_eq!(30002u16.into_reference(), Ok(Reference::input_register(1)));
        assert_eq!(10005u32.into_reference(), Ok(Reference::discrete_input(4)));
        let index: usize = 4;
        assert_eq!((30001 + index).into_reference(), Ok(Reference::input_register(4)));
        assert_eq!(50_000usize.into_reference(), Err(Error::BadReference));
    }
}
