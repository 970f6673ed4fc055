//! The serial line on a timer's input capture (feature `capture-line`: the Uno's pins 8 RX,
//! ICP1, and 9 TX, OC1A) against masters and a slave nobody here wrote, the virtual Uno with
//! that line on a pty of its own (`--pins 8,9 --pins-link PATH`) beside USART0's:
//!
//! - examples/boards.rs (slave 1 at 19200 8E1, the peers' contract map) polled by mbpoll, one
//!   process a request (every function code it has, then rounds of writes read back) and one
//!   polling process, and by pymodbus (`demo/pymodbus_check.py --board boards --rounds N`);
//!   every request counted, none may fail, and USART0's console (`writes N` at 9600) counts
//!   every write the master made;
//! - examples/gateway.rs on one Uno: pymodbus's serial server (`demo/plant_slave.py --unit 1`)
//!   as the field device on the pins' pty, mbpoll as the SCADA on USART0's reading the field
//!   device's holding registers 0-9 at 40001-40010 and writing coils 1-8 (FC 15 and FC 5) that
//!   must reach the field device's coils 0-7; the gateway's own count of failed polls (30002)
//!   must not move while the field device answers.
//!
//! pymodbus's server runs at parity N: a pty carries no parity bit, and pyserial cannot set
//! parity E on one (a Linux pty clears PARENB; glibc's tcsetattr reads the settings back and
//! fails with EINVAL when PARENB did not take and nothing else changed, which after the first
//! open is every reconfiguration, such as the read timeout pyserial-asyncio sets). The pins
//! carry 8E1 all the same: `--pins-frame` (8E by default) is what virtual-uno puts on the pins
//! when the pty shows "no parity".
//!
//! Needs `make capture-firmware` (target/chips/atmega328p-capture and
//! atmega328p-capture-gateway) and what `make setup` installs: mbpoll, the Python with
//! pymodbus. `make interop` runs it.

mod common;

use common::{collect, python, run, serialise, workspace, Spawned};

use std::fs::OpenOptions;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};

/// `examples/NAME.rs` as `make capture-firmware` builds it into target/chips/DIR.
fn firmware(dir: &str, name: &str) -> PathBuf {
    let elf = target_dir().join("chips").join(dir).join("avr-none/release/examples").join(format!("{name}.elf"));
    built(elf, "make capture-firmware")
}

/// The slave's and the gateway's line: 19200 8E1, slave 1.
const MBPOLL_LINE: &str = "-m rtu -b 19200 -P even -a 1";

/// A running `virtual-uno`: USART0 on the pty `usart`, pins 8/9 on the pty `pins`.
struct Board {
    process: Spawned,
    usart: PathBuf,
    pins: PathBuf,
}

impl Board {
    fn start(firmware: &Path) -> Board {
        let tag = format!("vuno-{}-capture-{}", std::process::id(), firmware.file_stem().unwrap().to_string_lossy());
        let usart = std::env::temp_dir().join(format!("{tag}.tty"));
        let pins = std::env::temp_dir().join(format!("{tag}-pins.tty"));
        let process = Spawned::start(
            Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
                .arg("--link")
                .arg(&usart)
                .args(["--no-stdin", "--pins", "8,9", "--pins-link"])
                .arg(&pins)
                .arg(firmware),
        );
        assert!(process.wait_for("serial: ", Duration::from_secs(10)), "USART0 not configured:\n{}", process.log());
        Board { process, usart, pins }
    }

    /// What the firmware prints on USART0 from now on, collected as it comes.
    fn console(&self) -> Arc<Mutex<String>> {
        let tty = OpenOptions::new()
            .read(true)
            .custom_flags(nix::libc::O_NOCTTY)
            .open(&self.usart)
            .unwrap_or_else(|e| panic!("open {}: {e}", self.usart.display()));
        let text = Arc::new(Mutex::new(String::new()));
        collect(tty, text.clone());
        text
    }

    /// virtual-uno's reports of malformed characters from TX read at the line's 19200 (before a
    /// master opens the pty it is at 38400, and what the firmware sends then is read at that).
    fn malformed(&self) -> Vec<String> {
        let log = self.process.log();
        log.lines()
            .filter(|l| l.contains("pin line: TX sent") && l.contains("read at 19200"))
            .map(str::to_owned)
            .collect()
    }
}

