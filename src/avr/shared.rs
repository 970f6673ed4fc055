//! One data model served by several ports at once ([`crate::shared_model!`]): an RTU or
//! ASCII slave and the TCP server (Application Protocol v1.1b3 §4.3: one device, one data
//! model, whatever the transport). The model lives in one static cell; each port holds a
//! zero-sized handle that reaches it.
//!
//! A request runs whole with no other port's in between. A serial slave runs its requests
//! in an interrupt handler, interrupts disabled, so they never interleave; the TCP server
//! serves with interrupts enabled and runs each request under
//! [`DataModel::exclusive`], interrupts held off for the request's execution alone (the
//! chip's reads and writes around it stay interruptible). The application's calls hold
//! them off too. So a write lands whole on every port at once, and a 32-bit pair written
//! together is never read half old, half new, whichever port reads it.

use core::cell::UnsafeCell;

use super::reg;
use super::values::Values;
use crate::error::Error;
#[cfg(feature = "eeprom-settings")]
use crate::link::config::Config;
use crate::protocol::reference::{IntoReference, Reference, Table};
use crate::protocol::Exception;
use crate::slave::model::{Access, DataModel};
use crate::slave::pdu::device_id::Identification;
use crate::slave::words::Place;
use crate::slave::written::{Port, Write, WriteLog};

/// A data model several ports serve at once: declare it with [`crate::shared_model!`],
/// name it in [`crate::slave!`] and [`crate::tcp_server!`] in place of the model type, and
/// hand it to each `start`. The application reads and writes it here, as it would a
/// [`crate::Slave`]'s values, and learns who wrote ([`SharedModel::take_write`]).
///
/// ```ignore
/// avr_modbus::shared_model!(MODEL: Registers);
/// avr_modbus::slave!(SLAVE: MODEL);
/// avr_modbus::tcp_server!(SERVER: MODEL, W5100);
/// // in main:
/// SERVER.start(NETWORK, dp.SPI, &*dp.TC0, MODEL)?;
/// SLAVE.start(CONFIG, dp.USART0, dp.TC0, MODEL)?;
/// MODEL.set(30001, reading)?;
/// ```
///
/// Each port keeps its own counters (`SLAVE.counters()`, `SERVER.counters()`).
pub struct SharedModel<M> {
    /// Inside [`SharedModel::with`] (or another access): a nested access is refused.
    busy: UnsafeCell<bool>,
    model: UnsafeCell<M>,
    log: UnsafeCell<WriteLog>,
}

// SAFETY: the chip has one core, and the cell is only touched with interrupts disabled
// (`reg::free` in `SharedModel::access`), with a flag that refuses a nested access.
unsafe impl<M: Send> Sync for SharedModel<M> {}

impl<M> SharedModel<M> {
    /// The cell, holding `model`: what [`crate::shared_model!`] declares.
    #[doc(hidden)]
    pub const fn new(model: M) -> Self {
        SharedModel {
            busy: UnsafeCell::new(false),
            model: UnsafeCell::new(model),
            log: UnsafeCell::new(WriteLog::new()),
        }
    }

    /// Runs `f` on the model with interrupts disabled, marked in use: `None` inside another
    /// access (a `with` inside a `with`).
    #[inline(always)]
    fn access<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        reg::free(|| {
            // SAFETY: interrupts are disabled, so no other access runs now but the one
            // `busy` marks, which this one then leaves alone.
            unsafe {
                if *self.busy.get() {
                    return None;
                }
                *self.busy.get() = true;
                let result = f(&mut *self.model.get());
                *self.busy.get() = false;
                Some(result)
            }
        })
    }

    /// A port's access to the model and the record: [`SharedModel::access`] without marking
    /// the model in use, which only the application's calls need (a port's access runs in
    /// the port's interrupt handler or inside [`DataModel::exclusive`], where no other
    /// access can start).
    #[inline(always)]
    fn port_access<R>(&self, f: impl FnOnce(&mut M, &mut WriteLog) -> R) -> Option<R> {
        reg::free(|| {
            // SAFETY: interrupts are disabled, and no access of the application's is under
            // way (`busy`): nothing else holds the model. What runs inside is the model's
            // own code, which does not reach its shared handle, and the record's.
            unsafe {
                if *self.busy.get() {
                    return None;
                }
                Some(f(&mut *self.model.get(), &mut *self.log.get()))
            }
        })
    }

    /// Runs `f` on the record of writes with interrupts disabled.
    #[inline(always)]
    fn log<R>(&self, f: impl FnOnce(&mut WriteLog) -> R) -> R {
        // SAFETY: interrupts are disabled, and the record is reached only here and inside a
        // port's access, where only the record's own code runs on it.
        reg::free(|| f(unsafe { &mut *self.log.get() }))
    }
}

