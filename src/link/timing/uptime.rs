//! Timer0's overflows counted into milliseconds: the clock behind `millis()` (feature
//! `millis`) and the master's timeouts.

use super::TICKS_PER_MS;

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
        // At most 249 + 255 + 256 ticks: up to three more milliseconds (five at 8 MHz), one
        // for each whole millisecond the ticks reach. Written as comparisons, not as a loop
        // that subtracts a millisecond at a time: the compiler turns such a loop into a
        // division by multiplication, a 32-bit multiply on the AVR.
        let mut extra = 0u8;
        let mut k = 1;
        while k <= Self::MAX_EXTRA_MS {
            extra += (ticks >= k * TICKS_PER_MS as u16) as u8;
            k += 1;
        }
        self.millis.wrapping_add(extra as u32)
    }

    /// The most whole milliseconds [`Uptime::millis_at`] adds: the ticks past `millis`
    /// (`fract`, the count and a pending overflow) are fewer than [`TICKS_PER_MS`] + 2 · 256,
    /// so they make at most ⌈2 · 256 / [`TICKS_PER_MS`]⌉ whole milliseconds: 3 (5 at 8 MHz).
    const MAX_EXTRA_MS: u16 = (2 * 256u32).div_ceil(TICKS_PER_MS) as u16;
}

/// Whether an overflow flag (TOV0) found set just after reading `tcnt` from TCNT0 is an
/// overflow before that read, which the overflow interrupt has not counted yet: yes, unless
/// the read gave 255, in which case the counter overflowed between the two reads. (A flag
/// left pending for a whole turn would be misread; interrupts are never held off that long.)
pub const fn overflow_before(tcnt: u8, overflow_pending: bool) -> bool {
    overflow_pending && tcnt != 255
}

#[cfg(test)]
mod tests {
    use super::super::{CLOCK_HZ, TURN_US};
    use super::*;

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

    #[cfg(avr_cpu_frequency_hz = "16000000")]
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

    #[cfg(avr_cpu_frequency_hz = "8000000")]
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

    #[test]
    fn millis_at_is_the_ticks_divided_by_a_millisecond_for_every_fract_count_and_flag() {
        let t = TICKS_PER_MS as u16;
        for fract in 0..t as u8 {
            for tcnt in 0..=255u8 {
                for pending in [false, true] {
                    let clock = Uptime { millis: u32::MAX - 1, fract };
                    let ticks = u16::from(fract) + u16::from(tcnt) + if pending && tcnt != 255 { 256 } else { 0 };
                    let want = clock.millis.wrapping_add(u32::from(ticks / t));
                    assert_eq!(clock.millis_at(tcnt, pending), want, "fract {fract}, TCNT0 {tcnt}, flag {pending}");
                }
            }
        }
    }
}
