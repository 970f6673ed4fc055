//! The targets of the size issues, each with what this run measured and whether it is met:
//! the section the report opens with.

use std::fmt::Write as _;

use uno_sim::CYCLES_PER_US;

use crate::bus::IsrTotal;
use crate::firmware::CONTRACTS;
use crate::log::Log;
use crate::master;
use crate::profile::Profile;
use crate::report::Report;
use crate::series::{us, TURNAROUND_PERCENTILE};
use crate::Result;

use super::{features, met_text};

/// The contract's flash as the avr-hal template builds it, per firmware of [`CONTRACTS`]:
/// the map fixed at build time, and the one from a run-time `Bank`.
const CONTRACT_FLASH_TARGETS: [u64; 2] = [2700, 3000];
const CONTRACT_RAM_TARGET: u64 = 330;
/// The stretch target for `minimal`, as the template builds it.
const MINIMAL_FLASH_TARGET: u64 = 2048;
const RX_TARGET_CYCLES: u64 = 100;
const TURNAROUND_TARGET_US: f64 = 25.0;

/// Writes a row: (target, measured, met; `None` when not measured).
pub(crate) type Row<'a> = &'a mut dyn FnMut(String, String, Option<bool>) -> std::fmt::Result;

/// The table of targets.
pub(crate) fn section(md: &mut String, r: &Report, log: &Log) -> Result<()> {
    writeln!(md, "## Targets\n")?;
    writeln!(
        md,
        "From the size issue; every figure measured in this run. A target not met is reported here, not a \
         failure of `make bench` (that is a missing or wrong reply). Flash is as the avr-hal template builds \
         the example (target `avr-none`, `-Zbuild-std=core`, `-C target-cpu=atmega328p`: `make chips`), the \
         size a user of the template meets; the repository's own target (`avr-atmega328p.json`, `make \
         firmware`, the builds the simulator runs) follows in parentheses.\n"
    )?;
    writeln!(md, "| target | measured | met |\n|---|---|---|")?;
    let mut row = |target: String, measured: String, met: Option<bool>| {
        writeln!(md, "| {target} | {measured} | {} |", met.map_or("–", met_text))
    };
    contract_rows(&mut row, r, log)?;
    minimal_row(&mut row, r)?;
    rx_rows(&mut row, r)?;
    master::target_rows(&r.master, &mut row)?;
    turnaround_rows(&mut row, r)?;
    features::target_rows(&mut row, &r.features)?;
    Ok(())
}

/// "N B (the repository's target: M B)" for a size as the template builds it and as the
/// repository's target does.
fn sizes(template: Option<u64>, repository: Option<u64>) -> String {
    let repository = repository.map_or("not built".into(), |b| format!("{b} B"));
    match template {
        Some(b) => format!("{b} B (the repository's target: {repository})"),
        None => format!("not built (`make chips`; the repository's target: {repository})"),
    }
}

/// Per contract: flash and static RAM as the template builds it, and every function code
/// answered right.
fn contract_rows(row: Row, r: &Report, log: &Log) -> std::fmt::Result {
    let rows = CONTRACTS.into_iter().zip(CONTRACT_FLASH_TARGETS).zip(&r.timing.contract_mix);
    for ((name, flash_target), cm) in rows {
        let contract = r.profile(name);
        let template = contract.and_then(|p| p.template);
        row(
            format!("{name} as the avr-hal template builds it: flash (text+data) ≤ {flash_target} B"),
            sizes(template.map(|(flash, _)| flash), contract.map(|p| p.flash)),
            template.map(|(flash, _)| flash <= flash_target),
        )?;
        row(
            format!("{name} as the avr-hal template builds it: static RAM (data+bss) ≤ {CONTRACT_RAM_TARGET} B"),
            sizes(template.map(|(_, ram)| ram), contract.map(|p| p.ram)),
            template.map(|(_, ram)| ram <= CONTRACT_RAM_TARGET),
        )?;
        let wrong_fcs = log.failed_fcs(name);
        row(
            format!("{name}: answers FC 1, 2, 3, 4, 5, 6, 15, 16 right (byte for byte)"),
            format!(
                "workload {}/{} right, {} mixed requests {}/{} right; function codes with a wrong or missing reply: {}",
                contract.map_or(0, |p| p.right),
                contract.map_or(0, |p| p.sent),
                cm.sent,
                cm.answered(),
                cm.sent,
                if wrong_fcs.is_empty() { "none".into() } else { wrong_fcs.join(", ") }
            ),
            contract.map(|p| p.right == p.sent && cm.answered() == cm.sent && wrong_fcs.is_empty()),
        )?;
    }
    Ok(())
}

