//! The interrupt-driven slave, Modbus over Serial Line v1.02 §2.5.1.1: every character
//! restarts Timer0, T3.5 of silence ends the frame, and the reply starts from that same
//! interrupt, so the application's main loop never has to call anything for the slave
//! to answer.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;

use avr_device::atmega328p::{TC0, USART0};
use avr_device::interrupt;
use embedded_hal::digital::OutputPin;

use super::pins::NoPin;
use super::timer::{Expired, FrameTimer};
use super::usart::Usart;
use crate::bank::Variables;
use crate::config::Config;
use crate::crc::Crc16;
use crate::model::DataModel;
use crate::reference::{BankError, IntoReference};
use crate::slave::{Counters, EndOfFrame, Slave};

/// The slave with its peripherals and the application's data model `M`; `DE` drives an
/// RS-485 transceiver's driver-enable pin, `LED` the communication LED.
pub struct ModbusSlave<M, DE = NoPin, LED = NoPin> {
    usart: Usart,
    timer: FrameTimer,
    slave: Slave,
    model: M,
    tx_next: usize,
    tx_len: usize,
    tx_crc: Crc16,
    driver_enable: DE,
    led: LED,
}

impl<M: DataModel> ModbusSlave<M> {
    /// Configures USART0 and Timer0 for `config` and starts the power-up wait (T3.5 of
    /// silence before the first frame). Interrupts must be enabled by the application
    /// once the slave is in its [`Shared`] cell.
    pub fn new(config: Config, usart: USART0, timer: TC0, model: M) -> Self {
        let mut timer = FrameTimer::new(timer, config.timer_plan());
        let usart = Usart::new(usart, &config);
        timer.restart();
        ModbusSlave {
            usart,
            timer,
            slave: Slave::new(config.slave_id()),
            model,
            tx_next: 0,
            tx_len: 0,
            tx_crc: Crc16::new(),
            driver_enable: NoPin,
            led: NoPin,
        }
    }
}

impl<M: DataModel, DE: OutputPin, LED: OutputPin> ModbusSlave<M, DE, LED> {
    /// Adds an RS-485 driver-enable pin: high from just before the first character of a
    /// reply until the last one has left the wire (transmit complete).
    pub fn with_driver_enable<P: OutputPin>(self, mut pin: P) -> ModbusSlave<M, P, LED> {
        let _ = pin.set_low();
        self.map_pins(|_, led| (pin, led))
    }

    /// Adds a communication LED: lit while this slave answers a frame addressed to it.
    pub fn with_led<P: OutputPin>(self, mut pin: P) -> ModbusSlave<M, DE, P> {
        let _ = pin.set_low();
        self.map_pins(|driver_enable, _| (driver_enable, pin))
    }

    /// The same slave with other pins.
    fn map_pins<D, L>(self, f: impl FnOnce(DE, LED) -> (D, L)) -> ModbusSlave<M, D, L> {
        let ModbusSlave { usart, timer, slave, model, tx_next, tx_len, tx_crc, driver_enable, led } = self;
        let (driver_enable, led) = f(driver_enable, led);
        ModbusSlave { usart, timer, slave, model, tx_next, tx_len, tx_crc, driver_enable, led }
    }

    /// The data model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The data model, to update inputs or read what the master wrote.
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// The slave's counters.
    pub fn counters(&self) -> Counters {
        self.slave.counters()
    }

    /// USART0 RX complete: one character (or a damaged one) arrived. The silence timer
    /// restarts first, so that its deadlines count from as close to the stop bit as can be.
    #[inline(always)]
    pub fn on_usart_rx(&mut self) {
        self.timer.restart();
        match self.usart.read() {
            Ok(byte) => self.slave.on_byte(byte),
            Err(e) => self.slave.on_error(e),
        }
    }

    /// Timer0 compare A: the inter-character gap deadline.
    #[inline(always)]
    pub fn on_timer_compare_a(&mut self) {
        if self.timer.on_compare_a() == Expired::Now {
            self.slave.on_gap_deadline();
        }
    }

