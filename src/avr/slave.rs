//! The interrupt-driven slave, Modbus over Serial Line v1.02 §2.5.1.1: every character
//! sets the silence deadlines on Timer0 anew, T3.5 of silence ends the frame, and the reply
//! starts from that same interrupt, so the application's main loop never has to call
//! anything for the slave to answer.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::no_pin::NoPin;
use super::receive::receive;
use super::reg;
use super::started::{open_line, Started};
use super::timer::{FrameTimer, Passed, B};
use super::usart::Usart;
use crate::error::Error;
use crate::link::config::Config;
use crate::link::framer::MAX_FRAME;
use crate::protocol::reference::IntoReference;
use crate::slave::counters::SlaveCounters;
use crate::slave::engine::{EndOfFrame, Engine};
use crate::slave::model::DataModel;
use crate::slave::words::Place;

#[cfg(feature = "ascii")]
mod ascii;

/// The running slave: its peripherals, protocol state with a frame buffer of `N` bytes,
/// the application's data model `M`, the RS-485 driver-enable pin `DE` and the
/// communication LED `LED`. It lives in a [`Slave`] and is reached only with interrupts
/// disabled.
#[repr(C)]
pub(crate) struct Running<M, DE, LED, const N: usize, const U: u8> {
    // First, in declaration order (`repr(C)`): the engine starts with the fields that start
    // other than zero, the rest of the slave follows its run of zeros (see `Engine`).
    engine: Engine<N>,
    usart: Usart<U>,
    timer: FrameTimer<B>,
    model: M,
    /// Index of the reply's next byte, and the reply's length (at most 255 bytes; in
    /// ASCII framing, characters: at most 513).
    tx_next: TxIndex,
    tx_len: TxIndex,
    driver_enable: DE,
    led: LED,
    /// The reply delay after T3.5, in Timer0 ticks (feature `reply-delay`; 0: none).
    #[cfg(feature = "reply-delay")]
    reply_delay: u16,
}

