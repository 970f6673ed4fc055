//! The settings block, Modbus over Serial Line v1.02 §2.5.1 (baud rate, parity, stop
//! bits), §2.2 (slave address) and, with feature `ascii`, §2.5 (transmission mode): four
//! holding registers (five with `ascii`), their codes, and the check of what a master
//! writes into them ([`LineSettings::from_registers`]).

#[cfg(feature = "ascii")]
use crate::link::config::Mode;
use crate::link::config::{Config, Parity, SlaveId, StopBits};
use crate::link::timing::{BaudDivisor, CLOCK_HZ};
use crate::slave::pdu::Exception;

/// Registers in the settings block: four, the transmission mode with feature `ascii`, and
/// the reply delay with feature `reply-delay`, in that order.
pub const BLOCK_LEN: u16 = 4 + cfg!(feature = "ascii") as u16 + cfg!(feature = "reply-delay") as u16;

/// Offset of the slave id in the settings block.
pub const SLAVE_ID: u16 = 0;
/// Offset of the baud rate / 100 in the settings block.
pub const BAUD_100: u16 = 1;
/// Offset of the parity code in the settings block.
pub const PARITY: u16 = 2;
/// Offset of the stop bits in the settings block.
pub const STOP_BITS: u16 = 3;
/// Offset of the transmission mode in the settings block (feature `ascii`).
#[cfg(feature = "ascii")]
pub const MODE: u16 = 4;
/// Offset of the reply delay in milliseconds in the settings block (feature `reply-delay`):
/// the last register.
#[cfg(feature = "reply-delay")]
pub const REPLY_DELAY: u16 = BLOCK_LEN - 1;
/// The longest reply delay the block and the record take, in milliseconds.
#[cfg(feature = "reply-delay")]
pub const MAX_REPLY_DELAY_MS: u16 = 255;

/// The transmission mode of a code (feature `ascii`): 0 RTU, 1 ASCII with 7 data bits,
/// 2 ASCII with 8 (the discriminants of [`Mode`]); `None` for another code.
#[cfg(feature = "ascii")]
pub const fn mode_from_code(code: u16) -> Option<Mode> {
    match code {
        0 => Some(Mode::Rtu),
        1 => Some(Mode::Ascii),
        2 => Some(Mode::Ascii8),
        _ => None,
    }
}

/// The code of a parity in the settings block and the record: 0 none, 1 odd, 2 even
/// (the discriminants of [`Parity`], so that no code table is needed).
pub const fn parity_code(parity: Parity) -> u8 {
    parity as u8
}

/// The parity of a code, `None` for an unknown code.
pub const fn parity_from_code(code: u16) -> Option<Parity> {
    match code {
        0 => Some(Parity::None),
        1 => Some(Parity::Odd),
        2 => Some(Parity::Even),
        _ => None,
    }
}

/// The number of stop bits: 1 or 2.
pub const fn stop_bits_count(stop_bits: StopBits) -> u8 {
    match stop_bits {
        StopBits::One => 1,
        StopBits::Two => 2,
    }
}

/// The stop bits of a count, `None` unless 1 or 2.
pub const fn stop_bits_from_count(count: u16) -> Option<StopBits> {
    match count {
        1 => Some(StopBits::One),
        2 => Some(StopBits::Two),
        _ => None,
    }
}

/// Line settings as plain values: what the master writes, checked with integer math fast
/// enough for an interrupt handler. Turning them into a [`Config`] (the USART divisor and
/// the Timer0 plan) takes several 32-bit divisions, under a millisecond on the Uno (about
/// 0.7 ms measured in simulation): the application does that in its main loop (see
/// [`Configurable::offer`](super::Configurable::offer)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineSettings {
    /// Slave id.
    pub slave_id: u8,
    /// Bits per second.
    pub baud: u32,
    /// Parity bit.
    pub parity: Parity,
    /// Stop bits.
    pub stop_bits: StopBits,
    /// RTU or ASCII (feature `ascii`).
    #[cfg(feature = "ascii")]
    pub mode: Mode,
    /// The reply delay after T3.5 in milliseconds, 0–255 (feature `reply-delay`).
    #[cfg(feature = "reply-delay")]
    pub reply_delay_ms: u8,
}

