//! The Modbus TCP server on the AVR (feature `tcp`): the pure server (`crate::tcp`) on a
//! WIZnet chip over the SPI, polled from Timer0's overflow interrupt, every 1.024 ms
//! (2.048 ms at 8 MHz), so that requests are answered whatever the application's main loop
//! does.
//!
//! The interrupt reads the chip's socket-event register (one register: 4 SPI bytes on either
//! chip) and returns when no socket has news. When one has, it serves with interrupts enabled
//! again, so that a serial role's interrupts (a slave's, a master's) keep their timing; a
//! second overflow meanwhile only keeps `millis()` and leaves the poll to the one running.
//! The data model is the application's only through [`TcpServer::with`] and the calls
//! built on it (interrupts off), so the poll and the application never touch it at once.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::reg::{self, claim, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
use super::spi::{Spi, SPI_BLOCK};
use super::started::Started;
use crate::error::Error;
use crate::link::timing::{CLOCK_HZ, TIMER0_CLOCK_SELECT, TIMER0_DIVISOR};
use crate::protocol::reference::IntoReference;
use crate::slave::model::DataModel;
use crate::tcp::server::Server;
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::{Network, Serving, TcpCounters};

pub use super::spi::Pin10;

/// Timer0 overflows in a second: 976 at 16 MHz (1.024 ms each), 488 at 8 MHz.
const OVERFLOWS_PER_SECOND: u16 = (CLOCK_HZ / TIMER0_DIVISOR / 256) as u16;
/// TIMSK0's overflow interrupt enable.
const TOIE0: u8 = 1 << 0;
/// TIMSK0's compare interrupt enables: a serial role runs Timer0 when one is set.
const COMPARES: u8 = 1 << 1 | 1 << 2;

/// The Modbus TCP server: declare it with [`crate::tcp_server!`], start it with the
/// application's SPI and `TC0`, then read and write its data like variables, as a
/// [`crate::Slave`]'s.
///
/// ```ignore
/// avr_modbus::tcp_server!(SERVER: Registers, W5100);
/// // in main:
/// SERVER.start(NETWORK, &dp.SPI, dp.TC0, registers)?;
/// let setpoint = SERVER.get(40001)?;
/// SERVER.set(30001, reading)?;
/// ```
///
/// `C` is the chip ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]), `CS` its chip-select
/// pin ([`Pin10`], the shields', by default), `B` the bytes of its one buffer (the MBAP
/// header and the model's longest PDU; [`crate::tcp_server!`] works it out).
pub struct TcpServer<M, C, CS = Pin10, const B: usize = 260> {
    running: Started<Running<M, C, CS, B>>,
}

/// The running server: the pure server, the chip, the settings, the model.
struct Running<M, C, CS, const B: usize> {
    server: Server<B>,
    chip: Wiznet<C, Spi<CS>>,
    network: Network,
    model: M,
    /// Overflows since the last whole second.
    overflows: u16,
    /// The application has the SPI ([`TcpServer::with_spi`]): the poll waits.
    lent: bool,
}

impl<M, C, CS, const B: usize> TcpServer<M, C, CS, B> {
    /// A server not yet started: what [`crate::tcp_server!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        TcpServer { running: Started::new() }
    }
}

impl<M: DataModel, C: Chip, const B: usize> TcpServer<M, C, Pin10, B> {
    /// Starts the server with the chip's select on the board's pin 10 (the shields'): see
    /// [`TcpServer::start_with_cs`].
    pub fn start<S: Deref, T: Deref>(&self, network: Network, spi: S, tc0: T, model: M) -> Result<(), Error>
    where
        S::Target: Sized,
        T::Target: Sized,
    {
        self.start_with_cs(network, spi, tc0, Pin10, model)
    }
}

impl<M: DataModel, C: Chip, CS: OutputPin, const B: usize> TcpServer<M, C, CS, B> {
    /// Starts the server: takes the SPI (`dp.SPI`, or `&dp.SPI` to keep it for
    /// [`TcpServer::with_spi`]) and `TC0` (`&dp.TC0` when a serial role shares Timer0) from
    /// the application's `Peripherals`, resets the chip and checks it is a `C`, gives it
    /// `network`'s addresses, and from here on serves `model` on every socket `network`
    /// gives it. [`Error::NoChip`] when the chip does not answer as a `C` (nothing is
    /// started then); [`Error::WrongPeripheral`] for another peripheral than the SPI or
    /// `TC0`.
    pub fn start_with_cs<S: Deref, T: Deref>(
        &self,
        network: Network,
        spi: S,
        tc0: T,
        cs: CS,
        model: M,
    ) -> Result<(), Error>
    where
        S::Target: Sized,
        T::Target: Sized,
    {
        claim::<_, { SPI_BLOCK.1 }>(spi, SPI_BLOCK.0)?;
        claim::<_, { reg::TC0.1 }>(tc0, reg::TC0.0)?;
        let mut chip = Wiznet::<C, _>::new(Spi::new(cs));
        if !chip.init(&network) {
            return Err(Error::NoChip);
        }
        let network = Network { sockets: network.sockets.min(C::SOCKETS), ..network };
        self.running.start(|| Running { server: Server::new(), chip, network, model, overflows: 0, lent: false })?;
        reg::free(start_timer0);
        // SAFETY: the server is in its cell, so its interrupt handler can run.
        unsafe { reg::enable_interrupts() };
        Ok(())
    }