    /// Timer0 compare B: T3.5 of silence. A frame for this slave is answered from here:
    /// the address goes out first, then the request is processed while it is on the wire.
    #[inline(always)]
    pub fn on_timer_compare_b(&mut self) {
        if self.timer.on_compare_b() == Expired::NotYet {
            return;
        }
        // A character that arrived while interrupts were held off (this interrupt outranks
        // the receive one) was on the wire before T3.5 expired: the silence starts over,
        // and the receive interrupt, pending, takes the character right after this one.
        if self.usart.has_data() {
            self.timer.restart();
            return;
        }
        match self.slave.on_end_deadline() {
            EndOfFrame::Reply => {
                let _ = self.driver_enable.set_high();
                let _ = self.led.set_high();
                let id = self.slave.id().get();
                self.usart.write(id);
                self.tx_crc = Crc16::new().update(id);
                self.tx_len = self.slave.prepare(&mut self.model);
                self.tx_next = 1;
                self.usart.start_feeding();
            }
            EndOfFrame::Broadcast | EndOfFrame::ListenOnly => {
                self.slave.process(&mut self.model);
            }
            EndOfFrame::Nothing | EndOfFrame::Dropped(_) | EndOfFrame::OtherSlave => {}
        }
    }

    /// USART0 data register empty: the next character of the reply, folded into the CRC,
    /// then the CRC's low and high bytes.
    #[inline(always)]
    pub fn on_usart_udre(&mut self) {
        let crc = self.tx_crc.to_wire();
        let (byte, last) = match self.tx_next.checked_sub(self.tx_len) {
            None => {
                let byte = self.slave.reply().get(self.tx_next).copied().unwrap_or(0);
                self.tx_crc = self.tx_crc.update(byte);
                (byte, false)
            }
            Some(0) => (crc[0], false),
            Some(_) => (crc[1], true),
        };
        self.usart.write(byte);
        self.tx_next += 1;
        if last {
            self.usart.last_written();
        }
    }

    /// USART0 transmit complete: the reply has left the wire.
    #[inline(always)]
    pub fn on_usart_tx(&mut self) {
        self.usart.finished();
        let _ = self.driver_enable.set_low();
        let _ = self.led.set_low();
        self.slave.on_reply_sent();
        #[cfg(feature = "eeprom-settings")]
        self.apply_new_settings();
    }

    /// Switches USART0, Timer0 and the slave id to settings the master wrote, if they are
    /// ready (see [`Shared::poll_settings`]); called when nothing of a reply is left to send.
    #[cfg(feature = "eeprom-settings")]
    #[inline(always)]
    fn apply_new_settings(&mut self) {
        if let Some(config) = self.model.take_new_settings() {
            self.usart.configure(&config);
            self.timer.configure(config.timer_plan());
            self.slave.set_id(config.slave_id());
        }
    }
}

/// The slave shared between the application and the interrupts (declare it with
/// [`crate::modbus_slave!`]).
///
/// Every access runs with interrupts disabled, and a flag refuses re-entry (a `with`
/// inside another `with` gets `None`). The cell starts all-zero, so it lives in `.bss`
/// and costs no flash for an initializer.
pub struct Shared<M, DE = NoPin, LED = NoPin> {
    state: UnsafeCell<u8>,
    slave: UnsafeCell<MaybeUninit<ModbusSlave<M, DE, LED>>>,
}

const EMPTY: u8 = 0;
const READY: u8 = 1;
const IN_USE: u8 = 2;

// SAFETY: the ATmega328P has one core, and the cell is only touched with interrupts
// disabled (`interrupt::free`, or inside an interrupt handler), so no two accesses overlap.
unsafe impl<M, DE, LED> Sync for Shared<M, DE, LED> {}

impl<M, DE, LED> Default for Shared<M, DE, LED> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M, DE, LED> Shared<M, DE, LED> {
    /// An empty cell.
    pub const fn new() -> Self {
        Shared { state: UnsafeCell::new(EMPTY), slave: UnsafeCell::new(MaybeUninit::zeroed()) }
    }

    /// Puts the slave in the cell; its interrupts start doing work once the application
    /// enables interrupts. A second call is ignored.
    pub fn start(&self, slave: ModbusSlave<M, DE, LED>) {
        interrupt::free(|_| {
            // SAFETY: interrupts are disabled, so nothing else accesses the cell.
            unsafe {
                if *self.state.get() == EMPTY {
                    (*self.slave.get()).write(slave);
                    *self.state.get() = READY;
                }
            }
        });
    }