/// `mbpoll -m rtu -b 19200 -P even -a 1 -o 1 -1 ARGS TTY VALUES`: its output, headed by the
/// command. Waited for as it ends (its time-out is 1 s), without `common::run`'s 50 ms for
/// the readers: a third of a one-shot request's time.
fn mbpoll(tty: &Path, args: &str, values: &str) -> String {
    let mut cmd = Command::new("mbpoll");
    cmd.args(MBPOLL_LINE.split(' ')).args(["-o", "1", "-1"]).args(args.split_whitespace());
    cmd.arg(tty).args(values.split_whitespace());
    let out = cmd.stdin(Stdio::null()).output().expect("run mbpoll");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    format!("$ mbpoll {args} {values}\n{stdout}{stderr}")
}

/// The values of mbpoll's `[ref]: value` lines (`50000 (-15536)`: the first number).
fn mbpoll_values(out: &str) -> Vec<i64> {
    out.lines()
        .filter(|l| l.starts_with('['))
        .filter_map(|l| l.split(':').nth(1)?.split_whitespace().next()?.parse().ok())
        .collect()
}

/// One master's requests, each checked: how many, how many wrong, and the wrong ones' output.
#[derive(Default)]
struct Tally {
    requests: u64,
    errors: u64,
    writes: u64,
    wrong: String,
}

impl Tally {
    /// Counts one request whose output `out` is `ok`.
    fn check(&mut self, out: String, ok: bool, why: &str) {
        self.requests += 1;
        if !ok {
            self.errors += 1;
            self.wrong.push_str(&format!("WRONG: {why}\n{out}"));
        }
    }

    /// A write of `count` references, counted as a write of the master.
    fn write(&mut self, tty: &Path, args: &str, values: &str, count: usize) {
        let out = mbpoll(tty, args, values);
        self.writes += 1;
        let ok = out.contains(&format!("Written {count} references"));
        self.check(out, ok, &format!("write {args} {values}"));
    }

    /// A read that must give `expected`.
    fn read(&mut self, tty: &Path, args: &str, expected: &[i64]) {
        let out = mbpoll(tty, args, "");
        let got = mbpoll_values(&out);
        self.check(out, got == expected, &format!("read {args}: {got:?}, expected {expected:?}"));
    }
}

/// The last `writes N` USART0's console printed.
fn console_writes(console: &Mutex<String>) -> Option<u64> {
    console.lock().unwrap().lines().rev().find_map(|l| l.trim().strip_prefix("writes ")?.parse().ok())
}

/// Waits up to 2 s for the console to print `writes N`; the last N it printed.
fn wait_for_writes(console: &Mutex<String>, writes: u64) -> Option<u64> {
    let deadline = Instant::now() + Duration::from_secs(2);
    while console_writes(console) != Some(writes) && Instant::now() < deadline {
        thread::sleep(Duration::from_millis(20));
    }
    console_writes(console)
}

/// Rounds of writes read back by mbpoll, one process a request.
const MBPOLL_ROUNDS: u64 = 15;
/// How long one mbpoll process polls 40001-40016 (every 10 ms).
const MBPOLL_POLLING: Duration = Duration::from_secs(2);
/// Rounds of eight requests by pymodbus.
const PYMODBUS_ROUNDS: u32 = 40;

