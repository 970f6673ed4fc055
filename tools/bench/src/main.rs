//! `make bench`: figures for the example firmware, measured on the ELF files in simavr
//! (through `uno-sim`, cycle-exact USART timing) and with `avr-size`.
//!
//! First the targets of the size issues, each measured and marked met or not: the
//! `sixteen_each` contract (flash, RAM, every function code answered right) with its map
//! fixed at build time and from a run-time `Bank` (`sixteen_each_bank`), beside the Arduino
//! libraries' figures, `minimal`'s flash, the USART RX interrupt's cycles, the
//! turnaround of `uno_slave` over 1000 mixed requests while its main loop reads and writes
//! registers, and what each optional feature costs against the README's claim.
//!
//! Per firmware: flash and static RAM, stack high-water mark (free RAM painted before
//! start-up, a request of every function code, then the lowest byte that changed), and the
//! cycles of each interrupt handler. Then the turnaround at three line speeds, answers and
//! turnaround while the main loop blocks (`busy_loop`), and back-to-back throughput against
//! the bound the bus allows. If a `max_frame` firmware (125 holding registers; pin 12 low
//! selects 115200 bps) is built, FC 3 × 125 and FC 16 × 123 are timed on it too. Every
//! reply is compared byte for byte with a model of the firmware's registers (values the
//! firmware changes itself only by length). The master (feature `master`): its interrupts'
//! cycles on every chip and USART (`master_boards`, answered by a simulated slave) and the
//! time from `Master::send` to the request's first start bit (`poll_holding`); `bench
//! master` measures that part alone, printed, not written. Every figure comes from this
//! run; all timings are simulated cycles, so a run on any machine gives the same numbers.
//!
//! Run from the workspace with the firmware built (`make firmware`, and `make
//! bench-features` for the feature costs); prints a Markdown report and writes it to
//! `bench/results.md`. Exits with 1 if a reply was missing or wrong; a target not met is
//! reported, not a failure.

mod bus;
mod master;
mod modbus;

use std::error::Error;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use bus::{Bus, IsrTotal, Transaction, RAMEND, VECTORS};
use modbus::{Expect, Model, Request};
use uno_sim::{cycles_to_us, us_to_cycles, Chip, CYCLES_PER_US};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// Where `make firmware` puts the ELF files, relative to the workspace.
const FIRMWARE_DIR: &str = "target/avr-atmega328p/release/examples";
/// Slave id of every example (lab_lights: button box, pin 12 open).
const ID: u8 = 1;

/// Where `make bench-features` puts `minimal` built with each optional feature.
const FEATURES_DIR: &str = "target/bench-features";

/// An example firmware and its data model at the default pin settings (from the register
/// table in the header of `examples/<name>.rs`); all tables start at address 0.
struct Firmware {
    name: &'static str,
    coils: u16,
    inputs: u16,
    input_regs: u16,
    holding: u16,
    /// Ranges (first reference, count) whose values the firmware sets itself: replies are
    /// not compared there.
    changing: &'static [(u32, u16)],
    /// References that start at a value other than 0.
    initial: &'static [(u32, u16)],
}

impl Firmware {
    const fn new(name: &'static str, [coils, inputs, input_regs, holding]: [u16; 4]) -> Firmware {
        Firmware { name, coils, inputs, input_regs, holding, changing: &[], initial: &[] }
    }

    /// The master's view of the registers just after start-up.
    fn model(&self) -> Model {
        Model::new([self.coils, self.inputs, self.input_regs, self.holding], self.changing, self.initial)
    }

    /// Bytes of register and bit values: 2 per register, 1 bit per coil or input.
    fn values(&self) -> u64 {
        2 * u64::from(self.input_regs + self.holding) + u64::from(self.coils + self.inputs).div_ceil(8)
    }
}

const FIRMWARE: [Firmware; 7] = [
    Firmware { changing: &[(40002, 2)], ..Firmware::new("minimal", [0, 0, 0, 4]) },
    Firmware {
        changing: &[(10001, 4), (30001, 12)],
        initial: &[(40001, 500), (40002, 512)],
        ..Firmware::new("uno_slave", [5, 4, 12, 10])
    },
    Firmware { changing: &[(30001, 1), (40004, 1)], ..Firmware::new("busy_loop", [0, 0, 1, 4]) },
    Firmware { changing: &[(10001, 2)], ..Firmware::new("lab_lights", [0, 2, 0, 0]) },
    Firmware { changing: &[(10001, 3), (30001, 1)], ..Firmware::new("dip_switch", [16, 3, 1, 10]) },
    Firmware::new("sixteen_each", [16, 16, 8, 16]),
    Firmware::new("sixteen_each_bank", [16, 16, 8, 16]),
];

fn firmware(name: &str) -> &'static Firmware {
    FIRMWARE.iter().find(|fw| fw.name == name).expect("firmware in the table")
}

/// dip_switch presets for the turnaround: (preset, line), one and two stop bits. Pin 10 + bit
/// is low for a 1 bit.
const LINE_PRESETS: [(u8, &str); 5] =
    [(1, "9600 8E1"), (5, "9600 8N1"), (0, "19200 8E1"), (2, "19200 8N2"), (6, "115200 8E1")];
/// Requests per line speed for the turnaround.
const TURNAROUND_REQUESTS: usize = 20;
/// Requests against the blocking main loop, and the most idle time added before each.
const BUSY_REQUESTS: usize = 200;
const BUSY_MAX_DELAY_US: u64 = 20_000;
/// Requests against the idle `minimal` for the reference turnaround.
const IDLE_REQUESTS: usize = 20;
/// Back-to-back transactions for the throughput.
const THROUGHPUT_REQUESTS: usize = 100;

