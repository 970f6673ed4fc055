//! The Modbus TCP server on the AVR (feature `tcp`): the pure server (`crate::tcp`) on a
//! WIZnet chip over the SPI, polled from Timer0's overflow interrupt, every 1.024 ms
//! (2.048 ms at 8 MHz), so that requests are answered whatever the application's main loop
//! does.
//!
//! The interrupt reads the chip's socket-event register (one register: 4 SPI bytes on either
//! chip) and returns when no socket has news. When one has, it serves with interrupts enabled
//! again, so that a serial role's interrupts (a slave's, a master's) keep their timing; a
//! second overflow meanwhile only keeps `millis()` and leaves the poll to the one running.
//!
//! Where the chip's INT line is wired to the board's pin 2 (the W5100 shield's solder jumper,
//! a module's INT pin), `tcp_server!(…, pin2_int)` serves from pin 2's external interrupt
//! instead, as soon as a socket has news: the overflow then only counts the seconds (and
//! serves requests left for lack of room). The line is low while the chip has events: the
//! interrupt is level-triggered and masked while the chip is served, so that none is lost.
//! The data model is the application's only through [`TcpServer::with`] and the calls
//! built on it (interrupts off), so the poll and the application never touch it at once.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::chip::CHIP;
use super::reg::{self, claim, Reg, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
use super::spi::{Spi, SPI_BLOCK};
use super::started::Started;
use super::values::Values;
use crate::error::Error;
use crate::link::timing::{CLOCK_HZ, TIMER0_CLOCK_SELECT, TIMER0_DIVISOR};
use crate::protocol::reference::IntoReference;
use crate::slave::model::DataModel;
use crate::tcp::server::{Server, Sockets};
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::{Network, Serving, TcpCounters};

pub use super::spi::Pin10;

/// The DHCP client's place in a running role (feature `dhcp`), nothing without it.
#[cfg(feature = "dhcp")]
#[path = "lease.rs"]
pub(crate) mod lease;
#[cfg(not(feature = "dhcp"))]
#[path = "no_lease.rs"]
pub(crate) mod lease;
use lease::Lease;

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
/// SERVER.start(NETWORK, dp.SPI, dp.TC0, registers)?;
/// let setpoint = SERVER.get(40001)?;
/// SERVER.set(30001, reading)?;
/// ```
///
/// `C` is the chip ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]), `CS` its chip-select
/// pin ([`Pin10`], the shields', by default), `B` the bytes of its one buffer (the MBAP
/// header and the model's longest PDU; [`crate::tcp_server!`] works it out).
pub struct TcpServer<M, C, CS = Pin10, const B: usize = 260, const INT: bool = false> {
    running: Started<Running<Served<M>, C, CS, B, INT>>,
}

/// What a running TCP role does with the chip when it has news: the server serves its
/// model; the gateway also passes its serial line's answers back.
pub(crate) trait Service {
    /// Serves the chip once (interrupts enabled).
    fn run<S: Sockets, const B: usize>(&mut self, server: &mut Server<B>, chip: &mut S, net: &Network, second: bool);

    /// True when there is work beside the chip's news (a gateway's answer to pass back).
    #[inline(always)]
    fn pending(&mut self) -> bool {
        false
    }

    /// True when a serial port serves beside this role and must not wait for its poll: the
    /// poll then enables interrupts as soon as it starts, before it asks the chip for news
    /// (one register read, about 400 cycles from the interrupt's entry with the checks
    /// around it, every 1.024 ms), so that a slave's T3.5 is not held back by it. False: the
    /// quiet poll runs whole with interrupts off, the smaller code.
    const NESTS_AT_ONCE: bool = false;
}

/// The server's service: its data model.
pub(crate) struct Served<M>(pub(crate) M);

impl<M: DataModel> Service for Served<M> {
    /// A shared model has a serial slave beside the server.
    const NESTS_AT_ONCE: bool = M::SHARED;

    #[inline(always)]
    fn run<S: Sockets, const B: usize>(&mut self, server: &mut Server<B>, chip: &mut S, net: &Network, second: bool) {
        server.poll(chip, net, &mut Serving(&mut self.0), second);
    }
}

/// A running TCP role: the pure server, the chip, the settings, the service (the model, or
/// the gateway's parts).
pub(crate) struct Running<V, C, CS, const B: usize, const INT: bool> {
    pub(crate) server: Server<B>,
    chip: Wiznet<C, Spi<CS>>,
    /// The addresses the chip has (the lease's with feature `dhcp`).
    network: Network,
    pub(crate) service: V,
    /// The DHCP client, with feature `dhcp`.
    lease: Lease,
    /// Overflows since the last whole second.
    overflows: u16,
    /// The application has the SPI ([`TcpServer::with_spi`]): the poll waits.
    pub(crate) lent: bool,
}

impl<M, C, CS, const B: usize, const INT: bool> TcpServer<M, C, CS, B, INT> {
    /// A server not yet started: what [`crate::tcp_server!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        TcpServer { running: Started::new() }
    }
}

