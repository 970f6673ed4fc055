//! The configuration of Modbus ASCII, Serial Line v1.02 §2.5.2 (feature `ascii`): the
//! transmission mode, 7 or 8 data bits, the inter-character timeout, and when a frame's
//! last character has left the line.

use super::{Config, Line, Parity, StopBits};
use crate::link::timing::{Deadline, TURN_US};

/// How frames travel on the line, Modbus over Serial Line v1.02 §2.5 (feature `ascii`;
/// without it every frame is RTU). The discriminants are the codes the settings block
/// (feature `eeprom-settings`) takes.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// RTU, §2.5.1: binary bytes with a CRC, 8 data bits, frames delimited by silence.
    Rtu = 0,
    /// ASCII, §2.5.2: hex characters from `:` to CR LF with an LRC, 7 data bits (the
    /// spec's default character format is 7E1).
    Ascii = 1,
    /// ASCII with 8 data bits, as some devices have it.
    Ascii8 = 2,
}

impl Line {
    /// ASCII's inter-character timeout unless [`Line::with_char_timeout`] says otherwise:
    /// 1 s, the spec's example (§2.5.2.1).
    pub const ASCII_CHAR_TIMEOUT_MS: u16 = 1000;

    /// An ASCII line for a constant (feature `ascii`): 7 data bits, the spec's default
    /// character format with even parity and one stop bit (7E1); 7O1 and 7N2 are the
    /// other formats it names. Invalid values stop the build, as with [`Line::new`];
    /// [`Line::with_mode`] turns a run-time line into an ASCII one.
    ///
    /// ```
    /// use avr_modbus::{Line, Mode, Parity, StopBits};
    /// const LINE: Line = Line::ascii(9600, Parity::Even, StopBits::One);
    /// assert_eq!((LINE.mode(), LINE.bits_per_char()), (Mode::Ascii, 10));
    /// ```
    pub const fn ascii(baud: u32, parity: Parity, stop_bits: StopBits) -> Self {
        Self::new(baud, parity, stop_bits).with_mode(Mode::Ascii)
    }

    /// The same line in another transmission mode (feature `ascii`): RTU, ASCII with 7 data
    /// bits, or ASCII with 8.
    pub const fn with_mode(self, mode: Mode) -> Self {
        Line { mode, ..self }
    }

    /// The same line with another ASCII inter-character timeout, in milliseconds
    /// (feature `ascii`): a frame inside which the line stays silent that long is dropped
    /// and counted as malformed. 0 waits for ever. Timed to a turn of Timer0 or so (1.024 ms,
    /// 2.048 ms at 8 MHz), counted from the last character.
    pub const fn with_char_timeout(self, milliseconds: u16) -> Self {
        Line { char_timeout: timeout_turns(milliseconds), ..self }
    }

    /// RTU or ASCII (feature `ascii`).
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// ASCII's inter-character timeout in milliseconds, 0 for none (feature `ascii`).
    pub const fn char_timeout_ms(&self) -> u16 {
        self.char_timeout.0
    }

    /// ASCII's inter-character timeout in Timer0 turns ([`TURN_US`]), 0 for none.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    pub(crate) const fn char_timeout_turns(&self) -> u16 {
        self.char_timeout.1
    }

    /// From the USART's receive flag to the end of a character on the line (half a bit, or
    /// one and a half with two stop bits, [`rx_flag_to_end_cycles`]) as a Timer0 deadline:
    /// ASCII's reply waits that long after the LF's flag (feature `ascii`).
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    pub(crate) const fn char_end(&self) -> Deadline {
        self.char_end
    }
}

impl Config {
    /// ASCII's inter-character timeout unless [`Config::with_char_timeout`] says otherwise
    /// ([`Line::ASCII_CHAR_TIMEOUT_MS`]).
    pub const ASCII_CHAR_TIMEOUT_MS: u16 = Line::ASCII_CHAR_TIMEOUT_MS;

    /// An ASCII configuration for a constant (feature `ascii`): the slave `slave_id` on
    /// [`Line::ascii`].
    ///
    /// ```
    /// use avr_modbus::{Config, Mode, Parity, StopBits};
    /// const CONFIG: Config = Config::ascii(1, 9600, Parity::Even, StopBits::One);
    /// assert_eq!((CONFIG.mode(), CONFIG.line().bits_per_char()), (Mode::Ascii, 10));
    /// ```
    pub const fn ascii(slave_id: u8, baud: u32, parity: Parity, stop_bits: StopBits) -> Self {
        Self::new(slave_id, baud, parity, stop_bits).with_mode(Mode::Ascii)
    }

    /// The same settings in another transmission mode ([`Line::with_mode`]).
    pub const fn with_mode(self, mode: Mode) -> Self {
        self.with_line(self.line().with_mode(mode))
    }

    /// The same settings with another ASCII inter-character timeout
    /// ([`Line::with_char_timeout`]).
    pub const fn with_char_timeout(self, milliseconds: u16) -> Self {
        self.with_line(self.line().with_char_timeout(milliseconds))
    }

    /// RTU or ASCII ([`Line::mode`]).
    pub const fn mode(&self) -> Mode {
        self.line().mode
    }
}

/// Timer0 turns ([`TURN_US`]: 1.024 ms, 2.048 ms at 8 MHz) for an ASCII timeout of
/// `milliseconds`, rounded up: the pair kept in [`Line`].
pub(super) const fn timeout_turns(milliseconds: u16) -> (u16, u16) {
    let turns = (milliseconds as u32 * 1000).div_ceil(TURN_US);
    (milliseconds, turns as u16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::timing::CLOCK_HZ;

    #[test]
    fn ascii_timeout_is_whole_timer0_turns_rounded_up() {
        // A turn is 1.024 ms at 16 MHz, 2.048 ms at 8 MHz (AVR_CPU_FREQUENCY_HZ=8000000).
        let turns = |ms| Line::new(9600, Parity::Even, StopBits::One).with_char_timeout(ms).char_timeout_turns();
        let per_turn = TURN_US;
        assert_eq!(u32::from(turns(1000)), (1_000_000u32).div_ceil(per_turn)); // 977 or 489
        assert_eq!(turns(0), 0);
        assert_eq!(turns(1), 1);
        assert_eq!(u32::from(turns(65_535)), (65_535_000u32).div_ceil(per_turn));
        assert_eq!(turns(1000), if CLOCK_HZ == 16_000_000 { 977 } else { 489 });
    }
}