/// Mixed requests against `uno_slave` for the turnaround target, and the most idle time
/// added before each (so that they meet the main loop at every point of its pass).
const MIX_REQUESTS: usize = 1000;
const MIX_MAX_DELAY_US: u64 = 2_000;
/// Mixed requests against `sixteen_each` and `sixteen_each_bank`, checked byte for byte.
const CONTRACT_MIX_REQUESTS: usize = 200;
/// The contract's two firmware: its map fixed at build time, and from a run-time `Bank`.
const CONTRACTS: [&str; 2] = ["sixteen_each", "sixteen_each_bank"];

/// Targets from the size issues (the same for the contract from a `Bank`).
const CONTRACT_FLASH_TARGET: u64 = 3000;
const CONTRACT_RAM_TARGET: u64 = 330;
const MINIMAL_FLASH_TARGET: u64 = 2048;
const RX_TARGET_CYCLES: u64 = 100;
const TURNAROUND_TARGET_US: f64 = 25.0;
const TURNAROUND_PERCENTILE: usize = 99;
/// A feature's cost meets the README's claim within this share of the claim or
/// [`FEATURE_SLACK_BYTES`], whichever is larger.
const FEATURE_SLACK_PCT: u64 = 10;
const FEATURE_SLACK_BYTES: u64 = 64;

/// The Arduino libraries the issue compares with, on the same register set at 19200 8E1:
/// (library, flash B, static RAM). Quoted from the issue, not measured here.
const LIBRARIES: [(&str, u64, &str); 3] = [
    ("smarmengol ModbusRtu", 3746, "319 B"),
    ("CMB27 ModbusRTUSlave 3.1", 4986, "309 B"),
    ("emelianov modbus-esp8266 4.1", 10038, "270 B + heap"),
];

/// Optional features measured on `minimal` (`make bench-features`).
const FEATURES: [&str; 7] = ["extra-fc", "diagnostics", "write-protect", "device-id", "millis", "ascii", "reply-delay"];

/// A request of every function code the examples serve, each answered normally where the
/// table exists and with exception 02 where it does not, plus FC 3 × 125 and an unsupported
/// function code.
fn workload(fw: &Firmware) -> Vec<Request> {
    let expect = |n: u16| if n > 0 { Expect::Normal } else { Expect::Exception(2) };
    let (c, i, h, r) = (fw.coils, fw.inputs, fw.holding, fw.input_regs);
    vec![
        Request::read(ID, 1, 0, c.max(1), expect(c)),
        Request::read(ID, 2, 0, i.max(1), expect(i)),
        Request::read(ID, 3, 0, h.max(1), expect(h)),
        Request::read(ID, 4, 0, r.max(1), expect(r)),
        Request::write_single(ID, 5, 0, 0xFF00, expect(c)),
        Request::write_single(ID, 6, 0, 1234, expect(h)),
        Request::write_coils(ID, 0, c.max(1), expect(c)),
        Request::write_registers(ID, 0, h.max(1), expect(h)),
        Request::read(ID, 3, 0, 125, if h >= 125 { Expect::Normal } else { Expect::Exception(2) }),
        Request::raw("FC 65 (unsupported)", ID, &[0x41, 0, 0, 0, 1], Expect::Exception(1)),
        // Read back what the writes left.
        Request::read(ID, 1, 0, c.max(1), expect(c)),
        Request::read(ID, 3, 0, h.max(1), expect(h)),
    ]
}

/// `count` requests, each of one of the eight function codes picked at random, on a
/// random range inside its table, with random values: all answered normally.
fn mixed(fw: &Firmware, count: usize, seed: u64) -> Vec<Request> {
    let mut rng = Lcg(seed);
    let mut requests = Vec::with_capacity(count);
    while requests.len() < count {
        let fc = [1u8, 2, 3, 4, 5, 6, 15, 16][rng.below(8) as usize];
        let size = match fc {
            1 | 5 | 15 => fw.coils,
            2 => fw.inputs,
            4 => fw.input_regs,
            _ => fw.holding,
        };
        if size == 0 {
            continue;
        }
        let start = rng.below(u64::from(size)) as u16;
        let qty = 1 + rng.below(u64::from(size - start)) as u16;
        let bit = |rng: &mut Lcg| rng.below(2) == 1;
        requests.push(match fc {
            5 => Request::write_single(ID, 5, start, if bit(&mut rng) { 0xFF00 } else { 0 }, Expect::Normal),
            6 => Request::write_single(ID, 6, start, rng.below(0x1_0000) as u16, Expect::Normal),
            15 => {
                let bits: Vec<bool> = (0..qty).map(|_| bit(&mut rng)).collect();
                Request::write_coil_values(ID, start, &bits, Expect::Normal)
            }
            16 => {
                let values: Vec<u16> = (0..qty).map(|_| rng.below(0x1_0000) as u16).collect();
                Request::write_register_values(ID, start, &values, Expect::Normal)
            }
            _ => Request::read(ID, fc, start, qty, Expect::Normal),
        });
    }
    requests
}

/// What the run found, besides the figures: wrong or missing replies.
#[derive(Default)]
struct Log {
    problems: Vec<String>,
    /// (where, function code) of each wrong or missing reply.
    failed: Vec<(String, u8)>,
    max_turnaround: i64,
    replies: usize,
}

impl Log {
    /// Function codes that got a wrong or missing reply from `firmware`, in order.
    fn failed_fcs(&self, firmware: &str) -> Vec<String> {
        let mut fcs: Vec<u8> = self
            .failed
            .iter()
            .filter(|(what, _)| what.split(' ').next() == Some(firmware))
            .map(|&(_, fc)| fc)
            .collect();
        fcs.sort_unstable();
        fcs.dedup();
        fcs.iter().map(|fc| format!("FC {fc}")).collect()
    }

