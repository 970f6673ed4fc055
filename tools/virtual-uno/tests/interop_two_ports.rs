//! One model on two ports against masters nobody here wrote, both at once: examples/tcp_rtu.rs
//! (`shared_model!`: the RTU slave on pins 0/1, slave 1 at 19200 8E1, and the TCP server on a
//! W5100) on the virtual Uno with its serial line on a pty and its shield bridged to a host
//! port (`--link PATH --wiznet w5100 --tcp 502:0`). mbpoll polls the serial line, one process
//! a request, writing the pair 40001-40002 (FC 16) and reading 40001-40004 back, while
//! pymodbus's TCP client (`demo/pymodbus_two_ports.py`, on pymodbus 3.0 or 3.13 as
//! `INTEROP_PYTHON` has it) loops on a connection of its own, writing 40003-40004 (FC 16) and
//! reading 40001-40004 back. Every reply on both sides is checked: each master reads its own
//! pair as it wrote it, and the other's as a whole pair that only moves forward and moves
//! while both run; at the end each reads the other's last write, and input registers
//! 30001-30002 (the loop's count of master writes and last writer) count every write of both
//! and name the port that wrote last. The control, examples/tcp_rtu_copy.rs (two maps and a
//! copy), fails the same check.
//!
//! Needs `make tcp-firmware` (tcp_rtu and tcp_rtu_copy in target/chips/atmega328p-tcp) and what
//! `make setup` installs: mbpoll, the Python with pymodbus. `make interop` runs it;
//! `TWO_PORTS_SECONDS` sets how long both masters poll (20 there).

mod common;

use common::{collect, python, run, serialise, stop, workspace, Spawned};

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};

/// `examples/NAME.rs` as `make tcp-firmware` builds it for the W5100 (atmega328p-tcp).
fn firmware(name: &str) -> PathBuf {
    let elf = target_dir().join("chips/atmega328p-tcp/avr-none/release/examples").join(format!("{name}.elf"));
    built(elf, "make tcp-firmware")
}

