//! The report, bench/results.md: a header, then its sections in order, each rendered by one
//! function of its own module.

mod busy;
mod chips;
mod features;
mod interrupts;
mod libraries;
mod sizes;
mod targets;
mod throughput;
mod turnaround;

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use crate::log::Log;
use crate::master;
use crate::report::Report;
use crate::Result;

/// The whole report in Markdown.
pub(crate) fn render(r: &Report, log: &Log, root: &Path) -> Result<String> {
    let mut md = String::new();
    header(&mut md, root)?;
    targets::section(&mut md, r, log)?;
    libraries::section(&mut md, r)?;
    master::section(&mut md, root, &r.master)?;
    crate::tcp::section(&mut md, &r.tcp)?;
    crate::gateway::section(&mut md, &r.gateway)?;
    crate::capture::section(&mut md, &r.capture)?;
    features::section(&mut md, &r.features)?;
    sizes::section(&mut md, &r.profiles)?;
    chips::section(&mut md, &r.chips)?;
    interrupts::handlers(&mut md, &r.profiles)?;
    interrupts::compare(&mut md, &r.profiles, &r.timing.big)?;
    turnaround::section(&mut md, &r.timing)?;
    busy::section(&mut md, &r.timing)?;
    if let Some(calls) = &r.calls {
        crate::calls::section(&mut md, calls)?;
    }
    throughput::section(&mut md, &r.timing)?;
    mutants(&mut md, root)?;
    footer(&mut md, log)?;
    Ok(md)
}

/// The last `make mutants` run (bench/mutants.md, which it writes), as it reported it.
fn mutants(md: &mut String, root: &Path) -> Result<()> {
    match std::fs::read_to_string(root.join("bench/mutants.md")) {
        Ok(section) => writeln!(md, "{section}")?,
        Err(_) => writeln!(md, "## Mutation testing (`make mutants`)\n\nNot run yet.\n")?,
    }
    Ok(())
}

/// "met" or "**not met**", for the targets' last column.
pub(crate) fn met_text(met: bool) -> &'static str {
    if met {
        "met"
    } else {
        "**not met**"
    }
}

/// The title, with the date, the commit (dirty: changes besides this report) and the setup.
fn header(md: &mut String, root: &Path) -> Result<()> {
    let date = Command::new("date").args(["-u", "+%Y-%m-%d %H:%M UTC"]).output()?;
    let commit = git(root, &["rev-parse", "--short", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = git(root, &["status", "--porcelain", "--", ".", ":!bench/results.md"]).is_some_and(|s| !s.is_empty());
    writeln!(md, "# Benchmarks\n")?;
    writeln!(
        md,
        "{} · commit `{commit}`{} · `make bench` · ATmega328P @ 16 MHz in simavr (uno-sim); every timing is \
         simulated cycles, so repeatable.\n",
        String::from_utf8_lossy(&date.stdout).trim(),
        if dirty { " (dirty)" } else { "" }
    )?;
    Ok(())
}

/// The wrong or missing replies, if any, and how many replies were checked.
fn footer(md: &mut String, log: &Log) -> Result<()> {
    if !log.problems.is_empty() {
        writeln!(md, "\n## Problems\n")?;
        for p in &log.problems {
            writeln!(md, "- {p}")?;
        }
    }
    writeln!(
        md,
        "\n{} replies checked byte for byte against a model of each firmware's registers (values the firmware \
         changes itself: length only), CRC included.",
        log.replies
    )?;
    Ok(())
}

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").arg("-C").arg(root).args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}
