//! The Modbus TCP client on the AVR (features `tcp` and `master`): the pure client
//! (`crate::tcp::client`) on a WIZnet chip over the SPI, driven from Timer0's overflow
//! interrupt every 1.024 ms (2.048 ms at 8 MHz), so that the connection is kept, requests go
//! out and replies come in whatever the application's main loop does. The application
//! starts a request and collects its outcome when it likes, as with the RTU [`crate::Master`];
//! it never touches the chip itself.
//!
//! Connected and with no request under way, each overflow reads the chip's socket events
//! (one register) and leaves when there are none; the clock and the socket itself are read
//! when it has news (data, a close), while a request is under way, and at least once a
//! second. The poll runs with interrupts enabled again, so that a serial role's interrupts
//! beside it keep their timing.

use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::clock;
use super::reg;
use super::spi::Spi;
use super::started::Started;
use super::tcp::lease::Lease;
use super::tcp::{open_chip, start_interrupts, Pin10};
use crate::error::Error;
use crate::link::timing::{CLOCK_HZ, TIMER0_DIVISOR};
use crate::master::{Failure, MasterCounters, Reply, Request, Timeouts};
use crate::tcp::client::Client;
use crate::tcp::health::{Health, Verdict};
use crate::tcp::server::Sockets;
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::Network;

/// The Modbus TCP client (master): declare it with [`crate::tcp_client!`], start it with the
/// server's address, the application's SPI and `TC0`, then send requests and collect their
/// outcomes; nothing waits.
///
/// ```ignore
/// avr_modbus::tcp_client!(CLIENT: W5100);
/// // in main:
/// CLIENT.start(NETWORK, [192, 168, 1, 10], 502, dp.SPI, dp.TC0)?;
/// // in the loop:
/// let _ = CLIENT.send(0xFF, &Request::ReadHoldingRegisters { address: 0, quantity: 10 });
/// let outcome = CLIENT.poll(|outcome| outcome.map(|reply| reply.register(0)));
/// ```
///
/// `C` is the chip ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]), `CS` its chip-select
/// pin ([`Pin10`], the shields', by default), `N` the bytes of each of its two buffers, the
/// request and the reply, counted as for the RTU [`crate::Master`] (a read of `q` registers
/// is answered in 5 + 2`q`; 256 fits every one).
pub struct TcpClient<C, CS = Pin10, const N: usize = 256> {
    pub(crate) running: Started<Running<C, CS, N>>,
}

/// The running client: the pure client, the chip and its settings (the lease's with
/// feature `dhcp`), its health, the DHCP client.
pub(crate) struct Running<C, CS, const N: usize> {
    client: Client<N>,
    chip: Wiznet<C, Spi<CS>>,
    pub(crate) network: Network,
    health: Health,
    /// The DHCP client, with feature `dhcp`.
    pub(crate) lease: Lease,
    /// Overflows since the last whole poll.
    overflows: u16,
    /// The application has the SPI ([`TcpClient::with_spi`]): the poll waits.
    lent: bool,
}

/// Timer0 overflows in a second: 976 at 16 MHz (1.024 ms each), 488 at 8 MHz.
const OVERFLOWS_PER_SECOND: u16 = (CLOCK_HZ / TIMER0_DIVISOR / 256) as u16;

impl<C, CS, const N: usize> TcpClient<C, CS, N> {
    /// A client not yet started: what [`crate::tcp_client!`] declares.
    #[doc(hidden)]
    pub const fn new() -> Self {
        TcpClient { running: Started::new() }
    }
}

impl<C: Chip, const N: usize> TcpClient<C, Pin10, N> {
    /// Starts the client with the chip's select on the board's pin 10 (the shields'): see
    /// [`TcpClient::start_with_cs`].
    pub fn start<S: Deref, T: Deref>(
        &self,
        network: Network,
        server: [u8; 4],
        port: u16,
        spi: S,
        tc0: T,
    ) -> Result<(), Error>
    where
        S::Target: Sized,
        T::Target: Sized,
    {
        self.start_with_cs(network, server, port, spi, tc0, Pin10)
    }
}

impl<C: Chip, CS: OutputPin, const N: usize> TcpClient<C, CS, N> {
    /// Starts the client: takes the SPI and `TC0` from the application's `Peripherals`,
    /// resets the chip and checks it is a `C`, gives it `network`'s addresses (its port and
    /// unit id are the server's, unused here), and from here on keeps a connection to
    /// `server`:`port` (Modbus: 502), opened again whenever it drops. [`Error::NoChip`] when
    /// the chip does not answer as a `C`; [`Error::WrongPeripheral`] for another peripheral
    /// than the SPI or `TC0`.
    pub fn start_with_cs<S: Deref, T: Deref>(
        &self,
        network: Network,
        server: [u8; 4],
        port: u16,
        spi: S,
        tc0: T,
        cs: CS,
    ) -> Result<(), Error>
    where
        S::Target: Sized,
        T::Target: Sized,
    {
        let (chip, network, lease) = open_chip::<C, _, _, _>(network, spi, tc0, cs)?;
        self.running.start(|| Running {
            client: Client::new(server, port),
            chip,
            network,
            health: Health::new(),
            lease,
            overflows: 0,
            lent: false,
        })?;
        start_interrupts::<false>();
        Ok(())
    }