    /// Runs `f` on the slave with interrupts disabled; `None` before [`Shared::start`].
    /// Keep `f` short: reception waits while it runs.
    pub fn with<R>(&self, f: impl FnOnce(&mut ModbusSlave<M, DE, LED>) -> R) -> Option<R> {
        // SAFETY: interrupts are disabled for the whole access.
        interrupt::free(|_| unsafe { self.access(f) })
    }

    /// For the interrupt handlers of [`crate::modbus_slave!`].
    #[doc(hidden)]
    #[inline(always)]
    pub fn in_interrupt(&self, f: impl FnOnce(&mut ModbusSlave<M, DE, LED>)) {
        // SAFETY: interrupt handlers run with interrupts disabled; nothing here enables them.
        unsafe { self.access(f) };
    }

    /// # Safety
    /// Interrupts must be disabled for the whole call.
    #[inline(always)]
    unsafe fn access<R>(&self, f: impl FnOnce(&mut ModbusSlave<M, DE, LED>) -> R) -> Option<R> {
        // SAFETY: no other access can run (the caller's promise); READY means the slave
        // was written by `start`, and IN_USE keeps a nested call from aliasing it.
        unsafe {
            if *self.state.get() != READY {
                return None;
            }
            *self.state.get() = IN_USE;
            let result = f((*self.slave.get()).assume_init_mut());
            *self.state.get() = READY;
            Some(result)
        }
    }
}

impl<M: DataModel, DE: OutputPin, LED: OutputPin> Shared<M, DE, LED> {
    /// Runs `f` on the data model with interrupts disabled.
    pub fn with_model<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.with(|s| f(s.model_mut()))
    }

    /// The slave's counters (all zero before [`Shared::start`]).
    pub fn counters(&self) -> Counters {
        self.with(|s| s.counters()).unwrap_or_default()
    }
}

impl<M: DataModel + Variables, DE: OutputPin, LED: OutputPin> Shared<M, DE, LED> {
    /// Reads a value (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, BankError> {
        // The reference is worked out before interrupts go off: shorter critical section.
        let reference = reference.into_reference()?;
        self.with_model(|model| model.value(reference)).unwrap_or(Err(BankError::NotFound))
    }

    /// Sets a value (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), BankError> {
        let reference = reference.into_reference()?;
        self.with_model(|model| model.set_value(reference, value)).unwrap_or(Err(BankError::NotFound))
    }

    /// How many master writes succeeded so far (see [`crate::Bank::master_writes`]).
    pub fn master_writes(&self) -> u16 {
        self.with_model(|model| model.write_count()).unwrap_or(0)
    }
}

#[cfg(feature = "eeprom-settings")]
impl<M: DataModel, DE: OutputPin, LED: OutputPin> Shared<crate::settings::Configurable<M>, DE, LED> {
    /// The main loop's part of a settings change (feature `eeprom-settings`): call it
    /// from the main loop as often as it comes round. Returns how many EEPROM bytes it
    /// wrote when it stored new settings at `address`, else `None`.
    ///
    /// When the master has written new settings, computes their [`Config`] (under 1 ms
    /// of 32-bit arithmetic, with interrupts enabled) and hands it to the slave, which switches when
    /// the reply to the write has left the wire; if it already has, the switch happens
    /// here. Then stores the settings the slave switched to, skipping bytes that are
    /// already right (≈3.4 ms per byte written, up to ≈34 ms, interrupts enabled): no
    /// interrupt handler ever waits for the EEPROM or the division routines.
    pub fn poll_settings(&self, eeprom: &mut super::Eeprom, address: u16) -> Option<usize> {
        if let Some(settings) = self.with_model(|model| model.pending()).flatten() {
            if let Some(config) = settings.to_config() {
                self.with(|s| {
                    s.model.offer(settings, config);
                    if !s.usart.is_sending() {
                        s.apply_new_settings();
                    }
                });
            }
        }
        let config = self.with_model(|model| model.take_unsaved()).flatten()?;
        Some(eeprom.store_config(address, &config))
    }

    /// The line settings the slave runs (see [`crate::settings::Configurable::config`]).
    pub fn config(&self) -> Option<Config> {
        self.with_model(|model| model.config())
    }
}