#[test]
fn mbpoll_reads_and_writes_the_slave_on_pins_8_9_without_an_error() {
    let _one = serialise();
    let board = Board::start(&firmware("atmega328p-capture", "boards"));
    let console = board.console();
    let tty = board.pins.as_path();
    let started = Instant::now();
    let mut tally = Tally::default();

    tally.read(tty, "-t 0 -r 1 -c 16", &[0; 16]);
    tally.read(tty, "-t 1 -r 1 -c 16", &[0; 16]);
    tally.read(tty, "-t 4 -r 1 -c 16", &[0; 16]);
    let out = mbpoll(tty, "-t 3 -r 1 -c 8", "");
    let inputs = mbpoll_values(&out);
    tally.check(out, inputs.len() == 8 && inputs[1..] == [0; 7], "30001-30008: seconds, then zeros");
    let mut seconds = inputs.first().copied().unwrap_or(0);
    for r in 0..MBPOLL_ROUNDS as i64 {
        let block: Vec<i64> = (0..16).map(|i| (r * 16 + i) * 257 % 65536).collect();
        let text: Vec<String> = block.iter().map(i64::to_string).collect();
        tally.write(tty, "-t 4 -r 1", &text.join(" "), 16);
        tally.read(tty, "-t 4 -r 1 -c 16", &block);
        let one = r % 16;
        tally.write(tty, &format!("-t 4 -r {}", one + 1), &(50_000 + r).to_string(), 1);
        tally.read(tty, &format!("-t 4 -r {}", one + 1), &[50_000 + r]);
        let mut coils: Vec<i64> = (0..16).map(|i| r >> (i % 4) & 1).collect();
        let text: Vec<String> = coils.iter().map(i64::to_string).collect();
        tally.write(tty, "-t 0 -r 1", &text.join(" "), 16);
        coils[one as usize] = 1 - coils[one as usize];
        tally.write(tty, &format!("-t 0 -r {}", one + 1), &coils[one as usize].to_string(), 1);
        tally.read(tty, "-t 0 -r 1 -c 16", &coils);
        let out = mbpoll(tty, "-t 3 -r 1", "");
        let now = mbpoll_values(&out).first().copied();
        tally.check(out, now.is_some_and(|s| s >= seconds), &format!("30001 counts seconds from {seconds}"));
        seconds = now.unwrap_or(seconds);
    }
    let console_saw = wait_for_writes(&console, tally.writes);

    // Last: an mbpoll polling every 10 ms, stopped with SIGINT (its statistics then; the request
    // it was waiting for answered after it left, into the pty).
    let mut cmd = Command::new("timeout");
    cmd.args(["-s", "INT", &format!("{}", MBPOLL_POLLING.as_secs_f64()), "mbpoll"]);
    cmd.args(MBPOLL_LINE.split(' ')).args("-l 10 -t 4 -r 1 -c 16".split(' ')).arg(tty);
    let (_, out) = run(&mut cmd, MBPOLL_POLLING + Duration::from_secs(5));
    let stats: Vec<u64> = out
        .lines()
        .find(|l| l.contains("frames transmitted"))
        .map(|l| l.split(|c: char| !c.is_ascii_digit()).filter_map(|n| n.parse().ok()).take(3).collect())
        .unwrap_or_default();
    let [sent, received, errors] = stats[..] else { panic!("no statistics from the polling mbpoll:\n{out}") };
    let last_block: Vec<i64> = (0..16).map(|i| ((MBPOLL_ROUNDS as i64 - 1) * 16 + i) * 257 % 65536).collect();
    let mut expected = last_block.clone();
    expected[((MBPOLL_ROUNDS - 1) % 16) as usize] = 50_000 + MBPOLL_ROUNDS as i64 - 1;
    let polls = mbpoll_values(&out);
    let wrong_values = polls.chunks(16).filter(|p| p.len() == 16 && *p != expected.as_slice()).count();
    thread::sleep(Duration::from_millis(100));
    let malformed = board.malformed();

    println!(
        "mbpoll on pins 8/9: {} one-shot requests ({} writes), {} errors; polling: {sent} sent, {received} \
         answered, {errors} errors, {wrong_values} with wrong values; {} malformed characters; USART0's console \
         counted {console_saw:?} writes; {:.1} s",
        tally.requests,
        tally.writes,
        tally.errors,
        malformed.len(),
        started.elapsed().as_secs_f64()
    );
    let log = board.process.log();
    assert_eq!(tally.errors, 0, "{}--- virtual-uno ---\n{log}", tally.wrong);
    assert!(sent >= 20 && errors == 0 && received + 1 >= sent && wrong_values == 0, "{out}--- virtual-uno ---\n{log}");
    assert!(malformed.is_empty(), "{}", malformed.join("\n"));
    assert_eq!(console_saw, Some(tally.writes), "USART0's console:\n{}", console.lock().unwrap());
}

