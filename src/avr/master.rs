//! The interrupt-driven master (feature `master`), Modbus over Serial Line v1.02 §2.4.1:
//! the application starts a request and goes on; the request goes out from the USART's
//! interrupts once the line has been quiet for T3.5, the reply is received, checked and
//! kept, timeouts and retries run from Timer0's compare interrupt, and the application
//! collects the outcome when it likes. The link is the slave's: the same USART driver,
//! Timer0 deadlines and framer. In ASCII framing (feature `ascii`, `Line::ascii`) the
//! interrupts take the paths of `ascii`.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::clock;
use super::no_pin::NoPin;
use super::receive::receive;
use super::started::{open_line, Started};
use super::timer::{FrameTimer, Passed, A};
use super::usart::Usart;
use crate::error::Error;
use crate::link::config::Line;
use crate::link::framer::MAX_FRAME;
use crate::link::framing::Framing;
use crate::master::internal::{Action, Engine};
use crate::master::{Failure, MasterCounters, Reply, Request, Timeouts};
use crate::protocol::SlaveId;

#[cfg(feature = "ascii")]
mod ascii;

/// The running master: its peripherals, protocol state with `N`-byte buffers, the RS-485
/// driver-enable pin and the communication LED. `repr(C)`, the engine first: its run of
/// zeros at the start goes on through `tx_next`.
#[repr(C)]
pub(crate) struct Running<DE, LED, const N: usize, const U: u8> {
    pub(crate) engine: Engine<N>,
    /// Index of the request's next byte.
    tx_next: usize,
    usart: Usart<U>,
    timer: FrameTimer<A>,
    driver_enable: DE,
    led: LED,
}

impl<DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Running<DE, LED, N, U> {
    pub(crate) fn new(line: Line, mut driver_enable: DE, mut led: LED) -> Self {
        // The power-up wait: T3.5 of silence before the first request (none in ASCII).
        #[allow(unused_mut)]
        let (usart, mut timer) = open_line(&line, &mut driver_enable, &mut led);
        #[allow(unused_mut)]
        let mut engine = Engine::new();
        #[cfg(feature = "ascii")]
        engine.set_ascii(timer.set_mode(&line));
        Running { engine, usart, timer, tx_next: 0, driver_enable, led }
    }

    /// Sends the request from its first byte: driver enabled, the address into the USART,
    /// the rest from the transmit-complete interrupt. Out of line: the application's
    /// request and Timer0's compare interrupt both send.
    #[inline(never)]
    pub(crate) fn act(&mut self, action: Action) {
        if action == Action::Send {
            let _ = self.driver_enable.set_high();
            let _ = self.led.set_high();
            self.usart.write(self.engine.request_char(0));
            self.tx_next = 1;
            self.usart.start_sending();
        }
    }

    #[inline(always)]
    fn on_usart_rx(&mut self) {
        receive(&self.usart, &mut self.timer, &mut self.engine);
    }

    /// Timer0 compare A: T1.5, T3.5, or a turn of the timer with neither (about once a
    /// millisecond), when the response timeout and the turnaround delay are checked.
    #[inline(always)]
    pub(crate) fn on_timer_compare(&mut self) {
        match self.engine.framing() {
            Framing::Rtu => self.on_rtu_compare(),
            #[cfg(feature = "ascii")]
            Framing::Ascii => self.on_ascii_compare(),
        }
    }

    /// Timer0 compare A in RTU framing.
    #[inline(always)]
    fn on_rtu_compare(&mut self) {
        let action = match self.timer.on_compare() {
            Passed::Gap => {
                self.engine.on_gap_deadline();
                return;
            }
            Passed::End => {
                // A character not yet taken came before T3.5 expired: the silence starts over.
                if self.usart.has_data() {
                    self.timer.restart();
                    return;
                }
                self.engine.on_end_deadline()
            }
            // The clock is read only while a timeout runs: an idle turn costs a few cycles.
            Passed::Nothing if self.engine.is_timing() => self.engine.on_tick(clock::millis()),
            Passed::Nothing => return,
            // The slave's reply delay, on compare B: the master sets none on compare A.
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => return,
        };
        self.act(action);
    }