    /// Timer0's overflow: the chip polled, with interrupts enabled while it is served; an
    /// overflow while a poll runs does nothing here.
    ///
    /// # Safety
    /// Only from the Timer0 overflow interrupt handler, with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_overflow(&self) {
        // `access` marks the server in use: a nested overflow, and the application's calls
        // from interrupt handlers of its own, find it so and leave.
        // SAFETY: interrupts are disabled on entry; the closure enables them only while the
        // server is marked in use, and disables them again before the mark goes.
        let _ = unsafe { self.running.access_marked(Running::poll) };
    }

    /// Runs `f` on the data model with interrupts disabled: `None` before
    /// [`TcpServer::start`] or inside another `with`. Keep `f` short.
    pub fn with<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.running.locked(|r| f(&mut r.model))
    }

    /// Lends the SPI to the application for `f` (the shield's SD card, CS on pin 4, or any
    /// other SPI device): the server does not poll meanwhile (requests wait in the chip),
    /// and sets the SPI up again for itself afterwards. Use the SPI only inside `f`:
    /// outside, a poll can come between two bytes of the application's transfer. `None`
    /// before the start or inside another `with`.
    pub fn with_spi<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        self.running.locked(|r| r.lent = true)?;
        let result = f();
        self.running.locked(|r| r.lent = false);
        Some(result)
    }

    /// The server's counters (all zero before [`TcpServer::start`]).
    pub fn counters(&self) -> TcpCounters {
        self.running.locked(|r| r.server.counters()).unwrap_or_default()
    }

    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let reference = reference.into_reference()?;
        self.with(|model| model.value(reference)).unwrap_or(Err(Error::NotFound))
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let reference = reference.into_reference()?;
        self.with(|model| model.set_value(reference, value)).unwrap_or(Err(Error::NotFound))
    }

    /// The `u32`, `i32` or `f32` in the two registers from `first`, read in one critical
    /// section (see [`crate::Slave::get_wide`]).
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        let first = first.into_reference()?;
        self.with(|model| model.get_wide(first, order)).unwrap_or(Err(Error::NotFound))
    }

    /// Sets the two registers from `first`, both in one critical section (see
    /// [`crate::Slave::set_wide`]).
    pub fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        let first = first.into_reference()?;
        let bits = crate::WordOrder::HighFirst.join::<u32>(order.split(value));
        self.with(|model| model.set_wide(first, bits, crate::WordOrder::HighFirst)).unwrap_or(Err(Error::NotFound))
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]).
    pub fn master_writes(&self) -> u16 {
        self.with(|model| model.master_writes()).unwrap_or(0)
    }
}

impl<M: DataModel, C: Chip, CS: OutputPin, const B: usize> Running<M, C, CS, B> {
    /// One poll, from the overflow interrupt (interrupts disabled on entry and on return):
    /// the second counted, then, unless the application has the SPI, the chip served with
    /// interrupts enabled.
    #[inline(never)]
    fn poll(&mut self) {
        self.overflows += 1;
        let second = self.overflows >= OVERFLOWS_PER_SECOND;
        if second {
            self.overflows = 0;
        }
        if self.lent {
            return;
        }
        // SAFETY: the server is marked in use (`access_marked`), so nothing else reaches it
        // meanwhile; other interrupts may run, which is the point.
        unsafe { reg::enable_interrupts() };
        self.chip.bus.configure();
        self.server.poll(&mut self.chip, &self.network, &mut Serving(&mut self.model), second);
        // SAFETY: interrupts off again before the mark goes (`access_marked`'s promise).
        unsafe { reg::disable_interrupts() };
    }
}

/// Timer0 free-running at clk/64 with its overflow interrupt on: started here unless a
/// serial role runs it already (which leaves the overflow interrupt on, `super::timer`).
fn start_timer0() {
    if TIMSK0.read() & (COMPARES | TOIE0) == 0 {
        TCCR0B.write(0);
        TCCR0A.write(0);
        TCNT0.write(0);
        TIFR0.write(0x07);
    }
    TIMSK0.modify(|m| m | TOIE0);
    TCCR0B.write(TIMER0_CLOCK_SELECT);
}
