//! The TCP server's addresses kept in the EEPROM (features `tcp` and `eeprom-settings`):
//! two record slots (48 bytes, `crate::tcp::NETWORK_SLOTS_LEN`), so that a reset or power
//! cut during a store leaves the old addresses or the new ones.

use super::Eeprom;
use crate::tcp::record::{self, NETWORK_SLOTS_LEN};
use crate::tcp::Network;

impl Eeprom {
    /// The two slots from `address` on; `None` if they would pass the end.
    fn read_network_slots(&self, address: u16) -> Option<[u8; NETWORK_SLOTS_LEN]> {
        let mut slots = [0; NETWORK_SLOTS_LEN];
        self.read_slice(address, &mut slots).then_some(slots)
    }

    /// `default` with the MAC, IP, subnet mask, gateway, port and unit id stored at `address`
    /// by [`Eeprom::store_network`] (the newest of its two slots); `default` itself when
    /// neither slot holds a record (a new board, an erased EEPROM). The allow-list, the
    /// sockets and the timeouts stay `default`'s.
    pub fn load_network(&self, address: u16, default: Network) -> Network {
        self.read_network_slots(address)
            .and_then(|slots| record::newest(&slots, default))
            .map_or(default, |(_, _, network)| network)
    }

    /// Stores `network`'s MAC, IP, subnet mask, gateway, port and unit id in the two slots at
    /// `address` (48 bytes): into the slot that does not hold the newest record, skipping
    /// bytes already right; returns how many bytes were written (0 when the newest record
    /// already holds them). About 3.4 ms per byte written, interrupts enabled. A reset at any
    /// instant leaves the old addresses or the new ones for the next `load_network`.
    #[inline(never)]
    pub fn store_network(&mut self, address: u16, network: &Network) -> usize {
        let Some((at, bytes)) = self.read_network_slots(address).and_then(|slots| record::store(&slots, network))
        else {
            return 0;
        };
        self.update_slice(address.wrapping_add(at as u16), &bytes)
    }
}
