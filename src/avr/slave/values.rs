//! The application's reads and writes of the slave's values: the role's side of the
//! shared accessors (`crate::avr::values`).

use embedded_hal::digital::OutputPin;

use super::Slave;
use crate::avr::values::Values;
use crate::error::Error;
use crate::protocol::reference::IntoReference;
use crate::slave::model::DataModel;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char> Values
    for Slave<M, DE, LED, N, U, C>
{
    type Model = M;

    #[inline(always)]
    fn with_model<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.with(f)
    }
}

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char>
    Slave<M, DE, LED, N, U, C>
{
    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        Values::get(self, reference)
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        Values::set(self, reference, value)
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]): both read with interrupts disabled, so never a pair the master
    /// is writing half of (its write runs whole in an interrupt).
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        Values::get_wide(self, first, order)
    }

    /// Sets the two registers from `first` to `value` in `order`, both with interrupts
    /// disabled: a master never reads the pair half old, half new.
    pub fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        Values::set_wide(self, first, value, order)
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]): compare it with the last value seen to learn that
    /// the master wrote something.
    pub fn master_writes(&self) -> u16 {
        Values::master_writes(self)
    }
}
