//! Character times and silences, Modbus over Serial Line v1.02 §2.5.1.1 (T1.5, T3.5),
//! and the ATmega328P arithmetic that turns them into USART settings and Timer0 deadlines,
//! and Timer0's overflows into milliseconds.
//!
//! Timer0 runs freely at clk/64 from the slave's start (datasheet §15): its overflow
//! interrupt keeps [`Uptime`], and a received character sets each deadline as a compare
//! value relative to the receive interrupt's one read of TCNT0 and a count of whole turns
//! ([`Deadline`]). Nothing restarts the counter, so the milliseconds never lose a tick.
//!
//! The USART flags a character (RXCn) before the character has left the line: once it has
//! sampled the first stop bit, at its middle ([`rx_flag_to_end_cycles`]). Silences on the
//! line count from a character's end, so T3.5 adds that time to what it counts from the
//! receive interrupt; the gap deadline, from one flag to the next, needs nothing.
//!
//! Everything here is `const fn` math: the AVR layer only copies the results into
//! registers, and the host tests check the results (`tests/timing.rs`: every accepted
//! rate and character format).

/// The CPU clock the crate is built for: 16 MHz (Uno, Nano, Mega, Leonardo, Pro Mini 5 V),
/// or 8 MHz with feature `clock-8mhz` (SparkFun Pro Mini 3.3 V, Pro Micro 3.3 V). Every
/// baud divisor, silence and millisecond is worked out from it while the firmware compiles.
pub const CLOCK_HZ: u32 = if cfg!(feature = "clock-8mhz") { 8_000_000 } else { 16_000_000 };

/// Above this rate the spec fixes T1.5 = 750 µs and T3.5 = 1750 µs.
pub const FIXED_TIMES_ABOVE_BAUD: u32 = 19_200;

const NS_PER_S: u32 = 1_000_000_000;

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

/// Timer0's clock divider, the same at every baud rate: clk/64, a tick of 4 µs at 16 MHz and
/// an overflow every 1.024 ms, as in Arduino's core (8 µs and 2.048 ms at 8 MHz). A tick is
/// small beside the silences (T1.5 is 750 µs or more), the overflow interrupt that keeps
/// [`Uptime`] runs about 980 times a second (490 at 8 MHz), and the longest deadline (T3.5 at
/// 1200 bps with 12-bit characters, 35 ms) is 35 counter turns (18 at 8 MHz), which the
/// compare interrupts count in a byte.
pub const TIMER0_DIVISOR: u32 = 64;

/// The clock-select bits CS02:0 of TCCR0B for [`TIMER0_DIVISOR`].
pub const TIMER0_CLOCK_SELECT: u8 = 0b011;

/// Timer0 ticks in a millisecond at [`CLOCK_HZ`]: 250 (125 at 8 MHz).
pub const TICKS_PER_MS: u32 = CLOCK_HZ / TIMER0_DIVISOR / 1000;
const _: () = assert!(TICKS_PER_MS * TIMER0_DIVISOR * 1000 == CLOCK_HZ, "a millisecond must be whole ticks");
const _: () = assert!(TICKS_PER_MS <= 256, "a turn of Timer0 must be a millisecond or more");

/// A turn of Timer0 (256 ticks) in microseconds: 1024 (2048 at 8 MHz).
pub const TURN_US: u32 = 256 * TIMER0_DIVISOR / (CLOCK_HZ / 1_000_000);
const _: () = assert!(TURN_US * (CLOCK_HZ / 1_000_000) == 256 * TIMER0_DIVISOR, "a turn must be whole microseconds");

