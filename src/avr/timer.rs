//! Timer0, ATmega328P datasheet §15 (8-bit Timer/Counter0): the RTU silence detector, and
//! with feature `millis` the application's millisecond clock too (`super::clock`). It runs
//! freely in normal mode at clk/64 from the slave's start and is never stopped or written
//! again; each received character sets compare A (the gap deadline) and compare B (T3.5)
//! relative to the counter's current value, the compare interrupts counting the whole turns
//! still to wait (`src/timing.rs` has the arithmetic). The compare interrupts stay enabled:
//! with no deadline set, their matches (one each per turn) find nothing to do.
//!
//! Timer0 is one peripheral, so its state lives in statics, like its registers: the
//! deadlines here, the clock in `super::clock`. They are only touched with interrupts
//! disabled.

use core::cell::UnsafeCell;

use super::reg::{OCR0A, OCR0B, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
use crate::timing::{Deadline, TimerPlan, TIMER0_CLOCK_SELECT};

const OCIE0A: u8 = 1 << 1;
const OCIE0B: u8 = 1 << 2;
pub(crate) const TOV0: u8 = 1 << 0;
const OCF0A: u8 = 1 << 1;
const OCF0B: u8 = 1 << 2;

/// A value only touched with interrupts disabled.
pub(crate) struct Exclusive<T>(pub(crate) UnsafeCell<T>);

// SAFETY: one core, and the value is only reached through `Exclusive::with`, whose callers
// have interrupts disabled, so no two accesses overlap.
unsafe impl<T: Send> Sync for Exclusive<T> {}

impl<T> Exclusive<T> {
    /// Runs `f` on the value.
    ///
    /// # Safety
    /// Interrupts must be disabled, and `f` must not reach the same value.
    #[inline(always)]
    pub(crate) unsafe fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        // SAFETY: with interrupts disabled nothing else holds a reference to the value.
        f(unsafe { &mut *self.0.get() })
    }
}

/// The silence deadlines: the plan of the configuration (compare offsets and whole turns),
/// how many matches of each compare value the compare interrupts have let pass since the
/// last character, and the compare flags found already set when the deadlines were set
/// (stale: their interrupts are not a match of the new values). The receive interrupt only
/// reads TCNT0 and TIFR0, writes the compare registers, and zeroes the two counts.
/// `repr(C)`: the counts apart, so that each is zeroed from the zero register instead of a
/// pair loaded for a 16-bit store.
#[repr(C)]
struct Deadlines {
    gap_matches: u8,
    plan: TimerPlan,
    end_matches: u8,
    stale: u8,
}

/// A match count past any deadline's turns: the deadline has passed.
const PASSED: u8 = u8::MAX;

/// All zero until [`FrameTimer::new`] writes the plan and parks the deadlines, before any
/// of Timer0's interrupts is enabled: in `.bss`, with no initial value kept in flash.
static DEADLINES: Exclusive<Deadlines> = Exclusive(UnsafeCell::new(Deadlines {
    gap_matches: 0,
    plan: TimerPlan { gap: Deadline { low: 0, turns: 0 }, end: Deadline { low: 0, turns: 0 } },
    end_matches: 0,
    stale: 0,
}));

/// A character arrived: sets both deadlines from now, first thing in the receive
/// interrupt, so that they count from as close to RXC0 as can be
/// (`timing::RX_LATENCY_CYCLES`). Only from the receive interrupt handler.
#[inline(always)]
pub(crate) fn on_receive() {
    // SAFETY: called from the receive interrupt handler, with interrupts disabled.
    unsafe { DEADLINES.with(Deadlines::set) }
}

impl Deadlines {
    /// Both deadlines count from now: one read of TCNT0, no wait for a tick edge (see
    /// [`Deadline`] for the accuracy that follows). Interrupts must be disabled.
    ///
    /// The compare interrupts stay enabled, so a compare flag already set once the compare
    /// registers are written is a match of the old values during this interrupt, pending:
    /// no match of the new values can come so soon (`low` is at least 1, two tick edges
    /// away). Such a flag is noted, and its interrupt let pass. (Clearing it through TIFR0
    /// would do on the ATmega328P, but under simavr 1.6 the simulated clock then loses
    /// turns (`tests/sim_clock.rs` saw it: the write also clears a pending overflow). And
    /// masking a compare interrupt between deadlines made simavr late by a turn: a flag
    /// that rose while masked, noted here, brought no interrupt once unmasked there, though
    /// it does on the silicon. Hence no masking, and a compare interrupt each per turn.)
    #[inline(always)]
    fn set(&mut self) {
        let tcnt = TCNT0.read();
        OCR0A.write(tcnt.wrapping_add(self.plan.gap.low));
        OCR0B.write(tcnt.wrapping_add(self.plan.end.low));
        self.stale = TIFR0.read();
        self.gap_matches = 0;
        self.end_matches = 0;
    }

