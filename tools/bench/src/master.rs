//! The master's sizes beside the Arduino masters, on the same benchmark sketch: 19200 8E1,
//! every 100 ms FC 3 × 10 registers, FC 16 × 2, FC 1 × 8 coils, FC 5 (`examples/poll_four.rs`),
//! and its read-only form, FC 3 × 10 alone (`examples/poll_holding.rs`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use uno_sim::{cycles_to_us, us_to_cycles, Chip, LineError, Options, Space, TxByte, Uno};

use crate::bus::IsrTotal;
use crate::modbus::{crc16, Expect, Request};
use crate::{avr_size, chip_build_path, firmware_path, Lcg, Log, Result, BOARDS};

/// The Arduino masters, built from source with Debian's arduino-core-avr and avr-gcc 5.4
/// `-Os -flto` on the same sketch: (library, flash with all four function codes, flash with
/// FC 3 only, static RAM). Quoted from the issue, not measured here: their sources stay
/// outside the repository.
const PEERS: [(&str, u64, u64, u64); 3] = [
    ("4-20ma/ModbusMaster 2.0.1", 3354, 2620, 493),
    ("CMB27/ModbusRTUMaster 2.0.1", 4738, 3534, 251),
    ("smarmengol ModbusRtu", 3592, 3172, 330),
];

/// The section: a table of flash and RAM, and whether ours is smaller than each peer's.
pub(crate) fn section(md: &mut String, root: &Path, measured: &Measured) -> Result<()> {
    writeln!(md, "\n### The master beside the Arduino masters\n")?;
    writeln!(
        md,
        "The benchmark sketch of the master issue: 19200 8E1, every 100 ms one of FC 3 × 10 registers, FC 16 × 2, \
         FC 1 × 8 coils, FC 5 (`poll_four`), and the read-only form, FC 3 × 10 alone (`poll_holding`). The \
         Arduino masters' figures are quoted from the issue (built from source with arduino-core-avr, avr-gcc 5.4 \
         `-Os -flto`), not measured here; `master_mirror` (every function code, outcomes reported on the line) \
         and `plc_poller` (pins, error LED) for scale.\n"
    )?;
    writeln!(md, "| firmware | flash, four FCs B | flash, FC 3 only B | static RAM B |\n|---|---:|---:|---:|")?;
    for (library, four, fc3, ram) in PEERS {
        writeln!(md, "| {library} | {four} | {fc3} | {ram} |")?;
    }
    let four = avr_size(&firmware_path(root, "poll_four"))?;
    let fc3 = avr_size(&firmware_path(root, "poll_holding"))?;
    writeln!(md, "| this crate (measured) | {} | {} | {} (four) / {} (FC 3) |", four.0, fc3.0, four.1, fc3.1)?;
    for name in ["master_mirror", "plc_poller"] {
        let (flash, ram) = avr_size(&firmware_path(root, name))?;
        writeln!(md, "| this crate, {name} | {flash} | – | {ram} |")?;
    }
    writeln!(md, "\n| goal: smaller than | flash, four FCs | flash, FC 3 only | static RAM |\n|---|---|---|---|")?;
    let verdict = |ours: u64, theirs: u64| {
        if ours < theirs {
            format!("met ({ours} < {theirs})")
        } else {
            format!("**not met** ({ours} ≥ {theirs})")
        }
    };
    for (library, their_four, their_fc3, their_ram) in PEERS {
        let ram = verdict(four.1.max(fc3.1), their_ram);
        writeln!(md, "| {library} | {} | {} | {ram} |", verdict(four.0, their_four), verdict(fc3.0, their_fc3))?;
    }
    timing_section(md, measured)
}

/// Requests `master_boards` sends per chip and USART, each answered as a slave would.
const BOARD_REQUESTS: usize = 100;
/// Every this many requests, the slave answers with exception 2 (illegal data address).
const EXCEPTION_EVERY: usize = 10;
/// The request whose reply has a parity error in its 4th character: the master drops the
/// reply at T3.5 and sends the request again at once (its one retry).
const DAMAGED_REPLY: usize = 50;
/// A silence past T3.5 before a reply, drawn below this many µs: the slave's turnaround.
const SLAVE_DELAY_US: u64 = 1500;
/// The target of the master's interrupts, as the slave's: cycles per run, mean and max.
pub(crate) const MASTER_ISR_TARGET_CYCLES: u64 = 100;