impl<M: DataModel, C: Chip, const B: usize, const INT: bool> TcpServer<M, C, Pin10, B, INT> {
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

impl<M: DataModel, C: Chip, CS: OutputPin, const B: usize, const INT: bool> TcpServer<M, C, CS, B, INT> {
    /// Starts the server: takes the SPI (`dp.SPI`, or `&*dp.SPI` to keep it for
    /// [`TcpServer::with_spi`]) and `TC0` (`&*dp.TC0` when a serial role shares Timer0) from
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
        let (chip, network, lease) = open_chip::<C, CS, S, T>(network, spi, tc0, cs)?;
        self.running.start(|| Running::new(chip, network, Served(model), lease))?;
        start_interrupts::<INT>();
        Ok(())
    }

    /// Timer0's overflow: the chip polled, with interrupts enabled while it is served; an
    /// overflow while a poll runs, or before the start, does nothing here.
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

    /// Pin 2's external interrupt (`tcp_server!(…, pin2_int)`): the chip served at once.
    /// The interrupt stays masked until the chip has been served (by this poll, or the one
    /// running that this one found), and fires again at once if the line is still low.
    ///
    /// # Safety
    /// Only from pin 2's external interrupt handler, with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_pin2(&self) {
        pin2_interrupt(false);
        // SAFETY: as `on_overflow`'s.
        let _ = unsafe { self.running.access_marked(Running::on_event) };
    }

    /// Runs `f` on the data model with interrupts disabled: `None` before
    /// [`TcpServer::start`] or inside another `with`. Keep `f` short.
    pub fn with<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.running.locked(|r| f(&mut r.service.0))
    }

    /// Lends the SPI to the application for `f` (the shield's SD card, CS on pin 4, or any
    /// other SPI device): the server does not poll meanwhile (requests wait in the chip),
    /// and sets the SPI up again for itself afterwards. Use the SPI only inside `f`:
    /// outside, a poll can come between two bytes of the application's transfer. `None`
    /// before the start or inside another `with`.
    pub fn with_spi<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        lend_spi(&self.running, f)
    }

    /// The server's counters (all zero before [`TcpServer::start`]).
    pub fn counters(&self) -> TcpCounters {
        self.running.locked(|r| r.server.counters()).unwrap_or_default()
    }

    /// Refuses every client's writes from now on (`true`), or gives the clients of
    /// [`Network::allow`] theirs back (feature `write-protect`): while a local panel holds a
    /// setpoint, say. Writes get exception 01 (Illegal Function), change nothing and are
    /// counted ([`TcpCounters::refused_writes`]); reads go on. Clients that may only ever
    /// read are [`Network::allow_reading`]'s. To start read-only, call it right after
    /// [`TcpServer::start`]: no client has connected yet. Does nothing before the start.
    #[cfg(feature = "write-protect")]
    pub fn set_read_only(&self, on: bool) {
        self.running.locked(|r| r.server.set_read_only(on));
    }

    /// True while the chip answers and its link is up, as the once-a-second check last saw
    /// them (the W5100 cannot tell its link: there, while the chip answers); false before
    /// [`TcpServer::start`].
    pub fn link_up(&self) -> bool {
        self.running.locked(|r| r.server.health.link_up()).unwrap_or(false)
    }

    /// Reads a coil, input or register by its classic reference (see [`crate::Bank::get`]).
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        Values::get(self, reference)
    }

    /// Sets a coil, input or register by its classic reference (see [`crate::Bank::set`]).
    pub fn set(&self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        Values::set(self, reference, value)
    }

    /// The `u32`, `i32` or `f32` in the two registers from `first`, read in one critical
    /// section (see [`crate::Slave::get_wide`]).
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        Values::get_wide(self, first, order)
    }

    /// Sets the two registers from `first`, both in one critical section (see
    /// [`crate::Slave::set_wide`]).
    pub fn set_wide<T: crate::Wide>(
        &self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        Values::set_wide(self, first, value, order)
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]).
    pub fn master_writes(&self) -> u16 {
        Values::master_writes(self)
    }
}