    /// No deadline until the next character: the compare interrupts, which keep coming
    /// once a turn, find nothing to do.
    fn park(&mut self) {
        self.gap_matches = PASSED;
        self.end_matches = PASSED;
    }

    /// A compare interrupt whose flag `flag` was noted stale: lets it pass, once.
    #[inline(always)]
    fn was_stale(&mut self, flag: u8) -> bool {
        if self.stale & flag == 0 {
            return false;
        }
        self.stale &= !flag;
        true
    }
}

/// Sets both deadlines from now, outside the receive interrupt.
#[inline(never)]
fn set_now() {
    // SAFETY: only called by `FrameTimer::restart`, with interrupts disabled.
    unsafe { DEADLINES.with(Deadlines::set) }
}

/// Which deadline a compare interrupt reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Expired {
    /// Not now: an earlier match of the same compare value, or one with no deadline set.
    NotYet,
    /// The deadline passed.
    Now,
}

/// The slave's hold on Timer0's deadlines (the plan lives with them, above).
pub(crate) struct FrameTimer(());

impl FrameTimer {
    /// Starts Timer0 from zero with its compare interrupts on (and the overflow interrupt,
    /// the clock of `millis()`, with feature `millis`) and no deadline set, for `plan`. The slave owns Timer0: it took the application's `TC0`.
    /// Call with interrupts disabled.
    pub(crate) fn new(plan: TimerPlan) -> Self {
        // Stopped, normal mode, no output compare pins, interrupts off, counter and flags
        // cleared: from here on nothing writes TCCR0x or TCNT0 again.
        TCCR0B.write(0);
        TCCR0A.write(0);
        TIMSK0.write(0);
        TCNT0.write(0);
        TIFR0.write(TOV0 | OCF0A | OCF0B);
        let mut timer = FrameTimer(());
        timer.plan(plan);
        TIMSK0.write(super::clock::OVERFLOW_INTERRUPT | OCIE0A | OCIE0B);
        TCCR0B.write(TIMER0_CLOCK_SELECT);
        timer
    }

    fn plan(&mut self, plan: TimerPlan) {
        // SAFETY: called with interrupts disabled (by `new`, and by `configure`'s callers).
        unsafe {
            DEADLINES.with(|d| {
                d.plan = plan;
                d.park();
            })
        }
    }

    /// Switches to `plan`; no deadline is set until the next character or
    /// [`FrameTimer::restart`]. Interrupts must be disabled.
    #[cfg(feature = "eeprom-settings")]
    pub(crate) fn configure(&mut self, plan: TimerPlan) {
        self.plan(plan);
    }

    /// Both deadlines count from now: at start-up, and when T3.5 finds a character not yet
    /// taken (the receive interrupt sets them itself, [`on_receive`]). Interrupts must be
    /// disabled.
    pub(crate) fn restart(&mut self) {
        set_now();
    }

    /// Compare A fired: has the gap deadline passed (its last match)?
    #[inline(always)]
    pub(crate) fn on_compare_a(&mut self) -> Expired {
        // SAFETY: called from the compare interrupt handler, with interrupts disabled.
        unsafe {
            DEADLINES.with(|d| if d.was_stale(OCF0A) { Expired::NotYet } else { count(&mut d.gap_matches, d.plan.gap) })
        }
    }

    /// Compare B fired: has T3.5 passed (its last match)? Then neither deadline is set until
    /// the next character; the timer runs on.
    #[inline(always)]
    pub(crate) fn on_compare_b(&mut self) -> Expired {
        // SAFETY: as above.
        unsafe {
            DEADLINES.with(|d| {
                if d.was_stale(OCF0B) {
                    return Expired::NotYet;
                }
                let expired = count(&mut d.end_matches, d.plan.end);
                if expired == Expired::Now {
                    d.park();
                }
                expired
            })
        }
    }
}

/// One more match of `deadline`'s compare value, `matches` the ones before: the last one
/// (then [`PASSED`]), or one more turn to let pass, or one after the deadline passed.
#[inline(always)]
fn count(matches: &mut u8, deadline: Deadline) -> Expired {
    if *matches == deadline.turns {
        *matches = PASSED;
        return Expired::Now;
    }
    if *matches < deadline.turns {
        *matches += 1;
    }
    Expired::NotYet
}