    /// Checks a reply against `model` and keeps its turnaround; returns it in cycles if the
    /// reply is right.
    fn check(&mut self, what: &str, req: &Request, t: &Transaction, model: &mut Model) -> Option<i64> {
        if let Err(e) = req.check(&t.reply, model) {
            let problem = if t.reply.is_empty() { format!("{}: no reply", req.label) } else { e };
            self.problems.push(format!("{what}: {problem}"));
            self.failed.push((what.to_owned(), req.frame[1]));
            return None;
        }
        let cycles = t.turnaround?;
        self.replies += 1;
        self.max_turnaround = self.max_turnaround.max(cycles);
        Some(cycles)
    }
}

/// Measurements of one firmware under the workload.
struct Profile {
    name: &'static str,
    flash: u64,
    ram: u64,
    /// Bytes of register and bit values in the example's data model.
    values: u64,
    stack: u16,
    isr: [IsrTotal; VECTORS.len()],
    /// (request label, gap deadline and T3.5 interrupt cycles) per workload request.
    t35: Vec<(String, u64, u64)>,
    /// Workload requests answered right, of those sent.
    right: usize,
    sent: usize,
}

fn label(req: &Request) -> String {
    match req.expect {
        Expect::Normal => req.label.clone(),
        Expect::Exception(code) => format!("{} → exception {code:02}", req.label),
    }
}

/// Sizes, stack high-water mark, interrupt cycles and per-request T3.5 cycles of one firmware.
fn profile(root: &Path, fw: &Firmware, log: &mut Log) -> Result<Profile> {
    let elf = firmware_path(root, fw.name);
    let (flash, ram) = avr_size(&elf)?;
    let requests = workload(fw);
    let mut stack = 0;
    let mut isr = [IsrTotal::default(); VECTORS.len()];
    let mut t35 = Vec::new();
    // Two passes with complementary patterns: a stack byte that happens to equal the
    // pattern cannot hide the high-water mark in both.
    let problems = log.problems.len();
    for (pass, pattern) in [0xA5u8, 0x5A].into_iter().enumerate() {
        let mut bus = Bus::boot(&elf, &[], Some(pattern))?;
        let mut model = fw.model();
        for req in &requests {
            let t = bus.transact(req, 0)?;
            if pass == 0 {
                log.check(fw.name, req, &t, &mut model);
                t35.push((label(req), t.gap_isr, t.t35_isr));
            }
        }
        stack = stack.max(bus.stack_used(pattern)?);
        if pass == 0 {
            isr = bus.isr;
        }
    }
    let sent = requests.len();
    let right = sent - (log.problems.len() - problems);
    Ok(Profile { name: fw.name, flash, ram, values: fw.values(), stack, isr, t35, right, sent })
}

fn firmware_path(root: &Path, name: &str) -> PathBuf {
    root.join(FIRMWARE_DIR).join(format!("{name}.elf"))
}

/// `name` as the avr-hal template builds it for the Uno (target `avr-none`, `build-std`;
/// `make firmware` puts it there): its (flash, static RAM), or `None` if not built.
fn template_size(root: &Path, name: &str) -> Option<(u64, u64)> {
    avr_size(&chip_build_path(root, Chip::Atmega328p.name(), name)).ok()
}

/// Example `name` of `make chips`' build `build` (`CHIP`, `CHIP-usartN`; `.ci/chip-build`).
fn chip_build_path(root: &Path, build: &str, name: &str) -> PathBuf {
    root.join("target/chips").join(build).join("avr-none/release/examples").join(format!("{name}.elf"))
}

/// (flash = text + data, static RAM = data + bss) from `avr-size`.
fn avr_size(elf: &Path) -> Result<(u64, u64)> {
    let out = Command::new("avr-size").arg(elf).output().map_err(|e| format!("avr-size: {e}"))?;
    if !out.status.success() {
        return Err(format!("avr-size {}: {}", elf.display(), String::from_utf8_lossy(&out.stderr).trim()).into());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let nums: Vec<u64> =
        text.lines().nth(1).unwrap_or("").split_whitespace().take(3).filter_map(|w| w.parse().ok()).collect();
    match nums[..] {
        [text, data, bss] => Ok((text + data, data + bss)),
        _ => Err(format!("cannot read avr-size output: {text}").into()),
    }
}

fn us(cycles: i64) -> String {
    format!("{:.1}", cycles as f64 / CYCLES_PER_US as f64)
}

fn met_text(met: bool) -> &'static str {
    if met {
        "met"
    } else {
        "**not met**"
    }
}

/// Low pins for a dip_switch preset: pin 10 carries bit 0.
fn preset_pins(preset: u8) -> Vec<u8> {
    (0..3).filter(|bit| preset & (1 << bit) != 0).map(|bit| 10 + bit).collect()
}

/// A reproducible pseudo-random sequence (64-bit LCG, Knuth's MMIX constants).
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: u64) -> u64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) % n
    }
}

/// One request repeated on one line setting, and how the replies came.
struct Series {
    /// Firmware name.
    firmware: String,
    /// Line setting, e.g. "19200 8E1".
    line: String,
    /// Request label.
    request: String,
    /// The Uno's actual bit rate and bits per character.
    baud: f64,
    char_bits: u32,
    /// Character time, cycles.
    char_cycles: u64,
    /// The master's T3.5 and T1.5, cycles.
    t35: u64,
    t15: u64,
    /// Requests sent.
    sent: usize,
    /// Turnarounds of the right replies, cycles, sorted.
    turnarounds: Vec<i64>,
    /// Longest silence inside a reply, cycles.
    max_gap: u64,
    /// Longest gap deadline and T3.5 interrupt runs, cycles.
    gap_isr: u64,
    t35_isr: u64,
    /// Length of the last reply, bytes.
    reply_len: usize,
    /// From the first request's start bit to T3.5 after the last reply, cycles.
    span: u64,
}

