//! Slave addresses on the serial line, Modbus over Serial Line v1.02 §2.2: 1–247 each
//! slave's own, 0 the broadcast, 248–255 reserved. (Modbus TCP's unit identifier takes the
//! same values when it names a slave behind a gateway.)

use crate::error::Error;

/// A slave's address: 1–247. A master sends to one (`Master::send`) or to all
/// (`Master::broadcast`); a slave answers its own.
///
/// [`SlaveId::new`] is for constants, where a bad id stops the build; [`SlaveId::try_new`]
/// (or `SlaveId::try_from(id)`, `id.try_into()`) for a `u8` read at run time, which gives
/// [`Error::SlaveId`] for 0 and 248–255. There is no `From<u8>`: not every byte is a slave's
/// id, so `5u8.into()` does not compile. [`SlaveId::get`] or `u8::from(id)` gives the byte back.
///
/// ```
/// use avr_modbus::{Error, SlaveId};
/// const PUMP: SlaveId = SlaveId::new(17);
/// assert_eq!(PUMP.get(), 17);
/// assert_eq!(u8::from(PUMP), 17);
/// assert_eq!(SlaveId::try_new(0), Err(Error::SlaveId));
/// let from_a_dip_switch: Result<SlaveId, Error> = 5u8.try_into();
/// assert_eq!(from_a_dip_switch, Ok(SlaveId::new(5)));
/// ```
///
/// ```compile_fail,E0080
/// use avr_modbus::SlaveId;
/// const NOBODY: SlaveId = SlaveId::new(248);
/// ```
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SlaveId(u8);

impl SlaveId {
    /// The broadcast address, 0: a write sent to it is carried out by every slave and
    /// answered by none.
    pub const BROADCAST: u8 = 0;

    /// The slave `id` (1–247), for a constant: outside a constant a bad id panics, so use
    /// [`SlaveId::try_new`] for run-time values.
    pub const fn new(id: u8) -> Self {
        match Self::try_new(id) {
            Ok(id) => id,
            Err(e) => panic!("{}", e.message()),
        }
    }

    /// The slave `id`, or [`Error::SlaveId`] unless it is 1–247.
    pub const fn try_new(id: u8) -> Result<Self, Error> {
        match id {
            1..=247 => Ok(SlaveId(id)),
            _ => Err(Error::SlaveId),
        }
    }

    /// The address as a byte.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl TryFrom<u8> for SlaveId {
    type Error = Error;

    fn try_from(id: u8) -> Result<Self, Error> {
        SlaveId::try_new(id)
    }
}

/// The address as a byte ([`SlaveId::get`]).
impl From<SlaveId> for u8 {
    fn from(id: SlaveId) -> u8 {
        id.get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slave_id_accepts_1_to_247_only() {
        assert_eq!(SlaveId::try_new(0), Err(Error::SlaveId));
        assert_eq!(SlaveId::try_new(1).map(SlaveId::get), Ok(1));
        assert_eq!(SlaveId::try_new(247).map(SlaveId::get), Ok(247));
        assert_eq!(SlaveId::try_new(248), Err(Error::SlaveId));
        assert_eq!(SlaveId::try_new(255), Err(Error::SlaveId));
        assert_eq!(SlaveId::try_from(17), Ok(SlaveId::new(17)));
    }

    #[test]
    fn a_slave_id_converts_from_a_u8_only_if_it_is_one_and_back_always() {
        for byte in 0..=255u8 {
            let id: Result<SlaveId, Error> = byte.try_into();
            assert_eq!(id.is_ok(), (1..=247).contains(&byte), "{byte}");
            if let Ok(id) = id {
                assert_eq!(u8::from(id), byte);
            }
        }
    }

    #[test]
    #[should_panic(expected = "slave id must be 1-247")]
    fn a_bad_id_outside_a_constant_panics() {
        let id = std::hint::black_box(0);
        SlaveId::new(id);
    }
}