    /// A character of the request has left the wire: the next goes out; after the last,
    /// the response timeout starts, and so do the silence deadlines (the next request waits
    /// T3.5 after this one even if nothing answers). One character at a time, from this
    /// one interrupt: the few cycles it takes between two characters are far inside T1.5.
    #[inline(always)]
    fn on_usart_tx(&mut self) {
        let next = self.tx_next;
        if next < self.engine.request_chars() {
            self.usart.write(self.engine.request_char(next));
            self.tx_next = next + 1;
            return;
        }
        self.usart.finished();
        let _ = self.driver_enable.set_low();
        let _ = self.led.set_low();
        self.engine.on_sent(clock::millis());
        self.timer.restart();
    }
}

/// The Modbus master (feature `master`), RTU or with feature `ascii` ASCII: declare it with [`crate::master!`], start it
/// with the application's USART (the one `master!` names) and `TC0`, then send requests
/// and collect their outcomes; nothing waits.
///
/// ```ignore
/// avr_modbus::master!(MASTER: 64);
/// // in main:
/// MASTER.start(LINE, dp.USART0, dp.TC0)?;
/// MASTER.send(SlaveId::new(1), &Request::ReadInputRegisters { address: 0, quantity: 5 })?;
/// // later, in the loop:
/// let outcome = MASTER.poll(|outcome| outcome.map(|reply| reply.register(0)));
/// ```
///
/// `N` is the size of each of its two buffers, the request as sent and the reply: the
/// longest request and the longest reply the firmware makes (a read of `q` registers is
/// answered in 5 + 2`q` bytes, a write of `q` registers takes 9 + 2`q`); 256 fits every
/// one. `U` is the number of the USART it serves, as `master!` names it.
pub struct Master<DE = NoPin, LED = NoPin, const N: usize = MAX_FRAME, const U: u8 = 0> {
    pub(crate) running: Started<Running<DE, LED, N, U>>,
}

impl<DE, LED, const N: usize, const U: u8> Master<DE, LED, N, U> {
    /// A master not yet started: what [`crate::master!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        Master { running: Started::new() }
    }
}

impl<const N: usize, const U: u8> Master<NoPin, NoPin, N, U> {
    /// Starts the master: takes the USART that [`crate::master!`] named and `TC0` from the
    /// application's `Peripherals` (arduino-hal's or `avr-device`'s, any version),
    /// configures them for `line`, and enables interrupts. The first request goes out
    /// after T3.5 of silence (on an ASCII `line`, feature `ascii`: at once, unless a frame
    /// is on the line).
    pub fn start<P: Deref, T: Deref>(&self, line: Line, usart: P, tc0: T) -> Result<(), Error>
    where
        P::Target: Sized,
        T::Target: Sized,
    {
        self.start_with_pins(line, usart, tc0, NoPin, NoPin)
    }
}

impl<DE: OutputPin, LED: OutputPin, const N: usize, const U: u8> Master<DE, LED, N, U> {
    /// [`Master::start`] with an RS-485 driver-enable pin (high from just before a
    /// request's first character until its last has left the wire; join DE and /RE of a
    /// MAX485 to it) and a communication LED (lit while a request goes out): any
    /// `embedded-hal` output pin, arduino-hal's included, or [`crate::NoPin`].
    pub fn start_with_pins<P: Deref, T: Deref>(
        &self,
        line: Line,
        usart: P,
        tc0: T,
        driver_enable: DE,
        led: LED,
    ) -> Result<(), Error>
    where
        P::Target: Sized,
        T::Target: Sized,
    {
        #[cfg(feature = "capture-line")]
        if Usart::<U>::CAPTURE && !super::capture::runs_at(&line) {
            return Err(Error::Baud);
        }
        self.running.start_on::<_, _, U>(usart, tc0, || Running::new(line, driver_enable, led))
    }