impl Series {
    /// Sends `req` `count` times on `bus`, each after a pseudo-random extra silence below
    /// `max_delay_us` (0: back to back, T3.5 after the previous reply).
    fn run(bus: &mut Bus, line: &str, req: &Request, count: usize, max_delay_us: u64, log: &mut Log) -> Result<Series> {
        let mut model = firmware_model(bus.name());
        Series::run_all(bus, line, &vec![req.clone(); count], &req.label, max_delay_us, &mut model, log)
    }

    /// Sends `requests` in order on `bus` (labelled `label` in the tables), each after a
    /// pseudo-random extra silence below `max_delay_us`, checking the replies against `model`.
    fn run_all(
        bus: &mut Bus,
        line: &str,
        requests: &[Request],
        label: &str,
        max_delay_us: u64,
        model: &mut Model,
        log: &mut Log,
    ) -> Result<Series> {
        let mut rng = Lcg(0x5EED);
        let first = bus.idle_from();
        let count = requests.len();
        let mut s = Series {
            firmware: bus.name().to_owned(),
            line: line.to_owned(),
            request: label.to_owned(),
            baud: bus.baud,
            char_bits: bus.char_bits,
            char_cycles: bus.char_cycles,
            t35: bus.t35,
            t15: bus.t15,
            sent: count,
            turnarounds: Vec::with_capacity(count),
            max_gap: 0,
            gap_isr: 0,
            t35_isr: 0,
            reply_len: 0,
            span: 0,
        };
        for req in requests {
            let delay = if max_delay_us == 0 { 0 } else { us_to_cycles(rng.below(max_delay_us)) };
            let t = bus.transact(req, delay)?;
            s.max_gap = s.max_gap.max(t.max_gap);
            s.gap_isr = s.gap_isr.max(t.gap_isr);
            s.t35_isr = s.t35_isr.max(t.t35_isr);
            s.reply_len = t.reply.len();
            s.turnarounds.extend(log.check(&format!("{} {line}", bus.name()), req, &t, model));
        }
        s.turnarounds.sort_unstable();
        s.span = bus.idle_from() - first;
        Ok(s)
    }

    fn answered(&self) -> usize {
        self.turnarounds.len()
    }

    fn median(&self) -> i64 {
        self.percentile(50).unwrap_or(0)
    }

    fn max(&self) -> i64 {
        self.turnarounds.last().copied().unwrap_or(0)
    }

    /// The earliest turnaround (negative: a reply that started before T3.5 had passed).
    fn min(&self) -> Option<i64> {
        self.turnarounds.first().copied()
    }

    /// "p50 / p99 / max" in µs.
    fn spread(&self) -> String {
        format!(
            "{} / {} / {}",
            us(self.median()),
            self.percentile(TURNAROUND_PERCENTILE).map_or("–".into(), us),
            us(self.max())
        )
    }

    /// The turnaround `pct` % of the requests sent came within; `None` if that many were
    /// not answered right.
    fn percentile(&self, pct: usize) -> Option<i64> {
        let rank = (self.sent * pct).div_ceil(100).max(1);
        self.turnarounds.get(rank - 1).copied()
    }
}