/// Milliseconds since Timer0 started, kept by its overflow interrupt as Arduino's core
/// keeps `millis()`: a turn of the counter is 256 ticks, one millisecond and 6 ticks
/// (1.024 ms; at 8 MHz two milliseconds and 6 ticks), so each overflow adds the whole
/// milliseconds and carries the 6 ticks into `fract`. Nothing is rounded away:
/// `millis · TICKS_PER_MS + fract` is always the number of ticks counted (modulo 2³²
/// milliseconds), so the clock never drifts from Timer0.
///
/// `repr(C)`: the simulator tests read it from the firmware's RAM (`millis` little-endian
/// at offset 0, `fract` at 4; the AVR aligns nothing).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Uptime {
    /// Whole milliseconds, wrapping after 2³² (49.7 days).
    pub millis: u32,
    /// Ticks past the last whole millisecond: below [`TICKS_PER_MS`].
    pub fract: u8,
}

impl Uptime {
    /// Timer0 just started.
    pub const ZERO: Uptime = Uptime { millis: 0, fract: 0 };

    /// Whole milliseconds in a turn of the counter: 1 (2 at 8 MHz).
    const TURN_MS: u32 = 256 / TICKS_PER_MS;
    /// Ticks of a turn beyond its whole milliseconds: 6 at 16 and 8 MHz.
    const TURN_SPARE_TICKS: u8 = (256 % TICKS_PER_MS) as u8;

    /// The clock after one more overflow. `fract` and the spare ticks are both below
    /// [`TICKS_PER_MS`], and a turn holds a whole millisecond or more, so their sum stays
    /// below 256.
    pub const fn after_overflow(self) -> Self {
        let mut millis = self.millis.wrapping_add(Self::TURN_MS);
        let mut fract = self.fract + Self::TURN_SPARE_TICKS;
        if fract >= TICKS_PER_MS as u8 {
            fract -= TICKS_PER_MS as u8;
            millis = millis.wrapping_add(1);
        }
        Uptime { millis, fract }
    }

    /// Whole milliseconds at the moment TCNT0 read `tcnt`, the overflow flag (TOV0, read
    /// after TCNT0) being `overflow_pending` (see [`overflow_before`]): the ticks counted
    /// divided by [`TICKS_PER_MS`], rounded down, so the result is never ahead of Timer0 and
    /// less than a millisecond behind it.
    pub const fn millis_at(self, tcnt: u8, overflow_pending: bool) -> u32 {
        let mut ticks = self.fract as u16 + tcnt as u16;
        if overflow_before(tcnt, overflow_pending) {
            ticks += 256;
        }
        // At most 249 + 255 + 256 ticks: up to three more milliseconds (five at 8 MHz), no
        // division.
        let mut millis = self.millis;
        while ticks >= TICKS_PER_MS as u16 {
            ticks -= TICKS_PER_MS as u16;
            millis = millis.wrapping_add(1);
        }
        millis
    }
}

/// Whether an overflow flag (TOV0) found set just after reading `tcnt` from TCNT0 is an
/// overflow before that read, which the overflow interrupt has not counted yet: yes, unless
/// the read gave 255, in which case the counter overflowed between the two reads. (A flag
/// left pending for a whole turn would be misread; interrupts are never held off that long.)
pub const fn overflow_before(tcnt: u8, overflow_pending: bool) -> bool {
    overflow_pending && tcnt != 255
}

/// CPU cycles from the USART's receive-complete flag (RXCn) to the end of the character on
/// the line, at the bit time `divisor` makes (UBRRn and U2Xn, [`BaudDivisor::bit_cycles`]) with
/// one stop bit, or two if `two_stop_bits`. The receiver moves a character to UDRn and sets RXCn once
/// it has sampled the first stop bit, at the middle of that bit (ATmega328P datasheet,
/// "Receiving Frames with 5 to 8 Data Bits": a second stop bit is ignored by the receiver),
/// so the character ends half a bit later with one stop bit and one and a half bits later
/// with two. A bit is a whole multiple of 8 cycles, so this is exact. The middle is the
/// earliest the flag comes: a receiver that takes a sample or two more only makes a deadline
/// that adds this later, never early.
pub const fn rx_flag_to_end_cycles(divisor: BaudDivisor, two_stop_bits: bool) -> u32 {
    let half_bit = divisor.bit_cycles() / 2;
    if two_stop_bits {
        3 * half_bit
    } else {
        half_bit
    }
}