/// A position in the reply as it goes out: bytes, or with feature `ascii` characters.
#[cfg(not(feature = "ascii"))]
type TxIndex = u8;
#[cfg(feature = "ascii")]
type TxIndex = u16;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Running<M, DE, LED, N, U> {
    /// Configures the USART and Timer0 for `config` and starts the power-up wait (T3.5 of
    /// silence before the first frame; none in ASCII framing).
    fn new(config: Config, model: M, mut driver_enable: DE, mut led: LED) -> Self {
        const { assert!(N >= M::FRAME, "the slave's frame buffer is smaller than its data model needs") };
        #[allow(unused_mut)]
        let (usart, mut timer) = open_line(config.line(), &mut driver_enable, &mut led);
        #[allow(unused_mut)]
        let mut engine = Engine::new(config.slave_id());
        #[cfg(feature = "ascii")]
        set_mode(&mut engine, &mut timer, config.line());
        Running {
            usart,
            timer,
            engine,
            model,
            tx_next: 0,
            tx_len: 0,
            driver_enable,
            led,
            #[cfg(feature = "reply-delay")]
            reply_delay: config.reply_delay_ticks(),
        }
    }

    /// USART RX complete: one character (or a damaged one) arrived. The interrupt handler
    /// set the silence deadlines before it got here (`timer::on_receive`), so that they
    /// count from as close to the USART's receive flag as can be.
    #[inline(always)]
    fn on_usart_rx(&mut self) {
        receive(&self.usart, &mut self.timer, &mut self.engine);
    }

    /// Timer0 compare B: a frame's end, when it is one (the RTU silences here, ASCII's in
    /// `ascii.rs`). A frame for this slave is answered from here: the first character (the
    /// address, in ASCII `:`) goes out first, then the request is processed and the reply's
    /// CRC (LRC) appended while it is on the wire.
    #[inline(always)]
    fn on_timer_compare(&mut self) {
        let passed = self.timer.on_compare();
        // The gap deadline: RTU's T1.5, ASCII's inter-character timeout.
        if passed == Passed::Gap {
            self.engine.on_gap_deadline();
        }
        #[cfg(feature = "ascii")]
        let ended = if self.engine.is_ascii() { self.ascii_ended(passed) } else { self.rtu_ended(passed) };
        #[cfg(not(feature = "ascii"))]
        let ended = self.rtu_ended(passed);
        if !ended {
            return;
        }
        let end = self.engine.on_end_deadline();
        // (Never in ASCII framing: its reply delay is 0, `Config::reply_delay_ticks`.)
        #[cfg(feature = "reply-delay")]
        if end == EndOfFrame::Reply && self.reply_delay != 0 {
            // Processed now, sent when the delay has passed.
            self.tx_len = self.engine.process(&mut self.model) as TxIndex;
            if !self.timer.delay(self.reply_delay) {
                self.send_processed();
            }
            return;
        }
        if end == EndOfFrame::Reply {
            let _ = self.driver_enable.set_high();
            let _ = self.led.set_high();
            self.usart.write(self.first_char());
            self.tx_next = 1;
        }
        // Executes what `on_end_deadline` accepted (nothing for the other ends) and, for a
        // reply, appends its CRC; the rest of the reply follows its first character from the
        // data-register-empty interrupt.
        let bytes = self.engine.process(&mut self.model);
        self.tx_len = self.reply_chars(bytes);
        if self.tx_len != 0 {
            self.usart.start_feeding();
        }
    }

    /// RTU framing: what `passed`, the inter-character gap deadline (T1.5, which marks a
    /// frame that goes on as damaged), or T3.5 of silence, which ends the frame (true). A reply's delay (feature `reply-delay`) that has passed
    /// sends it.
    #[inline(always)]
    fn rtu_ended(&mut self, passed: Passed) -> bool {
        match passed {
            Passed::Nothing => false,
            Passed::Gap => false,
            // A character that arrived while interrupts were held off (this interrupt
            // outranks the receive one) was on the wire before T3.5 expired: the silence
            // starts over, and the receive interrupt, pending, takes the character right
            // after this one.
            Passed::End if self.usart.has_data() => {
                self.timer.restart();
                false
            }
            Passed::End => true,
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => {
                self.send_processed();
                false
            }
        }
    }

    /// The reply's first character: the address, or in ASCII framing `:`.
    #[inline(always)]
    fn first_char(&self) -> u8 {
        #[cfg(feature = "ascii")]
        if self.engine.is_ascii() {
            return crate::link::framer::ascii::COLON;
        }
        self.engine.id().get()
    }

    /// Characters on the wire for a reply of `bytes` bytes (at most 255, FC 3 or 4 with 125
    /// registers): as many, or in ASCII framing its frame's (`:`, two hex digits a byte,
    /// CR LF; at most 513).
    #[inline(always)]
    fn reply_chars(&self, bytes: usize) -> TxIndex {
        #[cfg(feature = "ascii")]
        if self.engine.is_ascii() && bytes != 0 {
            return crate::link::framer::ascii::encoded_len(bytes) as TxIndex;
        }
        bytes as TxIndex
    }

    /// Sends a reply processed already (feature `reply-delay`): its delay has passed.
    #[cfg(feature = "reply-delay")]
    fn send_processed(&mut self) {
        let _ = self.driver_enable.set_high();
        let _ = self.led.set_high();
        self.usart.write(self.engine.id().get());
        self.tx_next = 1;
        self.usart.start_feeding();
    }

    /// USART data register empty: the next character of the reply (CRC included).
    #[inline(always)]
    fn on_usart_udre(&mut self) {
        #[cfg(feature = "ascii")]
        if self.engine.is_ascii() {
            return self.on_ascii_udre();
        }
        let next = self.tx_next;
        self.usart.write(self.engine.reply_byte(usize::from(next)));
        self.tx_next = next.wrapping_add(1);
        if self.tx_next == self.tx_len {
            self.usart.last_written();
        }
    }

    /// USART transmit complete: the reply has left the wire.
    #[inline(always)]
    fn on_usart_tx(&mut self) {
        self.usart.finished();
        let _ = self.driver_enable.set_low();
        let _ = self.led.set_low();
        self.engine.on_reply_sent();
        #[cfg(feature = "eeprom-settings")]
        self.apply_new_settings();
    }

    /// Switches the USART, Timer0 and the slave id (and with feature `ascii` the framing) to
    /// settings the master wrote, if they are ready (see [`Slave::poll_settings`]); called
    /// when nothing of a reply is left to send.
    #[cfg(feature = "eeprom-settings")]
    #[inline(always)]
    fn apply_new_settings(&mut self) {
        if let Some(config) = self.model.take_new_settings() {
            self.usart.configure(config.line());
            self.timer.configure(config.line().timer_plan());
            self.engine.set_id(config.slave_id());
            #[cfg(feature = "reply-delay")]
            {
                self.reply_delay = config.reply_delay_ticks();
            }
            #[cfg(feature = "ascii")]
            set_mode(&mut self.engine, &mut self.timer, config.line());
        }
    }
}

