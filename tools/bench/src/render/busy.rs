//! Answers and turnaround while the main loop blocks for 500 ms at a time.

use std::fmt::Write as _;

use uno_sim::cycles_to_us;

use crate::series::TURNAROUND_PERCENTILE;
use crate::timing::{Timing, BUSY_MAX_DELAY_US};
use crate::Result;

/// The table: `busy_loop`, and the idle `minimal` for reference.
pub(crate) fn section(md: &mut String, t: &Timing) -> Result<()> {
    writeln!(md, "\n## Main loop blocking 500 ms at a time\n")?;
    writeln!(
        md,
        "FC 3 × 4 at 19200 8E1, each request after a pseudo-random 0–{} ms of extra silence ({:.1} s simulated).\n",
        BUSY_MAX_DELAY_US / 1000,
        cycles_to_us(t.busy.span) / 1e6
    )?;
    writeln!(
        md,
        "| firmware | requests | answered | turnaround p50 / p{TURNAROUND_PERCENTILE} / max µs |\n|---|---:|---:|---:|"
    )?;
    for (name, s) in [("busy_loop", &t.busy), ("minimal (idle loop, reference)", &t.idle)] {
        writeln!(
            md,
            "| {name} | {} | {:.1} % | {} |",
            s.sent,
            100.0 * s.answered() as f64 / s.sent as f64,
            s.spread()
        )?;
    }
    Ok(())
}
