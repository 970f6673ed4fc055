//! No DHCP client (feature `dhcp` off): a running role's place for one holds nothing and
//! does nothing.

use embedded_hal::digital::OutputPin;

use super::super::spi::Spi;
use crate::tcp::wiznet::{Chip, Wiznet};
use crate::tcp::Network;

/// No DHCP client.
pub(crate) struct Lease;

impl Lease {
    /// The network as given. `C` unused: the DHCP client's signature (`lease.rs`), which
    /// picks the chip's socket count.
    #[allow(clippy::extra_unused_type_parameters)]
    #[inline(always)]
    pub(crate) fn new<C: Chip>(_: &mut Network) -> Lease {
        Lease
    }

    /// Nothing to do.
    #[inline(always)]
    pub(crate) fn poll<C: Chip, CS: OutputPin>(&mut self, _: &mut Wiznet<C, Spi<CS>>, _: &mut Network, _: bool) {}
}