/// `place`, worked out before this point. A bit's mask, `1 << (i % 8)`, is a loop on the
/// AVR that the compiler could sink into the critical section that alone uses it: the mask
/// passes [`reg::computed`]. A word's index does not: the map's lookup ends in a choice
/// between its ranges, which the compiler has not sunk into the section (`bench calls`
/// shows it if it does), and a barrier would cost every call with a known reference its
/// folded address.
#[inline(always)]
fn computed(place: Place) -> Place {
    match place {
        Place::Bit(i, mask) => Place::Bit(i, reg::computed(u16::from(mask)) as u8),
        other => other,
    }
}

/// The engine and Timer0 in the framing `config` asks for (feature `ascii`).
#[cfg(feature = "ascii")]
fn set_mode<const N: usize>(engine: &mut Engine<N>, timer: &mut FrameTimer<B>, config: &crate::Line) {
    engine.set_ascii(timer.set_mode(config));
}

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
/// USART it serves, as `slave!` names it.
pub struct Slave<M, DE = NoPin, LED = NoPin, const N: usize = MAX_FRAME, const U: u8 = 0> {
    running: Started<Running<M, DE, LED, N, U>>,
}

impl<M, DE, LED, const N: usize, const U: u8> Slave<M, DE, LED, N, U> {
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
    unsafe fn access_in_handler<R>(&self, f: impl FnOnce(&mut Running<M, DE, LED, N, U>) -> R) -> R {
        // SAFETY: the caller's promise.
        unsafe { self.running.access_in_handler(f) }
    }

    /// Runs `f` on the running slave with interrupts disabled.
    fn locked<R>(&self, f: impl FnOnce(&mut Running<M, DE, LED, N, U>) -> R) -> Option<R> {
        self.running.locked(f)
    }
}

