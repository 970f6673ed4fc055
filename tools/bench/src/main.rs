//! `make bench`: figures for the example firmware, measured on the ELF files in simavr
//! (through `uno-sim`, cycle-exact USART timing) and with `avr-size`.
//!
//! Per firmware: flash and static RAM, stack high-water mark (free RAM painted before
//! start-up, a request of every function code, then the lowest byte that changed), and the
//! cycles of each interrupt handler. Then the turnaround at three line speeds, answers and
//! turnaround while the main loop blocks (`busy_loop`), and back-to-back throughput against
//! the bound the bus allows. If a `max_frame` firmware (125 holding registers; pin 12 low
//! selects 115200 bps) is built, FC 3 × 125 and FC 16 × 123 are timed on it too. Every
//! figure comes from this run; all timings are simulated cycles, so a run on any machine
//! gives the same numbers.
//!
//! Run from the workspace with the firmware built (`make firmware`); prints a Markdown report
//! and writes it to `bench/results.md`. Exits with 1 if a reply was missing or wrong.

mod bus;
mod modbus;

use std::error::Error;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use bus::{Bus, IsrTotal, Transaction, RAMEND, VECTORS};
use modbus::{Expect, Request};
use uno_sim::{cycles_to_us, us_to_cycles, CYCLES_PER_US};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// Where `make firmware` puts the ELF files, relative to the workspace.
const FIRMWARE_DIR: &str = "target/avr-atmega328p/release/examples";
/// Slave id of every example (lab_lights: button box, pin 12 open).
const ID: u8 = 1;

/// An example firmware and its data model at the default pin settings (from the register
/// table in the header of `examples/<name>.rs`); all tables start at address 0.
struct Firmware {
    name: &'static str,
    coils: u16,
    inputs: u16,
    input_regs: u16,
    holding: u16,
}

const FIRMWARE: [Firmware; 5] = [
    Firmware { name: "minimal", coils: 0, inputs: 0, input_regs: 0, holding: 4 },
    Firmware { name: "uno_slave", coils: 5, inputs: 4, input_regs: 5, holding: 10 },
    Firmware { name: "busy_loop", coils: 0, inputs: 0, input_regs: 1, holding: 4 },
    Firmware { name: "lab_lights", coils: 0, inputs: 2, input_regs: 0, holding: 0 },
    Firmware { name: "dip_switch", coils: 16, inputs: 3, input_regs: 1, holding: 10 },
];

/// dip_switch presets for the turnaround: (preset, line). Pin 10 + bit is low for a 1 bit.
const LINE_PRESETS: [(u8, &str); 3] = [(1, "9600 8E1"), (0, "19200 8E1"), (6, "115200 8E1")];
/// Requests per line speed for the turnaround.
const TURNAROUND_REQUESTS: usize = 10;
/// Requests against the blocking main loop, and the most idle time added before each.
const BUSY_REQUESTS: usize = 200;
const BUSY_MAX_DELAY_US: u64 = 20_000;
/// Requests against the idle `minimal` for the reference turnaround.
const IDLE_REQUESTS: usize = 20;
/// Back-to-back transactions for the throughput.
const THROUGHPUT_REQUESTS: usize = 100;

/// Targets from the issue.
const FLASH_TARGET: u64 = 2048;
const RAM_TARGET: u64 = 300;
const TURNAROUND_TARGET_US: f64 = 50.0;
const RX_TARGET_CYCLES: u64 = 100;
const THROUGHPUT_TARGET_PCT: f64 = 99.0;

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
    ]
}

/// What the run found, besides the figures: wrong or missing replies.
#[derive(Default)]
struct Log {
    problems: Vec<String>,
    max_turnaround: i64,
    replies: usize,
}

