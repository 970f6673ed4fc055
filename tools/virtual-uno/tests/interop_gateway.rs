//! Modbus TCP masters nobody here wrote through the TCP to RTU gateway
//! (examples/tcp_gateway.rs) on a virtual Uno with its virtual W5100, to slaves on a virtual
//! RS-485 line (`virtual-line --board gateway=… wiznet=w5100 tcp=502:PORT`): libmodbus 3.1.6's
//! own `unit-test-client tcp` to examples/libmodbus_map_rtu.rs (libmodbus's unit-test map, RTU
//! slave 17); mbpoll and pymodbus's TCP client (`demo/pymodbus_gateway_check.py`) to pymodbus's
//! serial server on a pty (`demo/plant_slave.py`, unit 3), with faults on both sides: the slave
//! switched off and on again (0B, then answers), units nobody answers (0B) or the gateway does
//! not route (0A), clients that go away mid-request; four mbpoll masters at once to the lab's
//! two boards (examples/lab_lights.rs), pymodbus and the gateway itself. Each test starts its
//! own line (one at a time: each keeps a core busy) and fails with the master's transcript and
//! the line's log.
//!
//! Needs `make firmware` (libmodbus_map_rtu), `make tcp-firmware` (tcp_gateway) and what `make
//! setup` installs: mbpoll, Debian's python3-pymodbus 3.0 with python3-serial-asyncio,
//! libmodbus's test programs (`.ci/libmodbus-tests`: unit-test-client-all, and
//! unit-test-client-gw, the same addressing unit 17 over TCP). `make interop` runs it.

mod common;

use common::{collect, run, serialise, stop, workspace, Spawned};

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};

/// examples/tcp_gateway.rs as `make tcp-firmware` builds it.
fn gateway_firmware() -> PathBuf {
    built(
        target_dir().join("chips/atmega328p-tcp-gateway/avr-none/release/examples/tcp_gateway.elf"),
        "make tcp-firmware",
    )
}

/// examples/libmodbus_map_rtu.rs as `make firmware` builds it.
fn unit_test_map_rtu() -> PathBuf {
    built(target_dir().join("avr-atmega328p/release/examples/libmodbus_map_rtu.elf"), "make firmware")
}

/// Debian's Python, which has pymodbus 3.0 and serial_asyncio (the interop venv sees them too).
fn python() -> String {
    common::python()
}

/// A running `virtual-line`: the gateway (DE on pin 3) and the rest, stopped when dropped.
struct Line {
    process: Spawned,
    /// Where the gateway's port 502 is on 127.0.0.1.
    port: u16,
}

impl Line {
    /// The gateway with its port 502 on 127.0.0.1:`host_port` (0: any) and `members` (more
    /// `--board`/`--pty` words); waits until the firmware listens.
    fn start(host_port: u16, members: &[String]) -> Line {
        let process = Spawned::start(
            Command::new(env!("CARGO_BIN_EXE_virtual-line"))
                .arg("--no-stdin")
                .arg("--board")
                .arg(format!("gateway={}", gateway_firmware().display()))
                .args(["de=3", "wiznet=w5100", &format!("tcp=502:{host_port}"), "watch=none"])
                .args(members),
        );
        let port = process.port_after("gateway tcp: 127.0.0.1:", "the gateway");
        Line { process, port }
    }

    fn log(&self) -> String {
        self.process.log()
    }

    /// Lines of the log with `what`.
    fn count(&self, what: &str) -> usize {
        self.process.count(what)
    }

    /// Waits up to `limit` for a line of the log with `what`.
    fn wait_for(&self, what: &str, limit: Duration) -> bool {
        self.process.wait_for(what, limit)
    }
}

/// What a failed test prints.
fn transcript(master: &str, line: &Line) -> String {
    format!("--- master ---\n{master}--- virtual-line ---\n{}", line.log())
}

/// pymodbus's serial server as unit 3 on the pty `tty` (demo/plant_slave.py), alone with the
/// gateway on the line: pymodbus's own framing. Stopped (switched off) when dropped.
struct Pymodbus {
    _process: Spawned,
}

