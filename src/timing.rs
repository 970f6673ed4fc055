//! Character times and silences, Modbus over Serial Line v1.02 §2.5.1.1 (T1.5, T3.5),
//! and the ATmega328P arithmetic that turns them into USART and Timer0 settings.
//!
//! Everything here is `const fn` math: the AVR layer only copies the results into
//! registers, and the host tests check the results over a table of configurations.

/// The Uno's CPU clock.
pub const CLOCK_HZ: u32 = 16_000_000;

/// Above this rate the spec fixes T1.5 = 750 µs and T3.5 = 1750 µs.
pub const FIXED_TIMES_ABOVE_BAUD: u32 = 19_200;

const NS_PER_S: u32 = 1_000_000_000;

/// A lower bound of the time from a character's stop bit to the Timer0 restart in the
/// receive interrupt (interrupt response and handler prologue, about 34 cycles in the
/// release build): the deadlines count from the restart, so they are shortened by this.
pub const RX_RESTART_LATENCY_NS: u32 = 2_000;

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
    /// The USART reports a character when its stop bit ends, one character time after
    /// its start bit began, so the gap on the wire is the time between two reports minus
    /// one character.
    pub const fn gap_deadline_ns(&self) -> u32 {
        self.char_ns + self.t15_ns
    }
}

/// Timer0 clock divider (TCCR0B CS02:0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prescaler {
    /// clk/1 (CS0 = 0b001).
    Div1,
    /// clk/8 (CS0 = 0b010).
    Div8,
    /// clk/64 (CS0 = 0b011).
    Div64,
    /// clk/256 (CS0 = 0b100).
    Div256,
    /// clk/1024 (CS0 = 0b101).
    Div1024,
}

impl Prescaler {
    const ALL: [Prescaler; 5] =
        [Prescaler::Div1, Prescaler::Div8, Prescaler::Div64, Prescaler::Div256, Prescaler::Div1024];

    /// The division factor.
    pub const fn divisor(self) -> u32 {
        match self {
            Prescaler::Div1 => 1,
            Prescaler::Div8 => 8,
            Prescaler::Div64 => 64,
            Prescaler::Div256 => 256,
            Prescaler::Div1024 => 1024,
        }
    }

    /// The clock-select bits CS02:0 of TCCR0B.
    pub const fn cs_bits(self) -> u8 {
        match self {
            Prescaler::Div1 => 0b001,
            Prescaler::Div8 => 0b010,
            Prescaler::Div64 => 0b011,
            Prescaler::Div256 => 0b100,
            Prescaler::Div1024 => 0b101,
        }
    }
}

/// A Timer0 deadline: after `wraps` full turns of the 8-bit counter, the compare match
/// at `ocr` is the one that counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Deadline {
    /// Compare value (OCR0A or OCR0B); never 0, so a match can't coincide with a restart.
    pub ocr: u8,
    /// Matches to let pass before the one that counts.
    pub wraps: u8,
}

impl Deadline {
    /// Timer clocks from a restart (TCNT0 = 0) to the one that raises the compare flag
    /// that counts: the flag rises on the clock after TCNT0 reached OCR0x (datasheet
    /// §15.7), so one more than the count.
    pub const fn ticks(self) -> u32 {
        self.wraps as u32 * 256 + self.ocr as u32 + 1
    }
}

/// Timer0 settings for the frame detector: a deadline for the inter-character gap
/// ([`CharTimes::gap_deadline_ns`]) and one for the end of frame (T3.5), both counted
/// from the end of the last received character.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimerPlan {
    /// Clock divider.
    pub prescaler: Prescaler,
    /// Compare A: a character reported after this had a gap longer than T1.5.
    pub gap: Deadline,
    /// Compare B: T3.5 of silence, the frame is complete.
    pub end: Deadline,
}

impl TimerPlan {
    /// The longest deadline the plan allows, in ticks: eight turns of the counter (each
    /// extra turn costs one short compare interrupt per deadline).
    const MAX_TICKS: u64 = 2048;