impl LineSettings {
    /// The settings of `config`.
    pub const fn of(config: &Config) -> Self {
        LineSettings {
            slave_id: config.slave_id().get(),
            baud: config.baud(),
            parity: config.parity(),
            stop_bits: config.stop_bits(),
            #[cfg(feature = "ascii")]
            mode: config.mode(),
            #[cfg(feature = "reply-delay")]
            reply_delay_ms: {
                let ms = config.reply_delay_us() / 1000;
                if ms > MAX_REPLY_DELAY_MS as u32 {
                    MAX_REPLY_DELAY_MS as u8
                } else {
                    ms as u8
                }
            },
        }
    }

    /// The settings block's registers.
    pub fn to_registers(&self) -> [u16; BLOCK_LEN as usize] {
        [
            u16::from(self.slave_id),
            u16::try_from(self.baud / 100).unwrap_or(u16::MAX),
            u16::from(parity_code(self.parity)),
            u16::from(stop_bits_count(self.stop_bits)),
            #[cfg(feature = "ascii")]
            (self.mode as u16),
            #[cfg(feature = "reply-delay")]
            u16::from(self.reply_delay_ms),
        ]
    }

    /// The settings the block's registers describe. `base` is what they were read from: a
    /// baud register still reading `base`'s value keeps `base`'s exact rate. Exception 03
    /// when the registers describe settings the slave can't run.
    pub fn from_registers(base: &LineSettings, registers: [u16; BLOCK_LEN as usize]) -> Result<Self, Exception> {
        let at = |offset: u16| registers.get(usize::from(offset)).copied().unwrap_or(0);
        let [id, baud_100, parity, stop] = [at(SLAVE_ID), at(BAUD_100), at(PARITY), at(STOP_BITS)];
        let baud = u32::from(baud_100) * 100;
        // `baud_100 == base.baud / 100`, without a division.
        let baud = if (baud..baud + 100).contains(&base.baud) { base.baud } else { baud };
        let settings = LineSettings {
            slave_id: u8::try_from(id).map_err(|_| Exception::IllegalDataValue)?,
            baud,
            parity: parity_from_code(parity).ok_or(Exception::IllegalDataValue)?,
            stop_bits: stop_bits_from_count(stop).ok_or(Exception::IllegalDataValue)?,
            #[cfg(feature = "ascii")]
            mode: mode_from_code(at(MODE)).ok_or(Exception::IllegalDataValue)?,
            #[cfg(feature = "reply-delay")]
            reply_delay_ms: u8::try_from(at(REPLY_DELAY)).map_err(|_| Exception::IllegalDataValue)?,
        };
        if settings.is_runnable() {
            Ok(settings)
        } else {
            Err(Exception::IllegalDataValue)
        }
    }

    /// True exactly when [`LineSettings::to_config`] succeeds: slave id 1–247, a rate from
    /// [`Config::MIN_BAUD`] to [`Config::MAX_BAUD`] that the USART makes at the CPU clock within
    /// [`BaudDivisor::MAX_ERROR_PPM`] at normal or double speed. Only the divisor search
    /// (two 32-bit divisions and a few 64-bit products), not the timer plan: cheap enough
    /// for the interrupt that answers the write.
    pub fn is_runnable(&self) -> bool {
        SlaveId::try_new(self.slave_id).is_ok()
            && (Config::MIN_BAUD..=Config::MAX_BAUD).contains(&self.baud)
            && BaudDivisor::new(self.baud, CLOCK_HZ).is_some()
    }

    /// The configuration, `None` when [`Config::try_new`] refuses it.
    pub fn to_config(&self) -> Option<Config> {
        let config = Config::try_new(self.slave_id, self.baud, self.parity, self.stop_bits).ok();
        #[cfg(feature = "ascii")]
        let config = config.map(|c| c.with_mode(self.mode));
        #[cfg(feature = "reply-delay")]
        let config = config.map(|c| c.with_reply_delay(u32::from(self.reply_delay_ms) * 1000));
        config
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parity_and_stop_codes_round_trip() {
        for parity in [Parity::None, Parity::Odd, Parity::Even] {
            assert_eq!(parity_from_code(u16::from(parity_code(parity))), Some(parity));
        }
        for stop in [StopBits::One, StopBits::Two] {
            assert_eq!(stop_bits_from_count(u16::from(stop_bits_count(stop))), Some(stop));
        }
        assert_eq!(parity_from_code(3), None);
        assert_eq!(stop_bits_from_count(0), None);
    }
}
