//! The line settings kept in the EEPROM (feature `eeprom-settings`): two record slots
//! (22 bytes), so that a reset or power cut during a store leaves the complete old
//! settings or the complete new ones, never a half-written record that would send the
//! device back to its default.

use super::Eeprom;
use crate::link::config::Config;
use crate::slave::settings::{Slots, SLOTS_LEN};

impl Eeprom {
    /// The two settings slots from `address` on; `None` if they would pass the end.
    fn read_slots(&self, address: u16) -> Option<Slots> {
        let mut bytes = [0; SLOTS_LEN];
        self.read_slice(address, &mut bytes).then_some(Slots::new(bytes))
    }

    /// The line settings stored at `address` by [`Eeprom::store_config`]: the newest valid
    /// record of the two slots there (a format-1 record of earlier firmware counts as the
    /// oldest). `None` when neither holds one (use the compiled-in default then).
    pub fn load_config(&self, address: u16) -> Option<Config> {
        self.read_slots(address)?.load()
    }

    /// Stores `config` in the two slots at `address` ([`SLOTS_LEN`] bytes): into the slot
    /// that does not hold the newest record, its first byte invalidated first and written
    /// last, skipping bytes that are already right; returns how many bytes were written
    /// (0 when the newest record already holds `config`, at most 12). Takes up to ≈41 ms
    /// (≈3.4 ms per byte written) with interrupts enabled.
    ///
    /// A reset at any instant, even one that tears the byte being written, leaves the old
    /// settings or the new ones for the next [`Eeprom::load_config`]: the new ones exactly
    /// when the last byte was written.
    // Inlined into the application's main loop it takes ≈190 bytes more flash.
    #[inline(never)]
    pub fn store_config(&mut self, address: u16, config: &Config) -> usize {
        let Some(slots) = self.read_slots(address) else {
            return 0;
        };
        slots.store(config).filter(|write| self.update(address.wrapping_add(write.offset), write.byte)).count()
    }
}