impl Pymodbus {
    fn start(tty: &str) -> Pymodbus {
        let process = Spawned::start(
            Command::new(python()).arg(workspace().join("demo/plant_slave.py")).args([tty, "--unit", "3"]),
        );
        let up = process.wait_for("plant_slave: unit 3 on", Duration::from_secs(10));
        assert!(up, "pymodbus's server did not start:\n{}", process.log());
        Pymodbus { _process: process }
    }
}

/// A pty path of this test's own.
fn tty(name: &str) -> String {
    format!("/tmp/ttyGW-{name}-{}", std::process::id())
}

// ------------------------------------------------------------------------------------------
// libmodbus's own unit-test-client

/// libmodbus 3.1.6's test programs, built by `.ci/libmodbus-tests` (`make setup`).
fn libmodbus_test(name: &str) -> PathBuf {
    built(workspace().join("target/libmodbus-tests").join(name), "make setup")
}

/// The checks that failed: the source line of each, and libmodbus's text.
fn failed_checks(out: &str) -> Vec<(u32, String)> {
    out.lines()
        .filter_map(|l| {
            let rest = l.strip_prefix("Line ")?;
            let (line, what) = rest.split_once(": assertion error for ")?;
            Some((line.parse().ok()?, what.to_owned()))
        })
        .collect()
}

/// The checks of unit-test-client.c (by line) that fail through a gateway to unit 17 on the
/// line, and why a gateway must differ, or why only libmodbus's own server passes them.
const THROUGH_A_GATEWAY: [(u32, &str); 7] = [
    (
        502,
        "1/3 unit 18 answered: a server answers any unit, a gateway passes 18 to the line, where no \
         slave 18 is, and answers 0B (gateway target device failed to respond, §4.4.2.5)",
    ),
    (
        510,
        "2/3 unit 0 answered: 0 is a broadcast for a gateway (§4.4.1.2): sent to the line as a write, \
         never answered; a read is no broadcast and is dropped, so the client times out",
    ),
    (519, "3/3 read 0x171: libmodbus's server answers with a wrong transaction id on purpose; the slave answers right"),
    (590, "5/6 read 0x172 with a 0.2 s timeout: libmodbus's server sleeps 0.5 s first; the slave answers at once"),
    (
        623,
        "1/2 read 0x173 with a 3 ms byte timeout: libmodbus's server sends a byte every 5 ms; the gateway \
         sends the answer whole",
    ),
    (650, "bad response: libmodbus's server answers a read of 2 registers with 1 on purpose; the slave with 2"),
    (659, "manual exception: libmodbus's server answers 0x170 with exception 06 (busy); the slave reads the register"),
];

