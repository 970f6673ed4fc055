//! Several slave ids on one line, Modbus over Serial Line v1.02 §2.2 (addresses 1–247,
//! broadcast 0): one board standing in for several slaves, each id with a model of its own
//! ([`Units`]) or with its own window of one model ([`Windows`]).
//!
//! The engine asks the model whether it answers a frame's address ([`DataModel::select`])
//! instead of comparing it with the slave id of [`crate::Config`], which a units model does
//! not use: its ids are its own. A broadcast's write runs once for each id. The line's
//! counters, FC 8's listen-only mode and the frame buffer stay the engine's, one for the
//! line; FC 17 (Report Server ID) reports the id addressed.

use crate::error::Error;
#[cfg(feature = "eeprom-settings")]
use crate::link::config::Config;
use crate::protocol::reference::{IntoReference, Table};
use crate::protocol::Exception;
use crate::slave::model::{Access, DataModel};
use crate::slave::pdu::device_id::Identification;
use crate::slave::words::Place;

/// The highest slave id (Serial Line §2.2: 248–255 are reserved).
const LAST_ID: u8 = 247;

/// The index of `unit` among `n` ids from `first`, when it is one of them and a slave id
/// (1–247).
#[inline(always)]
fn index(first: u8, n: usize, unit: u8) -> Option<u8> {
    let k = unit.wrapping_sub(first);
    (usize::from(k) < n && unit != 0 && unit <= LAST_ID).then_some(k)
}

/// `N` slaves on one line, each with a model of its own: slave ids `first` to
/// `first + N - 1` (ids past 247 are never answered), id `first + k` served by `models[k]`.
///
/// ```
/// use avr_modbus::Units;
/// avr_modbus::register_map! {
///     /// One sensor: its reading and its alarm threshold.
///     struct Sensor { 30001..=30001, 40001..=40001 }
/// }
/// // Four sensors at slave ids 1–4.
/// let mut sensors = Units::new(1, [Sensor::new(), Sensor::new(), Sensor::new(), Sensor::new()]);
/// sensors.set(3, 30001, 215).unwrap();
/// assert_eq!(sensors.get(3, 30001), Ok(215));
/// assert_eq!(sensors.get(5, 30001), Err(avr_modbus::Error::NotFound));
/// ```
///
/// In a firmware the slave holds it: `SLAVE.with(|s| s.set(3, 30001, reading))`. A
/// broadcast's write is made in every model; the slave's own `get` and `set` find nothing
/// ([`crate::Error::NotFound`]): a reference alone does not say which unit.
#[derive(Clone, Debug)]
pub struct Units<M, const N: usize> {
    models: [M; N],
    first: u8,
    /// The unit [`DataModel::select`] chose last.
    selected: u8,
}

impl<M, const N: usize> Units<M, N> {
    /// Slave ids `first` to `first + N - 1`, id `first + k` served by `models[k]`.
    pub const fn new(first: u8, models: [M; N]) -> Self {
        const { assert!(N >= 1 && N <= LAST_ID as usize, "Units: 1 to 247 units") };
        Units { models, first, selected: 0 }
    }

    /// Slave id `unit`'s model, if `unit` is one of the ids.
    pub fn unit(&self, unit: u8) -> Option<&M> {
        self.models.get(usize::from(index(self.first, N, unit)?))
    }

    /// Slave id `unit`'s model, to change, if `unit` is one of the ids.
    pub fn unit_mut(&mut self, unit: u8) -> Option<&mut M> {
        self.models.get_mut(usize::from(index(self.first, N, unit)?))
    }

    /// The model of the unit selected last.
    #[inline(always)]
    fn chosen(&self) -> Option<&M> {
        self.models.get(usize::from(self.selected))
    }

    /// The model of the unit selected last, to change.
    #[inline(always)]
    fn chosen_mut(&mut self) -> Option<&mut M> {
        self.models.get_mut(usize::from(self.selected))
    }
}

impl<M: DataModel, const N: usize> Units<M, N> {
    /// The value at `reference` in slave id `unit`'s model ([`crate::Error::NotFound`]
    /// when `unit` is not one of the ids).
    pub fn get(&self, unit: u8, reference: impl IntoReference) -> Result<u16, Error> {
        let reference = reference.into_reference()?;
        self.unit(unit).ok_or(Error::NotFound)?.value(reference)
    }

    /// Sets the value at `reference` in slave id `unit`'s model.
    pub fn set(&mut self, unit: u8, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let reference = reference.into_reference()?;
        self.unit_mut(unit).ok_or(Error::NotFound)?.set_value(reference, value)
    }
}

impl<M: DataModel, const N: usize> DataModel for Units<M, N> {
    const FRAME: usize = M::FRAME;
    const FRAME_HOLDS_ALL: bool = M::FRAME_HOLDS_ALL;
    const UNITS: bool = true;

