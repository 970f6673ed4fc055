//! The Modbus TCP to RTU gateway on the AVR (features `tcp` and `master`): the TCP server
//! (`super::tcp`) in front of the RTU master (`super::master`), with the gateway's rules
//! (`crate::tcp::gateway`) between them, and its own registers at its own unit.
//!
//! The two sides keep their own interrupts: the master's USART and Timer0 compare A
//! handlers run the serial line as they do for a [`crate::Master`]; Timer0's overflow (or
//! pin 2's interrupt) serves the chip as it does for a [`crate::TcpServer`]. The TCP side
//! reaches the line only in short critical sections: a request is written into the
//! master's request buffer from the chip a buffer at a time, its answer read out the same
//! way. When the line's outcome comes (Timer0 compare A, at T3.5 after the answer, or at
//! the timeout), that handler serves the TCP side at once, so that the answer is sent and
//! the next request taken without waiting for the next poll.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::clock;
use super::master::{Master, Running as LineRunning};
use super::no_pin::NoPin;
use super::started::Started;
use super::tcp::{lend_spi, open_chip, start_interrupts, Pin10, Running, Service};
use crate::error::Error;
use crate::link::config::Line;
use crate::link::framer::MAX_FRAME;
use crate::master::request::Shape;
use crate::master::{Failure, MasterCounters, Timeouts};
use crate::tcp::gateway::{
    Direct, Gate, Gateway, GatewayCounters, GatewaySettings, Routes, RtuSide, SlaveHealth, BUFFER,
};
use crate::tcp::server::{Server, Sockets};
use crate::tcp::wiznet::Chip;
use crate::tcp::{Network, TcpCounters};

/// The master the gateway drives: 256-byte buffers (every request and answer), no LED.
type LineMaster<DE, const U: u8> = Master<DE, NoPin, MAX_FRAME, U>;

/// The Modbus TCP to RTU gateway (features `tcp` and `master`): declare it with
/// [`crate::tcp_gateway!`], start it with the application's SPI, USART and `TC0`, and it
/// passes every TCP master's requests to the serial line's slaves and their answers back;
/// its own registers (its counters: [`crate::tcp::STATUS_REGISTERS`]; each slave's health
/// from [`crate::tcp::HEALTH_REGISTERS`]) answer at its own unit id (0xFF).
///
/// ```ignore
/// avr_modbus::tcp_gateway!(GATEWAY: W5100, DePin);
/// // in main:
/// GATEWAY.start_with_pins(NETWORK, LINE, dp.SPI, dp.USART0, dp.TC0, Pin10, de)?;
/// GATEWAY.set_timeouts(Timeouts { response_ms: 200, turnaround_ms: 50, retries: 1 });
/// ```
///
/// `C` is the chip, `R` the [`Routes`] (units 1–247 to the same
/// address by default), `DE` the RS-485 driver-enable pin, `CS` the chip select, `B` the
/// TCP side's buffer (through which requests and answers are copied), `U` the USART.
pub struct TcpGateway<
    C,
    R = Direct,
    DE: 'static = NoPin,
    CS = Pin10,
    const B: usize = BUFFER,
    const INT: bool = false,
    const U: u8 = 0,
> {
    tcp: Started<Running<Forwarding<R, DE, U>, C, CS, B, INT>>,
    line: LineMaster<DE, U>,
}

/// The gateway's TCP side's service: the routes, its rules, the line.
pub(crate) struct Forwarding<R, DE: 'static, const U: u8> {
    routes: R,
    settings: GatewaySettings,
    gateway: Gateway,
    line: &'static LineMaster<DE, U>,
}

/// The serial line, each call a critical section on the master.
struct Locked<'a, DE, const U: u8>(&'a Started<LineRunning<DE, NoPin, MAX_FRAME, U>>);