/// `minimal`'s flash as the template builds it, against the stretch target.
fn minimal_row(row: Row, r: &Report) -> std::fmt::Result {
    let minimal = r.profile("minimal");
    let template = minimal.and_then(|p| p.template);
    row(
        format!("stretch: minimal as the avr-hal template builds it: flash ≤ {MINIMAL_FLASH_TARGET} B"),
        sizes(template.map(|(flash, _)| flash), minimal.map(|p| p.flash)),
        template.map(|(flash, _)| flash <= MINIMAL_FLASH_TARGET),
    )
}

/// The USART RX interrupt's cycles: the worst mean and max over the Uno's examples, and
/// over `boards` on every chip and USART.
fn rx_rows(row: Row, r: &Report) -> std::fmt::Result {
    let worst = |stat: fn(&IsrTotal) -> f64| {
        r.profiles.iter().map(|p| (stat(&p.isr[0]), p.name)).max_by(|a, b| a.0.total_cmp(&b.0)).unwrap_or((0.0, ""))
    };
    let (rx_mean, rx_mean_name) = worst(IsrTotal::mean);
    let (rx_max, rx_max_name) = worst(|s| s.max as f64);
    let names: Vec<&str> = r.profiles.iter().map(|p: &Profile| p.name).collect();
    row(
        format!("USART RX interrupt ≤ {RX_TARGET_CYCLES} cycles per byte, mean"),
        format!("worst mean {rx_mean:.1} cycles ({rx_mean_name}), over {}", names.join(", ")),
        Some(rx_mean <= RX_TARGET_CYCLES as f64),
    )?;
    row(
        format!("USART RX interrupt ≤ {RX_TARGET_CYCLES} cycles per byte, max"),
        format!("worst max {rx_max:.0} cycles ({rx_max_name})"),
        Some(rx_max <= RX_TARGET_CYCLES as f64),
    )?;
    let chip_rx = |stat: fn(&IsrTotal) -> f64| {
        r.chips
            .iter()
            .map(|c| (stat(&c.isr[0]), format!("{} USART{}", c.chip, c.usart)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    if let (Some((mean, mean_on)), Some((max, max_on))) = (chip_rx(IsrTotal::mean), chip_rx(|s| s.max as f64)) {
        row(
            format!("every chip and USART (`boards`): USART RX interrupt ≤ {RX_TARGET_CYCLES} cycles, mean and max"),
            format!("worst mean {mean:.1} ({mean_on}), worst max {max:.0} ({max_on}), over {} builds", r.chips.len()),
            Some(mean <= RX_TARGET_CYCLES as f64 && max <= RX_TARGET_CYCLES as f64),
        )?;
    }
    Ok(())
}

/// `uno_slave`'s turnaround over the mixed requests, and the earliest reply of every series
/// and chip against T3.5.
fn turnaround_rows(row: Row, r: &Report) -> std::fmt::Result {
    let mix = &r.timing.mix;
    let p99 = mix.percentile(TURNAROUND_PERCENTILE);
    let target_cycles = (TURNAROUND_TARGET_US * CYCLES_PER_US as f64) as i64;
    row(
        format!(
            "uno_slave, main loop running: turnaround ≤ {TURNAROUND_TARGET_US:.0} µs past T3.5 at \
             p{TURNAROUND_PERCENTILE} over {} mixed requests, none before T3.5",
            mix.sent
        ),
        format!(
            "min {} µs, p50 {} µs, p{TURNAROUND_PERCENTILE} {} µs, max {} µs; {}/{} answered right",
            mix.min().map_or("–".into(), us),
            mix.percentile(50).map_or("–".into(), us),
            p99.map_or("no reply".into(), us),
            us(mix.max()),
            mix.answered(),
            mix.sent
        ),
        Some(p99.is_some_and(|c| c <= target_cycles) && mix.min().is_some_and(|c| c >= 0)),
    )?;
    let chips = r.chips.iter().map(|c| (format!("boards on the {} USART{}", c.chip, c.usart), &c.mixed));
    let series = r.timing.named().chain(chips);
    let earliest = series.filter_map(|(name, s)| Some((s.min()?, name))).min_by_key(|(c, _)| *c);
    if let Some((cycles, name)) = earliest {
        row(
            "no reply starts before T3.5 after the request's end (every series and chip)".into(),
            format!("earliest T3.5 {} µs ({name})", if cycles < 0 { us(cycles) } else { format!("+{}", us(cycles)) }),
            Some(cycles >= 0),
        )?;
    }
    Ok(())
}