impl<M: DataModel, C: Chip, CS: OutputPin, const B: usize, const INT: bool> Values for TcpServer<M, C, CS, B, INT> {
    type Model = M;

    #[inline(always)]
    fn with_model<R>(&self, f: impl FnOnce(&mut M) -> R) -> Option<R> {
        self.with(f)
    }
}

impl<V: Service, C: Chip, CS: OutputPin, const B: usize, const INT: bool> Running<V, C, CS, B, INT> {
    /// A role about to run on `chip`.
    pub(crate) fn new(chip: Wiznet<C, Spi<CS>>, network: Network, service: V, lease: Lease) -> Self {
        Running { server: Server::new(), chip, network, service, lease, overflows: 0, lent: false }
    }

    /// One poll, from the overflow interrupt (interrupts disabled on entry and on return):
    /// the second counted, then, unless the application has the SPI, the chip served with
    /// interrupts enabled.
    #[inline(never)]
    pub(crate) fn poll(&mut self) {
        self.overflows += 1;
        let second = self.overflows >= OVERFLOWS_PER_SECOND;
        if second {
            self.overflows = 0;
        }
        // With the INT line, the overflow only counts seconds and retries what was left;
        // polled, it first asks the chip whether a socket has news (one register, with
        // interrupts still off: 6 µs on the W5100) and leaves at once when none has.
        // A chip that stopped answering is not served (its registers read 0x00 or 0xFF): the
        // once-a-second check tries to set it up again.
        if V::NESTS_AT_ONCE {
            // SAFETY: the role is marked in use (`access_marked`), as in `serve`.
            unsafe { reg::enable_interrupts() };
        }
        if self.lent
            || (!second
                && (self.server.health.is_lost()
                    || self.server.is_quiet() && !self.service.pending() && (INT || self.chip.events() == 0)))
        {
            if V::NESTS_AT_ONCE {
                // SAFETY: interrupts off again before the mark goes.
                unsafe { reg::disable_interrupts() };
            }
            return;
        }
        if second {
            // Once a second, the chip's and the link's health (`crate::tcp::health`), with
            // interrupts enabled (setting a chip up again takes a few milliseconds): a chip
            // that lost its settings, or whose link went, set up again, and its sockets
            // opened again by the serve that follows; none served while the chip does not
            // answer (pin 2's interrupt stays masked then).
            // SAFETY: as in `serve`: the role is marked in use.
            unsafe { reg::enable_interrupts() };
            self.chip.bus.configure();
            let answers = self.server.check(&mut self.chip, &self.network);
            // SAFETY: interrupts off again before the mark goes.
            unsafe { reg::disable_interrupts() };
            if !answers {
                return;
            }
        }
        self.serve(second);
    }

    /// Pin 2's interrupt, or work that cannot wait for the next poll: the chip served,
    /// unless the application has the SPI (its `with_spi` unmasks the interrupt when it is
    /// done). Events that come meanwhile keep the line low, and the interrupt, unmasked at
    /// the end, comes again at once.
    #[inline(never)]
    pub(crate) fn on_event(&mut self) {
        if !self.lent && !self.server.health.is_lost() {
            self.serve(false);
        }
    }

    /// Serves the chip with interrupts enabled, then (with the INT line) unmasks pin 2's
    /// interrupt. Interrupts disabled on entry and on return. Not inlined: the quiet poll
    /// does not pay for its registers.
    #[inline(never)]
    fn serve(&mut self, second: bool) {
        // SAFETY: the role is marked in use (`access_marked`), so nothing else reaches it
        // meanwhile; other interrupts may run, which is the point.
        unsafe { reg::enable_interrupts() };
        self.chip.bus.configure();
        self.lease.poll(&mut self.chip, &mut self.network, second);
        let mut second = second;
        loop {
            self.service.run(&mut self.server, &mut self.chip, &self.network, second);
            second = false;
            // SAFETY: interrupts off again before the mark goes (`access_marked`'s promise).
            unsafe { reg::disable_interrupts() };
            // Work that came while the chip was served (a gateway's answer from the line:
            // its interrupt found the role in use and left it) is done now, not at the next
            // poll; asked with interrupts off, so that none comes between.
            if !self.service.pending() {
                break;
            }
            // SAFETY: as above: the role is still marked in use.
            unsafe { reg::enable_interrupts() };
        }
        if INT {
            pin2_interrupt(true);
        }
    }
}

