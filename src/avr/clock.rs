//! Arduino's `millis()` on Timer0's overflow interrupt (feature `millis`), ATmega328P
//! datasheet §15.9: Timer0 runs at clk/64 for the silence detector (`super::timer`), and
//! overflows every 256 ticks (1.024 ms, 2.048 ms at 8 MHz); the interrupt counts the
//! milliseconds ([`Uptime`]). Without the feature the overflow interrupt stays off and none of this is
//! in the firmware.

use core::cell::UnsafeCell;

use super::reg::{self, TCNT0, TIFR0};
use super::timer::{Exclusive, TOV0};
use crate::link::timing::Uptime;

/// TIMSK0's overflow interrupt enable (TOIE0).
pub(crate) const OVERFLOW_INTERRUPT: u8 = 1 << 0;

/// What the overflow interrupt keeps: the milliseconds, all zero until the slave starts
/// Timer0 (it starts once). `repr(C)`: the simulator tests read it from RAM.
#[repr(C)]
struct Clock {
    uptime: Uptime,
}

static CLOCK: Exclusive<Clock> = Exclusive(UnsafeCell::new(Clock { uptime: Uptime::ZERO }));

/// Milliseconds since the slave started: Timer0's ticks counted so far divided by 250 (125
/// at 8 MHz), rounded down, so never ahead of true time and less than a millisecond behind
/// it (0 before the start). Interrupts are off for a few cycles while it reads.
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

/// TIMER0_OVF: Timer0 overflowed (every 1.024 ms, 2.048 at 8 MHz), the clock moves on. Bound here rather
/// than by [`crate::slave!`]: it touches nothing of the slave's, and a firmware without
/// the feature has no handler at all (the interrupt stays off). The firmware's alone: the
/// host has no AVR interrupt ABI, so the docs built there (`--cfg docsrs`) leave it out.
#[cfg(target_arch = "avr")]
#[export_name = __chip!(vector TIMER0_OVF)]
unsafe extern "avr-interrupt" fn timer0_overflow() {
    // SAFETY: the overflow interrupt handler, which runs with interrupts disabled.
    unsafe { CLOCK.with(|c| c.uptime = c.uptime.after_overflow()) }
}
