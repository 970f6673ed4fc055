//! [`Configurable`]: a data model with the settings block (see the `block` module) among
//! its holding registers, Modbus over Serial Line v1.02 §2.5.1 and §2.2.

use super::block::{LineSettings, BLOCK_LEN};
use crate::error::Error;
use crate::link::config::Config;
use crate::protocol::reference::{IntoReference, Reference, Table};
use crate::slave::model::DataModel;
use crate::slave::pdu::Exception;

/// A data model with a settings block: holding registers `first`..`first + 3` hold the
/// line settings (see the module documentation), every other address is `M`'s.
///
/// The switch to settings the master wrote takes three steps: the write is checked and
/// answered in the interrupt ([`LineSettings::is_runnable`]); the main loop computes the
/// [`Config`] ([`Configurable::pending`], then [`Configurable::offer`]); the slave switches
/// when the reply has left the wire ([`DataModel::take_new_settings`]), and the main loop
/// stores what it switched to ([`Configurable::take_unsaved`]). On the Uno,
/// `Slave::poll_settings` does the main loop's part.
///
/// ```
/// use avr_modbus::Configurable;
/// use avr_modbus::{bit_bytes, Bank, Config, Parity, StopBits};
/// const DEFAULT: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
/// let mut bank: Bank<1, 4, { bit_bytes(0) }> = Bank::new();
/// bank.add_range(40001, 4).unwrap();
/// let mut model = Configurable::new(bank, 40101, DEFAULT).unwrap();
/// model.set(40001, 7).unwrap();
/// assert_eq!(model.get(40102), Ok(192)); // 19200 bps
/// ```
#[derive(Clone, Debug)]
pub struct Configurable<M> {
    model: M,
    first: u16,
    current: Config,
    pending: Option<LineSettings>,
    ready: Option<Config>,
    unsaved: bool,
    writes: u16,
}

impl<M: DataModel> Configurable<M> {
    /// Wraps `model` with a settings block of four holding registers from `first` (e.g.
    /// 40101), showing `config`, the settings the slave starts with. Fails when `first` is
    /// not a holding register, the block would pass address 65535, or `model` already has
    /// one of the block's addresses.
    pub fn new(model: M, first: impl IntoReference, config: Config) -> Result<Self, Error> {
        let Reference { table, address } = first.into_reference()?;
        if table != Table::HoldingRegisters {
            return Err(Error::BadReference);
        }
        address.checked_add(BLOCK_LEN - 1).ok_or(Error::BadRange)?;
        if (0..BLOCK_LEN).any(|k| model.has_range(Table::HoldingRegisters, address + k, 1)) {
            return Err(Error::Duplicate);
        }
        Ok(Configurable {
            model,
            first: address,
            current: config,
            pending: None,
            ready: None,
            unsaved: false,
            writes: 0,
        })
    }

    /// The settings the slave runs.
    pub fn config(&self) -> Config {
        self.current
    }

    /// The settings the block shows: the ones the master last wrote, even if the slave has
    /// not switched to them yet.
    pub fn settings(&self) -> LineSettings {
        self.pending.unwrap_or(LineSettings::of(&self.current))
    }

    /// Settings the master wrote that still wait for their [`Config`] (see
    /// [`Configurable::offer`]).
    pub fn pending(&self) -> Option<LineSettings> {
        self.pending.filter(|_| self.ready.is_none())
    }

    /// Hands over the [`Config`] computed for [`Configurable::pending`] `settings`;
    /// ignored if the master has written something else since.
    pub fn offer(&mut self, settings: LineSettings, config: Config) {
        if self.pending == Some(settings) && LineSettings::of(&config) == settings {
            self.ready = Some(config);
        }
    }

    /// The wrapped model.
    pub fn inner(&self) -> &M {
        &self.model
    }

    /// The wrapped model, to update inputs or read what the master wrote.
    pub fn inner_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// Settings the slave switched to since the last call, to be made persistent: once per
    /// switch.
    pub fn take_unsaved(&mut self) -> Option<Config> {
        core::mem::take(&mut self.unsaved).then_some(self.current)
    }