/// A lower bound of the time, in CPU cycles, from the USART flagging a received character
/// (RXC0) to the receive interrupt's read of TCNT0, the first thing its handler does
/// (`slave!` binds it): the interrupt response (4), the vector table's jump (3) and the
/// handler's prologue, which saves SREG (through `r0`, 5 cycles), `r1` (3) and the
/// registers the handler uses (2 each) before it reaches the read. The prologue is the
/// compiler's: 5 registers saved in every example (25 cycles in all); the bound leaves room
/// for two fewer. A CPU that was sleeping or in the middle of a longer instruction takes up
/// to 4 cycles more; one held off by another interrupt or a critical section, that much
/// more. Deadlines count from this bound, so a later read only makes them later.
/// `tests/sim_clock.rs` checks it on every example.
pub const RX_LATENCY_CYCLES: u32 = 21;

/// Cycles from the receive interrupt's read of TCNT0 to the next tick edge, earliest and
/// latest: the prescaler runs freely, so the edge can come anywhere within a tick of the
/// read, with one cycle allowed either way for the moment within its cycle at which an
/// `in` instruction samples TCNT0.
pub const EDGE_AFTER_READ: (u32, u32) = (0, TIMER0_DIVISOR + 1);

/// CPU cycles in `ns` nanoseconds, rounded up. For a whole number of MHz (the Uno's 16) in
/// 32-bit arithmetic: ns · MHz stays below 2³² for every silence in range (35 ms · 16).
const fn cycles(ns: u32, clock_hz: u32) -> u32 {
    if clock_hz % 1_000_000 == 0 {
        (ns * (clock_hz / 1_000_000)).div_ceil(1000)
    } else {
        (ns as u64 * clock_hz as u64).div_ceil(NS_PER_S as u64) as u32
    }
}

/// A silence deadline as the receive interrupt sets it, without waiting for a tick edge:
/// compare value = TCNT0 as read + [`Deadline::low`], then [`Deadline::turns`] more
/// matches of that value (one per 256 ticks), which the compare interrupt counts.
///
/// The compare flag rises on the tick that takes TCNT0 past the compare value (datasheet
/// §15.7), so the deadline passes at tick edge [`Deadline::edges`] after the read, the first
/// edge coming 0 to 65 cycles after it ([`EDGE_AFTER_READ`]). `edges` is the fewest for
/// which even the earliest first edge, after a receive interrupt of the shortest latency
/// ([`RX_LATENCY_CYCLES`]), is at or after the exact time: never early. The latest comes
/// less than 2 ticks + 2 cycles (130 cycles, 8.1 µs at 16 MHz) after the exact time: the
/// unknown prescaler phase (65 cycles), the rounding up to whole ticks (63) and to whole
/// cycles and nanoseconds. A compare value equal to the count read could be left by the
/// counter before the interrupt writes it (a whole turn late), so `low` is never 0: for
/// those deadlines (about 1 in 256: 42 of the 39 672 checked) one edge more, up to
/// 3 ticks + 2 cycles (194 cycles, 12.1 µs) late. Times count from the USART's receive flag
/// (RXCn; [`TimerPlan`] adds what lies between it and the character's end); a receive
/// interrupt held off beyond its shortest latency makes the deadline that much later, and a
/// compare interrupt held off for more than a turn (1.024 ms, 2.048 ms at 8 MHz), a turn
/// later.
/// `tests/timing.rs` checks every accepted rate and format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Deadline {
    /// Added to TCNT0 as read: the compare value. Never 0.
    pub low: u8,
    /// Matches of the compare value to let pass before the one that ends the deadline.
    pub turns: u8,
}

