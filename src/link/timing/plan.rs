//! Timer0's deadline plan: Timer0 runs freely at clk/64 from the role's start (datasheet
//! §15), and a received character sets each silence deadline as a compare value relative
//! to the receive interrupt's one read of TCNT0 and a count of whole turns ([`Deadline`]).
//!
//! The USART flags a character (RXCn) before the character has left the line: once it has
//! sampled the first stop bit, at its middle ([`rx_flag_to_end_cycles`]). Silences on the
//! line count from a character's end, so T3.5 adds that time to what it counts from the
//! receive interrupt; the gap deadline, from one flag to the next, needs nothing.

use super::chars::{CharTimes, NS_PER_S};
use super::{BaudDivisor, CLOCK_HZ};

/// Timer0's clock divider, the same at every baud rate: clk/64, a tick of 4 µs at 16 MHz and
/// an overflow every 1.024 ms, as in Arduino's core (8 µs and 2.048 ms at 8 MHz). A tick is
/// small beside the silences (T1.5 is 750 µs or more), the overflow interrupt that keeps
/// [`Uptime`](super::Uptime) runs about 980 times a second (490 at 8 MHz), and the longest deadline (T3.5 at
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Line, Parity, StopBits};

    const MHZ16: u32 = 16_000_000;

    #[cfg(avr_cpu_frequency_hz = "16000000")]
    fn times(baud: u32, parity: Parity, stop: StopBits) -> CharTimes {
        Line::new(baud, parity, stop).char_times()
    }

    #[cfg(avr_cpu_frequency_hz = "16000000")]
    fn plan(baud: u32, parity: Parity, stop: StopBits) -> TimerPlan {
        Line::new(baud, parity, stop).timer_plan()
    }

    #[cfg(avr_cpu_frequency_hz = "16000000")]
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

    #[cfg(avr_cpu_frequency_hz = "16000000")]
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

    #[cfg(avr_cpu_frequency_hz = "8000000")]
    #[test]
    fn t35_at_19200_8e1_at_8_mhz_worked_example() {
        let plan = Line::new(19_200, Parity::Even, StopBits::One).timer_plan();
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
