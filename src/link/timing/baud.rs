//! The USART's baud-rate divisor (UBRRn, U2Xn) for a rate at the crate's clock, with the
//! datasheet's error bound.

/// USART baud-rate register settings (UBRR0, U2X0) for a rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BaudDivisor {
    /// UBRR0 value (12 bits).
    pub ubrr: u16,
    /// Double-speed mode (U2X0): divides by 8 instead of 16.
    pub double_speed: bool,
}

/// A candidate divisor and its error as an exact fraction `diff / made`: `made` is
/// divider · (UBRR0 + 1) · baud, `diff` the clock minus that (the rate made is
/// clock / (divider · (UBRR0 + 1))). Comparisons cross-multiply in 64 bits: no division.
#[derive(Clone, Copy)]
struct Candidate {
    divisor: BaudDivisor,
    diff: u64,
    made: u64,
}

impl Candidate {
    /// |error| ≤ ppm / 10⁶.
    const fn within(&self, ppm: u64) -> bool {
        self.diff * 1_000_000 <= ppm * self.made
    }

    const fn closer_than(&self, other: &Candidate) -> bool {
        self.diff * other.made < other.diff * self.made
    }
}

impl BaudDivisor {
    /// Largest error accepted: 2.5 % (the serial-line spec asks 1 % on transmit; several
    /// standard rates can't meet that at 16 MHz, see the README's table).
    pub const MAX_ERROR_PPM: i32 = 25_000;
    /// The serial-line spec's transmit tolerance: 1 %.
    pub const SPEC_ERROR_PPM: i32 = 10_000;

    /// Normal speed (16 samples per bit, the more tolerant receiver) whenever its error is
    /// within the spec's 1 %, else whichever of normal and double speed is closer; `None`
    /// if that is more than [`Self::MAX_ERROR_PPM`] off or out of UBRR0's range.
    /// `clock_hz` must be below 2³¹.
    pub const fn new(baud: u32, clock_hz: u32) -> Option<Self> {
        if baud == 0 {
            return None;
        }
        let normal = Self::candidate(baud, clock_hz, 16, false);
        let double = Self::candidate(baud, clock_hz, 8, true);
        let best = match (normal, double) {
            (Some(n), _) if n.within(Self::SPEC_ERROR_PPM as u64) => Some(n),
            (Some(n), Some(d)) => {
                if d.closer_than(&n) {
                    Some(d)
                } else {
                    Some(n)
                }
            }
            (Some(n), None) => Some(n),
            (None, d) => d,
        };
        match best {
            Some(b) if b.within(Self::MAX_ERROR_PPM as u64) => Some(b.divisor),
            _ => None,
        }
    }

    /// CPU cycles per bit: 16 · (UBRRn + 1), or 8 · (UBRRn + 1) in double-speed mode.
    pub const fn bit_cycles(&self) -> u32 {
        let double_speed = (self.ubrr as u32 + 1) * 8;
        if self.double_speed {
            double_speed
        } else {
            2 * double_speed
        }
    }

    const fn candidate(baud: u32, clock_hz: u32, divider: u32, double_speed: bool) -> Option<Candidate> {
        let denominator = match divider.checked_mul(baud) {
            Some(d) if d <= u32::MAX / 2 => d,
            _ => return None,
        };
        // Nearest integer to clock / (divider · baud), minus one.
        let rounded = match (2 * clock_hz + denominator).checked_div(2 * denominator) {
            Some(rounded) => rounded,
            None => return None,
        };
        if rounded == 0 || rounded > 4096 {
            return None;
        }
        let made = denominator as u64 * rounded as u64;
        let diff = (clock_hz as u64).abs_diff(made);
        Some(Candidate { divisor: BaudDivisor { ubrr: (rounded - 1) as u16, double_speed }, diff, made })
    }