impl<M: DataModel, const N: usize, const U: u8> Slave<M, NoPin, NoPin, N, U> {
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

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Slave<M, DE, LED, N, U> {
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
}

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Slave<M, DE, LED, N, U> {
    // `get`, `set`, `get_wide` and `set_wide` work out where the value is (the map's lookup,
    // the word's byte order, a bit's mask) and what to store before interrupts go off, and
    // hold them off only for the loads or stores (`DataModel::place`); a model without a
    // layout fixed at build time (`Bank`, a `DataModel` of your own) is asked with
    // interrupts off, as `with` would.

    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let reference = reference.into_reference()?;
        match M::place(reference) {
            Place::Ask => self.with(|model| model.value(reference)).unwrap_or(Err(Error::NotFound)),
            Place::Missing => Err(Error::NotFound),
            place => {
                let place = computed(place);
                self.with(|model| model.load(place)).map(|loaded| place.value(loaded)).ok_or(Error::NotFound)
            }
        }
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let reference = reference.into_reference()?;
        match M::place(reference) {
            Place::Ask => {
                // Worked out before interrupts go off, whatever it took (`reg::computed`).
                let value = reg::computed(value);
                self.with(|model| model.set_value(reference, value)).unwrap_or(Err(Error::NotFound))
            }
            Place::Missing => Err(Error::NotFound),
            place => {
                let place = computed(place);
                // What is stored, and `value` with whatever it took, worked out before
                // interrupts go off.
                let stored = reg::computed(place.stored(value));
                self.with(|model| model.store(place, stored)).ok_or(Error::NotFound)
            }
        }
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]): both read with interrupts disabled, so never a pair the master
    /// is writing half of (its write runs whole in an interrupt).
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        let first = first.into_reference()?;
        let (first_ref, second_ref) = crate::slave::model::pair(first)?;
        match (M::place(first_ref), M::place(second_ref)) {
            (Place::Ask, _) | (_, Place::Ask) => {
                self.with(|model| model.get_wide(first, order)).unwrap_or(Err(Error::NotFound))
            }
            (Place::Missing, _) | (_, Place::Missing) => Err(Error::NotFound),
            (a, b) => {
                // Both loads in one critical section.
                let (x, y) = self.with(|model| (model.load(a), model.load(b))).ok_or(Error::NotFound)?;
                Ok(order.join([a.value(x), b.value(y)]))
            }
        }
    }

    /// Sets the two registers from `first` to `value` in `order`, both with interrupts
    /// disabled: a master never reads the pair half old, half new.
    pub fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        let first = first.into_reference()?;
        let (first_ref, second_ref) = crate::slave::model::pair(first)?;
        let [a, b] = order.split(value);
        match (M::place(first_ref), M::place(second_ref)) {
            (Place::Ask, _) | (_, Place::Ask) => {
                let bits = crate::WordOrder::HighFirst.join::<u32>([reg::computed(a), reg::computed(b)]);
                self.with(|model| model.set_wide(first, bits, crate::WordOrder::HighFirst))
                    .unwrap_or(Err(Error::NotFound))
            }
            (Place::Missing, _) | (_, Place::Missing) => Err(Error::NotFound),
            (pa, pb) => {
                let (sa, sb) = (reg::computed(pa.stored(a)), reg::computed(pb.stored(b)));
                // Both stores in one critical section: the slave's interrupts, which answer
                // the master, see the old pair or the new one, never half of each.
                self.with(|model| {
                    model.store(pa, sa);
                    model.store(pb, sb);
                })
                .ok_or(Error::NotFound)
            }
        }
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]): compare it with the last value seen to learn that
    /// the master wrote something.
    pub fn master_writes(&self) -> u16 {
        self.with(|model| model.master_writes()).unwrap_or(0)
    }
}

#[cfg(feature = "eeprom-settings")]
// Named for the docs: inside the AVR layer the automatic badge misses impl blocks (src/lib.rs).
#[cfg_attr(docsrs, doc(cfg(feature = "eeprom-settings")))]
impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8>
    Slave<crate::slave::settings::Configurable<M>, DE, LED, N, U>
{
    /// The main loop's part of a settings change (feature `eeprom-settings`): call it
    /// from the main loop as often as it comes round. Returns how many EEPROM bytes it
    /// wrote when it stored new settings at `address`, else `None`.
    ///
    /// When the master has written new settings, computes their [`Config`] (under 1 ms
    /// of 32-bit arithmetic, with interrupts enabled) and hands it to the slave, which switches when
    /// the reply to the write has left the wire; if it already has, the switch happens
    /// here. Then stores the settings the slave switched to in the two slots at `address`
    /// ([`super::eeprom::Eeprom::store_config`]: a reset during the store leaves the old
    /// settings or the new ones; ≈3.4 ms per byte written, at most 12, interrupts
    /// enabled): no interrupt handler ever waits for the EEPROM or the division routines.
    pub fn poll_settings(&self, eeprom: &mut super::eeprom::Eeprom, address: u16) -> Option<usize> {
        if let Some(settings) = self.with(|model| model.pending()).flatten() {
            if let Some(config) = settings.to_config() {
                self.locked(|s| {
                    s.model.offer(settings, config);
                    if !s.usart.is_sending() {
                        s.apply_new_settings();
                    }
                });
            }
        }
        let config = self.with(|model| model.take_unsaved()).flatten()?;
        Some(eeprom.store_config(address, &config))
    }

    /// The line settings the slave runs (see [`crate::slave::settings::Configurable::config`]).
    pub fn config(&self) -> Option<Config> {
        self.with(|model| model.config())
    }
}
