//! Serial-line configuration, Modbus over Serial Line v1.02 §2.5.1 (character format) and
//! §2.2 (addresses).
//!
//! A configuration is plain data. [`Config::new`] is a `const fn` meant for constants: a
//! bad value there stops the build. [`Config::try_new`] is for values read at run time
//! (EEPROM, jumpers) and returns an error instead.

use crate::error::Error;
#[cfg(feature = "ascii")]
use crate::link::timing::Deadline;
use crate::link::timing::{rx_flag_to_end_cycles, BaudDivisor, CharTimes, TimerPlan, CLOCK_HZ};
pub use crate::protocol::SlaveId;

#[cfg(feature = "ascii")]
mod ascii;
#[cfg(feature = "ascii")]
use ascii::timeout_turns;
#[cfg(feature = "ascii")]
pub use ascii::Mode;

/// Parity of each character.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit (the spec then asks for 2 stop bits; 1 is common in the field).
    None = 0,
    /// Even parity: the spec's required default.
    Even = 2,
    /// Odd parity.
    Odd = 1,
}

/// Stop bits of each character.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopBits {
    /// One stop bit.
    One,
    /// Two stop bits.
    Two,
}

/// The line's settings, Modbus over Serial Line v1.02 §2.5.1: baud rate, parity, stop bits
/// (and, with feature `ascii`, the transmission mode), with the USART divisor and the
/// Timer0 plan worked out from them in a `const`: the firmware does no division at run
/// time. What a master starts with (`Master::start`); a slave's [`Config`] is one
/// of these and its address.
///
/// ```
/// use avr_modbus::{Line, Parity, StopBits};
/// const LINE: Line = Line::new(9600, Parity::None, StopBits::Two);
/// assert_eq!(LINE.bits_per_char(), 11);
/// assert_eq!(Line::DEFAULT.baud(), 19_200);
/// ```
///
/// ```compile_fail
/// use avr_modbus::{Line, Parity, StopBits};
/// const LINE: Line = Line::new(300, Parity::None, StopBits::Two);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line {
    baud: u32,
    parity: Parity,
    stop_bits: StopBits,
    divisor: BaudDivisor,
    timer_plan: TimerPlan,
    /// RTU or ASCII (feature `ascii`).
    #[cfg(feature = "ascii")]
    mode: Mode,
    /// ASCII's inter-character timeout in milliseconds (0: none), and in Timer0 turns
    /// ([`TURN_US`] each), as the compare interrupt counts it.
    #[cfg(feature = "ascii")]
    char_timeout: (u16, u16),
    /// ASCII: from a character's receive flag to its end on the line, as a Timer0 deadline
    /// (the reply waits for the LF to leave the line).
    #[cfg(feature = "ascii")]
    char_end: Deadline,
}

impl Line {
    /// Slowest supported rate.
    pub const MIN_BAUD: u32 = 1200;
    /// Fastest supported rate (16 MHz / 16; at 8 MHz with double speed).
    pub const MAX_BAUD: u32 = 1_000_000;

    /// The serial-line spec's default: 19200 bps, 8 data bits, even parity, 1 stop bit.
    pub const DEFAULT: Line = Line::new(19_200, Parity::Even, StopBits::One);

    /// Line settings for a constant: invalid values stop the build. Called outside a
    /// constant it would panic on bad input: use [`Line::try_new`] for run-time values.
    pub const fn new(baud: u32, parity: Parity, stop_bits: StopBits) -> Self {
        match Self::try_new(baud, parity, stop_bits) {
            Ok(line) => line,
            Err(e) => panic!("{}", e.message()),
        }
    }