    /// Starts `request` to unit id `unit` (0xFF: the server itself; a gateway's serial
    /// slaves by their address) and returns at once: the request is checked and built now
    /// and goes out from the next overflow (within about a millisecond).
    /// [`Error::NotConnected`] while the connection is down (the client connects again by
    /// itself: ask again later), [`Error::Busy`] while another request is under way or its
    /// outcome waits to be collected with [`TcpClient::poll`], [`Error::NotStarted`] before
    /// [`TcpClient::start`]; a quantity outside the spec's limits, a request or reply longer
    /// than the buffers are refused before a byte is sent.
    pub fn send(&self, unit: u8, request: &Request<'_>) -> Result<(), Error> {
        let now = clock::millis();
        self.running.locked(|r| r.client.start(unit, request, now)).unwrap_or(Err(Error::NotStarted))
    }

    /// The outcome of the last request, once it is there: `f` runs on the reply (read in
    /// place, with interrupts disabled: keep it short) or on why there is none, and the
    /// client is ready for the next request. `None` while the request is under way, or
    /// when there is none.
    pub fn poll<R>(&self, f: impl FnOnce(Result<Reply<'_>, Failure>) -> R) -> Option<R> {
        self.running
            .locked(|r| {
                let result = r.client.outcome().map(f);
                r.client.collect();
                result
            })
            .flatten()
    }

    /// True from [`TcpClient::send`] until the outcome is collected with [`TcpClient::poll`].
    pub fn is_busy(&self) -> bool {
        self.running.locked(|r| r.client.is_busy()).unwrap_or(false)
    }

    /// True while the connection to the server is up: [`TcpClient::send`] is refused
    /// otherwise.
    pub fn is_connected(&self) -> bool {
        self.running.locked(|r| r.client.is_connected()).unwrap_or(false)
    }

    /// Connections made to the server so far (wrapping): one more after each drop.
    pub fn connections(&self) -> u16 {
        self.running.locked(|r| r.client.connections()).unwrap_or(0)
    }

    /// True while the chip answers and its link is up, as the once-a-second check last saw
    /// them (the W5100 cannot tell its link: there, while the chip answers); false before
    /// [`TcpClient::start`].
    pub fn link_up(&self) -> bool {
        self.running.locked(|r| r.health.link_up()).unwrap_or(false)
    }

    /// Times the chip was set up again (reset, addresses, the connection made again) after
    /// it lost its settings or stopped answering, and times the link went down (W5500),
    /// each wrapping: as the server's [`crate::tcp::TcpCounters`]' `chip_resets` and
    /// `link_losses`.
    pub fn chip_resets_and_link_losses(&self) -> (u16, u16) {
        self.running.locked(|r| (r.health.restarts(), r.health.losses())).unwrap_or_default()
    }

    /// Sets the response timeout (from the request's start to its reply) and the retries,
    /// from the next request on ([`Timeouts::DEFAULT`]: 1000 ms, one retry; the turnaround
    /// delay is unused over TCP).
    pub fn set_timeouts(&self, timeouts: Timeouts) {
        self.running.locked(|r| r.client.set_timeouts(timeouts));
    }

    /// The client's counters (all zero before [`TcpClient::start`]): as the RTU master's,
    /// `crc_errors` and `uart_errors` always 0 (see `crate::tcp` for the rest).
    pub fn counters(&self) -> MasterCounters {
        self.running.locked(|r| r.client.counters()).unwrap_or_default()
    }

    /// Lends the SPI to the application for `f` (the shield's SD card, CS on pin 4, or any
    /// other SPI device; start the client with `&*dp.SPI` to keep `dp.SPI` for your HAL's
    /// driver): the client does not touch the chip meanwhile (a reply waits in it, a request
    /// waits to go out, timeouts run on), and sets the SPI up again for itself afterwards.
    /// Use the SPI only inside `f`. `None` before the start or inside another call.
    pub fn with_spi<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        self.running.locked(|r| r.lent = true)?;
        let result = f();
        self.running.locked(|r| r.lent = false);
        Some(result)
    }

    /// Timer0's overflow: the client polled, with interrupts enabled meanwhile; an overflow
    /// while a poll runs, or before the start, does nothing here.
    ///
    /// # Safety
    /// Only from the Timer0 overflow interrupt handler, with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    pub unsafe fn on_overflow(&self) {
        // SAFETY: interrupts are disabled on entry; `Running::poll` enables them only while
        // the client is marked in use, and disables them again before the mark goes.
        let _ = unsafe { self.running.access_marked(Running::poll) };
    }
}

impl<C: Chip, CS: OutputPin, const N: usize> Running<C, CS, N> {
    /// One poll, interrupts disabled on entry and on return. Quiet (connected, no request
    /// under way), it asks the chip whether the socket has news (one register, interrupts
    /// still off: 6 µs on a W5100) and leaves at once when it has none, but once a second.
    #[inline(never)]
    fn poll(&mut self) {
        self.overflows += 1;
        let second = self.overflows >= OVERFLOWS_PER_SECOND;
        if self.lent || !second && self.client.is_quiet() && self.chip.events() == 0 {
            return;
        }
        if second {
            self.overflows = 0;
        }
        let now = clock::millis();
        // SAFETY: the client is marked in use (`access_marked`), so nothing else reaches it
        // meanwhile; other interrupts may run.
        unsafe { reg::enable_interrupts() };
        self.chip.bus.configure();
        self.lease.poll(&mut self.chip, &mut self.network, second);
        // Once a second, the chip's and the link's health (`crate::tcp::health`): a chip
        // that lost its settings set up again and the connection made again, as after a
        // link loss. While the chip does not answer, the client goes on (its connection
        // attempts fail, a request times out as usual).
        if second && self.health.check(&mut self.chip, &self.network) == Verdict::Reopen {
            self.client.reconnect(&mut self.chip, now);
        }
        self.client.poll(&mut self.chip, now);
        // SAFETY: interrupts off again before the mark goes (`access_marked`'s promise).
        unsafe { reg::disable_interrupts() };
    }
}