/// The model of a firmware in [`FIRMWARE`] by name; one that knows nothing for others
/// (`max_frame`: 125 holding registers kept for the master, all 0 at start-up).
fn firmware_model(name: &str) -> Model {
    match FIRMWARE.iter().find(|fw| fw.name == name) {
        Some(fw) => fw.model(),
        None if name == "max_frame" => Model::new([0, 0, 0, 125], &[], &[]),
        None => Model::new([0; 4], &[], &[]),
    }
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

/// Every chip and USART the crate serves: `examples/boards.rs` is built for each (`make chips`;
/// the ATmega328P's from `make firmware`), and `examples/master_boards.rs` too: (chip, USART).
pub(crate) const BOARDS: [(Chip, u8); 11] = [
    (Chip::Atmega328p, 0),
    (Chip::Atmega168, 0),
    (Chip::Atmega32u4, 1),
    (Chip::Atmega1280, 0),
    (Chip::Atmega1280, 1),
    (Chip::Atmega1280, 2),
    (Chip::Atmega1280, 3),
    (Chip::Atmega2560, 0),
    (Chip::Atmega2560, 1),
    (Chip::Atmega2560, 2),
    (Chip::Atmega2560, 3),
];
/// Mixed requests per chip and USART, each after a random silence (the turnaround's spread).
const BOARD_REQUESTS: usize = 200;

/// `examples/boards.rs`'s map: sixteen_each's, with 30001 counting seconds.
const BOARDS_MAP: Firmware = Firmware { changing: &[(30001, 1)], ..Firmware::new("boards", [16, 16, 8, 16]) };

/// Where `boards` is for `chip` and `usart`: as tests/sim/mod.rs's `chip_firmware_path`.
fn board_path(root: &Path, chip: Chip, usart: u8) -> PathBuf {
    if chip == Chip::Atmega328p && usart == 0 {
        return firmware_path(root, "boards");
    }
    let dir =
        if usart == chip.default_usart() { chip.name().to_owned() } else { format!("{}-usart{usart}", chip.name()) };
    chip_build_path(root, &dir, "boards")
}

/// `boards` on one chip and USART: sizes, interrupt cycles over the workload and the mixed
/// requests, and the turnaround of the mixed requests.
struct ChipRun {
    chip: Chip,
    usart: u8,
    flash: u64,
    ram: u64,
    isr: [IsrTotal; VECTORS.len()],
    /// Workload requests answered right, of those sent.
    right: usize,
    sent: usize,
    mixed: Series,
}

fn chip_runs(root: &Path, log: &mut Log) -> Result<Vec<ChipRun>> {
    let mut runs = Vec::new();
    for (chip, usart) in BOARDS {
        let elf = board_path(root, chip, usart);
        if !elf.is_file() {
            log.problems.push(format!("{} is missing: run `make firmware`", elf.display()));
            continue;
        }
        eprintln!("bench: boards on the {chip}, USART{usart} (workload, {BOARD_REQUESTS} mixed requests)");
        let (flash, ram) = avr_size(&elf)?;
        let mut bus = Bus::boot_on(&elf, usart)?;
        let mut model = BOARDS_MAP.model();
        let problems = log.problems.len();
        let requests = workload(&BOARDS_MAP);
        let what = format!("boards ({chip}, USART{usart})");
        for req in &requests {
            let t = bus.transact(req, 0)?;
            log.check(&what, req, &t, &mut model);
        }
        let right = requests.len() - (log.problems.len() - problems);
        let mixed_requests = mixed(&BOARDS_MAP, BOARD_REQUESTS, 0xB0A2D);
        let mixed = Series::run_all(&mut bus, "19200 8E1", &mixed_requests, "mix", MIX_MAX_DELAY_US, &mut model, log)?;
        runs.push(ChipRun { chip, usart, flash, ram, isr: bus.isr, right, sent: requests.len(), mixed });
    }
    Ok(runs)
}

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").arg("-C").arg(root).args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// Everything measured in one run.
struct Report {
    profiles: Vec<Profile>,
    /// FC 3 × 10 on dip_switch at each of [`LINE_PRESETS`]: (preset, series).
    lines: Vec<(u8, Series)>,
    busy: Series,
    idle: Series,
    throughput: Series,
    request_len: usize,
    big: Vec<Series>,
    /// `uno_slave`, mixed requests while its main loop runs.
    mix: Series,
    /// `sixteen_each` and `sixteen_each_bank` ([`CONTRACTS`]), mixed requests.
    contract_mix: Vec<Series>,
    /// Feature costs on `minimal`, then `configurable`'s total.
    features: Vec<FeatureCost>,
    /// `boards` on every chip and USART.
    chips: Vec<ChipRun>,
    /// The master: `master_boards` on every chip and USART, `poll_holding`'s send latency.
    master: master::Measured,
}

/// An optional feature: what it costs as measured, and what the README says.
struct FeatureCost {
    feature: String,
    /// What was measured, e.g. "`minimal` + feature − `minimal`".
    how: String,
    /// (flash, RAM) measured: a difference, or a total for `total` rows; `None` if not built.
    measured: Option<(i64, i64)>,
    /// The README's claim (its table's cell) and the figure in it compared with.
    claim: Option<(String, i64)>,
    /// Whether `measured` is a total (configurable) rather than a difference.
    total: bool,
}

impl FeatureCost {
    fn met(&self) -> Option<bool> {
        let ((flash, _), (_, claim)) = (self.measured?, self.claim.as_ref()?);
        let slack = (claim.unsigned_abs() * FEATURE_SLACK_PCT / 100).max(FEATURE_SLACK_BYTES);
        Some(flash.abs_diff(*claim) <= slack)
    }
}

/// The README's cell for `feature` in the table of optional features (the row that starts
/// with "| `feature` |"), and the claimed cost in it: the first "+N B" or "+N.N KB" figure,
/// or with `total`, the "N B in all" figure.
fn readme_claim(root: &Path, feature: &str, total: bool) -> Option<(String, i64)> {
    let readme = std::fs::read_to_string(root.join("README.md")).ok()?;
    // The first row of a table for the feature whose last cell has a figure (other tables,
    // QModMaster's for one, name the `ascii` example in their first column too).
    readme.lines().filter(|l| l.starts_with(&format!("| `{feature}` |"))).find_map(|row| {
        let cell = row.trim_end().trim_end_matches('|').rsplit('|').next()?.trim().to_owned();
        let figure = if total { figure_before(&cell, " B in all")? } else { signed_figure(&cell)? };
        Some((cell, figure))
    })
}

/// The number (digits, spaces as thousands separators) that ends right before `suffix`.
fn figure_before(text: &str, suffix: &str) -> Option<i64> {
    let head = &text[..text.find(suffix)?];
    let digits: String = head.chars().rev().take_while(|c| c.is_ascii_digit() || *c == ' ').collect();
    digits.chars().rev().filter(char::is_ascii_digit).collect::<String>().parse().ok()
}

/// The first "+N B" or "+N.N KB" (1 KB = 1000 B) in `text`.
fn signed_figure(text: &str) -> Option<i64> {
    let rest = &text[text.find('+')? + 1..];
    let number: String = rest.chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    let value: f64 = number.parse().ok()?;
    let unit = rest[number.len()..].trim_start();
    let scale = if unit.starts_with("KB") || unit.starts_with("kB") { 1000.0 } else { 1.0 };
    Some((value * scale).round() as i64)
}

/// Flash and RAM of `minimal` with each optional feature against the plain build (both
/// from `make bench-features`), and `configurable`'s total from `make firmware`.
fn feature_costs(root: &Path) -> Vec<FeatureCost> {
    let features = root.join(FEATURES_DIR);
    let plain = avr_size(&features.join("minimal.elf")).ok();
    let minimal_src = std::fs::read_to_string(root.join("examples/minimal.rs")).unwrap_or_default();
    let mut out: Vec<FeatureCost> = FEATURES
        .iter()
        .map(|feature| {
            let with = avr_size(&features.join(format!("minimal+{feature}.elf"))).ok();
            let measured = plain.zip(with).map(|((f0, r0), (f1, r1))| (f1 as i64 - f0 as i64, r1 as i64 - r0 as i64));
            let mut how = format!("`minimal` with `{feature}` − `minimal`");
            let mut claim = readme_claim(root, feature, false);
            // A cost that only comes with a call (write-protect: `Bank::protect`) is not
            // there in a build that never makes it: then the README's "0 B unless enabled"
            // is what this build can check.
            if let Some((cell, figure)) = &mut claim {
                if cell.contains("0 B unless enabled") && !minimal_src.contains(".protect(") {
                    *figure = 0;
                    how.push_str(
                        "; minimal never calls `Bank::protect`, so this checks the README's \"0 B unless enabled\" \
                         (its one-range figure needs a build that protects a range)",
                    );
                }
            }
            FeatureCost { feature: (*feature).to_owned(), how, measured, claim, total: false }
        })
        .collect();
    let configurable = avr_size(&firmware_path(root, "configurable")).ok();
    out.push(FeatureCost {
        feature: "eeprom-settings".into(),
        how:
            "`configurable` in all (`make firmware`: with eeprom-settings, diagnostics, extra-fc, write-protect, ascii, device-id)"
                .into(),
        measured: configurable.map(|(f, r)| (f as i64, r as i64)),
        claim: readme_claim(root, "eeprom-settings", true),
        total: true,
    });
    out
}

fn measure(root: &Path, log: &mut Log) -> Result<Report> {
    let mut profiles = Vec::new();
    for fw in &FIRMWARE {
        eprintln!("bench: {} (workload, stack)", fw.name);
        profiles.push(profile(root, fw, log)?);
    }

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
        contract_mix.push(Series::run_all(&mut bus, "19200 8E1", &requests, "mix", MIX_MAX_DELAY_US, &mut model, log)?);
    }

    Ok(Report {
        profiles,
        lines,
        busy,
        idle,
        throughput,
        request_len: fc3x10.frame.len(),
        big,
        mix,
        contract_mix,
        features: feature_costs(root),
        chips: chip_runs(root, log)?,
        master: master::measure(root, log)?,
    })
}