#[test]
fn libmodbus_unit_test_client_through_the_gateway_to_an_rtu_slave() {
    let _one = serialise();
    let shipped = libmodbus_test("unit-test-client-all");
    let to_unit_17 = libmodbus_test("unit-test-client-gw");
    let server = libmodbus_test("unit-test-server");
    let slave = unit_test_map_rtu();

    // The reference: the same client against libmodbus's own server on 127.0.0.1:1502 (it serves
    // one connection, then quits; over TCP it answers every unit id).
    let mut reference = String::new();
    for _ in 0..10 {
        let mut server = Command::new(&server)
            .arg("tcp")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .expect("unit-test-server");
        thread::sleep(Duration::from_millis(300));
        reference = run(Command::new(&to_unit_17).arg("tcp"), Duration::from_secs(60)).1;
        let _ = server.kill();
        let _ = server.wait();
        if !reference.contains("Connection failed") {
            break;
        }
    }
    let reference_failed = failed_checks(&reference);
    assert!(
        reference.contains("CHECKS FAILED.") && reference.matches("OK").count() > 90,
        "unit-test-client-gw did not run through against libmodbus's own server:\n{reference}"
    );
    let line =
        Line::start(1502, &["--board".into(), format!("ut={}", slave.display()), "de=10".into(), "watch=none".into()]);

    // As shipped, over TCP the client asks unit 255 (MODBUS_TCP_SLAVE), but for its unit 18 and
    // unit 0 checks: through a gateway, 255 is the gateway itself (its own registers).
    let (_, out) = run(Command::new(&shipped).arg("tcp"), Duration::from_secs(120));
    let passed = out.lines().filter(|l| l.ends_with("OK")).count();
    let failed = failed_checks(&out).len();
    let requests = |unit: &str| line.log().lines().filter(|l| l.contains("request tid") && l.contains(unit)).count();
    let to_255 = requests("unit 255 fc");
    println!(
        "libmodbus 3.1.6 unit-test-client tcp (as shipped, unit 255) through the gateway: {passed} checks OK, \
         {failed} failed; {to_255} of its requests for unit 255, the gateway's own registers"
    );
    assert!(out.contains("CHECKS FAILED."), "unit-test-client did not run through:\n{}", transcript(&out, &line));

    // Addressing unit 17, the slave on the line.
    let requests_before = line.count("request tid");
    let started = Instant::now();
    let (_, out) = run(Command::new(&to_unit_17).arg("tcp"), Duration::from_secs(120));
    let took = started.elapsed();
    println!("{out}");
    let failed = failed_checks(&out);
    let passed = out.lines().filter(|l| l.ends_with("OK")).count();
    let frames = line.count("frame from ut:");
    println!(
        "libmodbus 3.1.6 unit-test-client tcp (unit 17) through the gateway to examples/libmodbus_map_rtu.rs: \
         {passed} checks OK, {} failed, {:.1} s; {} TCP requests, {frames} answers from the slave on the line",
        failed.len(),
        took.as_secs_f64(),
        line.count("request tid") - requests_before
    );
    for (l, what) in &reference_failed {
        println!("  line {l}: fails against libmodbus's own server too (no request sent): {what}");
    }
    for (l, why) in THROUGH_A_GATEWAY {
        let seen = failed.iter().any(|&(f, _)| f == l);
        println!("  line {l}: {} {why}", if seen { "fails as expected:" } else { "PASSES, not expected:" });
    }
    let known =
        |l: u32| THROUGH_A_GATEWAY.iter().any(|&(k, _)| k == l) || reference_failed.iter().any(|&(k, _)| k == l);
    let unexpected: Vec<String> =
        failed.iter().filter(|(l, _)| !known(*l)).map(|(l, what)| format!("line {l}: {what}")).collect();
    let missing: Vec<u32> =
        THROUGH_A_GATEWAY.iter().map(|&(l, _)| l).filter(|&l| !failed.iter().any(|&(f, _)| f == l)).collect();
    assert!(
        out.contains("CHECKS FAILED.") && unexpected.is_empty() && missing.is_empty(),
        "unit-test-client through the gateway: failed checks not explained {unexpected:?}; expected deviations \
         that did not fail {missing:?}\n{}",
        transcript(&out, &line)
    );
    assert_eq!(line.count("COLLISION") + line.count("bad CRC"), 0, "{}", transcript("", &line));
}

// ------------------------------------------------------------------------------------------
// mbpoll and pymodbus to pymodbus's serial server, with faults

/// `mbpoll -m tcp -p PORT -1 ARGS 127.0.0.1 VALUES`: its output, after the command.
fn mbpoll(line: &Line, args: &str, values: &str) -> String {
    let mut cmd = Command::new("mbpoll");
    cmd.args(["-m", "tcp", "-p", &line.port.to_string(), "-1", "-o", "2"]).args(args.split_whitespace());
    cmd.arg("127.0.0.1").args(values.split_whitespace());
    let (_, out) = run(&mut cmd, Duration::from_secs(10));
    format!("$ mbpoll -m tcp -p {} -1 -o 2 {args} 127.0.0.1 {values}\n{out}", line.port)
}