impl<DE: OutputPin, const U: u8> RtuSide for Locked<'_, DE, U> {
    fn is_free(&mut self) -> bool {
        self.0.locked(|m| !m.engine.is_busy()).unwrap_or(false)
    }

    fn put(&mut self, at: usize, bytes: &[u8]) {
        self.0.locked(|m| {
            if let Some(slot) = m.engine.request_mut().and_then(|r| r.get_mut(at..at + bytes.len())) {
                slot.copy_from_slice(bytes);
            }
        });
    }

    fn forward(&mut self, len: usize, retries: u8, response_ms: u16, shape: Shape) -> bool {
        self.0
            .locked(|m| match m.engine.forward(len, retries, response_ms, shape) {
                Ok(action) => {
                    m.act(action);
                    true
                }
                Err(_) => false,
            })
            .unwrap_or(false)
    }

    fn outcome(&mut self) -> Option<Result<usize, Failure>> {
        self.0.locked(|m| m.engine.outcome().map(|o| o.map(|reply| reply.data().len()))).flatten()
    }

    fn reply(&mut self, at: usize, out: &mut [u8]) {
        self.0.locked(|m| {
            if let Some(bytes) = m.engine.answer_pdu().and_then(|pdu| pdu.get(at..at + out.len())) {
                out.copy_from_slice(bytes);
            }
        });
    }

    fn collect(&mut self) {
        self.0.locked(|m| m.engine.collect());
    }

    fn retries(&mut self) -> u8 {
        self.0.locked(|m| m.engine.timeouts().retries).unwrap_or(0)
    }

    fn now(&mut self) -> u32 {
        clock::millis()
    }
}

impl<R: Routes, DE: OutputPin + 'static, const U: u8> Forwarding<R, DE, U> {
    /// One pass of the server with the gateway's rules.
    fn serve<S: Sockets, const B: usize>(&mut self, server: &mut Server<B>, chip: &mut S, net: &Network, second: bool) {
        let mut line = Locked(&self.line.running);
        let waiting = server.waiting();
        let mut gate = Gate {
            gateway: &mut self.gateway,
            line: &mut line,
            routes: &self.routes,
            settings: &self.settings,
            waiting,
            health: server.health,
            first: 0,
        };
        server.poll(chip, net, &mut gate, second);
    }
}

impl<R: Routes, DE: OutputPin + 'static, const U: u8> Service for Forwarding<R, DE, U> {
    fn run<S: Sockets, const B: usize>(&mut self, server: &mut Server<B>, chip: &mut S, net: &Network, second: bool) {
        // The line's answer first (the sooner it is sent, the sooner the line takes the
        // next request), then the chip: the connections that waited for the line, and any
        // news. An answer for a connection that closed and was not yet seen closed goes to
        // a socket that has no connection (the chip ignores the SEND); a new connection on
        // that socket would have had to be seen first (its socket listens again only then).
        let mut line = Locked(&self.line.running);
        if self.gateway.deliver(server, chip, &mut line, &self.settings, net) {
            server.resume();
        }
        self.serve(server, chip, net, second);
    }

    fn pending(&mut self) -> bool {
        self.gateway.is_forwarding() && Locked(&self.line.running).outcome().is_some()
    }
}

impl<C, R, DE: 'static, CS, const B: usize, const INT: bool, const U: u8> TcpGateway<C, R, DE, CS, B, INT, U> {
    /// A gateway not yet started: what [`crate::tcp_gateway!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        TcpGateway { tcp: Started::new(), line: Master::new() }
    }
}

impl<C: Chip, R: Routes + Default, const B: usize, const INT: bool, const U: u8>
    TcpGateway<C, R, NoPin, Pin10, B, INT, U>
{
    /// Starts the gateway with the chip's select on pin 10 (the shields') and no RS-485
    /// driver-enable pin: see [`TcpGateway::start_with_pins`].
    pub fn start<S: Deref, P: Deref, T: Deref>(
        &'static self,
        network: Network,
        line: Line,
        spi: S,
        usart: P,
        tc0: T,
    ) -> Result<(), Error>
    where
        S::Target: Sized,
        P::Target: Sized,
        T::Target: Sized,
    {
        self.start_with_pins(network, line, spi, usart, tc0, Pin10, NoPin)
    }
}

