//! Timer0, ATmega328P datasheet §15 (8-bit Timer/Counter0): the RTU silence detector of each
//! role, and with feature `millis` the application's millisecond clock too (`super::clock`).
//! It runs freely in normal mode at clk/64 from the first role's start and is never stopped
//! or written again. Each received character sets the role's compare unit to the gap
//! deadline relative to the counter's current value; when that passes, the compare
//! interrupt moves it on to T3.5, counting the whole turns still to wait (`src/link/timing/plan.rs`
//! has the arithmetic, [`TimerPlan`]). One compare unit and one interrupt serve both
//! silences of a line: compare B a slave's ([`B`]), compare A the master's ([`A`]), so that
//! a gateway runs both roles on one timer; a second slave takes compare A in the master's
//! place (`slave!(… with TIMER0_COMPA: …)`). The units share the counter and its clock
//! (clk/64, whatever each line's baud rate): each keeps its own plan and deadlines, counted
//! from the counter's value when its own line's character arrived. The compare interrupt
//! stays enabled: with no deadline set, its match (once a turn) finds nothing to do.
//!
//! Timer0 is one peripheral, so its state lives in statics, like its registers: the
//! deadlines of each compare unit here, the clock in `super::clock`. They are only touched
//! with interrupts disabled.

use core::cell::UnsafeCell;

use core::marker::PhantomData;

use super::reg::{Reg, OCR0A, OCR0B, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
pub(crate) use crate::link::timing::Passed;
use crate::link::timing::{Schedule, TimerPlan, TIMER0_CLOCK_SELECT};

#[cfg(feature = "ascii")]
mod ascii;
#[cfg(feature = "ascii")]
use ascii::AsciiTimer;

const OCIE0A: u8 = 1 << 1;
const OCIE0B: u8 = 1 << 2;
pub(crate) const TOV0: u8 = 1 << 0;
/// TIMSK0's overflow interrupt enable (TOIE0), set when `millis()` keeps time on it
/// (feature `millis`); without it the interrupt stays off and costs nothing (unless a TCP
/// server started it, which a serial role started after it leaves on).
const OVERFLOW_INTERRUPT: u8 = if cfg!(feature = "millis") { TOIE0 } else { 0 };
/// TIMSK0's overflow interrupt enable.
pub(crate) const TOIE0: u8 = 1 << 0;
const OCF0A: u8 = 1 << 1;
const OCF0B: u8 = 1 << 2;

/// A compare unit of Timer0 and the deadlines it keeps: its register, its flag and
/// interrupt enable, its state.
pub(crate) trait Unit {
    /// OCR0x.
    const OCR: Reg;
    /// OCF0x in TIFR0 (and OCIE0x in TIMSK0: the same bit).
    const FLAG: u8;
    /// The unit's deadlines.
    fn deadlines() -> &'static Exclusive<Deadlines>;
}

/// Timer0's compare unit `C`, `'A'` or `'B'` (the slave's const parameter names it so).
pub(crate) struct Compare<const C: char>;
/// Compare B: a slave's (the one slave's, or the first of two).
pub(crate) type B = Compare<'B'>;
/// Compare A: the master's, or a second slave's.
pub(crate) type A = Compare<'A'>;

impl<const C: char> Unit for Compare<C> {
    const OCR: Reg = {
        assert!(C == 'A' || C == 'B', "Timer0 has compare units A and B");
        if C == 'A' {
            OCR0A
        } else {
            OCR0B
        }
    };
    const FLAG: u8 = if C == 'A' { OCF0A } else { OCF0B };
    #[inline(always)]
    fn deadlines() -> &'static Exclusive<Deadlines> {
        if C == 'A' {
            &DEADLINES_A
        } else {
            &DEADLINES_B
        }
    }
}

const _: () = assert!(OCF0A == OCIE0A && OCF0B == OCIE0B, "a unit's flag and enable share their bit");

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
/// how many matches of the unit's compare value the compare interrupt has seen since the last character
/// ([`Schedule::on_match`]), and the compare flags found already set when the deadline
/// was set (stale: their interrupt is not a match of the new value). The receive interrupt
/// only reads TCNT0 and TIFR0, writes the compare register, and zeroes the count.
pub(crate) struct Deadlines {
    matches: u8,
    plan: Schedule,
    stale: u8,
    /// ASCII framing (feature `ascii`), whose own events the compare interrupt reports.
    #[cfg(feature = "ascii")]
    ascii: AsciiTimer,
    /// A reply waits for its delay (feature `reply-delay`): the matches of the compare
    /// value still to let pass, and whether one is waiting.
    #[cfg(feature = "reply-delay")]
    delay: (u8, bool),
}

