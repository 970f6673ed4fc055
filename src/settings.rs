//! Line settings a master can change and the device keeps across resets, Modbus over
//! Serial Line v1.02 §2.5.1 (baud rate, parity, stop bits) and §2.2 (slave address).
//!
//! Two representations of one [`Config`]:
//!
//! * **The settings block**: four holding registers at an address the application
//!   chooses, read and written with FC 03, 06 and 16 (and 22/23 with `extra-fc`):
//!
//!   | offset | register  | values                                         |
//!   |-------:|-----------|------------------------------------------------|
//!   | 0      | slave id  | 1–247                                          |
//!   | 1      | baud/100  | 12–10000 (115200 bps = 1152)                   |
//!   | 2      | parity    | 0 none, 1 odd, 2 even                          |
//!   | 3      | stop bits | 1 or 2                                         |
//!
//!   A write builds a candidate from the settings with the written registers replaced (so
//!   FC 06 on one register changes just that setting) and checks it as
//!   [`Config::try_new`] would ([`LineSettings::is_runnable`]): anything the slave can't
//!   run (an unknown code, a rate the 16 MHz USART can't make) is answered with exception
//!   03 (Illegal Data Value) and changes nothing. A baud register written with the value it already reads keeps the exact rate,
//!   so rates that are not a multiple of 100 survive a write of the whole block.
//!   [`Configurable`] wraps any [`DataModel`] with such a block; the slave applies a valid
//!   write only after the reply to it has left the wire (see
//!   [`DataModel::take_new_settings`]).
//!
//! * **The EEPROM record**: [`RECORD_LEN`] bytes with a sequence number and a CRC
//!   ([`encode`], [`decode`]; a format-1 record of earlier firmware is still read,
//!   [`decode_legacy`]), kept in two [`Slots`] so that a reset during a store leaves the
//!   old settings or the new ones, never neither. The AVR layer reads and writes the
//!   slots' bytes. When neither slot holds a valid record, the application starts with its
//!   compiled-in default.

use crate::config::{Config, Parity, SlaveId, StopBits};
use crate::error::Error;
use crate::model::DataModel;
use crate::pdu::Exception;
use crate::reference::{IntoReference, Reference, Table};
use crate::timing::{BaudDivisor, CLOCK_HZ};

mod record;
mod slots;

pub use record::{decode, decode_legacy, encode, Record, LEGACY_LEN, LEGACY_MAGIC, MAGIC, RECORD_LEN};
pub use slots::{is_newer, Newest, Slot, Slots, Write, Writes, MAX_WRITES, SLOTS_LEN};

/// Registers in the settings block.
pub const BLOCK_LEN: u16 = 4;

/// Offset of the slave id in the settings block.
pub const SLAVE_ID: u16 = 0;
/// Offset of the baud rate / 100 in the settings block.
pub const BAUD_100: u16 = 1;
/// Offset of the parity code in the settings block.
pub const PARITY: u16 = 2;
/// Offset of the stop bits in the settings block.
pub const STOP_BITS: u16 = 3;

/// The code of a parity in the settings block and the record: 0 none, 1 odd, 2 even.
pub const fn parity_code(parity: Parity) -> u8 {
    match parity {
        Parity::None => 0,
        Parity::Odd => 1,
        Parity::Even => 2,
    }
}

/// The parity of a code, `None` for an unknown code.
pub const fn parity_from_code(code: u16) -> Option<Parity> {
    match code {
        0 => Some(Parity::None),
        1 => Some(Parity::Odd),
        2 => Some(Parity::Even),
        _ => None,
    }
}

/// The number of stop bits: 1 or 2.
pub const fn stop_bits_count(stop_bits: StopBits) -> u8 {
    match stop_bits {
        StopBits::One => 1,
        StopBits::Two => 2,
    }
}

/// The stop bits of a count, `None` unless 1 or 2.
pub const fn stop_bits_from_count(count: u16) -> Option<StopBits> {
    match count {
        1 => Some(StopBits::One),
        2 => Some(StopBits::Two),
        _ => None,
    }
}