impl<M: DataModel> SharedModel<M> {
    /// Runs `f` on the model with interrupts disabled: `None` inside another `with`. Keep
    /// `f` short: every port's interrupts wait while it runs.
    pub fn with<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.access(f)
    }

    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        Values::get(self, reference)
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        Values::set(self, reference, value)
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]): both read with interrupts disabled, so never a pair a master
    /// is writing half of, on any port.
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        Values::get_wide(self, first, order)
    }

    /// Sets the two registers from `first` to `value` in `order`, both with interrupts
    /// disabled: no master, on any port, reads the pair half old, half new.
    pub fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        Values::set_wide(self, first, value, order)
    }

    /// How many master writes succeeded so far, on every port, wrapping (see
    /// [`crate::Bank::master_writes`]).
    pub fn master_writes(&self) -> u16 {
        Values::master_writes(self)
    }

    /// The last write a master made, on any port, since the last call: the port and
    /// client, the unit id, the first reference and how many values (see [`Write`]), and
    /// how many writes before it went untaken. `None` when no master wrote since. Writes
    /// by the application (`set`, `with`) are not recorded.
    pub fn take_write(&self) -> Option<Write> {
        self.log(WriteLog::take)
    }
}

impl<M: DataModel> Values for SharedModel<M> {
    type Model = M;

    #[inline(always)]
    fn with_model<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.with(f)
    }
}

/// What [`crate::shared_model!`] implements for the handle it declares: where the model
/// is. Every handle is then a [`DataModel`], the ports' view of the model.
#[doc(hidden)]
pub trait SharedHandle: 'static {
    /// The model's type.
    type Model: DataModel;

    /// The cell.
    fn cell() -> &'static SharedModel<Self::Model>;
}

/// Runs `f` on `H`'s model and record, interrupts disabled.
#[inline(always)]
fn on<H: SharedHandle, R>(f: impl FnOnce(&mut H::Model, &mut WriteLog) -> R) -> Option<R> {
    H::cell().port_access(f)
}

/// What a port is refused while the application holds the model (only an interrupt
/// handler of the application's own that enables interrupts inside `with` can see it).
const BUSY: Exception = Exception::ServerDeviceFailure;

/// A write `result` of `count` values of `table` from `start` that succeeded goes in the
/// record.
#[inline(always)]
fn record(
    log: &mut WriteLog,
    result: Result<(), Exception>,
    table: Table,
    start: u16,
    count: u16,
) -> Result<(), Exception> {
    if result.is_ok() {
        log.wrote(table, start, count);
    }
    result
}

