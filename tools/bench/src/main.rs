//! `make bench`: figures for the example firmware, measured on the ELF files in simavr
//! (through `uno-sim`, cycle-exact USART timing) and with `avr-size`.
//!
//! First the targets of the size issues, each measured and marked met or not: the
//! `sixteen_each` contract (flash, RAM, every function code answered right) with its map
//! fixed at build time and from a run-time `Bank` (`sixteen_each_bank`), its flash as the
//! avr-hal template builds it (the sizes a user meets) beside the Arduino libraries'
//! figures, `minimal`'s flash, the USART RX interrupt's cycles, the turnaround of
//! `uno_slave` over 1000 mixed requests while its main loop reads and writes registers, and
//! what each optional feature costs against the README's claim.
//!
//! Per firmware: flash (as the template builds it, then as the repository's own target
//! does) and static RAM, stack high-water mark (free RAM painted before start-up, a request
//! of every function code, then the lowest byte that changed), and the cycles of each
//! interrupt handler. Then the turnaround at three line speeds, answers and turnaround
//! while the main loop blocks (`busy_loop`), and back-to-back throughput against the bound
//! the bus allows. If a `max_frame` firmware (125 holding registers; pin 12 low selects
//! 115200 bps) is built, FC 3 × 125 and FC 16 × 123 are timed on it too. Every reply is
//! compared byte for byte with a model of the firmware's registers (values the firmware
//! changes itself only by length). The master (feature `master`): its interrupts' cycles
//! on every chip and USART (`master_boards`, answered by a simulated slave) and the time
//! from `Master::send` to the request's first start bit (`poll_holding`); `bench master`
//! measures that part alone, printed, not written. The main loop's own critical sections
//! (`call_loop`: each call's interrupts-off cycles, and the replies' turnaround while it
//! calls the slave as fast as it can); `bench calls` measures that part alone. Modbus TCP
//! ([`tcp`]; `bench tcp` alone) and the TCP to RTU gateway's sizes and overheads with four
//! TCP masters polling three RTU slaves ([`gateway`]; `bench gateway` alone). The serial line
//! on the Uno's pins 8/9 (feature `capture-line`): its flash over the USART's, its interrupts'
//! cycles per edge and per character, the reply past T3.5, its CPU share ([`capture`];
//! `bench capture` alone). Every figure
//! comes from this run; all timings are simulated cycles, so a run on any machine gives the
//! same numbers.
//!
//! Run from the workspace with the firmware built (`make firmware`, and `make
//! bench-features` for the feature costs); prints a Markdown report and writes it to
//! `bench/results.md`. Exits with 1 if a reply was missing or wrong; a target not met is
//! reported, not a failure.
//!
//! What is measured: [`report`] gathers [`profile`] (each firmware under the workload),
//! [`timing`] (the turnaround series), [`features`], [`chips`] and [`master`]; [`render`]
//! writes the report, one function per section.

mod bus;
mod calls;
mod capture;
mod chips;
mod elf;
mod features;
mod firmware;
mod gateway;
mod log;
mod master;
mod modbus;
mod profile;
mod random;
mod readme;
mod render;
mod report;
mod requests;
mod series;
mod tcp;
mod timing;

use std::error::Error;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use log::Log;
use report::Report;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn main() -> ExitCode {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.canonicalize().unwrap_or(root);
    let mut log = Log::default();
    // `bench master`: the master's timing alone, printed and not written.
    match std::env::args().nth(1).as_deref() {
        Some("master") => return print_only(master::only(&root, &mut log), &log),
        // `bench calls`: the main loop's critical sections alone, printed and not written.
        Some("calls") => return print_only(calls::only(&root, &mut log), &log),
        // `bench tcp`: Modbus TCP alone, printed and not written.
        Some("tcp") => return print_only(tcp::only(&root, &mut log), &log),
        // `bench capture`: the serial line on pins 8/9 alone, printed and not written.
        Some("capture") => return print_only(capture::only(&root, &mut log), &log),
        // `bench gateway`: the TCP to RTU gateway alone, printed and not written.
        Some("gateway") => return print_only(gateway::only(&root, &mut log), &log),
        _ => {}
    }
    let started = Instant::now();
    let md = match Report::measure(&root, &mut log).and_then(|report| render::render(&report, &log, &root)) {
        Ok(md) => md,
        Err(e) => {
            eprintln!("bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    print!("{md}");
    let out = root.join("bench/results.md");
    if let Err(e) = std::fs::create_dir_all(root.join("bench")).and_then(|()| std::fs::write(&out, &md)) {
        eprintln!("bench: cannot write {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    eprintln!("bench: wrote bench/results.md in {:.1} s", started.elapsed().as_secs_f64());
    if log.problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        eprintln!("bench: {} wrong or missing replies (see Problems)", log.problems.len());
        ExitCode::FAILURE
    }
}

/// `bench master` or `bench calls`: one part's tables, printed.
fn print_only(md: Result<String>, log: &Log) -> ExitCode {
    match md {
        Ok(md) => {
            print!("{md}");
            log.problems.iter().for_each(|p| eprintln!("bench: {p}"));
            if log.problems.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            eprintln!("bench: {e}");
            ExitCode::FAILURE
        }
    }
}