/// Line settings as plain values: what the master writes, checked with integer math fast
/// enough for an interrupt handler. Turning them into a [`Config`] (the USART divisor and
/// the Timer0 plan) takes several 32-bit divisions, under a millisecond on the Uno (about
/// 0.7 ms measured in simulation): the application does that in its main loop (see
/// [`Configurable::offer`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineSettings {
    /// Slave id.
    pub slave_id: u8,
    /// Bits per second.
    pub baud: u32,
    /// Parity bit.
    pub parity: Parity,
    /// Stop bits.
    pub stop_bits: StopBits,
}

impl LineSettings {
    /// The settings of `config`.
    pub const fn of(config: &Config) -> Self {
        LineSettings {
            slave_id: config.slave_id().get(),
            baud: config.baud(),
            parity: config.parity(),
            stop_bits: config.stop_bits(),
        }
    }

    /// The settings block's four registers.
    pub fn to_registers(&self) -> [u16; BLOCK_LEN as usize] {
        [
            u16::from(self.slave_id),
            u16::try_from(self.baud / 100).unwrap_or(u16::MAX),
            u16::from(parity_code(self.parity)),
            u16::from(stop_bits_count(self.stop_bits)),
        ]
    }

    /// The settings four block registers describe. `base` is what they were read from: a
    /// baud register still reading `base`'s value keeps `base`'s exact rate. Exception 03
    /// when the registers describe settings the slave can't run.
    pub fn from_registers(base: &LineSettings, registers: [u16; BLOCK_LEN as usize]) -> Result<Self, Exception> {
        let [id, baud_100, parity, stop] = registers;
        let baud = u32::from(baud_100) * 100;
        // `baud_100 == base.baud / 100`, without a division.
        let baud = if (baud..baud + 100).contains(&base.baud) { base.baud } else { baud };
        let settings = LineSettings {
            slave_id: u8::try_from(id).map_err(|_| Exception::IllegalDataValue)?,
            baud,
            parity: parity_from_code(parity).ok_or(Exception::IllegalDataValue)?,
            stop_bits: stop_bits_from_count(stop).ok_or(Exception::IllegalDataValue)?,
        };
        if settings.is_runnable() {
            Ok(settings)
        } else {
            Err(Exception::IllegalDataValue)
        }
    }

    /// True exactly when [`LineSettings::to_config`] succeeds: slave id 1–247, a rate from
    /// [`Config::MIN_BAUD`] to [`Config::MAX_BAUD`] that the 16 MHz USART makes within
    /// [`BaudDivisor::MAX_ERROR_PPM`] at normal or double speed. Only the divisor search
    /// (two 32-bit divisions and a few 64-bit products), not the timer plan: cheap enough
    /// for the interrupt that answers the write.
    pub fn is_runnable(&self) -> bool {
        SlaveId::new(self.slave_id).is_ok()
            && (Config::MIN_BAUD..=Config::MAX_BAUD).contains(&self.baud)
            && BaudDivisor::new(self.baud, CLOCK_HZ).is_some()
    }

    /// The configuration, `None` when [`Config::try_new`] refuses it.
    pub fn to_config(&self) -> Option<Config> {
        Config::try_new(self.slave_id, self.baud, self.parity, self.stop_bits).ok()
    }
}

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
/// use avr_modbus_slave::Configurable;
/// use avr_modbus_slave::{bit_bytes, Bank, Config, Parity, StopBits};
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

    fn take_new_settings(&mut self) -> Option<Config> {
        let config = self.ready.take()?;
        self.pending = None;
        self.current = config;
        self.unsaved = true;
        Some(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parity_and_stop_codes_round_trip() {
        for parity in [Parity::None, Parity::Odd, Parity::Even] {
            assert_eq!(parity_from_code(u16::from(parity_code(parity))), Some(parity));
        }
        for stop in [StopBits::One, StopBits::Two] {
            assert_eq!(stop_bits_from_count(u16::from(stop_bits_count(stop))), Some(stop));
        }
        assert_eq!(parity_from_code(3), None);
        assert_eq!(stop_bits_from_count(0), None);
    }
}