/// How long both masters poll at once.
fn seconds() -> u64 {
    std::env::var("TWO_PORTS_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(20)
}

/// A running `virtual-uno`: USART0 on the pty `tty`, the chip's port 502 on 127.0.0.1:`port`.
struct Board {
    process: Spawned,
    tty: PathBuf,
    port: u16,
}

impl Board {
    fn start(firmware: &Path) -> Board {
        let tty = std::env::temp_dir().join(format!("vuno-{}-two-ports.tty", std::process::id()));
        let process = Spawned::start(
            Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
                .arg("--link")
                .arg(&tty)
                .args(["--no-stdin", "--wiznet", "w5100", "--tcp", "502:0"])
                .arg(firmware),
        );
        let port = process.port_after("tcp: 127.0.0.1:", "the firmware");
        assert!(process.wait_for("serial: ", Duration::from_secs(10)), "no serial line:\n{}", process.log());
        Board { process, tty, port }
    }
}

/// `mbpoll -m rtu -b 19200 -P even -a 1 -o 1 -1 ARGS TTY VALUES`: the command and its output.
fn mbpoll(board: &Board, args: &str, values: &str) -> String {
    let mut cmd = Command::new("mbpoll");
    cmd.args("-m rtu -b 19200 -P even -a 1 -o 1 -1".split(' ')).args(args.split_whitespace());
    cmd.arg(&board.tty).args(values.split_whitespace());
    let (_, out) = run(&mut cmd, Duration::from_secs(10));
    format!("$ mbpoll {args} {values}\n{out}")
}

/// The values of mbpoll's `[ref]: value` lines.
fn mbpoll_values(out: &str) -> Vec<i64> {
    out.lines().filter(|l| l.starts_with('[')).filter_map(|l| l.split(':').nth(1)?.trim().parse().ok()).collect()
}

/// `demo/pymodbus_two_ports.py` on the board's TCP port, fed commands on its standard input.
struct Pymodbus {
    child: Child,
    stdin: Option<ChildStdin>,
    out: Arc<Mutex<String>>,
}

impl Pymodbus {
    fn start(board: &Board) -> Pymodbus {
        let mut child = Command::new(python())
            .arg(workspace().join("demo/pymodbus_two_ports.py"))
            .args(["127.0.0.1", &board.port.to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start pymodbus_two_ports.py");
        let out = Arc::new(Mutex::new(String::new()));
        collect(child.stdout.take().unwrap(), out.clone());
        collect(child.stderr.take().unwrap(), out.clone());
        let stdin = child.stdin.take();
        let pymodbus = Pymodbus { child, stdin, out };
        let deadline = Instant::now() + Duration::from_secs(10);
        while !pymodbus.out().contains(" on 127.0.0.1:") {
            assert!(Instant::now() < deadline, "pymodbus did not connect:\n{}", pymodbus.out());
            thread::sleep(Duration::from_millis(20));
        }
        pymodbus
    }

    fn out(&self) -> String {
        self.out.lock().unwrap().clone()
    }

    /// Sends `command`; the next JSON line of its output (waited for up to 10 s).
    fn ask(&mut self, command: &str) -> String {
        let before = self.out().lines().filter(|l| l.starts_with('{')).count();
        writeln!(self.stdin.as_mut().unwrap(), "{command}").expect("write to pymodbus");
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(line) = self.out().lines().filter(|l| l.starts_with('{')).nth(before) {
                return line.to_owned();
            }
            assert!(Instant::now() < deadline, "pymodbus did not answer `{command}`:\n{}", self.out());
            thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Pymodbus {
    fn drop(&mut self) {
        drop(self.stdin.take());
        stop(&mut self.child);
    }
}

/// The number after `"key": ` in a JSON line.
fn number(json: &str, key: &str) -> i64 {
    let at = json.find(&format!("\"{key}\": ")).unwrap_or_else(|| panic!("no {key} in {json}")) + key.len() + 4;
    let digits: String = json[at..].chars().take_while(|c| c.is_ascii_digit() || *c == '-').collect();
    digits.parse().unwrap_or_else(|_| panic!("{key} in {json}"))
}

/// The list of numbers after `"key": ` in a JSON line (`null`: none).
fn numbers(json: &str, key: &str) -> Option<Vec<i64>> {
    let at = json.find(&format!("\"{key}\": ")).unwrap_or_else(|| panic!("no {key} in {json}")) + key.len() + 4;
    let rest = json[at..].strip_prefix('[')?;
    Some(rest[..rest.find(']')?].split(',').filter_map(|v| v.trim().parse().ok()).collect())
}

/// What the run found.
struct Verdict {
    /// Requests and errors of mbpoll (serial) and pymodbus (TCP) while both polled.
    serial: (u64, u64),
    tcp: (i64, i64),
    /// What went wrong, each a line.
    wrong: Vec<String>,
    /// mbpoll's and pymodbus's transcripts, and the board's log.
    transcript: String,
}

/// Both masters on `firmware` for `seconds`, then the end checks.
fn two_masters(firmware: &Path, seconds: u64) -> Verdict {
    let board = Board::start(firmware);
    let mut tcp = Pymodbus::start(&board);
    let mut log = String::new();
    let mut wrong = Vec::new();
    let (mut requests, mut errors, mut writes) = (0u64, 0u64, 0i64);
    let (mut k, mut j, mut moves) = (0i64, 0i64, 0u64);
    let until = Instant::now() + Duration::from_secs(seconds);
    let mut fail = |log: &mut String, errors: &mut u64, out: &str, why: String| {
        *errors += 1;
        wrong.push(why);
        log.push_str(out);
    };
    while Instant::now() < until {
        // The serial master writes its pair, then reads both pairs back.
        requests += 1;
        let out = mbpoll(&board, "-t 4 -r 1", &format!("{} {}", k + 1, k + 1));
        if !out.contains("Written 2 references") {
            fail(&mut log, &mut errors, &out, format!("serial write of 40001-40002 = {}", k + 1));
            continue;
        }
        k += 1;
        writes += 1;
        requests += 1;
        let out = mbpoll(&board, "-t 4 -r 1 -c 4", "");
        let v = mbpoll_values(&out);
        if v.len() != 4 || v[..2] != [k, k] || v[2] != v[3] || v[2] < j {
            fail(
                &mut log,
                &mut errors,
                &out,
                format!("serial read of 40001-40004 {v:?}: wrote {k}, TCP's pair was {j}"),
            );
            continue;
        }
        if v[2] != j {
            moves += 1;
            j = v[2];
        }
    }
    let summary = tcp.ask("stop");
    let (tcp_requests, tcp_errors, tcp_writes) =
        (number(&summary, "requests"), number(&summary, "errors"), number(&summary, "writes"));
    let (last_j, seen) = (number(&summary, "j"), number(&summary, "seen"));
    let version = tcp.out().lines().next().unwrap_or_default().split(" on ").next().unwrap_or_default().to_owned();
    println!(
        "{seconds} s: serial (mbpoll, one process a request): {requests} requests, {errors} errors, {writes} writes, \
         TCP's pair seen moving {moves} times; TCP ({version}): {tcp_requests} requests, {tcp_errors} errors, \
         {tcp_writes} writes, the serial pair seen moving {seen} times"
    );
    if tcp_errors != 0 {
        wrong.push(format!("pymodbus: {tcp_errors} errors"));
    }
    if moves < 2 || seen < 2 {
        wrong.push(format!("a pair written on one port moved on the other {moves} (serial) and {seen} (TCP) times"));
    }

    // Each reads the other's last write; the writes of both are counted, the last writer named.
    let out = mbpoll(&board, "-t 4 -r 3 -c 2", "");
    if mbpoll_values(&out) != [last_j, last_j] {
        wrong.push(format!("serial read of 40003-40004 {:?}: TCP wrote {last_j} last", mbpoll_values(&out)));
    }
    log.push_str(&out);
    let out = mbpoll(&board, "-t 4 -r 1", &format!("{} {}", k + 1, k + 1));
    if out.contains("Written 2 references") {
        writes += 1;
    }
    log.push_str(&out);
    let total = writes + tcp_writes;
    let answer = tcp.ask("read");
    if numbers(&answer, "holding") != Some(vec![k + 1, k + 1]) || numbers(&answer, "input") != Some(vec![total, 1]) {
        wrong.push(format!("TCP read {answer}: serial wrote {} last; {total} writes, the last serial (1)", k + 1));
    }
    let answer = tcp.ask("write");
    if numbers(&answer, "input") != Some(vec![total + 1, 2]) {
        wrong.push(format!("TCP read {answer} after its write: {} writes, the last TCP (2)", total + 1));
    }
    let out = mbpoll(&board, "-t 3 -r 1 -c 2", "");
    if mbpoll_values(&out) != [total + 1, 2] {
        wrong.push(format!(
            "serial read of 30001-30002 {:?}: {} writes, the last TCP (2)",
            mbpoll_values(&out),
            total + 1
        ));
    }
    log.push_str(&out);
    drop(tcp.stdin.take());
    let transcript = format!(
        "--- mbpoll (failed steps and the end) ---\n{log}--- pymodbus ---\n{}--- virtual-uno ---\n{}",
        tcp.out(),
        board.process.log()
    );
    Verdict { serial: (requests, errors), tcp: (tcp_requests, tcp_errors), wrong, transcript }
}

#[test]
fn mbpoll_on_the_serial_line_and_pymodbus_over_tcp_at_once_read_each_others_writes() {
    let _one = serialise();
    let verdict = two_masters(&firmware("tcp_rtu"), seconds());
    assert!(verdict.wrong.is_empty(), "{}\n{}", verdict.wrong.join("\n"), verdict.transcript);
    assert!(verdict.serial.0 > 0 && verdict.tcp.0 > 0);
}

#[test]
fn two_maps_and_a_copy_fail_the_same_check() {
    // tcp_rtu_copy copies TCP's 40001-40002 to the serial side's every 4 ms and nothing back:
    // the serial master's writes are overwritten and never reach TCP, TCP's 40003-40004 never
    // reach the serial line.
    let _one = serialise();
    let verdict = two_masters(&firmware("tcp_rtu_copy"), 3);
    println!("two maps and a copy: {}; …", verdict.wrong[..verdict.wrong.len().min(3)].join("; "));
    assert!(verdict.wrong.iter().any(|w| w.contains("moved on the other")), "{}", verdict.transcript);
    assert!(verdict.wrong.iter().any(|w| w.contains("40003-40004")), "{}", verdict.transcript);
}