    /// Offset in the block of `qty` registers from `start`: `None` when they miss the block
    /// entirely, `Some(Err)` when they cover only part of it and something outside.
    fn in_block(&self, start: u16, qty: u16) -> Option<Result<usize, Exception>> {
        let last = u32::from(start) + u32::from(qty.max(1)) - 1;
        let (first, block_last) = (u32::from(self.first), u32::from(self.first) + u32::from(BLOCK_LEN) - 1);
        if last < first || u32::from(start) > block_last {
            None
        } else if u32::from(start) >= first && last <= block_last {
            Some(Ok(usize::from(start - self.first)))
        } else {
            // A range lies in one run: half in the block is like half in a bank run.
            Some(Err(Exception::IllegalDataAddress))
        }
    }
}

impl<M: DataModel> Configurable<M> {
    /// A value of the bank, or of the settings block (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let r = reference.into_reference()?;
        match (r.table, self.in_block(r.address, 1)) {
            (Table::HoldingRegisters, Some(Ok(k))) => {
                self.settings().to_registers().get(k).copied().ok_or(Error::NotFound)
            }
            _ => self.model.value(r),
        }
    }

    /// Sets a value of the bank (see [`crate::Bank::set`]); the settings block is the
    /// master's, and setting it is [`Error::BadReference`].
    pub fn set(&mut self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let r = reference.into_reference()?;
        match (r.table, self.in_block(r.address, 1)) {
            (Table::HoldingRegisters, Some(_)) => Err(Error::BadReference),
            _ => self.model.set_value(r, value),
        }
    }

    /// How many master writes succeeded, to the bank or the settings block (wrapping).
    pub fn master_writes(&self) -> u16 {
        self.model.master_writes().wrapping_add(self.writes)
    }
}

impl<M: DataModel> DataModel for Configurable<M> {
    fn value(&self, reference: Reference) -> Result<u16, Error> {
        self.get(reference)
    }

    fn set_value(&mut self, reference: Reference, value: u16) -> Result<(), Error> {
        self.set(reference, value)
    }

    fn master_writes(&self) -> u16 {
        Configurable::master_writes(self)
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.model.read_bits(table, start, qty, out)
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        let qty = u16::try_from(out.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        match (table, self.in_block(start, qty)) {
            (Table::HoldingRegisters, Some(offset)) => {
                let registers = self.settings().to_registers();
                for (pair, value) in out.chunks_exact_mut(2).zip(registers.get(offset?..).unwrap_or(&[])) {
                    pair.copy_from_slice(&value.to_be_bytes());
                }
                Ok(())
            }
            _ => self.model.read_registers(table, start, out),
        }
    }

    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        match (table, self.in_block(start, qty)) {
            (Table::HoldingRegisters, Some(offset)) => offset.is_ok(),
            _ => self.model.has_range(table, start, qty),
        }
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        self.model.write_coils(start, qty, packed)
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        let qty = u16::try_from(values.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        let Some(offset) = self.in_block(start, qty) else {
            return self.model.write_registers(start, values);
        };
        let base = self.settings();
        let mut registers = base.to_registers();
        for (slot, pair) in registers.iter_mut().skip(offset?).zip(values.chunks_exact(2)) {
            if let [hi, lo] = *pair {
                *slot = u16::from_be_bytes([hi, lo]);
            }
        }
        self.pending = Some(LineSettings::from_registers(&base, registers)?);
        self.ready = None;
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }

    fn exception_status(&self) -> u8 {
        self.model.exception_status()
    }

    fn device_info(&self) -> &[u8] {
        self.model.device_info()
    }

    fn identification(&self) -> Option<&crate::Identification> {
        self.model.identification()
    }

    fn take_new_settings(&mut self) -> Option<Config> {
        let config = self.ready.take()?;
        self.pending = None;
        self.current = config;
        self.unsaved = true;
        Some(config)
    }
}
