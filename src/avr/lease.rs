//! The DHCP client in a running TCP role (feature `dhcp`): the pure client
//! (`crate::tcp::dhcp`) on its socket of the chip, run in the same interrupt as the role,
//! when the chip has news and once a second; the addresses it obtains written to the chip
//! and kept in the role's `network` (so that whatever sets the chip up again restores them).
//! The application reads them, and the lease's state, with [`TcpServer::network`] and
//! [`TcpServer::dhcp`] (the TCP client's: `TcpClient::network`, `TcpClient::dhcp`).

use embedded_hal::digital::OutputPin;

use super::super::spi::Spi;
use super::TcpServer;
use crate::slave::model::DataModel;
use crate::tcp::dhcp::{self, Dhcp, DhcpStatus};
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::Network;

/// The DHCP client, when the network asks for one.
pub(crate) struct Lease(Option<Dhcp>);

impl Lease {
    /// The client for `network` and the network to start with: with [`Network::dhcp`], no
    /// IP address yet, the client's socket one the chip `C` has (its last when asked for one
    /// beyond) and the role's sockets below it.
    pub(crate) fn new<C: Chip>(network: &mut Network) -> Lease {
        let Some(settings) = network.dhcp else { return Lease(None) };
        let socket = settings.socket.min(C::SOCKETS - 1);
        network.sockets = network.sockets.min(socket);
        let dhcp = Dhcp::new(network, dhcp::Settings { socket, ..settings });
        // No address before a lease (the fallback comes a second or more after the start).
        network.addresses[dhcp::IP..].fill(0);
        Lease(Some(dhcp))
    }

    /// Runs the client (interrupts enabled, the role in use): its socket's datagrams
    /// taken, with `second` its timers, and the addresses it wants given to the chip and
    /// kept in `network`.
    #[inline(never)]
    pub(crate) fn poll<C: Chip, CS: OutputPin>(
        &mut self,
        chip: &mut Wiznet<C, Spi<CS>>,
        network: &mut Network,
        second: bool,
    ) {
        if let Some(dhcp) = &mut self.0 {
            dhcp::poll(dhcp, chip, network, second);
        }
    }
}

impl<M: DataModel, C: Chip, CS: OutputPin, const B: usize, const INT: bool> TcpServer<M, C, CS, B, INT> {
    /// The addresses the shield has now (feature `dhcp`): the lease's, the fallback, or
    /// none (IP 0.0.0.0) while there is neither; `ip()`, `subnet_mask()`,
    /// `gateway_address()` read them. `None` before the start.
    pub fn network(&self) -> Option<Network> {
        self.running.locked(|r| r.network)
    }

    /// The DHCP client's state, the lease's time left and the counters (feature `dhcp`):
    /// `None` before the start, or without [`Network::dhcp`].
    pub fn dhcp(&self) -> Option<DhcpStatus> {
        self.running.locked(|r| r.lease.0.as_ref().map(Dhcp::status)).flatten()
    }
}

#[cfg(feature = "master")]
impl<C: Chip, CS: OutputPin, const N: usize> crate::TcpClient<C, CS, N> {
    /// The addresses the shield has now (feature `dhcp`): the lease's, the fallback, or
    /// none (IP 0.0.0.0); `None` before the start.
    pub fn network(&self) -> Option<Network> {
        self.running.locked(|r| r.network)
    }

    /// The DHCP client's state, the lease's time left and the counters (feature `dhcp`):
    /// `None` before the start, or without [`Network::dhcp`].
    pub fn dhcp(&self) -> Option<DhcpStatus> {
        self.running.locked(|r| r.lease.0.as_ref().map(Dhcp::status)).flatten()
    }
}
