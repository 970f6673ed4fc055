//! Serial line settings on both ends of the pseudo-terminal: what the master asked for (its
//! termios) against what the firmware configured (its USART's registers), and what a mismatch does
//! to the bytes on a real wire.
//!
//! A Linux pty keeps the baud rate, CSTOPB, PARODD and CMSPAR a master sets, but forces CS8 and
//! clears PARENB (`pty_set_termios` in drivers/tty/pty.c). So wrong baud rates, stop bits and odd
//! or mark/space parity are caught, while "none" and "even" parity look the same, and so do 7
//! and 8 data bits: a Modbus ASCII master's 7E1 reaches the pty as 8 data bits with PARENB
//! cleared, the same ten bits a character as 8N1. Bytes pass unchanged (ASCII characters have
//! bit 7 clear).

use std::fmt;

use nix::libc;
use nix::sys::termios::ControlFlags;
use uno_sim::{LineError, Parity as UnoParity, SerialConfig, F_CPU};

/// Largest baud-rate difference a real UART pair tolerates here, as in the firmware's own
/// configuration check (115200 on the Uno is +2.12 %).
const BAUD_TOLERANCE: f64 = 0.025;

/// Rates printed by name when the USART's rate is within [`BAUD_TOLERANCE`] of one.
const STANDARD_BAUDS: [u32; 16] =
    [300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 38400, 57600, 76800, 115200, 230400, 250000, 500000, 1000000];

/// Parity as a master can set it (termios knows mark and space parity too).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit.
    None,
    /// No parity or even parity: what a pty shows for both (PARENB cleared, PARODD clear).
    NoneOrEven,
    /// Even parity.
    Even,
    /// Odd parity.
    Odd,
    /// Parity bit always 1 (CMSPAR with PARODD).
    Mark,
    /// Parity bit always 0 (CMSPAR).
    Space,
}

/// Baud rate and frame format of one end of the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Settings {
    /// Bits per second; 0 if unknown (a custom rate set through `BOTHER`, or B0).
    pub baud: u32,
    /// Data bits, 5-9.
    pub data_bits: u8,
    /// Parity.
    pub parity: Parity,
    /// Stop bits, 1 or 2.
    pub stop_bits: u8,
}

impl Settings {
    /// Decodes a termios `c_cflag` (Linux encoding of the baud rate).
    pub fn from_cflag(cflag: ControlFlags) -> Settings {
        let data_bits = match cflag & ControlFlags::CSIZE {
            ControlFlags::CS5 => 5,
            ControlFlags::CS6 => 6,
            ControlFlags::CS7 => 7,
            _ => 8,
        };
        let parity = match (
            cflag.contains(ControlFlags::PARENB),
            cflag.contains(ControlFlags::CMSPAR),
            cflag.contains(ControlFlags::PARODD),
        ) {
            (_, true, true) => Parity::Mark,
            (_, true, false) => Parity::Space,
            (_, false, true) => Parity::Odd,
            (true, false, false) => Parity::Even,
            (false, false, false) => Parity::NoneOrEven,
        };
        let stop_bits = if cflag.contains(ControlFlags::CSTOPB) { 2 } else { 1 };
        Settings { baud: baud_of(cflag.bits() & libc::CBAUD), data_bits, parity, stop_bits }
    }

    /// What the firmware configured, its baud rate rounded to the standard rate it approximates.
    pub fn of_firmware(cfg: &SerialConfig) -> Settings {
        let actual = cfg.baud();
        let baud = STANDARD_BAUDS
            .into_iter()
            .find(|&b| ((actual - f64::from(b)) / f64::from(b)).abs() <= BAUD_TOLERANCE)
            .unwrap_or(actual.round() as u32);
        let parity = match cfg.parity {
            UnoParity::None => Parity::None,
            UnoParity::Even => Parity::Even,
            UnoParity::Odd => Parity::Odd,
        };
        Settings { baud, data_bits: cfg.data_bits, parity, stop_bits: cfg.stop_bits }
    }