/// Requests timed on `poll_holding` for the send latency.
const LATENCY_REQUESTS: usize = 50;
/// The target: the request's first start bit at most this long after `Master::send` is
/// called, on a line idle for T3.5.
pub(crate) const LATENCY_TARGET_US: f64 = 25.0;

/// The master's interrupts, in the order of [`MasterRun::isr`].
const MASTER_VECTORS: [&str; 5] = ["USART_RX", "TIMER0_COMPA", "USART_UDRE", "USART_TX", "TIMER0_OVF (millis)"];

/// `master_boards` on one chip and USART.
pub(crate) struct MasterRun {
    chip: Chip,
    usart: u8,
    flash: u64,
    ram: u64,
    /// Interrupt cycles per entry of [`MASTER_VECTORS`], from the first request on.
    isr: [IsrTotal; MASTER_VECTORS.len()],
    /// Requests seen on the wire (retries included), and those byte for byte right.
    requests: usize,
    right: usize,
    /// Replies the master was done with at once: the next request (or the retry of a
    /// damaged one) came within 100 ms of the reply's end, not after a response timeout.
    taken: usize,
    replies: usize,
    /// The reply's end to the next request's first start bit, cycles: min, max (replies taken).
    next_after: (u64, u64),
    /// T3.5 on this line, cycles.
    t35: u64,
}

/// `poll_holding`: from the call of its `ask` (which calls `Master::send`) to the request's
/// first start bit.
pub(crate) struct Latency {
    /// Cycles, sorted.
    samples: Vec<u64>,
    /// Shortest silence on the line before a call (from the last reply's end), cycles.
    idle_min: u64,
    t35: u64,
}

/// What the master's part of the bench measured.
#[derive(Default)]
pub(crate) struct Measured {
    runs: Vec<MasterRun>,
    latency: Option<Latency>,
}

/// Where `master_boards` is for `chip` and `usart`.
fn master_board_path(root: &Path, chip: Chip, usart: u8) -> PathBuf {
    let dir = if usart == chip.default_usart() {
        format!("{}-master", chip.name())
    } else {
        format!("{}-usart{usart}-master", chip.name())
    };
    chip_build_path(root, &dir, "master_boards")
}