fn render(r: &Report, log: &Log, root: &Path) -> Result<String> {
    let mut md = String::new();
    let date = Command::new("date").args(["-u", "+%Y-%m-%d %H:%M UTC"]).output()?;
    let commit = git(root, &["rev-parse", "--short", "HEAD"]).unwrap_or_else(|| "unknown".into());
    // Dirty: changes besides this report itself.
    let dirty = git(root, &["status", "--porcelain", "--", ".", ":!bench/results.md"]).is_some_and(|s| !s.is_empty());
    writeln!(md, "# Benchmarks\n")?;
    writeln!(
        md,
        "{} · commit `{commit}`{} · `make bench` · ATmega328P @ 16 MHz in simavr (uno-sim); every timing is \
         simulated cycles, so repeatable.\n",
        String::from_utf8_lossy(&date.stdout).trim(),
        if dirty { " (dirty)" } else { "" }
    )?;

    // Throughput against the bound: request and reply characters plus T3.5 on both sides.
    let tp = &r.throughput;
    let period = tp.span as f64 / tp.sent as f64;
    let bound = ((r.request_len + tp.reply_len) as u64 * tp.char_cycles + 2 * tp.t35) as f64;
    let pct = 100.0 * bound / period;
    let per_second = |cycles: f64| uno_sim::F_CPU as f64 / cycles;

    writeln!(md, "## Targets\n")?;
    writeln!(
        md,
        "From the size issue; every figure measured in this run. A target not met is reported here, not a \
         failure of `make bench` (that is a missing or wrong reply).\n"
    )?;
    writeln!(md, "| target | measured | met |\n|---|---|---|")?;
    let profile = |name: &str| r.profiles.iter().find(|p| p.name == name);
    let mut row = |target: String, measured: String, met: Option<bool>| {
        writeln!(md, "| {target} | {measured} | {} |", met.map_or("–", met_text))
    };

    for (name, cm) in CONTRACTS.into_iter().zip(&r.contract_mix) {
        let contract = profile(name);
        row(
            format!("{name}: flash (text+data) ≤ {CONTRACT_FLASH_TARGET} B"),
            contract.map_or("not built".into(), |p| format!("{} B", p.flash)),
            contract.map(|p| p.flash <= CONTRACT_FLASH_TARGET),
        )?;
        let template = template_size(root, name);
        row(
            format!("{name} as the avr-hal template builds it (`avr-none`): flash ≤ {CONTRACT_FLASH_TARGET} B"),
            template.map_or("not built".into(), |(flash, _)| format!("{flash} B")),
            template.map(|(flash, _)| flash <= CONTRACT_FLASH_TARGET),
        )?;
        row(
            format!("{name}: static RAM (data+bss) ≤ {CONTRACT_RAM_TARGET} B"),
            contract.map_or("not built".into(), |p| format!("{} B", p.ram)),
            contract.map(|p| p.ram <= CONTRACT_RAM_TARGET),
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
    let minimal = profile("minimal");
    row(
        format!("minimal: flash ≤ {MINIMAL_FLASH_TARGET} B"),
        minimal.map_or("not built".into(), |p| format!("{} B", p.flash)),
        minimal.map(|p| p.flash <= MINIMAL_FLASH_TARGET),
    )?;
    let rx = |stat: fn(&IsrTotal) -> f64| {
        r.profiles.iter().map(|p| (stat(&p.isr[0]), p.name)).max_by(|a, b| a.0.total_cmp(&b.0)).unwrap_or((0.0, ""))
    };
    let (rx_mean, rx_mean_name) = rx(IsrTotal::mean);
    let (rx_max, rx_max_name) = rx(|s| s.max as f64);
    let names: Vec<&str> = r.profiles.iter().map(|p| p.name).collect();
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
    master::target_rows(&r.master, &mut row)?;
    let mix = &r.mix;
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
    // Every series, every chip: the earliest reply against T3.5 from the request's end.
    let series = r.lines.iter().map(|(p, s)| (format!("dip_switch preset {p} {}", s.line), s));
    let series = series.chain(r.big.iter().map(|s| (format!("max_frame {}", s.line), s)));
    let series = series.chain(
        [
            (&r.busy, "busy_loop"),
            (&r.idle, "minimal"),
            (&r.throughput, "uno_slave back to back"),
            (&r.mix, "uno_slave mix"),
        ]
        .map(|(s, name)| (format!("{name} {}", s.line), s)),
    );
    let series =
        series.chain(r.contract_mix.iter().zip(CONTRACTS).map(|(s, name)| (format!("{name} mix {}", s.line), s)));
    let series = series.chain(r.chips.iter().map(|c| (format!("boards on the {} USART{}", c.chip, c.usart), &c.mixed)));
    let earliest = series.filter_map(|(name, s)| Some((s.min()?, name))).min_by_key(|(c, _)| *c);
    if let Some((cycles, name)) = earliest {
        row(
            "no reply starts before T3.5 after the request's end (every series and chip)".into(),
            format!("earliest T3.5 {} µs ({name})", if cycles < 0 { us(cycles) } else { format!("+{}", us(cycles)) }),
            Some(cycles >= 0),
        )?;
    }
    for f in &r.features {
        let (target, claim) = match &f.claim {
            Some((_, figure)) if f.total => {
                (format!("`{}`: `configurable` in all as the README says", f.feature), format!("{figure} B"))
            }
            Some((_, figure)) => (format!("`{}` costs what the README says", f.feature), format!("{figure:+} B")),
            None => (format!("`{}` costs what the README says", f.feature), "no claim found in README.md".into()),
        };
        let measured = match f.measured {
            Some((flash, ram)) if f.total => format!("{flash} B flash, {ram} B RAM"),
            Some((flash, ram)) => format!("{flash:+} B flash, {ram:+} B RAM"),
            None if f.total => "not built (`make firmware`)".into(),
            None => "not built (`make bench-features`)".into(),
        };
        row(format!("{target} ({claim})"), format!("{measured}; {}", f.how), f.met())?;
    }

    writeln!(md, "\n### sixteen_each beside the Arduino libraries\n")?;
    writeln!(
        md,
        "The same register set (16 coils, 16 discrete inputs, 8 input registers, 16 holding registers, slave 1, \
         19200 8E1, idle main loop). The libraries' figures are quoted from the issue, not measured here (there \
         they reply 0.8–2.9 ms after T3.5, and 127–308 ms (median) after it once the loop calls delay(200)).\n"
    )?;
    writeln!(
        md,
        "Flash in the avr-hal template's form is the same source built as the template builds (target `avr-none`, \
         `-Zbuild-std=core`): cargo's `core` brings compiler_builtins' `memset` and `memcpy`, where the \
         repository's target links avr-libc's.\n"
    )?;
    writeln!(
        md,
        "| firmware | flash (text+data) B | flash, the template's form B | static RAM (data+bss) |\n|---|---:|---:|---:|"
    )?;
    for (library, flash, ram) in LIBRARIES {
        writeln!(md, "| {library} | {flash} | – | {ram} |")?;
    }
    for (name, map) in CONTRACTS.into_iter().zip(["`register_map!`, fixed at build time", "a run-time `Bank`"]) {
        let template = template_size(root, name).map_or("not built".into(), |(flash, _)| flash.to_string());
        match profile(name) {
            Some(p) => {
                writeln!(md, "| this crate ({name}: {map}; measured) | {} | {template} | {} B |", p.flash, p.ram)?
            }
            None => writeln!(md, "| this crate ({name}: {map}) | not built | {template} | not built |")?,
        }
    }

    master::section(&mut md, root, &r.master)?;

    writeln!(md, "\n### Optional features against the README\n")?;
    writeln!(
        md,
        "`minimal` built with each feature (`make bench-features`, the `firmware` target's cargo invocation with \
         `--features examples,<feature>` into `{FEATURES_DIR}`) against the same plain build; `eeprom-settings` \
         as `configurable`'s total from `make firmware` (the example needs the feature). Met: within \
         {FEATURE_SLACK_PCT} % of the README's figure or {FEATURE_SLACK_BYTES} B, whichever is larger. The \
         README's cells:\n"
    )?;
    writeln!(md, "| feature | flash | RAM | README says |\n|---|---:|---:|---|")?;
    for f in &r.features {
        let (flash, ram) = match f.measured {
            Some((flash, ram)) if f.total => (format!("{flash} B in all"), format!("{ram} B in all")),
            Some((flash, ram)) => (format!("{flash:+} B"), format!("{ram:+} B")),
            None => ("not built".into(), "not built".into()),
        };
        let cell = f.claim.as_ref().map_or("–", |(cell, _)| cell.as_str());
        writeln!(md, "| `{}` | {flash} | {ram} | {cell} |", f.feature)?;
    }
    writeln!(md)?;

    writeln!(md, "## Size and stack\n")?;
    writeln!(
        md,
        "Flash and static RAM from `avr-size`. Stack: the free RAM above `.bss` painted before reset, then the \
         workload (one request of every function code, below); bytes from the lowest one changed up to RAMEND \
         (0x{RAMEND:03X}). Register values: 2 B per register, 1 bit per coil or input of the example's register \
         table.\n"
    )?;
    writeln!(
        md,
        "| firmware | flash (text+data) B | static RAM (data+bss) B | register values B | stack high-water B | RAM left B |\n\
         |---|---:|---:|---:|---:|---:|"
    )?;
    for p in &r.profiles {
        let left = 2048 - p.ram as i64 - i64::from(p.stack);
        writeln!(md, "| {} | {} | {} | {} | {} | {left} |", p.name, p.flash, p.ram, p.values, p.stack)?;
    }

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
    for c in &r.chips {
        write!(md, "| {} | USART{} | {} | {} |", c.chip, c.usart, c.flash, c.ram)?;
        for s in &c.isr {
            write!(md, " {:.1} / {} |", s.mean(), s.max)?;
        }
        let m = &c.mixed;
        writeln!(md, " {} µs | {}/{} + {}/{} |", m.spread(), c.right, c.sent, m.answered(), m.sent)?;
    }

    writeln!(md, "\n## Interrupt handlers over the workload\n")?;
    let fcs: Vec<String> = workload(&FIRMWARE[1]).iter().map(label).collect();
    writeln!(
        md,
        "Cycles from the interrupt response to the end of RETI: mean / max (runs). Workload: {} (addresses \
         that do not exist get exception 02).\n",
        fcs.join(", ")
    )?;
    write!(md, "| firmware |")?;
    for name in VECTORS {
        write!(md, " {name} |")?;
    }
    writeln!(md, " most interrupt time |\n|---|{}---|", "---:|".repeat(VECTORS.len()))?;
    for p in &r.profiles {
        write!(md, "| {} |", p.name)?;
        for s in &p.isr {
            write!(md, " {:.1} / {} ({}) |", s.mean(), s.max, s.entries)?;
        }
        let total: u64 = p.isr.iter().map(|s| s.cycles).sum();
        let (top, name) = p.isr.iter().zip(VECTORS).map(|(s, n)| (s.cycles, n)).max().unwrap_or((0, ""));
        writeln!(md, " {name}: {:.0} % |", 100.0 * top as f64 / total.max(1) as f64)?;
    }

    writeln!(md, "\n## Compare interrupt: frame check at the gap deadline, processing and reply CRC at T3.5\n")?;
    if r.big.is_empty() {
        writeln!(
            md,
            "No example has 125 holding registers (no max_frame firmware): FC 3 × 125 is measured on its \
             exception path; the largest normal register cases are 10 registers.\n"
        )?;
    }
    writeln!(
        md,
        "| firmware | request | gap deadline cycles | µs | T3.5 cycles | µs |\n|---|---|---:|---:|---:|---:|"
    )?;
    let cases = [
        ("minimal", "FC 3 × 4"),
        ("uno_slave", "FC 3 × 10"),
        ("dip_switch", "FC 3 × 10"),
        ("dip_switch", "FC 16 × 10"),
        ("dip_switch", "FC 1 × 16"),
        ("dip_switch", "FC 15 × 16"),
        ("dip_switch", "FC 3 × 125 → exception 02"),
    ];
    for (name, case) in cases {
        let hit = r.profiles.iter().filter(|p| p.name == name).flat_map(|p| &p.t35).find(|(l, _, _)| l == case);
        if let Some((_, gap, t35)) = hit {
            writeln!(
                md,
                "| {name} | {case} | {gap} | {:.1} | {t35} | {:.1} |",
                cycles_to_us(*gap),
                cycles_to_us(*t35)
            )?;
        }
    }
    for s in &r.big {
        writeln!(
            md,
            "| max_frame ({}) | {} | {} | {:.1} | {} | {:.1} |",
            s.line,
            s.request,
            s.gap_isr,
            cycles_to_us(s.gap_isr),
            s.t35_isr,
            cycles_to_us(s.t35_isr)
        )?;
    }

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
    let rows = r.lines.iter().map(|(p, s)| (format!("dip_switch (preset {p})"), s));
    let rows = rows.chain(r.big.iter().map(|s| ("max_frame".to_owned(), s)));
    let mixed = [(&r.mix, "uno_slave (main loop running)")].into_iter().chain(r.contract_mix.iter().zip(CONTRACTS));
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
    let all = r.lines.iter().map(|(_, s)| s).chain(&r.big).chain([&r.busy, &r.idle, tp, &r.mix]).chain(&r.contract_mix);
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

    writeln!(md, "\n## Main loop blocking 500 ms at a time\n")?;
    writeln!(
        md,
        "FC 3 × 4 at 19200 8E1, each request after a pseudo-random 0–{} ms of extra silence ({:.1} s simulated).\n",
        BUSY_MAX_DELAY_US / 1000,
        cycles_to_us(r.busy.span) / 1e6
    )?;
    writeln!(
        md,
        "| firmware | requests | answered | turnaround p50 / p{TURNAROUND_PERCENTILE} / max µs |\n|---|---:|---:|---:|"
    )?;
    for (name, s) in [("busy_loop", &r.busy), ("minimal (idle loop, reference)", &r.idle)] {
        writeln!(
            md,
            "| {name} | {} | {:.1} % | {} |",
            s.sent,
            100.0 * s.answered() as f64 / s.sent as f64,
            s.spread()
        )?;
    }

    writeln!(md, "\n## Throughput\n")?;
    writeln!(
        md,
        "uno_slave, FC 3 × 10 back to back at 19200 8E1: the master sends each request T3.5 after the reply's last \
         stop bit. Bus bound per transaction: ({} + {}) characters × {} bits at the actual {:.0} bps + 2 × T3.5 \
         = {:.0} µs.\n",
        r.request_len,
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
    Ok(md)
}

fn main() -> ExitCode {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.canonicalize().unwrap_or(root);
    let started = Instant::now();
    let mut log = Log::default();
    // `bench master`: the master's timing alone, printed and not written.
    if std::env::args().nth(1).as_deref() == Some("master") {
        return match master::only(&root, &mut log) {
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
        };
    }
    let md = match measure(&root, &mut log).and_then(|report| render(&report, &log, &root)) {
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
