//! Timer0, ATmega328P datasheet §15 (8-bit Timer/Counter0): the application's millisecond
//! clock and the RTU silence detector at once. It runs freely in normal mode at clk/64 from
//! the slave's start and is never stopped or written again; the overflow interrupt keeps
//! [`millis`], and each received character sets compare A (the gap deadline) and compare B
//! (T3.5) relative to the counter's current value (`src/timing.rs` has the arithmetic).
//!
//! Timer0 is one peripheral, so its state lives here in two statics, like its registers:
//! the clock, and the deadlines. They are only touched with interrupts disabled.

use core::arch::asm;
use core::cell::UnsafeCell;

use super::reg::{self, OCR0A, OCR0B, TCCR0A, TCCR0B, TCNT0, TIFR0, TIMSK0};
use crate::timing::{has_passed, tick_count, Deadline, TimerPlan, Uptime, TIMER0_CLOCK_SELECT};

const TOIE0: u8 = 1 << 0;
const OCIE0A: u8 = 1 << 1;
const OCIE0B: u8 = 1 << 2;
const TOV0: u8 = 1 << 0;
const OCF0A: u8 = 1 << 1;
const OCF0B: u8 = 1 << 2;

/// A value only touched with interrupts disabled.
struct Exclusive<T>(UnsafeCell<T>);

// SAFETY: one core, and the value is only reached through `Exclusive::with`, whose callers
// have interrupts disabled, so no two accesses overlap.
unsafe impl<T: Send> Sync for Exclusive<T> {}

impl<T> Exclusive<T> {
    /// Runs `f` on the value.
    ///
    /// # Safety
    /// Interrupts must be disabled, and `f` must not reach the same value.
    #[inline(always)]
    unsafe fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        // SAFETY: with interrupts disabled nothing else holds a reference to the value.
        f(unsafe { &mut *self.0.get() })
    }
}

/// What the overflow interrupt keeps: the milliseconds, and the turns of the counter
/// (modulo 256) that extend TCNT0 to the 16-bit tick counts of the deadlines. `repr(C)`:
/// the simulator tests read it from RAM (the uptime's 5 bytes, then `turns`).
#[repr(C)]
struct Clock {
    uptime: Uptime,
    turns: u8,
}

static CLOCK: Exclusive<Clock> = Exclusive(UnsafeCell::new(Clock { uptime: Uptime::ZERO, turns: 0 }));

/// The silence deadlines: the plan of the configuration, when they were last set (the tick
/// count of the read of TCNT0 and the poll that saw the next edge), and whether the receive
/// interrupt has just set them for a new character. The compare interrupts work out when
/// their deadline passes, which keeps that arithmetic out of the receive interrupt.
struct Deadlines {
    gap: Deadline,
    end: Deadline,
    start: u16,
    polls: u8,
    set_on_receive: bool,
}

const NO_DEADLINE: Deadline = Deadline { ticks: 0, one_less_from: 0 };

static DEADLINES: Exclusive<Deadlines> = Exclusive(UnsafeCell::new(Deadlines {
    gap: NO_DEADLINE,
    end: NO_DEADLINE,
    start: 0,
    polls: 0,
    set_on_receive: false,
}));

/// Milliseconds since the slave started: Timer0's ticks counted so far divided by 250,
/// rounded down, so never ahead of true time and less than a millisecond behind it (0
/// before the start). Interrupts are off for a few cycles while it reads.
pub(crate) fn millis() -> u32 {
    let (uptime, tcnt, overflow) = reg::free(|| {
        // TCNT0 first: an overflow flag set after it is recognised by the 255 read.
        let tcnt = TCNT0.read();
        let overflow = TIFR0.read() & TOV0 != 0;
        // SAFETY: interrupts are disabled.
        (unsafe { CLOCK.with(|c| c.uptime) }, tcnt, overflow)
    });
    uptime.millis_at(tcnt, overflow)
}

/// Timer0 overflowed (every 1.024 ms): one more turn.
#[inline(always)]
pub(crate) fn on_overflow() {
    // SAFETY: called from the overflow interrupt handler, with interrupts disabled.
    unsafe {
        CLOCK.with(|c| {
            c.turns = c.turns.wrapping_add(1);
            c.uptime = c.uptime.after_overflow();
        })
    }
}

/// A character arrived: sets both deadlines from now, first thing in the receive
/// interrupt, before its handler reaches the slave, so that they count from as close to
/// RXC0 as can be (`timing::RX_LATENCY_CYCLES`). The slave's [`FrameTimer::restart`] that
/// follows only takes note. Only from the receive interrupt handler.
#[inline(always)]
pub(crate) fn on_receive() {
    // SAFETY: called from the receive interrupt handler, with interrupts disabled.
    unsafe {
        DEADLINES.with(|d| {
            d.set();
            d.set_on_receive = true;
        })
    }
}

/// Timer0's tick count now (see [`tick_count`]). Interrupts must be disabled.
#[inline(always)]
fn now() -> u16 {
    let tcnt = TCNT0.read();
    now_at(tcnt)
}

/// The tick count of a TCNT0 value read a moment ago, from the turns counted and the
/// overflow flag read after it. Interrupts must be disabled.
#[inline(always)]
fn now_at(tcnt: u8) -> u16 {
    let overflow = TIFR0.read() & TOV0 != 0;
    // SAFETY: interrupts are disabled (the callers' promise).
    tick_count(unsafe { CLOCK.with(|c| c.turns) }, tcnt, overflow)
}