/// All zero until [`FrameTimer::new`] writes the plan and parks the deadlines, before any
/// of Timer0's interrupts is enabled: in `.bss`, with no initial value kept in flash.
static DEADLINES_B: Exclusive<Deadlines> = Exclusive(UnsafeCell::new(Deadlines::zero()));
/// Compare A's, as [`DEADLINES_B`].
static DEADLINES_A: Exclusive<Deadlines> = Exclusive(UnsafeCell::new(Deadlines::zero()));

impl Deadlines {
    /// No plan, no deadline: what the statics hold before a role starts.
    const fn zero() -> Deadlines {
        Deadlines {
            matches: 0,
            plan: Schedule::NONE,
            stale: 0,
            #[cfg(feature = "ascii")]
            ascii: AsciiTimer::OFF,
            #[cfg(feature = "reply-delay")]
            delay: (0, false),
        }
    }
}

/// A character arrived on the line of unit `U`: the gap deadline (and after it T3.5)
/// counts from now, first thing in the receive interrupt, so that it counts from as close
/// to RXC0 as can be (`timing::RX_LATENCY_CYCLES`). Only from the receive interrupt handler.
#[inline(always)]
pub(crate) fn on_receive<U: Unit>() {
    // SAFETY: called from the receive interrupt handler, with interrupts disabled.
    unsafe { U::deadlines().with(Deadlines::set::<U>) }
}

impl Deadlines {
    /// The gap deadline (and after it T3.5) counts from now: one read of TCNT0, no wait for
    /// a tick edge (see `timing::Deadline` for the accuracy that follows). Interrupts must be
    /// disabled.
    ///
    /// The compare interrupt stays enabled, so a compare flag already set once the compare
    /// register is written is a match of the old value during this interrupt, pending: no
    /// match of the new value can come so soon (`low` is at least 1, two tick edges away).
    /// Such a flag is noted, and its interrupt let pass. (Clearing it through TIFR0 would
    /// do on the ATmega328P, but under simavr 1.6 the simulated clock then loses turns
    /// (`tests/sim_clock.rs` saw it: the write also clears a pending overflow). And masking
    /// the compare interrupt between deadlines made simavr late by a turn: a flag that rose
    /// while masked, noted here, brought no interrupt once unmasked there, though it does
    /// on the silicon. Hence no masking, and a compare interrupt each turn.)
    #[inline(always)]
    fn set<U: Unit>(&mut self) {
        #[cfg(feature = "ascii")]
        if self.ascii.on {
            self.ascii.idle = 0;
            return;
        }
        let tcnt = TCNT0.read();
        U::OCR.write(tcnt.wrapping_add(self.plan.gap_low));
        self.stale = TIFR0.read();
        self.matches = 0;
    }

    /// No deadline until the next character: the compare interrupt, which keeps coming
    /// once a turn, finds nothing to do.
    fn park(&mut self) {
        self.matches = u8::MAX;
    }

    /// The gap deadline passed: the unit's compare value moves on to T3.5's value, and the count to the
    /// matches seen of it ([`Schedule::count_after_gap`]). TCNT0 is read before the write;
    /// when it reads T3.5's value itself, the write waits for the next tick edge (at most
    /// a tick, 64 cycles), so that whether the match comes does not hang on the moment of
    /// the write.
    ///
    /// `plan` is the plan as the interrupt read it first: read again after the volatile
    /// reads of TCNT0, it would be loaded again.
    #[inline(always)]
    fn move_to_end<U: Unit>(&mut self, plan: Schedule) {
        let gap_value = U::OCR.read();
        let to_end = plan.to_end;
        let read = TCNT0.read();
        let mut elapsed = read.wrapping_sub(gap_value);
        if to_end != 0 && elapsed == to_end {
            while TCNT0.read() == read {}
            elapsed = elapsed.wrapping_add(1);
        }
        U::OCR.write(gap_value.wrapping_add(to_end));
        self.matches = plan.count_after_gap(elapsed);
    }

    /// A compare interrupt whose flag was noted stale: lets it pass, once.
    #[inline(always)]
    fn was_stale<U: Unit>(&mut self) -> bool {
        if self.stale & U::FLAG == 0 {
            return false;
        }
        self.stale &= !U::FLAG;
        true
    }
}