    /// Starts `request` to `slave` and returns at once: the request is checked and built
    /// now, and goes out as soon as the line has been quiet for T3.5 (at once if it has;
    /// in ASCII, as soon as no frame is on the line). [`Error::Busy`] while another is
    /// under way (it goes on) or its outcome waits to be collected with [`Master::poll`]
    /// (nothing is ever dropped), [`Error::NotStarted`] before [`Master::start`]; a
    /// quantity outside the spec's limits, a request or reply longer than the buffers are
    /// refused before a byte is sent.
    pub fn send(&self, slave: SlaveId, request: &Request<'_>) -> Result<(), Error> {
        self.begin(slave.get(), request)
    }

    /// Sends the write `request` to every slave (address 0) and returns at once, as
    /// [`Master::send`] does: no slave answers; its outcome, an empty [`Reply`], is there
    /// after the turnaround delay ([`Timeouts::turnaround_ms`]). A read is refused
    /// ([`Error::Broadcast`]): nobody would answer it.
    pub fn broadcast(&self, request: &Request<'_>) -> Result<(), Error> {
        self.begin(SlaveId::BROADCAST, request)
    }

    fn begin(&self, slave: u8, request: &Request<'_>) -> Result<(), Error> {
        self.running
            .locked(|m| {
                let action = m.engine.begin(slave, request)?;
                // The address goes out first; the CRC is worked out while it is on the wire
                // (the rest follows from the transmit-complete interrupt, once this
                // critical section ends).
                m.act(action);
                m.engine.seal();
                Ok(())
            })
            .unwrap_or(Err(Error::NotStarted))
    }

    /// The outcome of the last request, once it is there: `f` runs on the reply (read in
    /// place, with interrupts disabled: keep it short, copy what you need) or on why there
    /// is none, and the master is ready for the next request. `None` while the request is
    /// under way, or when there is none.
    pub fn poll<R>(&self, f: impl FnOnce(Result<Reply<'_>, Failure>) -> R) -> Option<R> {
        self.running
            .locked(|m| {
                let result = m.engine.outcome().map(f);
                m.engine.collect();
                result
            })
            .flatten()
    }

    /// True from [`Master::send`] until the outcome is collected with [`Master::poll`]:
    /// `send` is refused meanwhile.
    pub fn is_busy(&self) -> bool {
        self.running.locked(|m| m.engine.is_busy()).unwrap_or(false)
    }

    /// Blocks until the request under way is done, then [`Master::poll`]s it: for simple
    /// firmware that has nothing else to do meanwhile. `None` when no request was sent.
    pub fn wait_blocking<R>(&self, f: impl FnOnce(Result<Reply<'_>, Failure>) -> R) -> Option<R> {
        while self.running.locked(|m| m.engine.is_under_way()).unwrap_or(false) {}
        self.poll(f)
    }

    /// Sets the response timeout, the broadcast turnaround delay and the retries, from the
    /// next request on ([`Timeouts::DEFAULT`]: 1000 ms, 100 ms, one retry).
    pub fn set_timeouts(&self, timeouts: Timeouts) {
        self.running.locked(|m| m.engine.set_timeouts(timeouts));
    }

    /// The master's counters (all zero before [`Master::start`]).
    pub fn counters(&self) -> MasterCounters {
        self.running.locked(|m| m.engine.counters()).unwrap_or_default()
    }

    /// The handlers [`crate::master!`] binds, one per interrupt.
    ///
    /// # Safety
    /// Only from the interrupt handler it is named for (interrupts disabled), and one that
    /// does not enable them.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_rx(&self) {
        // SAFETY: the receive interrupt handler (the caller's promise).
        unsafe { self.running.access_in_handler(Running::on_usart_rx) };
    }

    /// See [`Master::on_usart_rx`].
    ///
    /// # Safety
    /// As for [`Master::on_usart_rx`].
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_tx(&self) {
        // SAFETY: the transmit-complete interrupt handler (the caller's promise).
        unsafe { self.running.access_in_handler(Running::on_usart_tx) };
    }

    /// See [`Master::on_usart_rx`].
    ///
    /// # Safety
    /// As for [`Master::on_usart_rx`].
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_timer_compare(&self) {
        // SAFETY: the timer compare interrupt handler (the caller's promise).
        unsafe { self.running.access_in_handler(Running::on_timer_compare) };
    }
}