    /// The rate this divisor makes minus `baud`, in parts per million of `baud`
    /// (truncated toward zero): for tables and logs, not needed by the firmware.
    pub const fn error_ppm(&self, baud: u32, clock_hz: u32) -> i32 {
        let divider: u64 = if self.double_speed { 8 } else { 16 };
        let actual_x1e6 = clock_hz as u64 * 1_000_000 / (divider * (self.ubrr as u64 + 1));
        ((actual_x1e6 as i64 - baud as i64 * 1_000_000) / baud as i64) as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MHZ16: u32 = 16_000_000;
    const MHZ8: u32 = 8_000_000;

    #[test]
    fn baud_divisors_match_the_datasheet_table() {
        // (baud, UBRR0, U2X0, error in ppm): ATmega328P datasheet table 20-7 at 16 MHz.
        let table = [
            (1200, 832, false, 400),
            (2400, 416, false, -799),
            (4800, 207, false, 1_602),
            (9600, 103, false, 1_602),
            (19_200, 51, false, 1_602),
            (38_400, 25, false, 1_602),
            (57_600, 34, true, -7_936),
            (115_200, 16, true, 21_241),
            (250_000, 3, false, 0),
            (500_000, 1, false, 0),
            (1_000_000, 0, false, 0),
        ];
        check_divisors(MHZ16, &table);
    }

    /// Each (baud, UBRR0, U2X0, error in ppm) of `table` at `clock_hz`.
    fn check_divisors(clock_hz: u32, table: &[(u32, u16, bool, i32)]) {
        for &(baud, ubrr, double_speed, error_ppm) in table {
            let d = BaudDivisor::new(baud, clock_hz).unwrap();
            let found = (d.ubrr, d.double_speed, d.error_ppm(baud, clock_hz));
            assert_eq!(found, (ubrr, double_speed, error_ppm), "{baud} at {clock_hz} Hz");
        }
    }

    #[test]
    fn past_1_percent_the_divisor_closer_in_ppm_wins_and_a_tie_keeps_normal_speed() {
        // 40 405 Bd: 40 000 at normal speed (UBRR 24, −1.00 %), 40 816 at double (UBRR 48,
        // +1.02 %): normal is closer.
        let d = BaudDivisor::new(40_405, MHZ16).unwrap();
        assert_eq!((d.ubrr, d.double_speed), (24, false));
        // 41 240 Bd: UBRR 23 at normal speed and 47 at double make the same 41 667: normal
        // speed, the more tolerant receiver.
        let d = BaudDivisor::new(41_240, MHZ16).unwrap();
        assert_eq!((d.ubrr, d.double_speed), (23, false));
    }

    #[test]
    fn ubrr_holds_12_bits() {
        // 300 Bd from a 19.6608 MHz crystal: 4096 × 16 cycles a bit, UBRR 4095, the largest.
        let d = BaudDivisor::new(300, 19_660_800).unwrap();
        assert_eq!((d.ubrr, d.double_speed, d.error_ppm(300, 19_660_800)), (4095, false, 0));
        // 244 Bd at 16 MHz would take UBRR 4097 (0.04 % off): too slow for the register.
        assert_eq!(BaudDivisor::new(244, MHZ16), None);
    }

    #[test]
    fn baud_with_more_than_2_5_percent_error_is_refused() {
        assert_eq!(BaudDivisor::new(300_000, MHZ16), None);
        assert_eq!(BaudDivisor::new(230_400, MHZ16), None);
        assert_eq!(BaudDivisor::new(0, MHZ16), None);
    }

    #[test]
    fn baud_divisors_at_8_mhz_match_the_datasheet_table() {
        // (baud, UBRR0, U2X0, error in ppm): ATmega328P datasheet table 20-5 at 8 MHz; 57 600
        // only at double speed, 115 200 not at all (−3.5 %).
        let table = [
            (1200, 416, false, -799),
            (9600, 51, false, 1_602),
            (14_400, 34, false, -7_936),
            (19_200, 25, false, 1_602),
            (28_800, 34, true, -7_936),
            (38_400, 12, false, 1_602),
            (57_600, 16, true, 21_241),
            (76_800, 12, true, 1_602),
            (250_000, 1, false, 0),
            (1_000_000, 0, true, 0),
        ];
        check_divisors(MHZ8, &table);
        assert_eq!(BaudDivisor::new(115_200, MHZ8), None);
        assert_eq!(BaudDivisor::new(230_400, MHZ8), None);
    }
}