    #[inline(always)]
    fn select(&mut self, unit: u8) -> bool {
        match index(self.first, N, unit) {
            Some(k) => {
                self.selected = k;
                true
            }
            None => false,
        }
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.chosen().ok_or(Exception::ServerDeviceFailure)?.read_bits(table, start, qty, out)
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.chosen().ok_or(Exception::ServerDeviceFailure)?.read_registers(table, start, out)
    }

    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        self.chosen().is_some_and(|m| m.has_range(table, start, qty))
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        self.chosen_mut().ok_or(Exception::ServerDeviceFailure)?.write_coils(start, qty, packed)
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        self.chosen_mut().ok_or(Exception::ServerDeviceFailure)?.write_registers(start, values)
    }

    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        self.chosen_mut().ok_or(Exception::ServerDeviceFailure)?.transfer(access, table, start, qty, data)
    }

    /// The sum of every unit's, wrapping.
    fn master_writes(&self) -> u16 {
        self.models.iter().fold(0, |sum, m| sum.wrapping_add(m.master_writes()))
    }

    fn exception_status(&self) -> u8 {
        self.chosen().map_or(0, M::exception_status)
    }

    fn device_info(&self) -> &[u8] {
        self.chosen().map_or(&[], M::device_info)
    }

    fn identification(&self) -> Option<&Identification> {
        self.chosen()?.identification()
    }

    #[cfg(feature = "eeprom-settings")]
    fn take_new_settings(&mut self) -> Option<Config> {
        self.models.iter_mut().find_map(M::take_new_settings)
    }
}

/// `N` slaves on one line sharing one model, each seeing its own window of it: slave ids
/// `first` to `first + N - 1` (ids past 247 are never answered), id `first + k` finding
/// address `a` of each table at `a + k * stride` of the model. A reference past 65535 or
/// outside the model is a missing address (exception 02).
///
/// ```
/// use avr_modbus::Windows;
/// avr_modbus::register_map! {
///     /// Four sensors' readings and thresholds, ten addresses apart.
///     struct Sensors { 30001..=30031, 40001..=40031 }
/// }
/// // Slave ids 1–4: id 1 reads 30001 as 30001, id 2 as 30011, id 3 as 30021, id 4 as 30031.
/// let mut sensors: Windows<Sensors, 4> = Windows::new(1, 10, Sensors::new());
/// sensors.model_mut().set(30021, 215).unwrap();
/// ```
///
/// The slave's own `get` and `set` (and [`DataModel::value`]) reach the whole model, by its
/// own references: `SLAVE.set(30021, reading)` is what id 3 reads at 30001.
#[derive(Clone, Debug)]
pub struct Windows<M, const N: usize> {
    model: M,
    first: u8,
    stride: u16,
    /// The unit [`DataModel::select`] chose last.
    selected: u8,
}

impl<M, const N: usize> Windows<M, N> {
    /// Slave ids `first` to `first + N - 1`, id `first + k` seeing `model` from `k * stride`.
    pub const fn new(first: u8, stride: u16, model: M) -> Self {
        const { assert!(N >= 1 && N <= LAST_ID as usize, "Windows: 1 to 247 windows") };
        Windows { model, first, stride, selected: 0 }
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The model, to change.
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// Where the selected unit's window puts `qty` (≥ 1) addresses from `start`: `None`
    /// when they run past 65535.
    #[inline(always)]
    fn shifted(&self, start: u16, qty: u16) -> Option<u16> {
        let at = u32::from(start) + u32::from(self.selected) * u32::from(self.stride);
        let at = u16::try_from(at).ok()?;
        at.checked_add(qty.wrapping_sub(1))?;
        Some(at)
    }

    /// [`Windows::shifted`], or exception 02.
    #[inline(always)]
    fn at(&self, start: u16, qty: u16) -> Result<u16, Exception> {
        self.shifted(start, qty).ok_or(Exception::IllegalDataAddress)
    }
}

impl<M: DataModel, const N: usize> DataModel for Windows<M, N> {
    const FRAME: usize = M::FRAME;
    const FRAME_HOLDS_ALL: bool = M::FRAME_HOLDS_ALL;
    const UNITS: bool = true;

    #[inline(always)]
    fn select(&mut self, unit: u8) -> bool {
        match index(self.first, N, unit) {
            Some(k) => {
                self.selected = k;
                true
            }
            None => false,
        }
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.model.read_bits(table, self.at(start, qty)?, qty, out)
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        let qty = (out.len() / 2) as u16;
        self.model.read_registers(table, self.at(start, qty)?, out)
    }

    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        self.shifted(start, qty).is_some_and(|at| self.model.has_range(table, at, qty))
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        let at = self.at(start, qty)?;
        self.model.write_coils(at, qty, packed)
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        let at = self.at(start, (values.len() / 2) as u16)?;
        self.model.write_registers(at, values)
    }

    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        let at = self.at(start, qty)?;
        self.model.transfer(access, table, at, qty, data)
    }

    fn value(&self, reference: crate::Reference) -> Result<u16, Error> {
        self.model.value(reference)
    }

    fn set_value(&mut self, reference: crate::Reference, value: u16) -> Result<(), Error> {
        self.model.set_value(reference, value)
    }

    #[inline(always)]
    fn place(reference: crate::Reference) -> Place {
        M::place(reference)
    }

    fn load(&self, place: Place) -> u16 {
        self.model.load(place)
    }

    fn store(&mut self, place: Place, stored: u16) {
        self.model.store(place, stored)
    }

    fn master_writes(&self) -> u16 {
        self.model.master_writes()
    }

    fn exception_status(&self) -> u8 {
        self.model.exception_status()
    }

    fn device_info(&self) -> &[u8] {
        self.model.device_info()
    }

    fn identification(&self) -> Option<&Identification> {
        self.model.identification()
    }

    #[cfg(feature = "eeprom-settings")]
    fn take_new_settings(&mut self) -> Option<Config> {
        self.model.take_new_settings()
    }
}