/// FC 3's reply with `values`, from slave 1.
fn fc3_reply(values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![3, (values.len() * 2) as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    frame(&pdu)
}

/// Slave 1's ADU around `pdu`.
fn frame(pdu: &[u8]) -> Vec<u8> {
    let mut f = vec![1];
    f.extend_from_slice(pdu);
    f.extend_from_slice(&crc16(&f).to_le_bytes());
    f
}

/// The line's character time and T3.5 (as the master counts them), cycles.
fn line_times(uno: &Uno) -> std::result::Result<(u64, u64), uno_sim::Error> {
    let cfg = uno.serial_config().ok_or(uno_sim::Error::UartNotConfigured)?;
    let fixed = cfg.baud() > 19_200.0 * 1.05;
    Ok((cfg.char_cycles(), if fixed { us_to_cycles(1750) } else { cfg.char_cycles() * 7 / 2 }))
}

/// Runs until the master has sent a request (and the line is quiet again for two
/// characters), at most `wait` cycles: its characters.
fn next_request(uno: &mut Uno, char_cycles: u64, wait: u64) -> std::result::Result<Vec<TxByte>, uno_sim::Error> {
    let deadline = uno.now() + wait;
    uno.run_until_tx_idle(2 * char_cycles, deadline)
}

/// Answers the request that ended at `request_end` as a slave would, T3.5 and a random
/// turnaround later: `n`'s registers, an exception now and then, one reply damaged.
/// Returns the reply's end on the line.
fn answer(uno: &mut Uno, n: usize, request_end: u64, times: (u64, u64), rng: &mut Lcg) -> Result<u64> {
    let (char_cycles, t35) = times;
    let start = (request_end + t35 + us_to_cycles(rng.below(SLAVE_DELAY_US))).max(uno.now() + 1);
    let reply = if n % EXCEPTION_EVERY == EXCEPTION_EVERY - 1 {
        frame(&[0x83, 2])
    } else {
        let values: Vec<u16> = (0..10).map(|i| (n as u16).wrapping_mul(0x0101) ^ (i * 0x1111)).collect();
        fc3_reply(&values)
    };
    if n == DAMAGED_REPLY {
        let mut end = start;
        for (i, &byte) in reply.iter().enumerate() {
            end += char_cycles;
            if i == 3 {
                uno.send_byte_with_error(byte, end, LineError::Parity)?;
            } else {
                uno.send_byte(byte, end)?;
            }
        }
        return Ok(end);
    }
    Ok(uno.send_frame(&reply, start + char_cycles, 0)?)
}

/// `master_boards` on one chip and USART against a simulated slave 1.
fn master_run(elf: &Path, chip: Chip, usart: u8, log: &mut Log) -> Result<MasterRun> {
    let (flash, ram) = avr_size(elf)?;
    let mut uno = Uno::load_with(elf, Options::new().chip(chip).usart(usart))?;
    uno.run_until(us_to_cycles(1000))?;
    let times = line_times(&uno)?;
    let (char_cycles, t35) = times;
    let v = uno.vectors();
    let vectors = [v.usart_rx, v.timer0_compa, v.usart_udre, v.usart_tx, v.timer0_ovf];
    let expected = Request::read(1, 3, 0, 10, Expect::Normal).frame;
    let what = format!("master_boards ({chip}, USART{usart})");
    let mut rng = Lcg(0x3A57E2);
    let mut run = MasterRun {
        chip,
        usart,
        flash,
        ram,
        isr: [IsrTotal::default(); MASTER_VECTORS.len()],
        requests: 0,
        right: 0,
        taken: 0,
        replies: 0,
        next_after: (u64::MAX, 0),
        t35,
    };
    // The first request, after the power-up silence: the statistics count from here.
    let mut request = next_request(&mut uno, char_cycles, us_to_cycles(100_000))?;
    uno.reset_isr_stats();
    let mut reply_end: Option<u64> = None;
    for n in 0..=BOARD_REQUESTS {
        let Some(first) = request.first() else {
            log.problems.push(format!("{what}: no request after reply {n} (2.5 s)"));
            break;
        };
        if let Some(end) = reply_end {
            let after = first.start_cycle.saturating_sub(end);
            if after < us_to_cycles(100_000) {
                run.taken += 1;
                run.next_after = (run.next_after.0.min(after), run.next_after.1.max(after));
            }
        }
        run.requests += 1;
        let bytes: Vec<u8> = request.iter().map(|b| b.byte).collect();
        if bytes == expected {
            run.right += 1;
        } else {
            log.problems.push(format!("{what}: request {n} was {bytes:02X?}, not {expected:02X?}"));
        }
        if n == BOARD_REQUESTS {
            break;
        }
        let end = request.last().map_or(first.end_cycle, |b| b.end_cycle);
        reply_end = Some(answer(&mut uno, n, end, times, &mut rng)?);
        run.replies += 1;
        request = next_request(&mut uno, char_cycles, us_to_cycles(2_500_000))?;
    }
    for (total, &vector) in run.isr.iter_mut().zip(&vectors) {
        let s = uno.isr_stats(vector);
        *total = IsrTotal { entries: s.entries, cycles: s.cycles, max: s.max_cycles };
    }
    // Every reply is done with at once, the damaged one by a retry.
    if run.taken != run.replies {
        log.problems.push(format!("{what}: the master took {} of {} replies at once", run.taken, run.replies));
    }
    Ok(run)
}

/// The entry of `poll_holding`'s `ask` (`#[inline(never)]`), which calls `Master::send`: the
/// moment the application asks.
fn send_entry(uno: &Uno) -> Option<u32> {
    uno.symbols()
        .iter()
        .find(|s| s.space == Space::Flash && s.name.contains("12poll_holding") && s.name.ends_with("3ask"))
        .map(|s| s.addr)
}

/// `poll_holding` on the Uno: each call of its `ask` (reached by stepping to its entry)
/// to the request's first start bit, the line idle since the last reply.
fn latency(root: &Path, log: &mut Log) -> Result<Option<Latency>> {
    let elf = firmware_path(root, "poll_holding");
    if !elf.is_file() {
        log.problems.push(format!("{} is missing: run `make firmware`", elf.display()));
        return Ok(None);
    }
    let mut uno = Uno::load(&elf)?;
    let Some(entry) = send_entry(&uno) else {
        log.problems.push(format!("{}: no symbol for poll_holding's ask (is it #[inline(never)]?)", elf.display()));
        return Ok(None);
    };
    uno.run_until(us_to_cycles(1000))?;
    let times = line_times(&uno)?;
    let (char_cycles, t35) = times;
    let mut rng = Lcg(0x1A7E);
    let mut samples = Vec::with_capacity(LATENCY_REQUESTS);
    let mut idle_min = u64::MAX;
    let mut quiet_from = 0;
    let mut called = None;
    for n in 0..LATENCY_REQUESTS {
        // A request every 100 ms of millis(): run to just before the next, then step.
        if let Some(at) = called {
            uno.run_until(at + us_to_cycles(95_000))?;
        }
        let limit = uno.now() + us_to_cycles(300_000);
        while uno.pc() != entry {
            uno.step()?;
            if uno.now() > limit {
                return Err(format!("poll_holding: ask not called within 300 ms (request {n})").into());
            }
        }
        let at = uno.now();
        called = Some(at);
        idle_min = idle_min.min(at - quiet_from);
        let request = next_request(&mut uno, char_cycles, us_to_cycles(20_000))?;
        let (Some(first), Some(last)) = (request.first(), request.last()) else {
            log.problems.push(format!("poll_holding: no request after Master::send (request {n})"));
            return Ok(None);
        };
        if first.start_cycle < at {
            log.problems.push(format!("poll_holding: a request went out before ask (request {n})"));
            return Ok(None);
        }
        samples.push(first.start_cycle - at);
        // Answered normally: the next call finds the master idle.
        quiet_from = answer(&mut uno, n % (EXCEPTION_EVERY - 1), last.end_cycle, times, &mut rng)?;
    }
    samples.sort_unstable();
    Ok(Some(Latency { samples, idle_min, t35 }))
}

/// Runs the master's measurements: `master_boards` on every chip and USART, then the send
/// latency on `poll_holding`.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Measured> {
    let mut m = Measured::default();
    // `master_boards` as `make chips` builds it: target/chips/CHIP[-usartN]-master/.
    for (chip, usart) in BOARDS {
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

/// The percentile `pct` of sorted `samples`.
fn percentile(samples: &[u64], pct: usize) -> u64 {
    let rank = (samples.len() * pct).div_ceil(100).max(1);
    samples.get(rank - 1).copied().unwrap_or(0)
}

fn cycles_us(cycles: u64) -> String {
    format!("{:.1}", cycles_to_us(cycles))
}

/// The master's rows of the targets table.
pub(crate) fn target_rows(
    m: &Measured,
    mut row: impl FnMut(String, String, Option<bool>) -> std::fmt::Result,
) -> std::fmt::Result {
    let worst = |stat: fn(&IsrTotal) -> f64| {
        m.runs
            .iter()
            .map(|r| (stat(&r.isr[0]), format!("{} USART{}", r.chip, r.usart)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    let target = format!(
        "master (`master_boards`): USART RX interrupt ≤ {MASTER_ISR_TARGET_CYCLES} cycles, mean and max, every chip"
    );
    match (worst(IsrTotal::mean), worst(|s| s.max as f64)) {
        (Some((mean, mean_on)), Some((max, max_on))) => {
            let limit = MASTER_ISR_TARGET_CYCLES as f64;
            let missing = BOARDS.len() - m.runs.len();
            row(
                target,
                format!(
                    "worst mean {mean:.1} ({mean_on}), worst max {max:.0} ({max_on}), over {} builds{}",
                    m.runs.len(),
                    if missing > 0 { format!(" ({missing} not built: `make chips`)") } else { String::new() }
                ),
                Some(mean <= limit && max <= limit && missing == 0),
            )?;
        }
        _ => row(target, "not built (`make chips`)".into(), None)?,
    }
    let target = format!(
        "master (`poll_holding`): the request's first start bit ≤ {LATENCY_TARGET_US:.0} µs after the application asks (`Master::send` called), \
         line idle T3.5"
    );
    match &m.latency {
        Some(l) => {
            let max = l.samples.last().copied().unwrap_or(0);
            row(
                target,
                format!(
                    "min {} µs, p50 {} µs, max {} µs over {} requests (line idle ≥ {} ms, T3.5 {} ms)",
                    cycles_us(l.samples.first().copied().unwrap_or(0)),
                    cycles_us(percentile(&l.samples, 50)),
                    cycles_us(max),
                    l.samples.len(),
                    format_args!("{:.1}", cycles_to_us(l.idle_min) / 1000.0),
                    format_args!("{:.2}", cycles_to_us(l.t35) / 1000.0),
                ),
                Some(cycles_to_us(max) <= LATENCY_TARGET_US && l.idle_min >= l.t35),
            )
        }
        None => row(target, "not built (`make firmware`)".into(), None),
    }
}

/// The master's interrupts on every chip, and the send latency.
fn timing_section(md: &mut String, m: &Measured) -> Result<()> {
    writeln!(md, "\n### The master on every chip\n")?;
    writeln!(
        md,
        "`examples/master_boards.rs` (FC 3 × 10 to slave 1, sent again as soon as the last outcome is in) as \
         `make chips` builds it for each chip and USART (target/chips/CHIP[-usartN]-master/), at 19200 8E1, \
         against a simulated slave that answers {BOARD_REQUESTS} requests T3.5 plus up to {SLAVE_DELAY_US} µs \
         after each, with exception 2 every {EXCEPTION_EVERY}th and a parity error in reply {DAMAGED_REPLY} (the \
         master drops it and asks again: {BOARD_REQUESTS} requests and a retry). \"Replies taken\": the next \
         request followed within 100 ms of the reply's end, not after a response timeout. Interrupt cycles (response to the end of RETI), mean / max, from the \
         first request on; TIMER0_COMPA also turns about once a millisecond for the timeouts.\n"
    )?;
    write!(md, "| chip | USART | flash (B) | RAM (B) |")?;
    for name in MASTER_VECTORS {
        write!(md, " {name} |")?;
    }
    writeln!(md, " requests right | replies taken | reply end → next request, µs (T3.5) |")?;
    writeln!(md, "|---|---|---:|---:|{}---:|---:|---:|", "---:|".repeat(MASTER_VECTORS.len()))?;
    for r in &m.runs {
        write!(md, "| {} | USART{} | {} | {} |", r.chip, r.usart, r.flash, r.ram)?;
        for s in &r.isr {
            write!(md, " {:.1} / {} |", s.mean(), s.max)?;
        }
        writeln!(
            md,
            " {}/{} | {}/{} | {}–{} ({}) |",
            r.right,
            r.requests,
            r.taken,
            r.replies,
            cycles_us(r.next_after.0.min(r.next_after.1)),
            cycles_us(r.next_after.1),
            cycles_us(r.t35)
        )?;
    }
    if m.runs.is_empty() {
        writeln!(md, "| not built (`make chips`) | | | | | | | | | | | |")?;
    }
    if let Some(l) = &m.latency {
        writeln!(md, "\n### The master's send latency\n")?;
        writeln!(
            md,
            "`poll_holding` on the Uno (FC 3 × 10 every 100 ms of `millis()`, each answered T3.5 plus up to \
             {SLAVE_DELAY_US} µs after it): from the entry of `poll_holding`'s `ask`, which calls `Master::send` (its ELF symbol; the simulator \
             steps to it) to the request's first start bit on the wire, over {} requests. The simulated USART \
             starts a character at the UDRn write.\n",
            l.samples.len()
        )?;
        writeln!(md, "| min µs | p50 µs | p99 µs | max µs | cycles min / max |\n|---:|---:|---:|---:|---:|")?;
        writeln!(
            md,
            "| {} | {} | {} | {} | {} / {} |",
            cycles_us(l.samples.first().copied().unwrap_or(0)),
            cycles_us(percentile(&l.samples, 50)),
            cycles_us(percentile(&l.samples, 99)),
            cycles_us(l.samples.last().copied().unwrap_or(0)),
            l.samples.first().copied().unwrap_or(0),
            l.samples.last().copied().unwrap_or(0)
        )?;
    }
    Ok(())
}

/// `bench master`: the master's timing alone (targets and tables), not written to
/// bench/results.md; for working on the master without the whole bench.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let m = measure(root, log)?;
    let mut md = String::new();
    writeln!(md, "| target | measured | met |\n|---|---|---|")?;
    target_rows(&m, |target, measured, met| {
        writeln!(md, "| {target} | {measured} | {} |", met.map_or("–", crate::met_text))
    })?;
    timing_section(&mut md, &m)?;
    Ok(md)
}
