//! The application's own critical sections: `call_loop`, whose main loop calls the slave's
//! `get`, `set`, `get_wide`, `set_wide` and `with` (and `millis`) as fast as it can, each
//! call in a function of its own. How long each holds interrupts off (stepped instruction by
//! instruction, from its `cli` to the instruction that sets the I flag again), and the
//! replies' turnaround while those windows meet the slave's interrupts at every point.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use uno_sim::{us_to_cycles, Space, Uno};

use crate::bus::Bus;
use crate::elf::firmware_path;
use crate::firmware::ID;
use crate::log::Log;
use crate::modbus::{Expect, Request};
use crate::series::{Series, TURNAROUND_PERCENTILE};
use crate::Result;

/// The firmware.
pub(crate) const FIRMWARE: &str = "call_loop";
/// Requests for the turnaround, and the most idle time added before each (a main loop turn
/// is a few hundred µs: the requests meet it at every point).
const REQUESTS: usize = 1000;
const MAX_DELAY_US: u64 = 2_000;
/// Simulated time stepped through for the windows.
const STEP_US: u64 = 20_000;

/// One function's interrupts-off windows in the main loop.
pub(crate) struct Window {
    /// The `call_loop` function it is in (`set`, `get_wide`, …), or the symbol's name.
    pub(crate) function: String,
    pub(crate) runs: usize,
    pub(crate) min: u64,
    pub(crate) max: u64,
}

/// What `call_loop` gave.
pub(crate) struct Calls {
    /// By function, in address order.
    pub(crate) windows: Vec<Window>,
    /// FC 4 × 6 (its input registers, which the loop writes).
    pub(crate) series: Series,
}

/// Measures `call_loop`: `None` if it is not built.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Option<Calls>> {
    let elf = firmware_path(root, FIRMWARE);
    if !elf.is_file() {
        log.problems.push(format!("{} is missing: run `make firmware`", elf.display()));
        return Ok(None);
    }
    eprintln!("bench: {FIRMWARE} (interrupts-off windows, {REQUESTS} requests)");
    let windows = windows(&mut Uno::load(&elf)?)?;
    let mut bus = Bus::boot(&elf, &[], None)?;
    let fc4x6 = Request::read(ID, 4, 0, 6, Expect::Normal);
    let series = Series::run(&mut bus, "19200 8E1", &fc4x6, REQUESTS, MAX_DELAY_US, log)?;
    Ok(Some(Calls { windows, series }))
}

/// Steps the main loop with the line idle and times every interrupts-off window outside
/// the interrupt handlers, grouped by the function its `cli` is in.
fn windows(uno: &mut Uno) -> Result<Vec<Window>> {
    uno.run_until(us_to_cycles(1_000))?;
    let functions: Vec<(u32, u32, String)> = uno
        .symbols()
        .iter()
        .filter(|s| s.space == Space::Flash && s.size > 0)
        .map(|s| (s.addr, s.addr + s.size, name(&s.name)))
        .collect();
    let function_at = |pc: u32| {
        functions.iter().find(|(from, to, _)| (*from..*to).contains(&pc)).map_or(format!("{pc:#x}"), |f| f.2.clone())
    };
    let mut found: BTreeMap<u32, (String, Vec<u64>)> = BTreeMap::new();
    let mut open: Option<(u32, u64)> = None;
    let end = uno.now() + us_to_cycles(STEP_US);
    while uno.now() < end {
        let before = uno.now();
        let step = uno.step()?;
        if step.vector.is_some() || uno.in_isr().is_some() {
            continue;
        }
        let enabled = uno.sreg() & 0x80 != 0;
        match open {
            None if !enabled => open = Some((step.pc, before)),
            Some((pc, start)) if enabled => {
                let entry = found.entry(pc).or_insert_with(|| (function_at(pc), Vec::new()));
                entry.1.push(uno.now() - start);
                open = None;
            }
            _ => {}
        }
    }
    let mut by_function: Vec<Window> = Vec::new();
    for (function, cycles) in found.into_values() {
        let (min, max) = (*cycles.iter().min().unwrap_or(&0), *cycles.iter().max().unwrap_or(&0));
        match by_function.iter_mut().find(|w| w.function == function) {
            Some(w) => {
                w.runs += cycles.len();
                w.min = w.min.min(min);
                w.max = w.max.max(max);
            }
            None => by_function.push(Window { function, runs: cycles.len(), min, max }),
        }
    }
    Ok(by_function)
}

/// `call_loop`'s own functions by their name (`…9call_loop8set_wide` → `set_wide`), its
/// main loop as `main`, anything else as it is.
fn name(symbol: &str) -> String {
    if symbol.contains("avr_device_rt_main") {
        return "main".into();
    }
    let Some(at) = symbol.find("9call_loop") else {
        return symbol.into();
    };
    let rest = &symbol[at + "9call_loop".len()..];
    let digits = rest.chars().take_while(char::is_ascii_digit).count();
    rest[digits..].into()
}

/// The section: the windows, then the turnaround.
pub(crate) fn section(md: &mut String, calls: &Calls) -> Result<()> {
    writeln!(md, "\n## Main loop calling the slave as fast as it can\n")?;
    writeln!(
        md,
        "`{FIRMWARE}`: each turn of its main loop calls `set`, `millis` and `set_wide`, `get` and `set`, \
         `get_wide` and `set_wide`, and `with` (a closure that reads `master_writes`), each call in a \
         function of its own, its reference through `black_box`. Interrupts-off windows outside the \
         interrupt handlers, stepped over {} ms with the line idle, cycles from the `cli` to the \
         instruction that sets the I flag again: max is the call's own, min the function's stack \
         frame set-up (3 cycles around the stack pointer's two bytes); `main`: `millis`.\n",
        STEP_US / 1000
    )?;
    writeln!(md, "| function | windows | cycles min | max |\n|---|---:|---:|---:|")?;
    for w in &calls.windows {
        writeln!(md, "| {} | {} | {} | {} |", w.function, w.runs, w.min, w.max)?;
    }
    let s = &calls.series;
    writeln!(
        md,
        "\nFC 4 × 6 at {}, each request after a pseudo-random 0–{} ms of extra silence: {}/{} answered \
         right, turnaround p50 / p{TURNAROUND_PERCENTILE} / max {} µs past T3.5.",
        s.line,
        MAX_DELAY_US / 1000,
        s.answered(),
        s.sent,
        s.spread()
    )?;
    Ok(())
}

/// `bench calls`: the section alone, printed and not written.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let mut md = String::new();
    if let Some(calls) = measure(root, log)? {
        section(&mut md, &calls)?;
    }
    Ok(md)
}