impl Log {
    /// Checks a reply and keeps its turnaround; returns it in cycles if the reply is right.
    fn check(&mut self, what: &str, req: &Request, t: &Transaction) -> Option<i64> {
        if let Err(e) = req.check(&t.reply) {
            let problem = if t.reply.is_empty() { format!("{}: no reply", req.label) } else { e };
            self.problems.push(format!("{what}: {problem}"));
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
    /// Bytes of register and bit values in the example's bank (its `Bank<_, REGS, BITS>`).
    bank_values: Option<u64>,
    stack: u16,
    isr: [IsrTotal; 5],
    /// (request label, T3.5 interrupt cycles) per workload request.
    t35: Vec<(String, u64)>,
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
    let mut isr = [IsrTotal::default(); 5];
    let mut t35 = Vec::new();
    // Two passes with complementary patterns: a stack byte that happens to equal the
    // pattern cannot hide the high-water mark in both.
    for (pass, pattern) in [0xA5u8, 0x5A].into_iter().enumerate() {
        let mut bus = Bus::boot(&elf, &[], Some(pattern))?;
        for req in &requests {
            let t = bus.transact(req, 0)?;
            if pass == 0 {
                log.check(fw.name, req, &t);
                t35.push((label(req), t.t35_isr));
            }
        }
        stack = stack.max(bus.stack_used(pattern)?);
        if pass == 0 {
            isr = bus.isr;
        }
    }
    let bank_values = bank_value_bytes(&root.join("examples").join(format!("{}.rs", fw.name)));
    Ok(Profile { name: fw.name, flash, ram, bank_values, stack, isr, t35 })
}

fn firmware_path(root: &Path, name: &str) -> PathBuf {
    root.join(FIRMWARE_DIR).join(format!("{name}.elf"))
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

/// 2 bytes per register and one bit per coil or input of the bank the example declares,
/// `Bank<RUNS, REGS, { bit_bytes(BITS) }>`.
fn bank_value_bytes(source: &Path) -> Option<u64> {
    let src = std::fs::read_to_string(source).ok()?;
    let generics = src.split("= Bank<").nth(1)?.split(">;").next()?;
    let mut parts = generics.splitn(3, ',');
    let regs: u64 = parts.nth(1)?.trim().parse().ok()?;
    let bits: u64 = parts.next()?.chars().filter(char::is_ascii_digit).collect::<String>().parse().ok()?;
    Some(2 * regs + bits.div_ceil(8))
}

fn us(cycles: i64) -> String {
    format!("{:.1}", cycles as f64 / CYCLES_PER_US as f64)
}

fn yes_no(met: bool) -> &'static str {
    if met {
        "yes"
    } else {
        "**no**"
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
    /// Longest T3.5 interrupt run, cycles.
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
        let mut rng = Lcg(0x5EED);
        let first = bus.idle_from();
        let mut s = Series {
            firmware: bus.name().to_owned(),
            line: line.to_owned(),
            request: req.label.clone(),
            baud: bus.baud,
            char_bits: bus.char_bits,
            char_cycles: bus.char_cycles,
            t35: bus.t35,
            t15: bus.t15,
            sent: count,
            turnarounds: Vec::with_capacity(count),
            max_gap: 0,
            t35_isr: 0,
            reply_len: 0,
            span: 0,
        };
        for _ in 0..count {
            let delay = if max_delay_us == 0 { 0 } else { us_to_cycles(rng.below(max_delay_us)) };
            let t = bus.transact(req, delay)?;
            s.max_gap = s.max_gap.max(t.max_gap);
            s.t35_isr = s.t35_isr.max(t.t35_isr);
            s.reply_len = t.reply.len();
            s.turnarounds.extend(log.check(&format!("{} {line}", bus.name()), req, &t));
        }
        s.turnarounds.sort_unstable();
        s.span = bus.idle_from() - first;
        Ok(s)
    }

    fn answered(&self) -> usize {
        self.turnarounds.len()
    }

    fn median(&self) -> i64 {
        self.turnarounds.get(self.turnarounds.len() / 2).copied().unwrap_or(0)
    }

    fn max(&self) -> i64 {
        self.turnarounds.last().copied().unwrap_or(0)
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

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").arg("-C").arg(root).args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// Everything measured in one run.
struct Report {
    profiles: Vec<Profile>,
    /// FC 3 × 10 on dip_switch at three line speeds: (preset, series).
    lines: Vec<(u8, Series)>,
    busy: Series,
    idle: Series,
    throughput: Series,
    request_len: usize,
    big: Vec<Series>,
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
    Ok(Report { profiles, lines, busy, idle, throughput, request_len: fc3x10.frame.len(), big })
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
    writeln!(md, "| target | measured | met |\n|---|---|---|")?;
    let minimal = &r.profiles[0];
    writeln!(
        md,
        "| minimal: flash ≤ {FLASH_TARGET} B | {} B | {} |",
        minimal.flash,
        yes_no(minimal.flash <= FLASH_TARGET)
    )?;
    let ram_target = format!("minimal: static RAM besides register values ≤ {RAM_TARGET} B");
    match minimal.bank_values {
        Some(values) => {
            let ram = minimal.ram.saturating_sub(values);
            writeln!(
                md,
                "| {ram_target} | {ram} B ({} B − {values} B of bank values) | {} |",
                minimal.ram,
                yes_no(ram <= RAM_TARGET)
            )?
        }
        None => writeln!(md, "| {ram_target} | bank not found in examples/minimal.rs | – |")?,
    }
    let target = (TURNAROUND_TARGET_US * CYCLES_PER_US as f64) as i64;
    let lines_max = r.lines.iter().map(|(_, s)| s.max()).max().unwrap_or(0);
    writeln!(
        md,
        "| turnaround ≤ {TURNAROUND_TARGET_US:.0} µs past T3.5 | FC 3 × 10 at 9600/19200/115200: max {} µs; \
         all {} replies of the run: max {} µs | {} |",
        us(lines_max),
        log.replies,
        us(log.max_turnaround),
        yes_no(log.max_turnaround <= target)
    )?;
    let (rx_max, rx_name) = r.profiles.iter().map(|p| (p.isr[0].max, p.name)).max().unwrap_or((0, ""));
    writeln!(
        md,
        "| USART RX interrupt ≤ {RX_TARGET_CYCLES} cycles per byte | max {rx_max} cycles ({rx_name}) | {} |",
        yes_no(rx_max <= RX_TARGET_CYCLES)
    )?;
    writeln!(
        md,
        "| busy loop: 100 % answers, turnaround unchanged (max ≤ idle max, or ≤ {TURNAROUND_TARGET_US:.0} µs) | {}/{} answered, max {} µs (idle minimal: max {} µs) | {} |",
        r.busy.answered(),
        r.busy.sent,
        us(r.busy.max()),
        us(r.idle.max()),
        yes_no(r.busy.answered() == r.busy.sent && r.busy.max() <= r.idle.max().max(target))
    )?;
    writeln!(
        md,
        "| throughput ≥ {THROUGHPUT_TARGET_PCT:.0} % of the bus bound | {pct:.2} % | {} |",
        yes_no(pct >= THROUGHPUT_TARGET_PCT)
    )?;
    let all = r.lines.iter().map(|(_, s)| s).chain(&r.big).chain([&r.busy, &r.idle, tp]);
    let worst = all.max_by(|a, b| (a.max_gap * b.t15).cmp(&(b.max_gap * a.t15))).unwrap_or(tp);
    writeln!(
        md,
        "| (Modbus rule, not in the issue) silence inside a reply ≤ T1.5 | longest {:.1} µs, T1.5 {:.0} µs \
         ({}, {}, {}) | {} |\n",
        cycles_to_us(worst.max_gap),
        cycles_to_us(worst.t15),
        worst.firmware,
        worst.request,
        worst.line,
        yes_no(worst.max_gap <= worst.t15)
    )?;

    writeln!(md, "## Size and stack\n")?;
    writeln!(
        md,
        "Flash and static RAM from `avr-size`. Stack: the free RAM above `.bss` painted before reset, then the \
         workload (one request of every function code, below); bytes from the lowest one changed up to RAMEND \
         (0x{RAMEND:03X}). Bank values: 2 B per register, 1 bit per coil or input of the example's `Bank`.\n"
    )?;
    writeln!(
        md,
        "| firmware | flash (text+data) B | static RAM (data+bss) B | bank values B | stack high-water B | RAM left B |\n\
         |---|---:|---:|---:|---:|---:|"
    )?;
    for p in &r.profiles {
        let values = p.bank_values.map_or("?".into(), |v| v.to_string());
        let left = 2048 - p.ram as i64 - i64::from(p.stack);
        writeln!(md, "| {} | {} | {} | {values} | {} | {left} |", p.name, p.flash, p.ram, p.stack)?;
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
    for (_, name) in VECTORS {
        write!(md, " {name} |")?;
    }
    writeln!(md, " most interrupt time |\n|---|{}---|", "---:|".repeat(VECTORS.len()))?;
    for p in &r.profiles {
        write!(md, "| {} |", p.name)?;
        for s in &p.isr {
            write!(md, " {:.1} / {} ({}) |", s.mean(), s.max, s.entries)?;
        }
        let total: u64 = p.isr.iter().map(|s| s.cycles).sum();
        let (top, name) = p.isr.iter().zip(VECTORS).map(|(s, (_, n))| (s.cycles, n)).max().unwrap_or((0, ""));
        writeln!(md, " {name}: {:.0} % |", 100.0 * top as f64 / total.max(1) as f64)?;
    }

    writeln!(md, "\n## T3.5 interrupt: frame check, processing, reply CRC\n")?;
    if r.big.is_empty() {
        writeln!(
            md,
            "No example has 125 holding registers (no max_frame firmware): FC 3 × 125 is measured on its \
             exception path; the largest normal register cases are 10 registers.\n"
        )?;
    }
    writeln!(md, "| firmware | request | cycles | µs |\n|---|---|---:|---:|")?;
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
        let hit = r.profiles.iter().filter(|p| p.name == name).flat_map(|p| &p.t35).find(|(l, _)| l == case);
        if let Some((_, cycles)) = hit {
            writeln!(md, "| {name} | {case} | {cycles} | {:.1} |", cycles_to_us(*cycles))?;
        }
    }
    for s in &r.big {
        writeln!(md, "| max_frame ({}) | {} | {} | {:.1} |", s.line, s.request, s.t35_isr, cycles_to_us(s.t35_isr))?;
    }

    writeln!(md, "\n## Turnaround: first reply start bit − end of T3.5 after the request\n")?;
    writeln!(
        md,
        "The master counts T3.5 from the last request byte's stop-bit end (3.5 characters at the Uno's actual bit \
         rate; 1750 µs above 19200). The address byte leaves from the T3.5 interrupt, the rest after the request is \
         processed: a processing time above one character shows as a gap after the first reply byte (Modbus allows \
         at most T1.5).\n"
    )?;
    writeln!(
        md,
        "| firmware | line | request | actual bps | T3.5 µs | answered | median µs | max µs | longest gap in reply µs \
         (T1.5) |\n|---|---|---|---:|---:|---:|---:|---:|---:|"
    )?;
    let rows = r.lines.iter().map(|(p, s)| (format!("dip_switch (preset {p})"), s));
    let rows = rows.chain(r.big.iter().map(|s| ("max_frame".to_owned(), s)));
    for (firmware, s) in rows {
        writeln!(
            md,
            "| {firmware} | {} ({} bits) | {} | {:.0} | {:.0} | {}/{} | {} | {} | {:.1} ({:.0}) |",
            s.line,
            s.char_bits,
            s.request,
            s.baud,
            cycles_to_us(s.t35),
            s.answered(),
            s.sent,
            us(s.median()),
            us(s.max()),
            cycles_to_us(s.max_gap),
            cycles_to_us(s.t15)
        )?;
    }

    writeln!(md, "\n## Main loop blocking 500 ms at a time\n")?;
    writeln!(
        md,
        "FC 3 × 4 at 19200 8E1, each request after a pseudo-random 0–{} ms of extra silence ({:.1} s simulated).\n",
        BUSY_MAX_DELAY_US / 1000,
        cycles_to_us(r.busy.span) / 1e6
    )?;
    writeln!(md, "| firmware | requests | answered | turnaround median µs | max µs |\n|---|---:|---:|---:|---:|")?;
    for (name, s) in [("busy_loop", &r.busy), ("minimal (idle loop, reference)", &r.idle)] {
        writeln!(
            md,
            "| {name} | {} | {:.1} % | {} | {} |",
            s.sent,
            100.0 * s.answered() as f64 / s.sent as f64,
            us(s.median()),
            us(s.max())
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

    writeln!(md, "\n## For scale (measured elsewhere, quoted from the issue; not by this bench)\n")?;
    writeln!(
        md,
        "Arduino libraries at 19200 8E1: smarmengol ModbusRtu 3746 B flash / 319 B RAM, CMB27 ModbusRTUSlave \
         4986 B / 309 B, emelianov modbus-esp8266 10038 B / 270 B plus heap; replies 0.8–2.9 ms after T3.5, and \
         127–308 ms (median) after it once the loop calls delay(200)."
    )?;

    if !log.problems.is_empty() {
        writeln!(md, "\n## Problems\n")?;
        for p in &log.problems {
            writeln!(md, "- {p}")?;
        }
    }
    writeln!(md, "\n{} replies checked (CRC, address, function code, length, exception code).", log.replies)?;
    Ok(md)
}

fn main() -> ExitCode {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.canonicalize().unwrap_or(root);
    let started = Instant::now();
    let mut log = Log::default();
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
