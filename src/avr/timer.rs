//! Timer0 as the RTU silence detector, ATmega328P datasheet §15 (8-bit Timer/Counter0):
//! normal mode, compare A at the gap deadline, compare B at T3.5, both counted from the
//! last received character; turns beyond 8 bits are counted in software.

use super::reg::{OCR0A, OCR0B, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
use crate::timing::TimerPlan;

const OCIE0A: u8 = 1 << 1;
const OCIE0B: u8 = 1 << 2;
const OCF0A: u8 = 1 << 1;
const OCF0B: u8 = 1 << 2;

/// Which deadline a compare interrupt reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Expired {
    /// Not yet: a full turn of the counter passed.
    NotYet,
    /// The deadline passed.
    Now,
}

/// Timer0 running the [`TimerPlan`] of the configuration.
pub(crate) struct FrameTimer {
    plan: TimerPlan,
    gap_turns: u8,
    end_turns: u8,
}

impl FrameTimer {
    /// Sets Timer0 up for `plan` (stopped until [`FrameTimer::restart`]). The slave owns
    /// Timer0: it took the application's `TC0`.
    pub(crate) fn new(plan: TimerPlan) -> Self {
        let mut timer = FrameTimer { plan, gap_turns: 0, end_turns: 0 };
        timer.configure(plan);
        timer
    }

    /// Stops the timer and switches to `plan` (stopped until [`FrameTimer::restart`]).
    pub(crate) fn configure(&mut self, plan: TimerPlan) {
        // Normal mode, no output compare pins, clock stopped, interrupts off.
        TCCR0B.write(0);
        TCCR0A.write(0);
        TIMSK0.write(0);
        OCR0A.write(plan.gap.ocr);
        OCR0B.write(plan.end.ocr);
        self.plan = plan;
    }

    /// A character ended: count both deadlines from now.
    #[inline(always)]
    pub(crate) fn restart(&mut self) {
        self.gap_turns = self.plan.gap.wraps;
        self.end_turns = self.plan.end.wraps;
        TCNT0.write(0);
        // Writing 1 clears a flag.
        TIFR0.write(OCF0A | OCF0B);
        TIMSK0.write(OCIE0A | OCIE0B);
        TCCR0B.write(self.plan.prescaler.cs_bits());
    }

    /// Compare A fired: has the gap deadline passed?
    #[inline(always)]
    pub(crate) fn on_compare_a(&mut self) -> Expired {
        if self.gap_turns > 0 {
            self.gap_turns -= 1;
            return Expired::NotYet;
        }
        self.disable(OCIE0A);
        Expired::Now
    }

    /// Compare B fired: has T3.5 passed? Then the timer stops until the next character.
    #[inline(always)]
    pub(crate) fn on_compare_b(&mut self) -> Expired {
        if self.end_turns > 0 {
            self.end_turns -= 1;
            return Expired::NotYet;
        }
        // Clock stopped, both compare interrupts masked.
        TCCR0B.write(0);
        TIMSK0.write(0);
        Expired::Now
    }

    fn disable(&mut self, mask: u8) {
        // Only the slave's interrupt handlers, which don't nest, change TIMSK0.
        TIMSK0.modify(|bits| bits & !mask);
    }
}

/// Milliseconds since start-up (not yet kept: 0).
pub(crate) fn millis() -> u32 {
    0
}

/// Timer0 overflowed.
#[inline(always)]
pub(crate) fn on_overflow() {}
