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
//!
//! Four jobs, a file each: the spec's character times (`chars`), Timer0's deadline plan
//! (`plan`), the milliseconds of its overflows (`uptime`), the USART's baud divisor
//! (`baud`).

mod baud;
mod chars;
mod plan;
mod uptime;

pub use baud::*;
pub use chars::*;
pub use plan::*;
pub use uptime::*;

/// The CPU clock the crate is built for: 16 MHz (Uno, Nano, Mega, Leonardo, Pro Mini 5 V),
/// or 8 MHz (SparkFun Pro Mini 3.3 V, Pro Micro 3.3 V) when the build's environment says
/// `AVR_CPU_FREQUENCY_HZ=8000000` (build.rs, which sets `cfg(avr_cpu_frequency_hz)` and
/// refuses any other clock). Every baud divisor, silence and millisecond is worked out from
/// it while the firmware compiles.
pub const CLOCK_HZ: u32 = if cfg!(avr_cpu_frequency_hz = "8000000") { 8_000_000 } else { 16_000_000 };