/// What `open_chip` gives a role: the chip, the settings as the chip has them, and the
/// DHCP client (feature `dhcp`).
pub(crate) type Opened<C, CS> = (Wiznet<C, Spi<CS>>, Network, Lease);

/// Resets the chip on `cs` and checks it is a `C`, gives it `network`'s addresses (none
/// yet with DHCP), after claiming the SPI and `TC0`: what a TCP role's start does before
/// anything runs. [`Error::NoChip`] when the chip does not answer as a `C`.
pub(crate) fn open_chip<C: Chip, CS: OutputPin, S: Deref, T: Deref>(
    network: Network,
    spi: S,
    tc0: T,
    cs: CS,
) -> Result<Opened<C, CS>, Error>
where
    S::Target: Sized,
    T::Target: Sized,
{
    let mut network = network;
    let lease = Lease::new::<C>(&mut network);
    claim::<_, { SPI_BLOCK.1 }>(spi, SPI_BLOCK.0)?;
    claim::<_, { reg::TC0.1 }>(tc0, reg::TC0.0)?;
    let mut chip = Wiznet::<C, _>::new(Spi::new(cs));
    // The shields hold the chip in reset for up to 560 ms after power-up (a reset chip
    // on the board): tried every 10 ms for 0.6 s before giving up.
    let mut tries: u8 = 60;
    while !chip.init(&network) {
        tries -= 1;
        if tries == 0 {
            return Err(Error::NoChip);
        }
        wait_10ms();
    }
    let network = Network { sockets: network.sockets.min(C::SOCKETS), ..network };
    // A UDP socket the chip lacks serves nothing.
    #[cfg(feature = "udp")]
    let network = Network { udp: if network.udp < C::SOCKETS { network.udp } else { crate::tcp::NO_UDP }, ..network };
    Ok((chip, network, lease))
}

/// Timer0's overflow (and with `INT` pin 2's interrupt) started, and interrupts enabled:
/// the end of a TCP role's start, its state in its cell.
pub(crate) fn start_interrupts<const INT: bool>() {
    reg::free(|| {
        start_timer0();
        if INT {
            start_pin2_interrupt();
        }
    });
    // SAFETY: the role is in its cell, so its interrupt handler can run.
    unsafe { reg::enable_interrupts() };
}

/// Lends the SPI to the application for `f` (see [`TcpServer::with_spi`]).
pub(crate) fn lend_spi<V, C, CS, const B: usize, const INT: bool, R>(
    running: &Started<Running<V, C, CS, B, INT>>,
    f: impl FnOnce() -> R,
) -> Option<R> {
    running.locked(|r| r.lent = true)?;
    let result = f();
    running.locked(|r| {
        r.lent = false;
        if INT {
            pin2_interrupt(true);
        }
    });
    Some(result)
}

/// About 10 ms of the CPU's time, before Timer0 runs.
#[inline(never)]
fn wait_10ms() {
    // Four cycles a turn: `sbiw` and `brne` (2 when taken) and the `nop` keeping it a loop.
    let mut turns = (CLOCK_HZ / 100 / 4) as u16;
    while turns != 0 {
        // SAFETY: no operands, no effect but time.
        unsafe { core::arch::asm!("nop") };
        turns -= 1;
    }
}

/// EIMSK, the same on every chip.
const EIMSK: Reg = Reg::at(0x3D);

/// Pin 2's external interrupt enabled or masked.
#[inline(always)]
pub(crate) fn pin2_interrupt(on: bool) {
    let (_, _, bit, _, _) = CHIP.pin2_int;
    EIMSK.modify(|m| if on { m | 1 << bit } else { m & !(1 << bit) });
}

/// Pin 2 an input with its pull-up, its interrupt on a low level (the chip's INT line is
/// low while it has events), enabled. (A level interrupt has no flag to clear: INTFn stays
/// clear in that mode.) Interrupts disabled.
fn start_pin2_interrupt() {
    let (eicr, shift, _, pin, pin_bit) = CHIP.pin2_int;
    // DDRx (PINx + 1) clear, PORTx (PINx + 2) set: an input pulled up.
    Reg::at(pin + 1).modify(|d| d & !(1 << pin_bit));
    Reg::at(pin + 2).modify(|p| p | 1 << pin_bit);
    Reg::at(eicr).modify(|e| e & !(0b11 << shift));
    pin2_interrupt(true);
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
