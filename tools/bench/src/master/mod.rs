//! The master (feature `master`): its sizes beside the Arduino masters ([`sizes`]), its
//! interrupts on every chip and USART ([`boards`]) and its send latency ([`latency`]), each
//! against a simulated slave ([`slave`]); [`report`] writes its part of the report.

mod boards;
mod latency;
mod report;
mod sizes;
mod slave;

use std::fmt::Write as _;
use std::path::Path;

use crate::chips::boards;
use crate::log::Log;
use crate::Result;

use boards::{master_board_path, master_run, MasterRun, BOARD_REQUESTS};
use latency::{latency, Latency, LATENCY_REQUESTS};
pub(crate) use report::target_rows;

/// What the master's part of the bench measured.
#[derive(Default)]
pub(crate) struct Measured {
    runs: Vec<MasterRun>,
    latency: Option<Latency>,
}

/// The master's sections: its sizes beside the Arduino masters, then its timing.
pub(crate) fn section(md: &mut String, root: &Path, measured: &Measured) -> Result<()> {
    sizes::section(md, root)?;
    report::timing_section(md, measured)
}

/// Runs the master's measurements: `master_boards` on every chip and USART, then the send
/// latency on `poll_holding`.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Measured> {
    let mut m = Measured::default();
    // `master_boards` as `make chips` builds it: target/chips/CHIP[-usartN]-master/.
    for (chip, usart) in boards() {
        let elf = master_board_path(root, chip, usart);
        if !elf.is_file() {
            log.problems.push(format!("{} is missing: run `make chips`", elf.display()));
            continue;
        }
        eprintln!("bench: master_boards on the {chip}, USART{usart} ({BOARD_REQUESTS} requests)");
        m.runs.push(master_run(&elf, chip, usart, log)?);
    }
    eprintln!("bench: poll_holding, ask (Master::send) to the first start bit ({LATENCY_REQUESTS} requests)");
    m.latency = latency(root, log)?;
    Ok(m)
}

/// `bench master`: the master's timing alone (targets and tables), not written to
/// bench/results.md; for working on the master without the whole bench.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let m = measure(root, log)?;
    let mut md = String::new();
    writeln!(md, "| target | measured | met |\n|---|---|---|")?;
    target_rows(&m, |target, measured, met| {
        writeln!(md, "| {target} | {measured} | {} |", met.map_or("–", crate::render::met_text))
    })?;
    report::timing_section(&mut md, &m)?;
    Ok(md)
}