    /// Line settings from run-time values: [`Error::Baud`] outside
    /// [`Line::MIN_BAUD`]–[`Line::MAX_BAUD`], [`Error::BaudError`] for a rate the USART
    /// can't make within 2.5 % at the CPU clock.
    pub const fn try_new(baud: u32, parity: Parity, stop_bits: StopBits) -> Result<Self, Error> {
        if baud < Self::MIN_BAUD || baud > Self::MAX_BAUD {
            return Err(Error::Baud);
        }
        let divisor = match BaudDivisor::new(baud, CLOCK_HZ) {
            Some(divisor) => divisor,
            None => return Err(Error::BaudError),
        };
        let times = CharTimes::new(baud, bits_per_char(8, parity, stop_bits));
        let flag_to_end = rx_flag_to_end_cycles(divisor, matches!(stop_bits, StopBits::Two));
        let timer_plan = TimerPlan::new(times, CLOCK_HZ, flag_to_end);
        Ok(Line {
            baud,
            parity,
            stop_bits,
            divisor,
            timer_plan,
            #[cfg(feature = "ascii")]
            mode: Mode::Rtu,
            #[cfg(feature = "ascii")]
            char_timeout: timeout_turns(Self::ASCII_CHAR_TIMEOUT_MS),
            #[cfg(feature = "ascii")]
            char_end: Deadline::after_flag(flag_to_end),
        })
    }

    /// Data bits of each character: 8, or 7 in ASCII mode.
    pub const fn data_bits(&self) -> u32 {
        #[cfg(feature = "ascii")]
        if matches!(self.mode, Mode::Ascii) {
            return 7;
        }
        8
    }

    /// Bits per second.
    pub const fn baud(&self) -> u32 {
        self.baud
    }

    /// Parity bit.
    pub const fn parity(&self) -> Parity {
        self.parity
    }

    /// Stop bits.
    pub const fn stop_bits(&self) -> StopBits {
        self.stop_bits
    }

    /// The USART's rate settings.
    pub const fn divisor(&self) -> BaudDivisor {
        self.divisor
    }

    /// Timer0 settings of the silence detector.
    pub const fn timer_plan(&self) -> TimerPlan {
        self.timer_plan
    }

    /// Bits on the wire per character: start, data bits (8, or 7 for ASCII), parity if
    /// any, stop bits.
    pub const fn bits_per_char(&self) -> u32 {
        bits_per_char(self.data_bits(), self.parity, self.stop_bits)
    }

    /// Character time and the T1.5 / T3.5 silences of this line.
    pub const fn char_times(&self) -> CharTimes {
        CharTimes::new(self.baud, self.bits_per_char())
    }
}

impl Default for Line {
    /// [`Line::DEFAULT`]: 19200 bps, 8E1.
    fn default() -> Self {
        Line::DEFAULT
    }
}

/// A slave's configuration: its address and its [`Line`] (and, with feature
/// `reply-delay`, how long it waits before it answers). Built in a `const`, the firmware
/// does no division at run time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    slave_id: SlaveId,
    line: Line,
    /// The reply delay after T3.5 in Timer0 ticks (feature `reply-delay`; 0: none).
    #[cfg(feature = "reply-delay")]
    reply_delay: u16,
}

impl Config {
    /// Slowest supported rate ([`Line::MIN_BAUD`]).
    pub const MIN_BAUD: u32 = Line::MIN_BAUD;
    /// Fastest supported rate ([`Line::MAX_BAUD`]).
    pub const MAX_BAUD: u32 = Line::MAX_BAUD;

    /// The serial-line spec's default line ([`Line::DEFAULT`]: 19200 bps, 8E1) for
    /// `slave_id`.
    pub const fn default_for(slave_id: SlaveId) -> Self {
        Self::on(slave_id, Line::DEFAULT)
    }

    /// The slave `slave_id` on `line`.
    pub const fn on(slave_id: SlaveId, line: Line) -> Self {
        Config {
            slave_id,
            line,
            #[cfg(feature = "reply-delay")]
            reply_delay: 0,
        }
    }

    /// A configuration for a constant: invalid values stop the build.
    ///
    /// ```
    /// use avr_modbus::{Config, Parity, StopBits};
    /// const CONFIG: Config = Config::new(17, 9600, Parity::None, StopBits::Two);
    /// assert_eq!(CONFIG.slave_id().get(), 17);
    /// ```
    ///
    /// ```compile_fail
    /// use avr_modbus::{Config, Parity, StopBits};
    /// const CONFIG: Config = Config::new(248, 9600, Parity::None, StopBits::Two);
    /// ```
    ///
    /// Called outside a constant it would panic on bad input: use [`Config::try_new`]
    /// for run-time values.
    pub const fn new(slave_id: u8, baud: u32, parity: Parity, stop_bits: StopBits) -> Self {
        match Self::try_new(slave_id, baud, parity, stop_bits) {
            Ok(config) => config,
            Err(e) => panic!("{}", e.message()),
        }
    }