    /// Cycles of the simulated CPU one character takes at these settings (0 if the rate is unknown).
    pub fn char_cycles(&self) -> u64 {
        let parity_bit = !matches!(self.parity, Parity::None | Parity::NoneOrEven);
        let bits = 1 + u64::from(self.data_bits) + u64::from(parity_bit) + u64::from(self.stop_bits);
        (bits * F_CPU).checked_div(u64::from(self.baud)).unwrap_or(0)
    }
}

impl fmt::Display for Settings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (d, s) = (self.data_bits, self.stop_bits);
        match self.baud {
            0 => write!(f, "(custom baud)"),
            baud => write!(f, "{baud}"),
        }?;
        match self.parity {
            Parity::None => write!(f, " {d}N{s}"),
            Parity::NoneOrEven => write!(f, " {d}N{s} or {d}E{s}"),
            Parity::Even => write!(f, " {d}E{s}"),
            Parity::Odd => write!(f, " {d}O{s}"),
            Parity::Mark => write!(f, " {d}M{s}"),
            Parity::Space => write!(f, " {d}S{s}"),
        }
    }
}

/// How the firmware receives a byte the master sent with `master` settings while its USART runs
/// `firmware`: `None` if they agree; a parity error if only the parity differs; otherwise (baud
/// rate, data or stop bits) a framing error, the stop bit sampled in the wrong place.
pub fn receive_error(master: &Settings, firmware: &SerialConfig) -> Option<LineError> {
    let fw = Settings::of_firmware(firmware);
    let baud_ok = master.baud > 0
        && ((firmware.baud() - f64::from(master.baud)) / f64::from(master.baud)).abs() <= BAUD_TOLERANCE;
    // A pty forces CS8: 8 data bits from the master may have been 7.
    let data_bits_ok = master.data_bits == fw.data_bits || (master.data_bits == 8 && fw.data_bits == 7);
    if !baud_ok || !data_bits_ok || master.stop_bits != fw.stop_bits {
        Some(LineError::Framing)
    } else if !(master.parity == fw.parity
        || master.parity == Parity::NoneOrEven && matches!(fw.parity, Parity::None | Parity::Even))
    {
        Some(LineError::Parity)
    } else {
        None
    }
}

