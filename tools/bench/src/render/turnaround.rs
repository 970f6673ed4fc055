//! The turnaround table: each series' first reply start bit against the end of T3.5, and
//! the longest silence inside a reply over the run.

use std::fmt::Write as _;

use uno_sim::cycles_to_us;

use crate::firmware::CONTRACTS;
use crate::series::TURNAROUND_PERCENTILE;
use crate::timing::{Timing, CONTRACT_MIX_REQUESTS, MIX_MAX_DELAY_US, MIX_REQUESTS};
use crate::Result;

/// The table, a row per line speed, max_frame request and mixed series.
pub(crate) fn section(md: &mut String, t: &Timing) -> Result<()> {
    writeln!(md, "\n## Turnaround: first reply start bit − end of T3.5 after the request\n")?;
    writeln!(
        md,
        "The master counts T3.5 from the request's true end on the line, its last character's last stop bit (3.5 \
         characters at the Uno's actual bit rate; 1750 µs above 19200). The simulated USART flags each character \
         where the chip's does, at the middle of its first stop bit: half a bit before that end with one stop bit, \
         one and a half bits with two. The address byte leaves from the T3.5 interrupt, the rest after the request \
         is processed: a processing time above one character shows as a gap after the first reply byte (Modbus \
         allows at most T1.5). Turnaround: p50 / p{TURNAROUND_PERCENTILE} / max, negative for a reply that \
         started before T3.5.\n"
    )?;
    writeln!(
        md,
        "| firmware | line | request | actual bps | T3.5 µs | answered | turnaround µs | longest gap in reply µs \
         (T1.5) |\n|---|---|---|---:|---:|---:|---:|---:|"
    )?;
    let rows = t.lines.iter().map(|(p, s)| (format!("dip_switch (preset {p})"), s));
    let rows = rows.chain(t.big.iter().map(|s| ("max_frame".to_owned(), s)));
    let mixed = [(&t.mix, "uno_slave (main loop running)")].into_iter().chain(t.contract_mix.iter().zip(CONTRACTS));
    let rows = rows.chain(mixed.map(|(s, name)| (name.to_owned(), s)));
    for (firmware, s) in rows {
        writeln!(
            md,
            "| {firmware} | {} ({} bits) | {} | {:.0} | {:.0} | {}/{} | {} | {:.1} ({:.0}) |",
            s.line,
            s.char_bits,
            s.request,
            s.baud,
            cycles_to_us(s.t35),
            s.answered(),
            s.sent,
            s.spread(),
            cycles_to_us(s.max_gap),
            cycles_to_us(s.t15)
        )?;
    }

    writeln!(
        md,
        "\nmix: the eight function codes on random ranges of the firmware's tables with random values \
         ({MIX_REQUESTS} to uno_slave, {CONTRACT_MIX_REQUESTS} to sixteen_each and to sixteen_each_bank), each after 0–{} ms of extra silence.",
        MIX_MAX_DELAY_US / 1000
    )?;
    let tp = &t.throughput;
    let all = t.lines.iter().map(|(_, s)| s).chain(&t.big).chain([&t.busy, &t.idle, tp, &t.mix]).chain(&t.contract_mix);
    let worst = all.max_by(|a, b| (a.max_gap * b.t15).cmp(&(b.max_gap * a.t15))).unwrap_or(tp);
    writeln!(
        md,
        "Longest silence inside a reply over the run: {:.1} µs, T1.5 {:.0} µs ({}, {}, {}): {} (Modbus allows at most T1.5).",
        cycles_to_us(worst.max_gap),
        cycles_to_us(worst.t15),
        worst.firmware,
        worst.request,
        worst.line,
        if worst.max_gap <= worst.t15 { "within" } else { "**over**" }
    )?;
    Ok(())
}