    /// A configuration from run-time values.
    pub const fn try_new(slave_id: u8, baud: u32, parity: Parity, stop_bits: StopBits) -> Result<Self, Error> {
        let slave_id = match SlaveId::try_new(slave_id) {
            Ok(id) => id,
            Err(e) => return Err(e),
        };
        match Line::try_new(baud, parity, stop_bits) {
            Ok(line) => Ok(Self::on(slave_id, line)),
            Err(e) => Err(e),
        }
    }

    /// The longest reply delay, in microseconds: 65 535 Timer0 ticks (262 ms at 16 MHz).
    #[cfg(feature = "reply-delay")]
    pub const MAX_REPLY_DELAY_US: u32 = 65_535 * 1000 / crate::link::timing::TICKS_PER_MS;

    /// The slave waits `microseconds` after T3.5 before it answers (feature
    /// `reply-delay`): for a master whose USB–RS-485 adapter or transceiver turns around
    /// slowly and loses the first bytes of a reply that comes at once. Rounded to Timer0's
    /// ticks (4 µs, 8 µs at 8 MHz), at most [`Config::MAX_REPLY_DELAY_US`] (more is that);
    /// RTU only (an ASCII reply waits for nothing). 0, the default, is none.
    #[cfg(feature = "reply-delay")]
    pub const fn with_reply_delay(mut self, microseconds: u32) -> Self {
        let us = if microseconds > Self::MAX_REPLY_DELAY_US { Self::MAX_REPLY_DELAY_US } else { microseconds };
        self.reply_delay = ((us * crate::link::timing::TICKS_PER_MS + 500) / 1000) as u16;
        self
    }

    /// The reply delay in microseconds, as Timer0 ticks make it (feature `reply-delay`).
    #[cfg(feature = "reply-delay")]
    pub const fn reply_delay_us(&self) -> u32 {
        self.reply_delay as u32 * 1000 / crate::link::timing::TICKS_PER_MS
    }

    /// The reply delay in Timer0 ticks (feature `reply-delay`): 0 in ASCII framing, whose
    /// reply waits for nothing.
    #[cfg(feature = "reply-delay")]
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    pub(crate) const fn reply_delay_ticks(&self) -> u16 {
        #[cfg(feature = "ascii")]
        if !matches!(self.line.mode, Mode::Rtu) {
            return 0;
        }
        self.reply_delay
    }

    /// The same settings for another slave address.
    pub const fn with_slave_id(self, slave_id: SlaveId) -> Self {
        Config { slave_id, ..self }
    }

    /// The same slave on another line.
    pub const fn with_line(self, line: Line) -> Self {
        Config { line, ..self }
    }

    /// This slave's address.
    pub const fn slave_id(&self) -> SlaveId {
        self.slave_id
    }

    /// The line's settings.
    pub const fn line(&self) -> &Line {
        &self.line
    }

    /// Bits per second ([`Line::baud`]).
    pub const fn baud(&self) -> u32 {
        self.line.baud
    }

    /// Parity bit ([`Line::parity`]).
    pub const fn parity(&self) -> Parity {
        self.line.parity
    }

    /// Stop bits ([`Line::stop_bits`]).
    pub const fn stop_bits(&self) -> StopBits {
        self.line.stop_bits
    }
}

const fn bits_per_char(data_bits: u32, parity: Parity, stop_bits: StopBits) -> u32 {
    let parity = match parity {
        Parity::None => 0,
        Parity::Even | Parity::Odd => 1,
    };
    let stop = match stop_bits {
        StopBits::One => 1,
        StopBits::Two => 2,
    };
    1 + data_bits + parity + stop
}

