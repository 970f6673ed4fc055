//! The replies' timing on the Uno: turnaround at each line speed, against a blocking main
//! loop, back to back, on the largest frames, and over mixed requests while the main loop
//! runs.

use std::path::Path;

use crate::bus::Bus;
use crate::elf::firmware_path;
use crate::firmware::{firmware, CONTRACTS, ID};
use crate::log::Log;
use crate::modbus::{Expect, Request};
use crate::requests::mixed;
use crate::series::Series;
use crate::Result;

/// dip_switch presets for the turnaround: (preset, line), one and two stop bits. Pin 10 + bit
/// is low for a 1 bit.
const LINE_PRESETS: [(u8, &str); 5] =
    [(1, "9600 8E1"), (5, "9600 8N1"), (0, "19200 8E1"), (2, "19200 8N2"), (6, "115200 8E1")];
/// Requests per line speed for the turnaround.
const TURNAROUND_REQUESTS: usize = 20;
/// Requests against the blocking main loop, and the most idle time added before each.
const BUSY_REQUESTS: usize = 200;
pub(crate) const BUSY_MAX_DELAY_US: u64 = 20_000;
/// Requests against the idle `minimal` for the reference turnaround.
const IDLE_REQUESTS: usize = 20;
/// Back-to-back transactions for the throughput.
const THROUGHPUT_REQUESTS: usize = 100;

/// Mixed requests against `uno_slave` for the turnaround target, and the most idle time
/// added before each (so that they meet the main loop at every point of its pass).
pub(crate) const MIX_REQUESTS: usize = 1000;
pub(crate) const MIX_MAX_DELAY_US: u64 = 2_000;
/// Mixed requests against `sixteen_each` and `sixteen_each_bank`, checked byte for byte.
pub(crate) const CONTRACT_MIX_REQUESTS: usize = 200;

/// Every timing series of one run.
pub(crate) struct Timing {
    /// FC 3 × 10 on dip_switch at each of [`LINE_PRESETS`]: (preset, series).
    pub(crate) lines: Vec<(u8, Series)>,
    /// FC 3 × 4 against `busy_loop`, and against the idle `minimal` for reference.
    pub(crate) busy: Series,
    pub(crate) idle: Series,
    /// FC 3 × 10 back to back on `uno_slave`, and that request's length.
    pub(crate) throughput: Series,
    pub(crate) request_len: usize,
    /// The largest requests on `max_frame`, if built.
    pub(crate) big: Vec<Series>,
    /// `uno_slave`, mixed requests while its main loop runs.
    pub(crate) mix: Series,
    /// `sixteen_each` and `sixteen_each_bank` ([`CONTRACTS`]), mixed requests.
    pub(crate) contract_mix: Vec<Series>,
}

impl Timing {
    /// Runs every series.
    pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Timing> {
        let fc3x10 = Request::read(ID, 3, 0, 10, Expect::Normal);
        let mut lines = Vec::new();
        for (preset, line) in LINE_PRESETS {
            eprintln!("bench: dip_switch preset {preset} ({line})");
            let mut bus = Bus::boot(&firmware_path(root, "dip_switch"), &preset_pins(preset), None)?;
            lines.push((preset, Series::run(&mut bus, line, &fc3x10, TURNAROUND_REQUESTS, 0, log)?));
        }

        eprintln!("bench: busy_loop ({BUSY_REQUESTS} requests)");
        let fc3x4 = Request::read(ID, 3, 0, 4, Expect::Normal);
        let mut bus = Bus::boot(&firmware_path(root, "busy_loop"), &[], None)?;
        let busy = Series::run(&mut bus, "19200 8E1", &fc3x4, BUSY_REQUESTS, BUSY_MAX_DELAY_US, log)?;
        let mut bus = Bus::boot(&firmware_path(root, "minimal"), &[], None)?;
        let idle = Series::run(&mut bus, "19200 8E1", &fc3x4, IDLE_REQUESTS, BUSY_MAX_DELAY_US, log)?;

        eprintln!("bench: uno_slave throughput ({THROUGHPUT_REQUESTS} transactions)");
        let mut bus = Bus::boot(&firmware_path(root, "uno_slave"), &[], None)?;
        let throughput = Series::run(&mut bus, "19200 8E1", &fc3x10, THROUGHPUT_REQUESTS, 0, log)?;

        let big = max_frame(root, log)?;

        eprintln!("bench: uno_slave ({MIX_REQUESTS} mixed requests)");
        let uno = firmware("uno_slave");
        let mut bus = Bus::boot(&firmware_path(root, uno.name), &[], None)?;
        let requests = mixed(uno, MIX_REQUESTS, 0x0D0);
        let mix = Series::run_all(&mut bus, "19200 8E1", &requests, "mix", MIX_MAX_DELAY_US, &mut uno.model(), log)?;

        let mut contract_mix = Vec::new();
        for name in CONTRACTS {
            eprintln!("bench: {name} ({CONTRACT_MIX_REQUESTS} mixed requests)");
            let contract = firmware(name);
            let mut bus = Bus::boot(&firmware_path(root, contract.name), &[], None)?;
            let requests = mixed(contract, CONTRACT_MIX_REQUESTS, 0x16);
            let mut model = contract.model();
            let series = Series::run_all(&mut bus, "19200 8E1", &requests, "mix", MIX_MAX_DELAY_US, &mut model, log)?;
            contract_mix.push(series);
        }

        Ok(Timing { lines, busy, idle, throughput, request_len: fc3x10.frame.len(), big, mix, contract_mix })
    }

    /// Every series with a name for the tables: "firmware [what] line".
    pub(crate) fn named(&self) -> impl Iterator<Item = (String, &Series)> {
        let lines = self.lines.iter().map(|(p, s)| (format!("dip_switch preset {p} {}", s.line), s));
        let big = self.big.iter().map(|s| (format!("max_frame {}", s.line), s));
        let runs = [
            (&self.busy, "busy_loop"),
            (&self.idle, "minimal"),
            (&self.throughput, "uno_slave back to back"),
            (&self.mix, "uno_slave mix"),
        ]
        .map(|(s, name)| (format!("{name} {}", s.line), s));
        let contracts = self.contract_mix.iter().zip(CONTRACTS).map(|(s, name)| (format!("{name} mix {}", s.line), s));
        lines.chain(big).chain(runs).chain(contracts)
    }
}

/// Low pins for a dip_switch preset: pin 10 carries bit 0.
fn preset_pins(preset: u8) -> Vec<u8> {
    (0..3).filter(|bit| preset & (1 << bit) != 0).map(|bit| 10 + bit).collect()
}

/// The largest requests on the optional `max_frame` firmware (125 holding registers), at
/// 19200 and (pin 12 low) 115200 8E1; empty if it is not built.
fn max_frame(root: &Path, log: &mut Log) -> Result<Vec<Series>> {
    let elf = firmware_path(root, "max_frame");
    let mut out = Vec::new();
    if !elf.exists() {
        return Ok(out);
    }
    let requests = [Request::read(ID, 3, 0, 125, Expect::Normal), Request::write_registers(ID, 0, 123, Expect::Normal)];
    for (pins, line) in [(&[][..], "19200 8E1"), (&[12u8][..], "115200 8E1")] {
        eprintln!("bench: max_frame ({line})");
        let mut bus = Bus::boot(&elf, pins, None)?;
        for req in &requests {
            out.push(Series::run(&mut bus, line, req, 1, 0, log)?);
        }
    }
    Ok(out)
}