    /// Picks the finest prescaler that reaches T3.5 within eight counter turns.
    ///
    /// The prescaler runs freely, so on silicon a restart lands anywhere inside a tick and
    /// a deadline of `n` ticks expires between `n − 1` and `n` ticks later. The end
    /// deadline (T3.5) must never expire early, or a reply could start before the silence
    /// the spec demands: `n` is T3.5 rounded up plus one, so it expires up to two ticks
    /// late. The gap deadline must not be lenient, or a gap over T1.5 would pass: `n` is
    /// only rounded up, so it expires less than one tick from the exact time, either way.
    /// (In simulation the prescaler has no phase and both expire at `n` ticks.) Both count
    /// from the restart, [`RX_RESTART_LATENCY_NS`] or more after the stop bit.
    pub const fn new(times: CharTimes, clock_hz: u32) -> Self {
        let mut i = 0;
        while i < Prescaler::ALL.len() - 1 {
            if Self::ticks(times.t35_ns, clock_hz, Prescaler::ALL[i]) <= Self::MAX_TICKS {
                break;
            }
            i += 1;
        }
        let prescaler = Prescaler::ALL[i];
        TimerPlan {
            prescaler,
            gap: Self::deadline(times.gap_deadline_ns() - RX_RESTART_LATENCY_NS, clock_hz, prescaler, 0),
            end: Self::deadline(times.t35_ns - RX_RESTART_LATENCY_NS, clock_hz, prescaler, 1),
        }
    }

    /// The duration of one tick in nanoseconds (rounded down).
    pub const fn tick_ns(&self, clock_hz: u32) -> u32 {
        (self.prescaler.divisor() as u64 * NS_PER_S as u64 / clock_hz as u64) as u32
    }

    /// ⌈ns / tick⌉. For a whole number of MHz (the Uno's 16) in 32-bit arithmetic:
    /// ns · MHz stays below 2³² for every silence in range (35 ms · 16 = 5.6 · 10⁸).
    const fn ticks(ns: u32, clock_hz: u32, prescaler: Prescaler) -> u64 {
        if clock_hz.is_multiple_of(1_000_000) {
            (ns * (clock_hz / 1_000_000)).div_ceil(1000 * prescaler.divisor()) as u64
        } else {
            (ns as u64 * clock_hz as u64).div_ceil(prescaler.divisor() as u64 * NS_PER_S as u64)
        }
    }

