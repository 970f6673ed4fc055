//! `boards` on every chip and USART: sizes, interrupt cycles and turnaround.

use std::fmt::Write as _;

use crate::chips::{ChipRun, BOARD_REQUESTS};
use crate::timing::MIX_MAX_DELAY_US;
use crate::Result;

/// The table, a row per chip and USART.
pub(crate) fn section(md: &mut String, chips: &[ChipRun]) -> Result<()> {
    writeln!(md, "\n## Every chip\n")?;
    writeln!(
        md,
        "`examples/boards.rs` (sixteen_each's map, 30001 counting seconds, the board's LED) as `make firmware` \
         builds it for each chip and USART, at 19200 8E1: the workload of every function code, then \
         {BOARD_REQUESTS} mixed requests each after a random silence below {MIX_MAX_DELAY_US} µs. Interrupt \
         cycles (response to the end of RETI) are mean / max over both; the turnaround is the reply's first \
         start bit after T3.5 of the master's, counted from the request's true end, over the mixed requests.\n"
    )?;
    writeln!(
        md,
        "| chip | USART | flash (B) | RAM (B) | USART_RX | TIMER0_COMPB | USART_UDRE | USART_TX | turnaround past \
         T3.5: p50 / p99 / max | right |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for c in chips {
        write!(md, "| {} | USART{} | {} | {} |", c.chip, c.usart, c.flash, c.ram)?;
        for s in &c.isr {
            write!(md, " {:.1} / {} |", s.mean(), s.max)?;
        }
        let m = &c.mixed;
        writeln!(md, " {} µs | {}/{} + {}/{} |", m.spread(), c.right, c.sent, m.answered(), m.sent)?;
    }
    Ok(())
}
