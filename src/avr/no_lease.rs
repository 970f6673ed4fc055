//! No DHCP client (feature `dhcp` off): a running role's place for one holds nothing and
//! does nothing.

use embedded_hal::digital::OutputPin;

use super::super::spi::Spi;
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::Network;

/// No DHCP client.
pub(crate) struct Lease;

impl Lease {
    /// The network as given.
    #[inline(always)]
    pub(crate) fn new<C: Chip>(network: Network) -> (Network, Lease) {
        (network, Lease)
    }

    /// Nothing to do.
    #[inline(always)]
    pub(crate) fn poll<C: Chip, CS: OutputPin>(&mut self, _: &mut Wiznet<C, Spi<CS>>, _: &mut Network, _: bool) {}
}

/// No DHCP client for the TCP client either.
#[cfg(feature = "master")]
pub(crate) struct ClientLease;

#[cfg(feature = "master")]
impl ClientLease {
    /// Nothing kept.
    #[inline(always)]
    pub(crate) fn new(_: Network, _: Lease) -> ClientLease {
        ClientLease
    }

    /// Never a second to count.
    #[inline(always)]
    pub(crate) fn tick(&mut self) -> bool {
        false
    }

    /// Nothing to do.
    #[inline(always)]
    pub(crate) fn poll<C: Chip, CS: OutputPin>(&mut self, _: &mut Wiznet<C, Spi<CS>>, _: bool) {}
}