#[test]
fn mbpoll_through_the_gateway_to_pymodbus_switched_off_and_on() {
    let _one = serialise();
    let tty = tty("mbpoll");
    let line = Line::start(0, &["--pty".into(), format!("pymodbus={tty}")]);
    let slave = Pymodbus::start(&tty);
    let mut log = String::new();
    let (mut checks, mut passed) = (0, 0);
    let mut check = |out: String, want: &str, log: &mut String| {
        checks += 1;
        let ok = out.contains(want);
        passed += usize::from(ok);
        log.push_str(&out);
        log.push_str(&format!("# {}: {want}\n", if ok { "ok" } else { "FAILED, expected" }));
    };
    check(mbpoll(&line, "-a 3 -t 4 -r 1 -c 4", ""), "[4]: \t771", &mut log);
    check(mbpoll(&line, "-a 3 -t 4 -r 9", "1000 2000"), "Written 2 references", &mut log);
    check(mbpoll(&line, "-a 3 -t 4 -r 9 -c 2", ""), "[10]: \t2000", &mut log);
    check(mbpoll(&line, "-a 3 -t 0 -r 1", "1 1 0 1"), "Written 4 references", &mut log);
    check(mbpoll(&line, "-a 3 -t 0 -r 1 -c 4", ""), "[4]: \t1", &mut log);
    check(mbpoll(&line, "-a 3 -t 1 -r 1 -c 2", ""), "[2]: \t1", &mut log);
    check(mbpoll(&line, "-a 3 -t 3 -r 1 -c 2", ""), "[2]: \t12289", &mut log);
    check(mbpoll(&line, "-a 3 -t 4 -r 11", ""), "Illegal data address", &mut log);
    check(mbpoll(&line, "-a 12 -t 4 -r 1", ""), "Target device failed to respond", &mut log);
    // mbpoll cannot ask units 248-254 (0A is pymodbus's check): libmodbus's modbus_set_slave
    // refuses them over TCP, mbpoll goes on, and the request goes to unit 255, the gateway.
    let before = line.count("request tid 0x0001 unit 255 ");
    check(mbpoll(&line, "-a 250 -t 4 -r 1", ""), "[1]: \t", &mut log);
    let asked = if line.count("request tid 0x0001 unit 255 ") == before + 1 { "255" } else { "another" };
    check(format!("# mbpoll -a 250 asked unit {asked}\n"), "asked unit 255", &mut log);
    // Switched off: 0B after the line's timeout and retry, three times (three misses in a
    // row take it down), then at once while it is down.
    drop(slave);
    let started = Instant::now();
    for _ in 0..3 {
        check(mbpoll(&line, "-a 3 -t 4 -r 1", ""), "Target device failed to respond", &mut log);
    }
    let first = started.elapsed() / 3;
    let started = Instant::now();
    check(mbpoll(&line, "-a 3 -t 4 -r 1", ""), "Target device failed to respond", &mut log);
    let again = started.elapsed();
    log.push_str(&format!("# switched off: 0B after {first:?}, then after {again:?}\n"));
    // Switched on again: answered once the gateway tries it again (each second).
    let slave = Pymodbus::start(&tty);
    thread::sleep(Duration::from_millis(1200));
    let mut back = mbpoll(&line, "-a 3 -t 4 -r 1", "");
    if !back.contains("[1]: \t768") {
        thread::sleep(Duration::from_millis(1200));
        back.push_str(&mbpoll(&line, "-a 3 -t 4 -r 1", ""));
    }
    check(back, "[1]: \t768", &mut log);
    check(mbpoll(&line, "-a 255 -t 4 -r 1 -c 9", ""), "[5]: \t", &mut log);
    // Unit 3's health at the gateway (registers 256 + 4 × 3 …, mbpoll counting from 1): up again.
    check(mbpoll(&line, "-a 255 -t 4 -r 269 -c 4", ""), "[272]: \t0", &mut log);
    drop(slave);
    println!("{log}");
    println!("mbpoll through the gateway to pymodbus's serial server: {checks} checks, {passed} passed");
    assert_eq!(passed, checks, "{}", transcript(&log, &line));
    assert_eq!(line.count("COLLISION") + line.count("bad CRC"), 0, "{}", transcript(&log, &line));
}

#[test]
fn pymodbus_tcp_client_through_the_gateway_with_faults() {
    let _one = serialise();
    let tty = tty("pymodbus");
    let line = Line::start(0, &["--pty".into(), format!("pymodbus={tty}")]);
    let _slave = Pymodbus::start(&tty);
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_gateway_check.py")).args(["127.0.0.1", &line.port.to_string()]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "pymodbus_gateway_check.py failed\n{}", transcript(&out, &line));
    assert!(line.wait_for("request cut short", Duration::from_secs(1)), "{}", transcript(&out, &line));
    assert_eq!(line.count("COLLISION") + line.count("bad CRC"), 0, "{}", transcript(&out, &line));
}

