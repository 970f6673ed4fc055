//! Arduino's `millis()` on Timer0's overflow interrupt (feature `millis`), ATmega328P
//! datasheet §15.9: Timer0 runs at clk/64 for the silence detector (`super::timer`), and
//! overflows every 256 ticks (1.024 ms, 2.048 ms at 8 MHz); the interrupt counts the
//! milliseconds ([`Uptime`]). Without the feature the overflow interrupt stays off and none of this is
//! in the firmware.

use core::cell::UnsafeCell;

use super::reg::{self, TCNT0, TIFR0};
use super::timer::{Exclusive, TOV0};
use crate::link::timing::Uptime;

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

/// Timer0 overflowed (every 1.024 ms, 2.048 at 8 MHz): the clock moves on. The overflow
/// handler's first call (`super::overflow`).
///
/// [`Uptime::after_overflow`] in place, written in assembly: the compiler adds the turn's
/// milliseconds to the `u32` through four registers (three of them zeros) and saves ten;
/// this adds a byte with carry and saves four, 40 B fewer in every firmware with a clock.
/// The host tests check `after_overflow`'s arithmetic; `tests/sim_clock.rs` checks the
/// handler's against Timer0 on the simulated chip, over the clock's whole range.
///
/// # Safety
/// Only from Timer0's overflow interrupt handler, interrupts disabled.
#[cfg(target_arch = "avr")]
#[inline(always)]
pub(crate) unsafe fn advance() {
    use crate::link::timing::TICKS_PER_MS;
    const _: () = assert!(core::mem::offset_of!(Uptime, millis) == 0 && core::mem::offset_of!(Uptime, fract) == 4);
    // SAFETY: the overflow interrupt handler, which runs with interrupts disabled, so
    // nothing else touches the clock; Z points at it: `millis` little-endian at 0 to 3,
    // `fract` at 4. `fract` + the spare ticks stays below 256 (`after_overflow`).
    unsafe {
        core::arch::asm!(
            // fract += the turn's spare ticks; a whole millisecond more when it reaches one.
            "ldd {f}, Z+4",
            "subi {f}, {minus_spare}",
            "ldi {ms}, {turn_ms}",
            "cpi {f}, {ticks}",
            "brlo 1f",
            "subi {f}, {ticks}",
            "inc {ms}",
            "1: std Z+4, {f}",
            // millis += ms, a byte at a time with the carry (`ldi` and `st` leave it alone).
            "ld {f}, Z",
            "add {f}, {ms}",
            "st Z, {f}",
            "ldi {ms}, 0",
            "ldd {f}, Z+1",
            "adc {f}, {ms}",
            "std Z+1, {f}",
            "ldd {f}, Z+2",
            "adc {f}, {ms}",
            "std Z+2, {f}",
            "ldd {f}, Z+3",
            "adc {f}, {ms}",
            "std Z+3, {f}",
            f = out(reg_upper) _,
            ms = out(reg_upper) _,
            minus_spare = const 256 - 256 % TICKS_PER_MS,
            turn_ms = const 256 / TICKS_PER_MS,
            ticks = const TICKS_PER_MS,
            inout("Z") CLOCK.0.get() => _,
            options(nostack),
        );
    }
}
