//! The master's part of the report: its rows of the targets table, its interrupts on
//! every chip, and the send latency.

use std::fmt::Write as _;

use uno_sim::cycles_to_us;

use crate::bus::IsrTotal;
use crate::chips::boards;
use crate::Result;

use super::boards::{BOARD_REQUESTS, MASTER_ISR_TARGET_CYCLES, MASTER_VECTORS};
use super::latency::LATENCY_TARGET_US;
use super::slave::{DAMAGED_REPLY, EXCEPTION_EVERY, SLAVE_DELAY_US};
use super::Measured;

/// The percentile `pct` of sorted `samples`.
fn percentile(samples: &[u64], pct: usize) -> u64 {
    let rank = (samples.len() * pct).div_ceil(100).max(1);
    samples.get(rank - 1).copied().unwrap_or(0)
}

fn cycles_us(cycles: u64) -> String {
    format!("{:.1}", cycles_to_us(cycles))
}

/// The master's rows of the targets table.
pub(crate) fn target_rows(
    m: &Measured,
    mut row: impl FnMut(String, String, Option<bool>) -> std::fmt::Result,
) -> std::fmt::Result {
    let worst = |stat: fn(&IsrTotal) -> f64| {
        m.runs
            .iter()
            .map(|r| (stat(&r.isr[0]), format!("{} USART{}", r.chip, r.usart)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    let target = format!(
        "master (`master_boards`): USART RX interrupt ≤ {MASTER_ISR_TARGET_CYCLES} cycles, mean and max, every chip"
    );
    match (worst(IsrTotal::mean), worst(|s| s.max as f64)) {
        (Some((mean, mean_on)), Some((max, max_on))) => {
            let limit = MASTER_ISR_TARGET_CYCLES as f64;
            let missing = boards().len() - m.runs.len();
            row(
                target,
                format!(
                    "worst mean {mean:.1} ({mean_on}), worst max {max:.0} ({max_on}), over {} builds{}",
                    m.runs.len(),
                    if missing > 0 { format!(" ({missing} not built: `make chips`)") } else { String::new() }
                ),
                Some(mean <= limit && max <= limit && missing == 0),
            )?;
        }
        _ => row(target, "not built (`make chips`)".into(), None)?,
    }
    let target = format!(
        "master (`poll_holding`): the request's first start bit ≤ {LATENCY_TARGET_US:.0} µs after the application asks (`Master::send` called), \
         line idle T3.5"
    );
    match &m.latency {
        Some(l) => {
            let max = l.samples.last().copied().unwrap_or(0);
            row(
                target,
                format!(
                    "min {} µs, p50 {} µs, max {} µs over {} requests (line idle ≥ {} ms, T3.5 {} ms)",
                    cycles_us(l.samples.first().copied().unwrap_or(0)),
                    cycles_us(percentile(&l.samples, 50)),
                    cycles_us(max),
                    l.samples.len(),
                    format_args!("{:.1}", cycles_to_us(l.idle_min) / 1000.0),
                    format_args!("{:.2}", cycles_to_us(l.t35) / 1000.0),
                ),
                Some(cycles_to_us(max) <= LATENCY_TARGET_US && l.idle_min >= l.t35),
            )
        }
        None => row(target, "not built (`make firmware`)".into(), None),
    }
}

/// The master's interrupts on every chip, and the send latency.
pub(super) fn timing_section(md: &mut String, m: &Measured) -> Result<()> {
    writeln!(md, "\n### The master on every chip\n")?;
    writeln!(
        md,
        "`examples/master_boards.rs` (FC 3 × 10 to slave 1, sent again as soon as the last outcome is in) as \
         `make chips` builds it for each chip and USART (target/chips/CHIP[-usartN]-master/), at 19200 8E1, \
         against a simulated slave that answers {BOARD_REQUESTS} requests T3.5 plus up to {SLAVE_DELAY_US} µs \
         after each, with exception 2 every {EXCEPTION_EVERY}th and a parity error in reply {DAMAGED_REPLY} (the \
         master drops it and asks again: {BOARD_REQUESTS} requests and a retry). \"Replies taken\": the next \
         request followed within 100 ms of the reply's end, not after a response timeout. Interrupt cycles (response to the end of RETI), mean / max, from the \
         first request on; TIMER0_COMPA also turns about once a millisecond for the timeouts.\n"
    )?;
    write!(md, "| chip | USART | flash (B) | RAM (B) |")?;
    for name in MASTER_VECTORS {
        write!(md, " {name} |")?;
    }
    writeln!(md, " requests right | replies taken | reply end → next request, µs (T3.5) |")?;
    writeln!(md, "|---|---|---:|---:|{}---:|---:|---:|", "---:|".repeat(MASTER_VECTORS.len()))?;
    for r in &m.runs {
        write!(md, "| {} | USART{} | {} | {} |", r.chip, r.usart, r.flash, r.ram)?;
        for s in &r.isr {
            write!(md, " {:.1} / {} |", s.mean(), s.max)?;
        }
        writeln!(
            md,
            " {}/{} | {}/{} | {}–{} ({}) |",
            r.right,
            r.requests,
            r.taken,
            r.replies,
            cycles_us(r.next_after.0.min(r.next_after.1)),
            cycles_us(r.next_after.1),
            cycles_us(r.t35)
        )?;
    }
    if m.runs.is_empty() {
        writeln!(md, "| not built (`make chips`) | | | | | | | | | | | |")?;
    }
    if let Some(l) = &m.latency {
        writeln!(md, "\n### The master's send latency\n")?;
        writeln!(
            md,
            "`poll_holding` on the Uno (FC 3 × 10 every 100 ms of `millis()`, each answered T3.5 plus up to \
             {SLAVE_DELAY_US} µs after it): from the entry of `poll_holding`'s `ask`, which calls `Master::send` (its ELF symbol; the simulator \
             steps to it) to the request's first start bit on the wire, over {} requests. The simulated USART \
             starts a character at the UDRn write.\n",
            l.samples.len()
        )?;
        writeln!(md, "| min µs | p50 µs | p99 µs | max µs | cycles min / max |\n|---:|---:|---:|---:|---:|")?;
        writeln!(
            md,
            "| {} | {} | {} | {} | {} / {} |",
            cycles_us(l.samples.first().copied().unwrap_or(0)),
            cycles_us(percentile(&l.samples, 50)),
            cycles_us(percentile(&l.samples, 99)),
            cycles_us(l.samples.last().copied().unwrap_or(0)),
            l.samples.first().copied().unwrap_or(0),
            l.samples.last().copied().unwrap_or(0)
        )?;
    }
    Ok(())
}