/// The settings as a firmware prints them: `Config { slave_id: 1, baud: 19200, .. }`.
#[cfg(feature = "ufmt")]
impl ufmt::uDebug for Config {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        f.debug_struct("Config")?
            .field("slave_id", &self.slave_id.get())?
            .field("baud", &self.line.baud)?
            .field("parity", &self.line.parity)?
            .field("stop_bits", &self.line.stop_bits)?
            .finish()
    }
}

/// The settings as a firmware prints them: `Line { baud: 19200, parity: Even, .. }`.
#[cfg(feature = "ufmt")]
impl ufmt::uDebug for Line {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        f.debug_struct("Line")?
            .field("baud", &self.baud)?
            .field("parity", &self.parity)?
            .field("stop_bits", &self.stop_bits)?
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_time_baud_outside_range_is_an_error() {
        assert_eq!(Config::try_new(1, 1199, Parity::Even, StopBits::One), Err(Error::Baud));
        assert_eq!(Config::try_new(1, 1_000_001, Parity::Even, StopBits::One), Err(Error::Baud));
        assert!(Config::try_new(1, 1200, Parity::Even, StopBits::One).is_ok());
        // 115 200 is 3.5 % off at 8 MHz (AVR_CPU_FREQUENCY_HZ=8000000), beyond what is accepted.
        let at_115200 = Config::try_new(1, 115_200, Parity::None, StopBits::One);
        assert_eq!(at_115200.is_ok(), CLOCK_HZ == 16_000_000, "{at_115200:?}");
        assert_eq!(Config::try_new(1, 230_400, Parity::None, StopBits::One), Err(Error::BaudError));
    }

    #[test]
    fn with_slave_id_changes_the_slave_id_only() {
        let c = Config::new(5, 9600, Parity::Odd, StopBits::Two);
        let moved = c.with_slave_id(SlaveId::new(247));
        assert_eq!(moved.slave_id().get(), 247);
        assert_eq!((moved.baud(), moved.parity(), moved.stop_bits()), (c.baud(), c.parity(), c.stop_bits()));
    }

    #[test]
    fn default_is_19200_8e1() {
        let c = Config::default_for(SlaveId::new(5));
        assert_eq!((c.baud(), c.parity(), c.stop_bits()), (19_200, Parity::Even, StopBits::One));
        assert_eq!(c.line().bits_per_char(), 11);
    }

    #[test]
    fn bits_per_char_counts_parity_and_stop_bits() {
        let bits = |p, s| Line::new(9600, p, s).bits_per_char();
        assert_eq!(bits(Parity::None, StopBits::One), 10);
        assert_eq!(bits(Parity::None, StopBits::Two), 11);
        assert_eq!(bits(Parity::Odd, StopBits::One), 11);
        assert_eq!(bits(Parity::Even, StopBits::Two), 12);
    }

    #[cfg(feature = "reply-delay")]
    #[test]
    fn a_reply_delay_above_the_longest_is_the_longest() {
        let delay = |us| Config::new(1, 9600, Parity::Even, StopBits::One).with_reply_delay(us).reply_delay_us();
        let max = Config::MAX_REPLY_DELAY_US;
        assert_eq!(delay(max), max);
        for us in [max + 1, max + 100, 1_000_000, u32::MAX / 1000] {
            assert_eq!(delay(us), max, "{us} µs");
        }
    }

    #[cfg(feature = "reply-delay")]
    #[test]
    fn the_reply_delay_is_counted_in_timer0_ticks_and_is_none_in_ascii() {
        use crate::link::timing::TICKS_PER_MS;
        let rtu = Config::new(1, 9600, Parity::Even, StopBits::One);
        assert_eq!(rtu.reply_delay_ticks(), 0);
        assert_eq!(u32::from(rtu.with_reply_delay(3_000).reply_delay_ticks()), 3 * TICKS_PER_MS);
        #[cfg(feature = "ascii")]
        for mode in [Mode::Ascii, Mode::Ascii8] {
            assert_eq!(rtu.with_reply_delay(3_000).with_mode(mode).reply_delay_ticks(), 0, "{mode:?}");
        }
    }
}