impl Deadline {
    /// The deadline `ns` nanoseconds after the USART flagged a character, at most 65 536
    /// ticks (262 ms at 16 MHz, 524 ms at 8 MHz, beyond any T3.5 at 1200 bps or more).
    pub const fn new(ns: u32, clock_hz: u32) -> Self {
        Self::after_flag(cycles(ns, clock_hz))
    }

    /// The deadline `cycles` CPU cycles after the USART flagged a character. (Not inlined: a
    /// configuration computed at run time sets three deadlines with it.)
    #[inline(never)]
    pub const fn after_flag(cycles: u32) -> Self {
        let after_read = cycles.saturating_sub(RX_LATENCY_CYCLES + EDGE_AFTER_READ.0);
        // Edges after the first one: the first is at least `EDGE_AFTER_READ.0` after the read.
        let mut after_first = after_read.div_ceil(TIMER0_DIVISOR);
        if after_first % 256 == 0 {
            after_first += 1;
        }
        Deadline { low: (after_first % 256) as u8, turns: (after_first / 256) as u8 }
    }

    /// Tick edges from the read of TCNT0 to the one that ends the deadline (the first edge
    /// after the read is edge 1).
    pub const fn edges(self) -> u32 {
        self.turns as u32 * 256 + self.low as u32 + 1
    }

    /// Earliest and latest expiry in CPU cycles after the USART flagged the character, for a
    /// receive interrupt of the shortest latency.
    pub const fn expiry_cycles(self) -> (u32, u32) {
        let after_first = (self.edges() - 1) * TIMER0_DIVISOR;
        (RX_LATENCY_CYCLES + EDGE_AFTER_READ.0 + after_first, RX_LATENCY_CYCLES + EDGE_AFTER_READ.1 + after_first)
    }
}

/// Timer0 settings for the frame detector: a deadline for the inter-character gap
/// ([`CharTimes::gap_deadline_ns`], from one receive flag to the next) and one for the end of
/// frame (T3.5 after the last received character's end on the line: from its receive flag,
/// T3.5 and [`rx_flag_to_end_cycles`]), both set by the receive interrupt, on one compare unit.
///
/// The receive interrupt sets the compare value for the gap deadline (TCNT0 as read +
/// `gap.low`). When the gap deadline passes, the compare interrupt moves the compare value
/// on by [`TimerPlan::to_end`], to the value T3.5 would have had (TCNT0 as read +
/// `end.low`), and counts on: T3.5 passes at the compare match [`TimerPlan::end_match`]
/// since the character, at the very tick edge [`Deadline::edges`] gives for `end`. One
/// compare interrupt serves both silences; it works with the plan's [`Schedule`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimerPlan {
    /// A character reported after this had a gap longer than T1.5.
    pub gap: Deadline,
    /// T3.5 of silence after the character's end, the frame is complete.
    pub end: Deadline,
}

/// What a match of the compare value means, for a count of the matches before it since the
/// character ([`Schedule::on_match`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Passed {
    /// Neither deadline: a turn to let pass, or a match after T3.5 (none is set).
    Nothing,
    /// The gap deadline: move the compare value on by [`TimerPlan::to_end`], and count on
    /// from [`Schedule::count_after_gap`].
    Gap,
    /// T3.5: no deadline is set until the next character.
    End,
    /// The reply delay after T3.5 has passed (feature `reply-delay`).
    #[cfg(feature = "reply-delay")]
    Delayed,
}

impl TimerPlan {
    /// The two deadlines for `times` at `clock_hz`, for a USART that flags each character
    /// `flag_to_end` CPU cycles before its end ([`rx_flag_to_end_cycles`]).
    pub const fn new(times: CharTimes, clock_hz: u32, flag_to_end: u32) -> Self {
        TimerPlan {
            gap: Deadline::new(times.gap_deadline_ns(), clock_hz),
            end: Deadline::after_flag(cycles(times.t35_ns, clock_hz) + flag_to_end),
        }
    }