impl<
        C: Chip,
        R: Routes + Default,
        DE: OutputPin + 'static,
        CS: OutputPin,
        const B: usize,
        const INT: bool,
        const U: u8,
    > TcpGateway<C, R, DE, CS, B, INT, U>
{
    /// Starts the gateway: the chip reset, checked and given `network`'s addresses as
    /// [`crate::TcpServer::start_with_cs`] does, the serial `line` opened on the USART
    /// [`crate::tcp_gateway!`] named as [`crate::Master::start_with_pins`] does (with
    /// `driver_enable`, high while a request goes out), and from here on every TCP
    /// request passed on. Pass `TC0` once: both
    /// sides share it. Nothing starts on an error ([`Error::NoChip`],
    /// [`Error::WrongPeripheral`]).
    #[allow(clippy::too_many_arguments)]
    pub fn start_with_pins<S: Deref, P: Deref, T: Deref>(
        &'static self,
        network: Network,
        line: Line,
        spi: S,
        usart: P,
        tc0: T,
        cs: CS,
        driver_enable: DE,
    ) -> Result<(), Error>
    where
        S::Target: Sized,
        P::Target: Sized,
        T::Target: Sized,
    {
        // The gateway routes the unit ids itself: `only_unit` would drop the line's.
        let network = Network { unit: 0, ..network };
        let (chip, network, lease) = open_chip::<C, CS, S, &T::Target>(network, spi, &*tc0, cs)?;
        self.line.running.start_on::<_, _, U>(usart, tc0, || LineRunning::new(line, driver_enable, NoPin))?;
        let forwarding = Forwarding {
            routes: R::default(),
            settings: GatewaySettings::new(),
            gateway: Gateway::new(),
            line: &self.line,
        };
        self.tcp.start(|| Running::new(chip, network, forwarding, lease))?;
        start_interrupts::<INT>();
        Ok(())
    }

    /// Sets the serial line's response timeout, broadcast turnaround delay and retries
    /// ([`Timeouts::DEFAULT`]: 1000 ms, 100 ms, one retry). Keep the response timeout and
    /// retries inside the TCP masters' own timeout: a slave that does not answer is
    /// reported (0B) after (1 + retries) × the response timeout.
    pub fn set_timeouts(&self, timeouts: Timeouts) {
        self.line.set_timeouts(timeouts);
    }

    /// Sets the gateway's own unit id, after how many misses in a row a slave is taken to
    /// be down, and how often a slave that is down is tried again ([`GatewaySettings`]).
    pub fn set_settings(&self, settings: GatewaySettings) {
        self.tcp.locked(|r| r.service.settings = settings);
    }

    /// Runs `f` on the routes (to change them) with interrupts disabled.
    pub fn with_routes<T>(&self, f: impl FnOnce(&mut R) -> T) -> Option<T> {
        self.tcp.locked(|r| f(&mut r.service.routes))
    }

    /// The gateway's counters (all zero before the start).
    pub fn counters(&self) -> GatewayCounters {
        self.tcp.locked(|r| r.service.gateway.counters()).unwrap_or_default()
    }

    /// The TCP side's counters (the chip's resets and the link's losses among them).
    pub fn tcp_counters(&self) -> TcpCounters {
        self.tcp.locked(|r| r.server.counters()).unwrap_or_default()
    }

    /// Refuses every client's writes from now on (`true`), or gives the clients of
    /// [`crate::tcp::Network::allow`] theirs back (feature `write-protect`): a refused write
    /// is answered exception 01 (Illegal Function) by the gateway, never forwarded to the
    /// line, and counted ([`TcpCounters::refused_writes`]). Does nothing before the start.
    #[cfg(feature = "write-protect")]
    pub fn set_read_only(&self, on: bool) {
        self.tcp.locked(|r| r.server.set_read_only(on));
    }

    /// True while the chip answers and its link is up, as the once-a-second check last saw
    /// them (the W5100 cannot tell its link: there, while the chip answers); false before
    /// the start. Its own register 11 says the same.
    pub fn link_up(&self) -> bool {
        self.tcp.locked(|r| r.server.health.link_up()).unwrap_or(false)
    }

    /// The serial line's counters (the master's).
    pub fn line_counters(&self) -> MasterCounters {
        self.line.counters()
    }

    /// True when the slave at `address` is taken to be down: it missed
    /// [`GatewaySettings::down_after`] requests in a row (its requests get 0B at once until
    /// it is tried again).
    pub fn is_down(&self, address: u8) -> bool {
        self.health(address).down
    }

    /// What the gateway knows of the slave at `address`: its answers, its misses, its
    /// misses in a row, whether it is down (all zero for a slave not asked, or whose record
    /// another slave took: [`crate::tcp::TRACKED`]).
    pub fn health(&self, address: u8) -> SlaveHealth {
        self.tcp.locked(|r| r.service.gateway.health(address, &r.service.settings)).unwrap_or_default()
    }

    /// How many connections hold a request waiting for the line (besides the one on it).
    pub fn waiting(&self) -> u8 {
        self.tcp.locked(|r| r.server.waiting()).unwrap_or(0)
    }

    /// Lends the SPI to the application for `f` (see [`crate::TcpServer::with_spi`]).
    pub fn with_spi<T>(&self, f: impl FnOnce() -> T) -> Option<T> {
        lend_spi(&self.tcp, f)
    }

    /// Timer0's overflow: the chip polled, as [`crate::TcpServer::on_overflow`].
    ///
    /// # Safety
    /// Only from the Timer0 overflow interrupt handler, with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_overflow(&self) {
        // SAFETY: interrupts disabled on entry; `poll` enables them only while the TCP
        // side is marked in use, and disables them again before the mark goes.
        let _ = unsafe { self.tcp.access_marked(Running::poll) };
    }

    /// Pin 2's external interrupt (`pin2_int`): the chip served at once.
    ///
    /// # Safety
    /// Only from pin 2's external interrupt handler, with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_pin2(&self) {
        super::tcp::pin2_interrupt(false);
        // SAFETY: as `on_overflow`'s.
        let _ = unsafe { self.tcp.access_marked(Running::on_event) };
    }

    /// The line's USART receive interrupt.
    ///
    /// # Safety
    /// Only from that handler, interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_rx(&self) {
        // SAFETY: the caller's promise.
        unsafe { self.line.on_usart_rx() };
    }

    /// The line's USART transmit-complete interrupt.
    ///
    /// # Safety
    /// Only from that handler, interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_usart_tx(&self) {
        // SAFETY: the caller's promise.
        unsafe { self.line.on_usart_tx() };
    }

    /// Timer0 compare A: the line's silences and timeouts; when they end a request (its
    /// answer judged at T3.5, or its last timeout), the TCP side is served at once.
    ///
    /// # Safety
    /// Only from that handler, interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_timer_compare(&self) {
        // SAFETY: the compare handler (the caller's promise); the TCP side reaches the
        // master only with interrupts disabled, so none of its accesses is under way.
        let ended = unsafe {
            self.line.running.access_in_handler(|m| {
                let under_way = m.engine.is_under_way();
                m.on_timer_compare();
                under_way && !m.engine.is_under_way()
            })
        };
        if ended {
            // SAFETY: interrupts disabled here; `on_event` enables them only while the
            // TCP side is marked in use (a poll running finds it so and leaves: the
            // outcome waits for it, `Service::pending`).
            let _ = unsafe { self.tcp.access_marked(Running::on_event) };
        }
    }
}