    /// A deadline expiring `ticks(ns) + margin` timer clocks after a restart: the compare
    /// value is one less, as the flag rises on the clock after the match.
    const fn deadline(ns: u32, clock_hz: u32, prescaler: Prescaler, margin: u64) -> Deadline {
        let mut ticks = Self::ticks(ns, clock_hz, prescaler) + margin - 1;
        if ticks.is_multiple_of(256) {
            ticks += 1;
        }
        // At 1200 bps with clk/256 T3.5 is 2007 ticks; nothing in range exceeds 255 wraps.
        let wraps = ticks / 256;
        Deadline { ocr: (ticks % 256) as u8, wraps: if wraps > 255 { 255 } else { wraps as u8 } }
    }
}

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
    use crate::{Config, Parity, StopBits};

    fn times(baud: u32, parity: Parity, stop: StopBits) -> CharTimes {
        Config::new(1, baud, parity, stop).char_times()
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
            for parity in [Parity::None, Parity::Even] {
                let t = times(baud, parity, StopBits::One);
                assert_eq!((t.t15_ns, t.t35_ns), (750_000, 1_750_000), "{baud}");
            }
        }
        assert_eq!(times(115_200, Parity::None, StopBits::One).char_ns, 86_806);
        assert_eq!(times(115_200, Parity::Even, StopBits::One).char_ns, 95_487);
    }

    #[test]
    fn gap_deadline_is_one_char_plus_t15() {
        let t = times(19_200, Parity::Even, StopBits::One);
        assert_eq!(t.gap_deadline_ns(), 572_917 + 859_375);
    }

    #[test]
    fn end_deadline_never_early_gap_deadline_never_lenient() {
        let latency = RX_RESTART_LATENCY_NS as u64;
        for baud in [1200, 2400, 4800, 9600, 19_200, 38_400, 57_600, 115_200, 250_000, 500_000, 1_000_000] {
            for (parity, stop) in
                [(Parity::Even, StopBits::One), (Parity::None, StopBits::One), (Parity::None, StopBits::Two)]
            {
                let t = times(baud, parity, stop);
                let plan = TimerPlan::new(t, CLOCK_HZ);
                let tick = plan.prescaler.divisor() as u64 * 1_000_000_000 / CLOCK_HZ as u64;
                // On silicon a deadline of n ticks expires between n − 1 and n ticks after
                // the restart, which comes at least `latency` after the stop bit.
                let (end, t35) = (plan.end.ticks() as u64, t.t35_ns as u64);
                assert!(latency + (end - 1) * tick >= t35, "{baud}: T3.5 early: {end} ticks of {tick} ns < {t35}");
                assert!(latency + end * tick < t35 + 2 * tick, "{baud}: T3.5 more than 2 ticks late");
                let (gap, limit) = (plan.gap.ticks() as u64, t.gap_deadline_ns() as u64);
                assert!(latency + gap * tick >= limit, "{baud}: gap deadline early in simulation");
                assert!(latency + gap * tick < limit + tick, "{baud}: gap deadline lenient");
                assert!(plan.end.ocr != 0 && plan.gap.ocr != 0);
                assert!(plan.gap.ticks() < plan.end.ticks(), "{baud}: gap deadline after T3.5");
            }
        }
    }

    #[test]
    fn prescaler_is_the_finest_that_reaches_t35_in_eight_turns() {
        let plan = |baud| TimerPlan::new(times(baud, Parity::Even, StopBits::One), CLOCK_HZ);
        assert_eq!(plan(1200).prescaler, Prescaler::Div256);
        // (32 083 334 − 2 000) ns / 16 µs = 2005.1 → 2006 ticks, + 1 for the prescaler
        // phase; the compare value is one less.
        assert_eq!(plan(1200).end, Deadline { ocr: 214, wraps: 7 });
        assert_eq!(plan(1200).end.ticks(), 2007);
        // (9 166 667 + 13 750 000 − 2 000) ns / 16 µs = 1432.2 → 1433 ticks.
        assert_eq!(plan(1200).gap, Deadline { ocr: 152, wraps: 5 });
        assert_eq!(plan(9600).prescaler, Prescaler::Div64);
        assert_eq!(plan(19_200).prescaler, Prescaler::Div64);
        assert_eq!(plan(115_200).prescaler, Prescaler::Div64);
        assert_eq!(plan(115_200).end.ticks(), (1_750_000_u32 - 2_000).div_ceil(4_000) + 1);
        assert_eq!(plan(115_200).gap.ticks(), (95_487 + 750_000_u32 - 2_000).div_ceil(4_000));
    }

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
        for (baud, ubrr, double_speed, error_ppm) in table {
            let d = BaudDivisor::new(baud, CLOCK_HZ).unwrap();
            assert_eq!(
                (d.ubrr, d.double_speed, d.error_ppm(baud, CLOCK_HZ)),
                (ubrr, double_speed, error_ppm),
                "{baud}"
            );
        }
    }

    #[test]
    fn baud_with_more_than_2_5_percent_error_is_refused() {
        assert_eq!(BaudDivisor::new(300_000, CLOCK_HZ), None);
        assert_eq!(BaudDivisor::new(230_400, CLOCK_HZ), None);
        assert_eq!(BaudDivisor::new(0, CLOCK_HZ), None);
    }
}