    /// How far the compare value moves at the gap deadline, modulo 256: from the gap
    /// deadline's value to T3.5's.
    pub const fn to_end(self) -> u8 {
        self.end.low.wrapping_sub(self.gap.low)
    }

    /// The number of the compare match since the character (the first is 0) at which T3.5
    /// passes. T3.5's value matches once a turn from the character on; the first of its
    /// matches the compare unit sees comes in the turn of the gap deadline if it lies after
    /// the gap deadline's value there, else a turn later.
    pub const fn end_match(self) -> u8 {
        if self.end.low > self.gap.low {
            self.end.turns + 1
        } else {
            self.end.turns
        }
    }

    /// What the compare interrupt works with, worked out once for the configuration.
    pub const fn schedule(self) -> Schedule {
        Schedule {
            gap_low: self.gap.low,
            gap_turns: self.gap.turns,
            to_end: self.to_end(),
            end_match: self.end_match(),
        }
    }
}

/// A [`TimerPlan`] as the receive and compare interrupts use it ([`TimerPlan::schedule`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Added to TCNT0 as read: the gap deadline's compare value ([`Deadline::low`]).
    pub gap_low: u8,
    /// The gap deadline's whole turns ([`Deadline::turns`]).
    pub gap_turns: u8,
    /// [`TimerPlan::to_end`].
    pub to_end: u8,
    /// [`TimerPlan::end_match`].
    pub end_match: u8,
}

impl Schedule {
    /// No deadline: what the compare interrupt works with before the slave starts.
    pub const NONE: Schedule = Schedule { gap_low: 0, gap_turns: 0, to_end: 0, end_match: 0 };

    /// The count of matches after the gap deadline's, when the compare interrupt that
    /// moved the compare value read TCNT0 `elapsed` ticks past the gap deadline's value,
    /// before it wrote the new one: T3.5's value has already gone by in this turn when
    /// TCNT0 is past it (the interrupt came that late), and that match is counted as seen.
    /// A read of T3.5's value itself must wait for the next tick edge before it writes
    /// (the match would come, or not, as the write falls): `elapsed` is then one more.
    pub const fn count_after_gap(self, elapsed: u8) -> u8 {
        if self.to_end != 0 && elapsed > self.to_end {
            self.gap_turns + 2
        } else {
            self.gap_turns + 1
        }
    }

