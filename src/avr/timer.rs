//! Timer0 as the RTU silence detector, ATmega328P datasheet §15 (8-bit Timer/Counter0):
//! normal mode, compare A at the gap deadline, compare B at T3.5, both counted from the
//! last received character; turns beyond 8 bits are counted in software.

use avr_device::atmega328p::TC0;

use crate::timing::TimerPlan;

const OCIE0A: u8 = 1 << 1;
const OCIE0B: u8 = 1 << 2;
const OCF0A: u8 = 1 << 1;
const OCF0B: u8 = 1 << 2;

/// Which deadline a compare interrupt reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expired {
    /// Not yet: a full turn of the counter passed.
    NotYet,
    /// The deadline passed.
    Now,
}

/// Timer0 running the [`TimerPlan`] of the configuration.
pub struct FrameTimer {
    regs: TC0,
    plan: TimerPlan,
    gap_turns: u8,
    end_turns: u8,
}

impl FrameTimer {
    /// Takes Timer0 (stopped until [`FrameTimer::restart`]).
    pub fn new(regs: TC0, plan: TimerPlan) -> Self {
        let mut timer = FrameTimer { regs, plan, gap_turns: 0, end_turns: 0 };
        timer.configure(plan);
        timer
    }

    /// Stops the timer and switches to `plan` (stopped until [`FrameTimer::restart`]).
    pub fn configure(&mut self, plan: TimerPlan) {
        let regs = &self.regs;
        // SAFETY: normal mode, no output compare pins, clock stopped, interrupts off.
        unsafe {
            regs.tccr0b().write(|w| w.bits(0));
            regs.tccr0a().write(|w| w.bits(0));
            regs.timsk0().write(|w| w.bits(0));
            regs.ocr0a().write(|w| w.bits(plan.gap.ocr));
            regs.ocr0b().write(|w| w.bits(plan.end.ocr));
        }
        self.plan = plan;
    }

    /// A character ended: count both deadlines from now.
    #[inline(always)]
    pub fn restart(&mut self) {
        self.gap_turns = self.plan.gap.wraps;
        self.end_turns = self.plan.end.wraps;
        // SAFETY: counter value, flag clearing (write 1), interrupt enables and the
        // clock select from the plan are all valid register contents.
        unsafe {
            self.regs.tcnt0().write(|w| w.bits(0));
            self.regs.tifr0().write(|w| w.bits(OCF0A | OCF0B));
            self.regs.timsk0().write(|w| w.bits(OCIE0A | OCIE0B));
            self.regs.tccr0b().write(|w| w.bits(self.plan.prescaler.cs_bits()));
        }
    }

    /// Compare A fired: has the gap deadline passed?
    #[inline(always)]
    pub fn on_compare_a(&mut self) -> Expired {
        if self.gap_turns > 0 {
            self.gap_turns -= 1;
            return Expired::NotYet;
        }
        self.disable(OCIE0A);
        Expired::Now
    }

    /// Compare B fired: has T3.5 passed? Then the timer stops until the next character.
    #[inline(always)]
    pub fn on_compare_b(&mut self) -> Expired {
        if self.end_turns > 0 {
            self.end_turns -= 1;
            return Expired::NotYet;
        }
        // SAFETY: stopping the clock and masking both compare interrupts.
        unsafe {
            self.regs.tccr0b().write(|w| w.bits(0));
            self.regs.timsk0().write(|w| w.bits(0));
        }
        Expired::Now
    }

    fn disable(&mut self, mask: u8) {
        // SAFETY: clears one interrupt-enable bit of TIMSK0.
        self.regs.timsk0().modify(|r, w| unsafe { w.bits(r.bits() & !mask) });
    }

    /// Gives the peripheral back.
    pub fn release(self) -> TC0 {
        self.regs
    }
}
