//! Character times and the silences between and inside frames, Modbus over Serial Line
//! v1.02 §2.5.1.1: T1.5 and T3.5 from the baud rate and the character's bits, fixed above
//! 19 200 bps.

/// Above this rate the spec fixes T1.5 = 750 µs and T3.5 = 1750 µs.
pub const FIXED_TIMES_ABOVE_BAUD: u32 = 19_200;

pub(super) const NS_PER_S: u32 = 1_000_000_000;

/// ⌈n · 10⁹ / d⌉ nanoseconds in 32-bit arithmetic (no 64-bit division on the AVR, where a
/// run-time [`crate::Config::try_new`] computes this): 10⁹ = q·d + r, so
/// n·10⁹/d = n·q + n·r/d, and n·r < n·d stays small for the values used here
/// (n ≤ 84, d ≤ 2 000 000).
const fn ceil_ns(n: u32, d: u32) -> u32 {
    let q = NS_PER_S / d;
    let r = NS_PER_S % d;
    n * q + (n * r).div_ceil(d)
}

/// One character time and the two silences derived from it, in nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CharTimes {
    /// Duration of one character on the wire (start, data, parity, stop bits).
    pub char_ns: u32,
    /// Longest silence allowed between two characters of a frame (T1.5).
    pub t15_ns: u32,
    /// Silence that ends a frame (T3.5).
    pub t35_ns: u32,
}

impl CharTimes {
    /// Times for `baud` bits per second and `bits_per_char` bits per character; rounded
    /// up to the next nanosecond. Above 19200 bps T1.5 and T3.5 are the fixed 750 µs and
    /// 1750 µs. `baud` must be non-zero (a [`crate::Config`] guarantees it).
    pub const fn new(baud: u32, bits_per_char: u32) -> Self {
        let baud = if baud == 0 { 1 } else { baud };
        let char_ns = ceil_ns(bits_per_char, baud);
        let (t15_ns, t35_ns) = if baud > FIXED_TIMES_ABOVE_BAUD {
            (750_000, 1_750_000)
        } else {
            (ceil_ns(3 * bits_per_char, 2 * baud), ceil_ns(7 * bits_per_char, 2 * baud))
        };
        CharTimes { char_ns, t15_ns, t35_ns }
    }

    /// How long after the end of one received character the end of the next may come
    /// before the gap between them exceeded T1.5.
    ///
    /// The USART reports each character at the same point of it (the middle of its first
    /// stop bit, [`rx_flag_to_end_cycles`] before its end), so two reports are as far apart
    /// as the two characters' ends, and the gap on the wire is the time between them minus
    /// one character: this deadline counts from one report to the next as it is.
    pub const fn gap_deadline_ns(&self) -> u32 {
        self.char_ns + self.t15_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Line, Parity, StopBits};

    fn times(baud: u32, parity: Parity, stop: StopBits) -> CharTimes {
        Line::new(baud, parity, stop).char_times()
    }

    #[test]
    fn t15_t35_scale_with_character_time_up_to_19200() {
        // (baud, parity, stop bits, char µs·1000, T1.5 ns, T3.5 ns)
        let table = [
            (1200, Parity::Even, StopBits::One, 9_166_667, 13_750_000, 32_083_334),
            (1200, Parity::None, StopBits::One, 8_333_334, 12_500_000, 29_166_667),
            (9600, Parity::Even, StopBits::One, 1_145_834, 1_718_750, 4_010_417),
            (9600, Parity::None, StopBits::One, 1_041_667, 1_562_500, 3_645_834),
            (9600, Parity::None, StopBits::Two, 1_145_834, 1_718_750, 4_010_417),
            (9600, Parity::Odd, StopBits::One, 1_145_834, 1_718_750, 4_010_417),
            (19_200, Parity::Even, StopBits::One, 572_917, 859_375, 2_005_209),
            (19_200, Parity::None, StopBits::One, 520_834, 781_250, 1_822_917),
            (19_200, Parity::None, StopBits::Two, 572_917, 859_375, 2_005_209),
            (19_200, Parity::Odd, StopBits::One, 572_917, 859_375, 2_005_209),
            (19_200, Parity::Even, StopBits::Two, 625_000, 937_500, 2_187_500),
        ];
        for (baud, parity, stop, char_ns, t15, t35) in table {
            let t = times(baud, parity, stop);
            assert_eq!((t.char_ns, t.t15_ns, t.t35_ns), (char_ns, t15, t35), "{baud} {parity:?} {stop:?}");
        }
    }

    #[test]
    fn above_19200_t15_and_t35_are_fixed() {
        for baud in [19_201, 38_400, 57_600, 115_200, 250_000, 1_000_000] {
            for bits in [10, 11] {
                let t = CharTimes::new(baud, bits);
                assert_eq!((t.t15_ns, t.t35_ns), (750_000, 1_750_000), "{baud}");
            }
        }
        assert_eq!(CharTimes::new(115_200, 10).char_ns, 86_806);
        assert_eq!(CharTimes::new(115_200, 11).char_ns, 95_487);
    }

    #[test]
    fn gap_deadline_is_one_char_plus_t15() {
        let t = times(19_200, Parity::Even, StopBits::One);
        assert_eq!(t.gap_deadline_ns(), 572_917 + 859_375);
    }
}