/// Reads TCNT0, then polls it until it changes: returns the first value read and the poll
/// that saw the change, which places the tick edge after the read to within 5 cycles
/// (`timing::edge_after_read`; the cycle counts there describe this loop). At most 14
/// polls, 68 cycles: the counter never stops.
#[inline(always)]
fn sync_to_tick() -> (u8, u8) {
    let (tcnt, polls): (u8, u8);
    // SAFETY: reads TCNT0 (I/O address 0x26) and touches only the registers named here.
    unsafe {
        asm!(
            "in {tcnt}, 0x26",
            "ldi {polls}, 0",
            "2:",
            "in {now}, 0x26",
            "inc {polls}",
            "cp {now}, {tcnt}",
            "breq 2b",
            tcnt = out(reg) tcnt,
            polls = out(reg_upper) polls,
            now = out(reg) _,
            options(nostack),
        );
    }
    (tcnt, polls)
}

impl Deadlines {
    /// Both deadlines count from now. Interrupts must be disabled.
    ///
    /// The compare flags are not cleared: a flag left from an earlier match (one that rose
    /// while its interrupt was masked) only brings an interrupt that finds its deadline not
    /// yet due. Writing TIFR0 here could also clear a pending overflow in simavr 1.6, whose
    /// TIFR0 clears every raised flag whatever is written.
    #[inline(always)]
    fn set(&mut self) {
        let (tcnt, polls) = sync_to_tick();
        let start = now_at(tcnt);
        // The counter is past `tcnt` already, so a compare value equal to it (a deadline of
        // whole turns) can't match before its time.
        OCR0A.write(self.gap.compare_value(tcnt, polls));
        OCR0B.write(self.end.compare_value(tcnt, polls));
        TIMSK0.write(TOIE0 | OCIE0A | OCIE0B);
        (self.start, self.polls) = (start, polls);
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
    /// Not yet: an earlier match of the same compare value.
    NotYet,
    /// The deadline passed.
    Now,
}

/// The slave's hold on Timer0's deadlines (the plan lives with them, above).
pub(crate) struct FrameTimer(());

impl FrameTimer {
    /// Starts Timer0 from zero (the clock of [`millis`]) with the overflow interrupt on and
    /// no deadline set, for `plan`. The slave owns Timer0: it took the application's `TC0`.
    /// Call with interrupts disabled.
    pub(crate) fn new(plan: TimerPlan) -> Self {
        // Stopped, normal mode, no output compare pins, interrupts off, counter and flags
        // cleared: from here on nothing writes TCCR0x, TCNT0 or TIFR0 again.
        TCCR0B.write(0);
        TCCR0A.write(0);
        TIMSK0.write(0);
        TCNT0.write(0);
        TIFR0.write(TOV0 | OCF0A | OCF0B);
        // SAFETY: the slave starts with interrupts disabled.
        unsafe { CLOCK.with(|c| *c = Clock { uptime: Uptime::ZERO, turns: 0 }) };
        let mut timer = FrameTimer(());
        timer.plan(plan);
        TIMSK0.write(TOIE0);
        TCCR0B.write(TIMER0_CLOCK_SELECT);
        timer
    }

    fn plan(&mut self, plan: TimerPlan) {
        // SAFETY: called with interrupts disabled (by `new`, and by `configure`'s callers).
        unsafe {
            DEADLINES.with(|d| {
                (d.gap, d.end) = (plan.gap, plan.end);
                d.set_on_receive = false;
            })
        }
    }

    /// Switches to `plan`; no deadline is set until the next character or
    /// [`FrameTimer::restart`]. Interrupts must be disabled.
    #[cfg(feature = "eeprom-settings")]
    pub(crate) fn configure(&mut self, plan: TimerPlan) {
        TIMSK0.write(TOIE0);
        self.plan(plan);
    }

    /// A character ended: both deadlines count from it. The receive interrupt has set them
    /// already ([`on_receive`]); anywhere else (at start-up, and when T3.5 finds a
    /// character not yet taken) they count from now. Interrupts must be disabled.
    #[inline(always)]
    pub(crate) fn restart(&mut self) {
        // SAFETY: interrupts are disabled (the caller's promise).
        let set = unsafe { DEADLINES.with(|d| core::mem::replace(&mut d.set_on_receive, false)) };
        if !set {
            set_now();
        }
    }

    /// Compare A fired: has the gap deadline passed? Then compare A is masked.
    #[inline(always)]
    pub(crate) fn on_compare_a(&mut self) -> Expired {
        // SAFETY: called from the compare interrupt handler, with interrupts disabled.
        if !has_passed(unsafe { DEADLINES.with(|d| d.gap.due(d.start, d.polls)) }, now()) {
            return Expired::NotYet;
        }
        // Only the slave's interrupt handlers, which don't nest, change TIMSK0.
        TIMSK0.modify(|bits| bits & !OCIE0A);
        Expired::Now
    }

    /// Compare B fired: has T3.5 passed? Then both compare interrupts are masked until the
    /// next character; the timer runs on.
    #[inline(always)]
    pub(crate) fn on_compare_b(&mut self) -> Expired {
        // SAFETY: as above.
        if !has_passed(unsafe { DEADLINES.with(|d| d.end.due(d.start, d.polls)) }, now()) {
            return Expired::NotYet;
        }
        TIMSK0.write(TOIE0);
        Expired::Now
    }
}
