//! The interrupt-driven slave, Modbus over Serial Line v1.02 §2.5.1.1: every character
//! sets the silence deadlines on Timer0 anew, T3.5 of silence ends the frame, and the reply
//! starts from that same interrupt, so the application's main loop never has to call
//! anything for the slave to answer.
//!
//! Here the front door: [`Slave`], its start and the entry points its interrupt handlers
//! call. The interrupt state and handlers are `running`, the application's reads and
//! writes of values `values`, the switch to new line settings `settings` (feature
//! `eeprom-settings`).

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::no_pin::NoPin;
use super::started::Started;
use crate::error::Error;
use crate::link::config::Config;
use crate::link::framer::MAX_FRAME;
use crate::slave::counters::SlaveCounters;
use crate::slave::model::DataModel;
use running::Running;

mod running;
#[cfg(feature = "eeprom-settings")]
mod settings;
mod values;

/// The Modbus RTU slave: declare it with [`crate::slave!`], start it with the
/// application's USART (the one `slave!` names) and `TC0`, then read and write its data like
/// variables.
///
/// ```ignore
/// avr_modbus::slave!(SLAVE: Registers);
/// // in main:
/// SLAVE.start(CONFIG, dp.USART0, dp.TC0, bank)?;
/// let setpoint = SLAVE.get(40001)?;
/// SLAVE.set(30001, reading)?;
/// ```
///
/// Every access from the application runs with interrupts disabled for a few
/// microseconds; a flag refuses re-entry (a [`Slave::with`] inside another gets `None`).
/// The slave starts all-zero, so it lives in `.bss` and costs no flash for an
/// initializer. `N` is its frame buffer's size: [`crate::slave!`] gives it the model's
/// [`DataModel::FRAME`]; 256, the default, fits every model. `U` is the number of the
/// USART it serves, as `slave!` names it, and `C` Timer0's compare unit that keeps its
/// silences: `'B'`, or `'A'` for a second slave (`slave!(… with TIMER0_COMPA: …)`).
pub struct Slave<M, DE = NoPin, LED = NoPin, const N: usize = MAX_FRAME, const U: u8 = 0, const C: char = 'B'> {
    running: Started<Running<M, DE, LED, N, U, C>>,
}

impl<M, DE, LED, const N: usize, const U: u8, const C: char> Slave<M, DE, LED, N, U, C> {
    /// A slave not yet started: what [`crate::slave!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        Slave { running: Started::new() }
    }

    /// Runs `f` on the running slave from one of its interrupt handlers.
    ///
    /// # Safety
    /// As for [`Started::access_in_handler`].
    #[inline(always)]
    unsafe fn access_in_handler<R>(&self, f: impl FnOnce(&mut Running<M, DE, LED, N, U, C>) -> R) -> R {
        // SAFETY: the caller's promise.
        unsafe { self.running.access_in_handler(f) }
    }

    /// Runs `f` on the running slave with interrupts disabled.
    fn locked<R>(&self, f: impl FnOnce(&mut Running<M, DE, LED, N, U, C>) -> R) -> Option<R> {
        self.running.locked(f)
    }
}

impl<M: DataModel, const N: usize, const U: u8, const C: char> Slave<M, NoPin, NoPin, N, U, C> {
    /// Starts the slave: takes the USART that [`crate::slave!`] named (`dp.USART0` on the
    /// Uno's pins 0/1, `dp.USART1` on the Leonardo's or the Mega's Serial1, …) and `TC0`
    /// from the application's `Peripherals` (arduino-hal's or `avr-device`'s, any version),
    /// configures them for `config`, and enables interrupts. Another USART than the one
    /// `slave!` named is [`Error::WrongPeripheral`], and nothing starts. From here on the slave
    /// answers by itself; the application reads and writes `model` through
    /// [`Slave::get`], [`Slave::set`] and [`Slave::with`].
    pub fn start<P: Deref, T: Deref>(&self, config: Config, usart: P, tc0: T, model: M) -> Result<(), Error>
    where
        P::Target: Sized,
        T::Target: Sized,
    {
        self.start_with_pins(config, usart, tc0, model, NoPin, NoPin)
    }
}

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char>
    Slave<M, DE, LED, N, U, C>
{
    /// [`Slave::start`] with an RS-485 driver-enable pin (high from just before the first
    /// character of a reply until its last one has left the wire) and a communication LED
    /// (lit while the slave answers a frame addressed to it): any `embedded-hal` output
    /// pin, arduino-hal's included, or [`crate::NoPin`].
    pub fn start_with_pins<P: Deref, T: Deref>(
        &self,
        config: Config,
        usart: P,
        tc0: T,
        model: M,
        driver_enable: DE,
        led: LED,
    ) -> Result<(), Error>
    where
        P::Target: Sized,
        T::Target: Sized,
    {
        #[cfg(feature = "capture-line")]
        if super::usart::Usart::<U>::CAPTURE && !super::capture::runs_at(config.line()) {
            return Err(Error::Baud);
        }
        self.running.start_on::<_, _, U>(usart, tc0, || Running::new(config, model, driver_enable, led))
    }

    /// The handlers [`crate::slave!`] binds, one per interrupt, each inlined into its
    /// vector.
    ///
    /// # Safety
    /// Only from the interrupt handler it is named for (interrupts disabled), and one that
    /// does not enable them.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_rx(&self) {
        // SAFETY: the receive interrupt handler (the caller's promise).
        unsafe { self.access_in_handler(Running::on_usart_rx) };
    }

    /// See [`Slave::on_usart_rx`].
    ///
    /// # Safety
    /// As for [`Slave::on_usart_rx`].
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_udre(&self) {
        // SAFETY: a USART interrupt handler (the caller's promise).
        unsafe { self.access_in_handler(Running::on_usart_udre) };
    }

    /// See [`Slave::on_usart_rx`].
    ///
    /// # Safety
    /// As for [`Slave::on_usart_rx`].
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_tx(&self) {
        // SAFETY: the transmit-complete interrupt handler (the caller's promise).
        unsafe { self.access_in_handler(Running::on_usart_tx) };
    }

    /// See [`Slave::on_usart_rx`].
    ///
    /// # Safety
    /// As for [`Slave::on_usart_rx`].
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_timer_compare(&self) {
        // SAFETY: the Timer0 compare interrupt handler (the caller's promise).
        unsafe { self.access_in_handler(Running::on_timer_compare) };
    }

    /// Runs `f` on the data model with interrupts disabled: `None` before
    /// [`Slave::start`] or inside another `with`. Keep `f` short: reception waits while it
    /// runs.
    pub fn with<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.locked(|s| f(&mut s.model))
    }

    /// The slave's counters (all zero before [`Slave::start`]).
    pub fn counters(&self) -> SlaveCounters {
        self.locked(|s| s.engine.counters()).unwrap_or_default()
    }

    /// Refuses the master's writes from now on (`true`), or allows them again (feature
    /// `write-protect`): while a local panel holds a setpoint, or for good on a port that
    /// must never change one. FC 5, 6, 15, 16, 22 and 23 get exception 01 (Illegal
    /// Function), change nothing and are counted ([`SlaveCounters::refused_writes`]; a
    /// broadcast write is dropped unanswered); reads and FC 8 go on. To start read-only,
    /// call it right after [`Slave::start`]: the first request can only end after the
    /// start's T3.5 of silence and a whole frame, milliseconds later. Does nothing before
    /// the start.
    #[cfg(feature = "write-protect")]
    pub fn set_read_only(&self, on: bool) {
        self.locked(|s| s.engine.set_read_only(on));
    }
}