// ------------------------------------------------------------------------------------------
// Several masters at once, to every slave of a plant

/// `N frames transmitted, M received, E errors` of an mbpoll run stopped with SIGINT.
fn mbpoll_statistics(out: &str) -> Option<(u64, u64, u64)> {
    let line = out.lines().find(|l| l.contains("frames transmitted"))?;
    let numbers: Vec<u64> = line.split(|c: char| !c.is_ascii_digit()).filter_map(|w| w.parse().ok()).collect();
    Some((*numbers.first()?, *numbers.get(1)?, *numbers.get(2)?))
}

#[test]
fn four_masters_at_once_through_the_gateway_to_two_boards_pymodbus_and_the_gateway_itself() {
    let _one = serialise();
    let lab = built(target_dir().join("avr-atmega328p/release/examples/lab_lights.elf"), "make firmware");
    let tty = tty("plant");
    let members: Vec<String> = [
        format!("--board box={}", lab.display()),
        "de=10 watch=none".into(),
        format!("--board tower={}", lab.display()),
        "de=10 pin12=low watch=none".into(),
        format!("--pty pymodbus={tty}"),
    ]
    .iter()
    .flat_map(|w| w.split_whitespace().map(str::to_owned).collect::<Vec<_>>())
    .collect();
    let line = Line::start(0, &members);
    // Among other slaves: pymodbus's framing resynchronised, and its answer held back for the
    // line's silence (demo/plant_slave.py says why).
    let mut child = Command::new(python())
        .arg(workspace().join("demo/plant_slave.py"))
        .args([tty.as_str(), "--unit", "3", "--resync", "--turnaround-ms", "2"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start demo/plant_slave.py");
    thread::sleep(Duration::from_millis(1500));
    let asks = ["-a 1 -t 1 -r 1 -c 2", "-a 2 -t 0 -r 1 -c 4", "-a 3 -t 4 -r 1 -c 4", "-a 255 -t 4 -r 1 -c 8"];
    let masters: Vec<(String, Child, Arc<Mutex<String>>)> = asks
        .iter()
        .map(|ask| {
            let mut child = Command::new("mbpoll")
                .args(["-m", "tcp", "-p", &line.port.to_string(), "-l", "20", "-q"])
                .args(ask.split_whitespace())
                .arg("127.0.0.1")
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("start mbpoll");
            let out = Arc::new(Mutex::new(String::new()));
            collect(child.stdout.take().unwrap(), out.clone());
            collect(child.stderr.take().unwrap(), out.clone());
            ((*ask).to_owned(), child, out)
        })
        .collect();
    thread::sleep(Duration::from_secs(6));
    let mut report = String::new();
    let mut all_answered = true;
    for (ask, mut child, out) in masters {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.id() as i32), nix::sys::signal::Signal::SIGINT);
        let deadline = Instant::now() + Duration::from_secs(3);
        while child.try_wait().unwrap().is_none() && Instant::now() < deadline {
            thread::sleep(Duration::from_millis(20));
        }
        stop(&mut child);
        thread::sleep(Duration::from_millis(50));
        let out = out.lock().unwrap().clone();
        let stats = mbpoll_statistics(&out);
        // The poll under way when SIGINT came may go unanswered; none may fail.
        let ok = stats.is_some_and(|(sent, received, errors)| sent >= 20 && received + 1 >= sent && errors == 0);
        all_answered &= ok;
        report += &format!("mbpoll {ask}: {stats:?} (sent, received, errors){}\n", if ok { "" } else { " FAILED" });
        if !ok {
            report += &out;
        }
    }
    stop(&mut child);
    let requests = line.count("request tid");
    let answers = line.count("answer tid");
    let frames = line.count("frame from");
    report += &format!(
        "through the gateway: {requests} TCP requests, {answers} answers; {frames} frames on the line, {} collisions, \
         {} frames after too short a silence\n",
        line.count("COLLISION"),
        line.count("character times after the previous frame")
    );
    println!("{report}");
    assert!(all_answered, "{}", transcript(&report, &line));
    assert_eq!(line.count("COLLISION") + line.count("bad CRC"), 0, "{}", transcript(&report, &line));
}