/// The rate of a termios `CBAUD` code (Linux), 0 for B0, `BOTHER` or anything unknown.
fn baud_of(code: libc::tcflag_t) -> u32 {
    const TABLE: [(libc::tcflag_t, u32); 24] = [
        (libc::B50, 50),
        (libc::B75, 75),
        (libc::B110, 110),
        (libc::B134, 134),
        (libc::B150, 150),
        (libc::B200, 200),
        (libc::B300, 300),
        (libc::B600, 600),
        (libc::B1200, 1200),
        (libc::B1800, 1800),
        (libc::B2400, 2400),
        (libc::B4800, 4800),
        (libc::B9600, 9600),
        (libc::B19200, 19200),
        (libc::B38400, 38400),
        (libc::B57600, 57600),
        (libc::B115200, 115200),
        (libc::B230400, 230400),
        (libc::B460800, 460800),
        (libc::B500000, 500000),
        (libc::B576000, 576000),
        (libc::B921600, 921600),
        (libc::B1000000, 1000000),
        (libc::B2000000, 2000000),
    ];
    TABLE.iter().find(|(c, _)| *c == code).map_or(0, |&(_, baud)| baud)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// UCSR0C for 8 data bits with the given UPM0 (parity) and USBS0 (stop) bits.
    fn firmware(ubrr: u16, u2x: bool, upm: u8, two_stop: bool) -> SerialConfig {
        let ucsr0c = 0b110 | (upm << 4) | if two_stop { 0x08 } else { 0 };
        SerialConfig::from_registers(if u2x { 0x02 } else { 0 }, 0x18, ucsr0c, ubrr as u8, (ubrr >> 8) as u8)
    }

    fn cflag(baud: libc::tcflag_t, extra: ControlFlags) -> ControlFlags {
        ControlFlags::from_bits_retain(baud) | ControlFlags::CS8 | ControlFlags::CREAD | extra
    }

    #[test]
    fn termios_19200_8e1_is_decoded() {
        let s = Settings::from_cflag(cflag(libc::B19200, ControlFlags::PARENB));
        assert_eq!(s, Settings { baud: 19200, data_bits: 8, parity: Parity::Even, stop_bits: 1 });
        assert_eq!(s.to_string(), "19200 8E1");
    }

    #[test]
    fn pty_without_parenb_is_none_or_even_and_matches_both() {
        let s = Settings::from_cflag(cflag(libc::B19200, ControlFlags::empty()));
        assert_eq!(s.to_string(), "19200 8N1 or 8E1");
        assert_eq!(receive_error(&s, &firmware(51, false, 2, false)), None);
        assert_eq!(receive_error(&s, &firmware(51, false, 0, false)), None);
        assert_eq!(receive_error(&s, &firmware(51, false, 3, false)), Some(LineError::Parity));
    }

    #[test]
    fn termios_9600_8o2_and_mark_parity_are_decoded() {
        let odd = Settings::from_cflag(cflag(
            libc::B9600,
            ControlFlags::PARENB | ControlFlags::PARODD | ControlFlags::CSTOPB,
        ));
        assert_eq!(odd.to_string(), "9600 8O2");
        let mark = Settings::from_cflag(cflag(
            libc::B9600,
            ControlFlags::PARENB | ControlFlags::PARODD | ControlFlags::CMSPAR,
        ));
        assert_eq!(mark.parity, Parity::Mark);
    }

    #[test]
    fn custom_baud_is_unknown_and_never_matches() {
        let s = Settings::from_cflag(cflag(libc::BOTHER, ControlFlags::PARENB));
        assert_eq!(s.baud, 0);
        assert_eq!(receive_error(&s, &firmware(51, false, 2, false)), Some(LineError::Framing));
    }

    #[test]
    fn firmware_115200_with_u2x_is_named_115200_and_accepted() {
        let fw = firmware(16, true, 2, false); // 117647 bps, +2.12 %
        assert_eq!(Settings::of_firmware(&fw).to_string(), "115200 8E1");
        let master = Settings::from_cflag(cflag(libc::B115200, ControlFlags::PARENB));
        assert_eq!(receive_error(&master, &fw), None);
    }

    #[test]
    fn wrong_parity_is_a_parity_error_wrong_baud_or_stop_bits_a_framing_error() {
        let fw = firmware(51, false, 2, false); // 19200 8E1
        let odd = Settings::from_cflag(cflag(libc::B19200, ControlFlags::PARODD));
        assert_eq!(receive_error(&odd, &fw), Some(LineError::Parity));
        let none = Settings { parity: Parity::None, ..odd };
        assert_eq!(receive_error(&none, &fw), Some(LineError::Parity));
        let slow = Settings::from_cflag(cflag(libc::B9600, ControlFlags::PARENB));
        assert_eq!(receive_error(&slow, &fw), Some(LineError::Framing));
        let two_stop = Settings::from_cflag(cflag(libc::B19200, ControlFlags::PARENB | ControlFlags::CSTOPB));
        assert_eq!(receive_error(&two_stop, &fw), Some(LineError::Framing));
    }

    #[test]
    fn a_seven_bit_firmware_takes_what_a_pty_shows_of_a_7e1_master() {
        // UCSZ01:0 = 10: 7 data bits, even parity (ASCII's 7E1 at 9600).
        let fw = SerialConfig::from_registers(0, 0x18, 0b100 | (2 << 4), 103, 0);
        assert_eq!(Settings::of_firmware(&fw).to_string(), "9600 7E1");
        // The pty shows 8 data bits and no PARENB whatever the master set.
        let master = Settings::from_cflag(cflag(libc::B9600, ControlFlags::empty()));
        assert_eq!(receive_error(&master, &fw), None);
        // Ten bits a character either way.
        assert_eq!((master.char_cycles(), fw.char_bits()), (10 * 16_000_000 / 9600, 10));
        // A master with two stop bits or at another rate is still caught.
        let two_stop = Settings::from_cflag(cflag(libc::B9600, ControlFlags::CSTOPB));
        assert_eq!(receive_error(&two_stop, &fw), Some(LineError::Framing));
    }

    #[test]
    fn character_time_counts_start_parity_and_stop_bits() {
        let s = Settings { baud: 19200, data_bits: 8, parity: Parity::Even, stop_bits: 1 };
        assert_eq!(s.char_cycles(), 11 * 16_000_000 / 19200);
    }
}
