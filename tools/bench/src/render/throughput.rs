//! Back-to-back transactions against the bound the bus allows.

use std::fmt::Write as _;

use uno_sim::{cycles_to_us, CYCLES_PER_US, F_CPU};

use crate::timing::Timing;
use crate::Result;

/// The table: transactions per second, and their share of the bus's bound.
pub(crate) fn section(md: &mut String, t: &Timing) -> Result<()> {
    // The bound: request and reply characters plus T3.5 on both sides.
    let tp = &t.throughput;
    let period = tp.span as f64 / tp.sent as f64;
    let bound = ((t.request_len + tp.reply_len) as u64 * tp.char_cycles + 2 * tp.t35) as f64;
    let pct = 100.0 * bound / period;
    let per_second = |cycles: f64| F_CPU as f64 / cycles;
    writeln!(md, "\n## Throughput\n")?;
    writeln!(
        md,
        "uno_slave, FC 3 × 10 back to back at 19200 8E1: the master sends each request T3.5 after the reply's last \
         stop bit. Bus bound per transaction: ({} + {}) characters × {} bits at the actual {:.0} bps + 2 × T3.5 \
         = {:.0} µs.\n",
        t.request_len,
        tp.reply_len,
        tp.char_bits,
        tp.baud,
        cycles_to_us(bound as u64)
    )?;
    writeln!(
        md,
        "| transactions | µs each | per second | bus bound per second | of the bound |\n|---:|---:|---:|---:|---:|"
    )?;
    writeln!(
        md,
        "| {} | {:.0} | {:.2} | {:.2} | {pct:.2} % |",
        tp.sent,
        period / CYCLES_PER_US as f64,
        per_second(period),
        per_second(bound)
    )?;
    Ok(())
}