impl<H: SharedHandle> DataModel for H {
    const FRAME: usize = H::Model::FRAME;
    const FRAME_HOLDS_ALL: bool = H::Model::FRAME_HOLDS_ALL;
    const SHARED: bool = true;

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        on::<H, _>(|model, _| model.read_bits(table, start, qty, out)).unwrap_or(Err(BUSY))
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        on::<H, _>(|model, _| model.read_registers(table, start, out)).unwrap_or(Err(BUSY))
    }

    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        on::<H, _>(|model, _| model.has_range(table, start, qty)).unwrap_or(false)
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        on::<H, _>(|model, log| record(log, model.write_coils(start, qty, packed), Table::Coils, start, qty))
            .unwrap_or(Err(BUSY))
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        let qty = (values.len() / 2) as u16;
        on::<H, _>(|model, log| record(log, model.write_registers(start, values), Table::HoldingRegisters, start, qty))
            .unwrap_or(Err(BUSY))
    }

    #[inline(always)]
    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        on::<H, _>(|model, log| {
            let result = model.transfer(access, table, start, qty, data);
            if access == Access::Write {
                return record(log, result, table, start, qty);
            }
            result
        })
        .unwrap_or(Err(BUSY))
    }

    fn value(&self, reference: Reference) -> Result<u16, Error> {
        on::<H, _>(|model, _| model.value(reference)).unwrap_or(Err(Error::Busy))
    }

    fn set_value(&mut self, reference: Reference, value: u16) -> Result<(), Error> {
        on::<H, _>(|model, _| model.set_value(reference, value)).unwrap_or(Err(Error::Busy))
    }

    fn get_wide<T: crate::Wide>(&self, first: Reference, order: crate::WordOrder) -> Result<T, Error> {
        on::<H, _>(|model, _| model.get_wide(first, order)).unwrap_or(Err(Error::Busy))
    }

    fn set_wide<T: crate::Wide>(&mut self, first: Reference, value: T, order: crate::WordOrder) -> Result<(), Error> {
        on::<H, _>(|model, _| model.set_wide(first, value, order)).unwrap_or(Err(Error::Busy))
    }

    #[inline(always)]
    fn place(reference: Reference) -> Place {
        H::Model::place(reference)
    }

    #[inline(always)]
    fn load(&self, place: Place) -> u16 {
        on::<H, _>(|model, _| model.load(place)).unwrap_or(0)
    }

    #[inline(always)]
    fn store(&mut self, place: Place, stored: u16) {
        on::<H, _>(|model, _| model.store(place, stored));
    }

    fn master_writes(&self) -> u16 {
        on::<H, _>(|model, _| model.master_writes()).unwrap_or(0)
    }

    fn exception_status(&self) -> u8 {
        on::<H, _>(|model, _| model.exception_status()).unwrap_or(0)
    }

    fn device_info(&self) -> &[u8] {
        // SAFETY: a shared reference for the reply's copy, made by a port inside its
        // request (interrupts disabled, no `&mut` to the model alive: every access above
        // ends before this call returns); device descriptions are constant data.
        unsafe { (*H::cell().model.get()).device_info() }
    }

    fn identification(&self) -> Option<&Identification> {
        // SAFETY: as `device_info`'s.
        unsafe { (*H::cell().model.get()).identification() }
    }

    #[cfg(feature = "eeprom-settings")]
    fn take_new_settings(&mut self) -> Option<Config> {
        on::<H, _>(|model, _| model.take_new_settings()).flatten()
    }

    #[inline(always)]
    fn exclusive<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R {
        reg::free(|| f(self))
    }

    #[inline(always)]
    fn serve_from(&mut self, by: Port, unit: u8) {
        H::cell().log(|log| log.serve_from(by, unit));
    }
}

/// Declares `NAME`, a data model that several ports serve at once: an RTU or ASCII slave
/// and the TCP server (feature `tcp`), each naming `NAME` where it names its model and
/// handed `NAME` at its start. `NAME` is a zero-sized handle; the model lives in a static,
/// all zero until set (`Model::new()`, or the constant expression after `=`). The
/// application reads and writes it as `NAME.get(…)`, `NAME.set(…)`, `NAME.with(…)` (see
/// [`crate::SharedModel`]).
///
/// ```ignore
/// avr_modbus::register_map! { struct Registers { 1..=16, 40001..=40016 } }
/// avr_modbus::shared_model!(MODEL: Registers);
/// avr_modbus::slave!(SLAVE: MODEL);
/// avr_modbus::tcp_server!(SERVER: MODEL, W5100);
/// ```
#[macro_export]
macro_rules! shared_model {
    ($(#[$attr:meta])* $vis:vis $name:ident : $model:ty) => {
        $crate::shared_model!($(#[$attr])* $vis $name: $model = <$model>::new());
    };
    ($(#[$attr:meta])* $vis:vis $name:ident : $model:ty = $init:expr) => {
        $(#[$attr])*
        #[allow(non_camel_case_types)]
        #[derive(Clone, Copy)]
        $vis struct $name;

        impl $crate::__private::SharedHandle for $name {
            type Model = $model;

            #[inline(always)]
            fn cell() -> &'static $crate::SharedModel<$model> {
                static CELL: $crate::SharedModel<$model> = $crate::SharedModel::new($init);
                &CELL
            }
        }

        impl ::core::ops::Deref for $name {
            type Target = $crate::SharedModel<$model>;

            #[inline(always)]
            fn deref(&self) -> &$crate::SharedModel<$model> {
                <$name as $crate::__private::SharedHandle>::cell()
            }
        }
    };
}
