//! The slave's switch to new line settings the master wrote (feature `eeprom-settings`):
//! the main loop's part, and where they are kept.

use embedded_hal::digital::OutputPin;

use super::Slave;
use crate::link::config::Config;
use crate::slave::model::DataModel;

#[cfg(feature = "eeprom-settings")]
// Named for the docs: inside the AVR layer the automatic badge misses impl blocks (src/lib.rs).
#[cfg_attr(docsrs, doc(cfg(feature = "eeprom-settings")))]
impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char>
    Slave<crate::slave::settings::Configurable<M>, DE, LED, N, U, C>
{
    /// The main loop's part of a settings change (feature `eeprom-settings`): call it
    /// from the main loop as often as it comes round. Returns how many EEPROM bytes it
    /// wrote when it stored new settings at `address`, else `None`.
    ///
    /// When the master has written new settings, computes their [`Config`] (under 1 ms
    /// of 32-bit arithmetic, with interrupts enabled) and hands it to the slave, which switches when
    /// the reply to the write has left the wire; if it already has, the switch happens
    /// here. Then stores the settings the slave switched to in the two slots at `address`
    /// ([`crate::avr::eeprom::Eeprom::store_config`]: a reset during the store leaves the old
    /// settings or the new ones; ≈3.4 ms per byte written, at most 12, interrupts
    /// enabled): no interrupt handler ever waits for the EEPROM or the division routines.
    pub fn poll_settings(&self, eeprom: &mut crate::avr::eeprom::Eeprom, address: u16) -> Option<usize> {
        if let Some(settings) = self.with(|model| model.pending()).flatten() {
            if let Some(config) = settings.to_config() {
                self.locked(|s| {
                    s.model.offer(settings, config);
                    if !s.usart.is_sending() {
                        s.apply_new_settings();
                    }
                });
            }
        }
        let config = self.with(|model| model.take_unsaved()).flatten()?;
        Some(eeprom.store_config(address, &config))
    }

    /// The line settings the slave runs (see [`crate::slave::settings::Configurable::config`]).
    pub fn config(&self) -> Option<Config> {
        self.with(|model| model.config())
    }
}