#[test]
fn pymodbus_reads_and_writes_the_slave_on_pins_8_9_without_an_error() {
    let _one = serialise();
    let board = Board::start(&firmware("atmega328p-capture", "boards"));
    let console = board.console();
    let started = Instant::now();
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_check.py")).arg(&board.pins);
    cmd.args(["--board", "boards", "--rounds", &PYMODBUS_ROUNDS.to_string()]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    // One broadcast, then four writes a round.
    let writes = 1 + 4 * u64::from(PYMODBUS_ROUNDS);
    let console_saw = wait_for_writes(&console, writes);
    let malformed = board.malformed();
    let summary = out.lines().find(|l| l.contains(" rounds: ")).unwrap_or("no summary");
    println!(
        "pymodbus on pins 8/9 (python: {}): {summary}; {} malformed characters; USART0's console counted \
         {console_saw:?} writes; {:.1} s",
        python(),
        malformed.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(ok, "{out}--- virtual-uno ---\n{}", board.process.log());
    assert!(malformed.is_empty(), "{}", malformed.join("\n"));
    assert_eq!(console_saw, Some(writes), "USART0's console:\n{}", console.lock().unwrap());
}

/// The field device's holding registers 0-9 (`demo/plant_slave.py`): 0x0300 + i.
fn field_registers() -> Vec<i64> {
    (0..10).map(|i| 0x0300 + i).collect()
}

/// The field device's coil writes `plant_slave: unit 1 coils 0-7 <- [..]` (FC 15 of the eight),
/// oldest first.
fn field_coil_writes(log: &str) -> Vec<Vec<i64>> {
    log.lines()
        .filter_map(|l| l.strip_prefix("plant_slave: unit 1 coils 0-7 <- [")?.strip_suffix(']'))
        .map(|list| list.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .collect()
}

/// Rounds of the SCADA: coils written (FC 15, every fourth round FC 5), read back, the field
/// device's registers read.
const GATEWAY_ROUNDS: i64 = 24;

#[test]
fn the_gateway_on_one_uno_carries_the_scadas_reads_and_writes_to_pymodbus_on_pins_8_9() {
    let _one = serialise();
    let board = Board::start(&firmware("atmega328p-capture-gateway", "gateway"));
    let started = Instant::now();
    let field = Spawned::start(
        Command::new(python()).arg(workspace().join("demo/plant_slave.py")).arg(&board.pins).args(["--unit", "1"]),
    );
    assert!(field.wait_for("plant_slave: unit 1 on", Duration::from_secs(10)), "pymodbus:\n{}", field.log());
    let scada = board.usart.as_path();
    let mut tally = Tally::default();

    // The gateway polls every 100 ms: its 40001-40010 are the field device's soon.
    let deadline = Instant::now() + Duration::from_secs(3);
    let mut first = String::new();
    while Instant::now() < deadline {
        first = mbpoll(scada, "-t 4 -r 1 -c 10", "");
        if mbpoll_values(&first) == field_registers() {
            break;
        }
        thread::sleep(Duration::from_millis(100));
    }
    let arrived = mbpoll_values(&first) == field_registers();
    tally.check(first, arrived, "40001-40010: the field device's registers within 3 s");
    let out = mbpoll(scada, "-t 3 -r 1 -c 3", "");
    let before = mbpoll_values(&out);
    tally.check(out, before.len() == 3, "30001-30003");

    let mut coils = vec![0i64; 8];
    let mut written = Vec::new();
    for r in 0..GATEWAY_ROUNDS {
        if r % 4 == 3 {
            let one = (r / 4 % 8) as usize;
            coils[one] = 1 - coils[one];
            tally.write(scada, &format!("-t 0 -r {}", one + 1), &coils[one].to_string(), 1);
        } else {
            coils = (0..8).map(|i| (r * 37 + 11) >> i & 1).collect();
            let text: Vec<String> = coils.iter().map(i64::to_string).collect();
            tally.write(scada, "-t 0 -r 1", &text.join(" "), 8);
        }
        written.push(coils.clone());
        tally.read(scada, "-t 0 -r 1 -c 8", &coils);
        tally.read(scada, "-t 4 -r 1 -c 10", &field_registers());
    }
    // The last coils on their way, then the gateway's counters.
    thread::sleep(Duration::from_millis(300));
    let out = mbpoll(scada, "-t 3 -r 1 -c 3", "");
    let after = mbpoll_values(&out);
    let polls = after.first().zip(before.first()).map(|(a, b)| (a - b).rem_euclid(65536));
    let failures = after.get(1).zip(before.get(1)).map(|(a, b)| (a - b).rem_euclid(65536));
    tally.check(out, failures == Some(0), &format!("30002 (failed polls) moved: {before:?} -> {after:?}"));

    // The gateway's first write, of its coils as they start (all off), then each of the SCADA's.
    let arrived: Vec<Vec<i64>> = field_coil_writes(&field.log()).into_iter().skip_while(|c| c == &[0; 8]).collect();
    let malformed = board.malformed();
    println!(
        "gateway on one Uno, pymodbus's serial server on pins 8/9: the SCADA (mbpoll on USART0) {} requests \
         ({} writes), {} errors; the gateway's polls answered meanwhile {polls:?}, failed {failures:?} (30001-30003 \
         {before:?} -> {after:?}); the field device took {} of the SCADA's {} coil writes; {} malformed characters; \
         {:.1} s",
        tally.requests,
        tally.writes,
        tally.errors,
        arrived.len(),
        written.len(),
        malformed.len(),
        started.elapsed().as_secs_f64()
    );
    let transcript = format!("--- pymodbus ---\n{}--- virtual-uno ---\n{}", field.log(), board.process.log());
    assert_eq!(tally.errors, 0, "{}{transcript}", tally.wrong);
    assert_eq!(arrived, written, "the SCADA's coil writes at the field device, in order\n{transcript}");
    assert!(polls.is_some_and(|n| n >= 10), "the gateway's polls answered: {polls:?}\n{transcript}");
    assert!(malformed.is_empty(), "{}", malformed.join("\n"));
}