/// Sets the deadlines of unit `U` from now, outside the receive interrupt.
#[inline(never)]
fn set_now<U: Unit>() {
    // SAFETY: only called by `FrameTimer::restart`, with interrupts disabled.
    unsafe { U::deadlines().with(Deadlines::set::<U>) }
}

/// A role's hold on the deadlines of Timer0's compare unit `U` (the plan lives with them,
/// above).
pub(crate) struct FrameTimer<U: Unit>(PhantomData<U>);

impl<U: Unit> FrameTimer<U> {
    /// Starts Timer0 from zero (unless the other role runs it already) with this unit's
    /// compare interrupt on (and the overflow interrupt, the clock of `millis()`, with
    /// feature `millis`) and no deadline set, for `plan`. The role took the application's
    /// `TC0` (the first of two roles a reference to it). Call with interrupts disabled.
    pub(crate) fn new(plan: TimerPlan) -> Self {
        let mut timer = FrameTimer(PhantomData);
        let running = TIMSK0.read() & (OCIE0A | OCIE0B | TOIE0);
        if running == 0 {
            // Stopped, normal mode, no output compare pins, interrupts off, counter and
            // flags cleared: from here on nothing writes TCCR0x or TCNT0 again.
            TCCR0B.write(0);
            TCCR0A.write(0);
            TCNT0.write(0);
            TIFR0.write(TOV0 | OCF0A | OCF0B);
        }
        timer.plan(plan);
        TIMSK0.write(running | OVERFLOW_INTERRUPT | U::FLAG);
        TCCR0B.write(TIMER0_CLOCK_SELECT);
        timer
    }

    fn plan(&mut self, plan: TimerPlan) {
        // SAFETY: called with interrupts disabled (by `new`, and by `configure`'s callers).
        unsafe {
            U::deadlines().with(|d| {
                d.plan = plan.schedule();
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

    /// The deadlines count from now: at start-up, and when T3.5 finds a character not yet
    /// taken (the receive interrupt sets them itself, [`on_receive`]). Interrupts must be
    /// disabled.
    pub(crate) fn restart(&mut self) {
        set_now::<U>();
    }

    /// Called at T3.5 from the compare interrupt: [`Passed::Delayed`] comes `ticks` (≥ 1)
    /// Timer0 ticks after T3.5's compare value (feature `reply-delay`), or at once when that
    /// has passed already.
    #[cfg(feature = "reply-delay")]
    pub(crate) fn delay(&mut self, ticks: u16) -> bool {
        // SAFETY: called from the compare interrupt handler, with interrupts disabled.
        unsafe {
            U::deadlines().with(|d| {
                let [turns, low] = ticks.to_be_bytes();
                let at = U::OCR.read();
                if low == 0 && turns == 0 {
                    return false;
                }
                if turns == 0 && TCNT0.read().wrapping_sub(at) >= low {
                    return false;
                }
                U::OCR.write(at.wrapping_add(low));
                d.stale = TIFR0.read();
                d.delay = (if low == 0 { turns - 1 } else { turns }, true);
                true
            })
        }
    }

    /// The unit's compare interrupt fired: which deadline passed, if one did. At the gap deadline the compare
    /// value moves on to T3.5's; after T3.5 no deadline is set until the next character, and
    /// the timer runs on. In ASCII framing: the end of a frame when one is due, the
    /// inter-character timeout as [`Passed::Gap`].
    #[inline(always)]
    pub(crate) fn on_compare(&mut self) -> Passed {
        // SAFETY: called from the compare interrupt handler, with interrupts disabled.
        unsafe {
            U::deadlines().with(|d| {
                if d.was_stale::<U>() {
                    return Passed::Nothing;
                }
                #[cfg(feature = "reply-delay")]
                if d.delay.1 {
                    if d.delay.0 != 0 {
                        d.delay.0 -= 1;
                        return Passed::Nothing;
                    }
                    d.delay.1 = false;
                    return Passed::Delayed;
                }
                #[cfg(feature = "ascii")]
                if d.ascii.on {
                    return d.ascii.on_compare();
                }
                let plan = d.plan;
                let (passed, matches) = plan.on_match(d.matches);
                d.matches = matches;
                if passed == Passed::Gap {
                    d.move_to_end::<U>(plan);
                }
                passed
            })
        }
    }
}