    /// The compare value matched, `matches` counted before this one since the character:
    /// what passed, and the count to keep (past [`Schedule::end_match`] once T3.5 has
    /// passed, where it stays until the next character).
    pub const fn on_match(self, matches: u8) -> (Passed, u8) {
        if matches == self.gap_turns {
            (Passed::Gap, matches)
        } else if matches == self.end_match {
            (Passed::End, u8::MAX)
        } else if matches < self.end_match {
            (Passed::Nothing, matches + 1)
        } else {
            (Passed::Nothing, matches)
        }
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
    use crate::{Config, Parity, StopBits};

    /// The tests that name a clock: the Uno's. Those built on [`Config`] follow [`CLOCK_HZ`]
    /// and are the 16 MHz build's (feature `clock-8mhz` has its own).
    const MHZ16: u32 = 16_000_000;
    const MHZ8: u32 = 8_000_000;

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

    #[test]
    fn uptime_adds_a_turn_per_overflow_without_drift() {
        // 250 ticks a millisecond at 16 MHz (a turn is 1.024 ms), 125 at 8 MHz (2.048 ms).
        assert_eq!(TICKS_PER_MS, CLOCK_HZ / 64_000);
        let mut clock = Uptime::ZERO;
        for turn in 1..=1_000_000_u64 {
            clock = clock.after_overflow();
            assert!(u32::from(clock.fract) < TICKS_PER_MS);
            // millis · ticks a millisecond + fract = 256 ticks per turn, exactly.
            let ticks = u64::from(clock.millis) * u64::from(TICKS_PER_MS) + u64::from(clock.fract);
            assert_eq!(ticks, turn * 256, "turn {turn}");
        }
        // 125 turns are 128 ms exactly at 16 MHz, 256 ms at 8 MHz.
        let mut clock = Uptime::ZERO;
        for _ in 0..125 {
            clock = clock.after_overflow();
        }
        assert_eq!(clock, Uptime { millis: 125 * TURN_US / 1000, fract: 0 });
    }

    #[test]
    fn uptime_wraps_after_2_to_the_32_ms() {
        let clock = Uptime { millis: u32::MAX, fract: TICKS_PER_MS as u8 - 1 };
        // One turn and the 6 spare ticks: 1 ms and 5 ticks past 0 at 16 MHz, 2 ms at 8.
        assert_eq!(clock.after_overflow(), Uptime { millis: Uptime::TURN_MS, fract: 5 });
        assert_eq!(clock.millis_at(1, false), 0);
    }

    #[cfg(not(feature = "clock-8mhz"))]
    #[test]
    fn millis_at_rounds_down_and_counts_a_pending_overflow() {
        let clock = Uptime { millis: 7, fract: 200 };
        assert_eq!(clock.millis_at(49, false), 7); // 249 ticks past 7 ms
        assert_eq!(clock.millis_at(50, false), 8); // 250
        assert_eq!(clock.millis_at(255, false), 8); // 455

        // An overflow not yet counted: 200 + 3 + 256 = 459 ticks.
        assert_eq!(clock.millis_at(3, true), 8);
        // Most there can be: 249 + 254 + 256 = 759 ticks, three more milliseconds.
        assert_eq!(Uptime { millis: 7, fract: 249 }.millis_at(254, true), 10);
        // TCNT0 read 255 and the flag rose after it: not counted.
        assert_eq!(clock.millis_at(255, true), 8);
    }

    #[cfg(feature = "clock-8mhz")]
    #[test]
    fn millis_at_8_mhz_counts_125_ticks_a_millisecond() {
        let clock = Uptime { millis: 7, fract: 100 };
        assert_eq!(clock.millis_at(24, false), 7); // 124 ticks past 7 ms
        assert_eq!(clock.millis_at(25, false), 8); // 125
        assert_eq!(clock.millis_at(255, false), 9); // 355

        // Most there can be: 124 + 254 + 256 = 634 ticks, five more milliseconds.
        assert_eq!(Uptime { millis: 7, fract: 124 }.millis_at(254, true), 12);
        assert_eq!(clock.millis_at(255, true), 9);
    }

    #[cfg(not(feature = "clock-8mhz"))]
    fn plan(baud: u32, parity: Parity, stop: StopBits) -> TimerPlan {
        Config::new(1, baud, parity, stop).timer_plan()
    }

    #[cfg(not(feature = "clock-8mhz"))]
    #[test]
    fn t35_at_19200_8e1_worked_example() {
        let plan = plan(19_200, Parity::Even, StopBits::One);
        // 2 005 209 ns = 32 083.3 → 32 084 cycles after the character's end, which comes
        // half a bit (UBRR0 51: 416 cycles) after RXC0: 32 500 cycles after the flag; 21 of
        // them before the read: 32 479 = 507.48 ticks → 508 edges after the first one, which
        // may come right after the read: 509 edges, the compare value 252 (509 − 1 − 256) past
        // the count read, and one match of it let pass.
        assert_eq!(plan.end, Deadline { low: 252, turns: 1 });
        assert_eq!(plan.end.edges(), 509);
        assert_eq!(plan.end.expiry_cycles(), (21 + 508 * 64, 21 + 65 + 508 * 64));
        assert!(plan.end.expiry_cycles().0 >= 32_084 + 416);
    }

    #[test]
    fn the_receive_flag_comes_half_a_bit_before_the_end_or_one_and_a_half_with_two_stop_bits() {
        // (baud, stop bits, cycles from RXCn to the character's end): UBRR0 and U2X0 as the
        // datasheet's table 20-7 has them.
        let table = [
            (1200, 1, 833 * 8),      // UBRR0 832: 13 328-cycle bits
            (1200, 2, 833 * 8 * 3),  // 19 992: beyond a turn of Timer0 (16 384)
            (9600, 1, 104 * 8),      // 832
            (9600, 2, 104 * 8 * 3),  // 2496: 156 µs
            (19_200, 1, 52 * 8),     // 416: 26 µs
            (19_200, 2, 52 * 8 * 3), // 1248: 78 µs
            (57_600, 1, 35 * 4),     // U2X0: 280-cycle bits
            (57_600, 2, 35 * 4 * 3), //
            (115_200, 1, 17 * 4),    // U2X0: 136-cycle bits
            (1_000_000, 2, 8 * 3),   // UBRR0 0: 16-cycle bits
        ];
        for (baud, stop, cycles) in table {
            let divisor = BaudDivisor::new(baud, MHZ16).unwrap();
            assert_eq!(rx_flag_to_end_cycles(divisor, stop == 2), cycles, "{baud} with {stop} stop bits");
        }
    }

    #[cfg(not(feature = "clock-8mhz"))]
    #[test]
    fn t35_adds_the_flag_to_end_time_and_the_gap_deadline_does_not() {
        // The same character time and silences, one stop bit or two (8E1 and 8N2 are both
        // 11 bits): T3.5 waits a bit longer (1248 − 416 cycles = 13 ticks) with two.
        let (one, two) = (plan(19_200, Parity::Even, StopBits::One), plan(19_200, Parity::None, StopBits::Two));
        assert_eq!(one.gap, two.gap);
        assert_eq!(two.end.edges() - one.end.edges(), 13);
        // Without the flag's lead the gap deadline is the same: it counts from flag to flag.
        let times = times(19_200, Parity::Even, StopBits::One);
        assert_eq!(TimerPlan::new(times, MHZ16, 0).gap, one.gap);
        assert_eq!(TimerPlan::new(times, MHZ16, 0).end, Deadline { low: 245, turns: 1 });
    }

    #[test]
    fn a_compare_value_equal_to_the_count_read_is_one_edge_later() {
        // 256 · 64 cycles after the read's earliest first edge: 256 edges after it, which
        // would be a compare value of the count read itself.
        let ns = (RX_LATENCY_CYCLES + 256 * TIMER0_DIVISOR) * 1000 / 16;
        let deadline = Deadline::new(ns, MHZ16);
        assert_eq!(deadline, Deadline { low: 1, turns: 1 });
        // A tick sooner: 255 edges after the first.
        assert_eq!(Deadline::new(ns - 4000, MHZ16), Deadline { low: 255, turns: 0 });
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

    #[cfg(feature = "clock-8mhz")]
    #[test]
    fn t35_at_19200_8e1_at_8_mhz_worked_example() {
        let plan = Config::new(1, 19_200, Parity::Even, StopBits::One).timer_plan();
        // 2 005 209 ns = 16 041.7 → 16 042 cycles after the character's end, which comes
        // half a bit (UBRR0 25: 416-cycle bits) after RXC0: 16 250 cycles after the flag; 21
        // of them before the read: 16 229 = 253.58 ticks → 254 edges after the first one,
        // which may come right after the read: 255 edges, the compare value 254 past the
        // count read, within the turn.
        assert_eq!(plan.end, Deadline { low: 254, turns: 0 });
        assert_eq!(plan.end.expiry_cycles(), (21 + 254 * 64, 21 + 65 + 254 * 64));
        assert!(plan.end.expiry_cycles().0 >= 16_042 + 208);
        assert_eq!(TURN_US, 2048);
        assert_eq!(TICKS_PER_MS, 125);
    }
}
