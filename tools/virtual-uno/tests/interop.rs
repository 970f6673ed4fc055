//! Real Modbus masters against the firmware on the virtual Uno: mbpoll (Debian), pymodbus
//! (`demo/pymodbus_check.py`), minimalmodbus (`demo/minimalmodbus_check.py`, the library of
//! most Arduino Modbus tutorials) and libmodbus, the library behind mbpoll and QModMaster
//! (`demo/libmodbus_check.c`, compiled here). Each test starts its own virtual Uno on a fresh
//! pty and fails with both transcripts on any mismatch.
//!
//! mbpoll sends only well-formed requests to slaves 1-247 (it refuses address 0 and more than
//! 125 values), so exception 03 and the broadcast are checked through libmodbus directly.
//!
//! Needs the firmware (`make firmware`) and what `make setup` installs and checks: mbpoll,
//! libmodbus-dev and a C compiler, and the Python in `$INTEROP_PYTHON` (target/python: Debian's
//! python3 with python3-pymodbus, python3-serial-asyncio and minimalmodbus).

mod common;

use common::{collect, python, run, serialise, stop, workspace};

use std::ffi::OsStr;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};

/// `$CARGO_TARGET_DIR` (or `<workspace>/target`)`/avr-atmega328p/release/examples/NAME.elf`;
/// missing, it skips these tests or fails them under `make` and in CI (`uno_sim::built`).
fn firmware(name: &str) -> PathBuf {
    built(target_dir().join("avr-atmega328p/release/examples").join(format!("{name}.elf")), "make firmware")
}

/// A running `virtual-uno`, stopped with SIGTERM when dropped.
struct VirtualUno {
    child: Child,
    link: PathBuf,
    control: PathBuf,
    log: Arc<Mutex<String>>,
}

impl VirtualUno {
    /// Starts `firmware` with `options` and waits until its USART0 is configured: the
    /// firmware alone, without a bootloader, so opening the port does not reset it.
    fn start(firmware: &Path, options: &[&str]) -> VirtualUno {
        let tag = firmware.file_stem().unwrap().to_string_lossy().into_owned();
        VirtualUno::spawn(&tag, options.iter().map(|o| o.as_ref()).chain([firmware.as_os_str()]), "serial: ")
    }

    /// Starts a whole Uno: optiboot (`make bootloaders`), its flash and EEPROM in `state`,
    /// the program `firmware` if given (else what `state` holds); waits for its power-on.
    fn board(state: &Path, firmware: Option<&Path>) -> VirtualUno {
        let boot = built(workspace().join("target/bootloaders/optiboot_atmega328.hex"), "make bootloaders");
        let args = [OsStr::new("--bootloader"), boot.as_os_str(), OsStr::new("--state"), state.as_os_str()];
        VirtualUno::spawn("board", args.into_iter().chain(firmware.map(Path::as_os_str)), "reset: power-on")
    }

    fn spawn<'a>(tag: &str, args: impl IntoIterator<Item = &'a OsStr>, ready: &str) -> VirtualUno {
        let dir = std::env::temp_dir();
        let tag = format!("vuno-{}-{tag}", std::process::id());
        let (link, control) = (dir.join(format!("{tag}.tty")), dir.join(format!("{tag}.ctl")));
        let mut child = Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
            .arg("--link")
            .arg(&link)
            .arg("--control")
            .arg(&control)
            .args(["--no-stdin"])
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start virtual-uno");
        let log = Arc::new(Mutex::new(String::new()));
        collect(child.stdout.take().unwrap(), log.clone());
        collect(child.stderr.take().unwrap(), log.clone());
        let uno = VirtualUno { child, link, control, log };
        let deadline = Instant::now() + Duration::from_secs(10);
        while !uno.log().contains(ready) {
            assert!(Instant::now() < deadline, "virtual-uno did not start:\n{}", uno.log());
            thread::sleep(Duration::from_millis(20));
        }
        uno
    }

    fn port(&self) -> &str {
        self.link.to_str().unwrap()
    }

    fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }

    /// Waits up to `limit` for `pattern` in the output after its first `from` bytes; the
    /// position just past it.
    fn wait_for(&self, pattern: &str, from: usize, limit: Duration) -> usize {
        let deadline = Instant::now() + limit;
        loop {
            let log = self.log();
            if let Some(at) = log.get(from..).and_then(|rest| rest.find(pattern)) {
                return from + at + pattern.len();
            }
            assert!(Instant::now() < deadline, "no `{pattern}` from the virtual board in {limit:?}:\n{log}");
            thread::sleep(Duration::from_millis(20));
        }
    }

    /// How many times the board reset because its port was opened.
    fn port_resets(&self) -> usize {
        self.log().matches("reset: RESET pin").count()
    }

    /// Sends a command (`pin 6 0`) and gives the firmware time to see it.
    fn control(&self, command: &str) {
        std::fs::write(&self.control, format!("{command}\n")).expect("write the control FIFO");
        thread::sleep(Duration::from_millis(100));
    }
}

impl Drop for VirtualUno {
    fn drop(&mut self) {
        stop(&mut self.child);
    }
}

/// What a failed test prints.
fn transcript(master: &str, uno: &VirtualUno) -> String {
    format!("--- master ---\n{master}--- virtual-uno ---\n{}", uno.log())
}

// ------------------------------------------------------------------------------------------
// mbpoll

/// `mbpoll -m rtu -b 19200 -P even -1 ARGS PORT VALUES`: its output.
fn mbpoll(uno: &VirtualUno, args: &str, values: &str) -> String {
    mbpoll_at(uno, "-b 19200 -P even", args, values)
}

/// `mbpoll -m rtu LINE -o 1 -1 ARGS PORT VALUES`: its output.
fn mbpoll_at(uno: &VirtualUno, line: &str, args: &str, values: &str) -> String {
    let mut cmd = Command::new("mbpoll");
    cmd.args("-m rtu -o 1 -1".split(' ')).args(line.split_whitespace()).args(args.split_whitespace());
    cmd.arg(uno.port()).args(values.split_whitespace());
    let (_, out) = run(&mut cmd, Duration::from_secs(10));
    format!("$ mbpoll {args} {} {values}\n{out}", uno.port())
}

/// The values of `[ref]: value` lines.
fn mbpoll_values(out: &str) -> Vec<i64> {
    out.lines().filter(|l| l.starts_with('[')).filter_map(|l| l.split(':').nth(1)?.trim().parse().ok()).collect()
}

#[test]
fn mbpoll_runs_every_function_code_and_gets_exceptions_01_02() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    let mut log = String::new();
    let mut check = |out: String, ok: bool| {
        log.push_str(&out);
        assert!(ok, "mbpoll step failed\n{}", transcript(&log, &uno));
    };

    let out = mbpoll(&uno, "-a 1 -t 0 -r 1 -c 5", "");
    check(out.clone(), mbpoll_values(&out) == [0, 0, 0, 0, 0]);
    uno.control("pin 6 0");
    let out = mbpoll(&uno, "-a 1 -t 1 -r 1 -c 4", "");
    check(out.clone(), mbpoll_values(&out) == [1, 0, 0, 0]);
    uno.control("adc A0 2500");
    let out = mbpoll(&uno, "-a 1 -t 3 -r 1 -c 3", "");
    check(out.clone(), mbpoll_values(&out).first() == Some(&511));
    let out = mbpoll(&uno, "-a 1 -t 4 -r 1 -c 2", "");
    check(out.clone(), mbpoll_values(&out) == [500, 512]);

    let out = mbpoll(&uno, "-a 1 -t 0 -r 2", "1"); // FC05
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(&uno, "-a 1 -t 0 -r 3", "1 0 1"); // FC15
    check(out.clone(), out.contains("Written 3 references"));
    let out = mbpoll(&uno, "-a 1 -t 0 -r 1 -c 5", "");
    check(out.clone(), mbpoll_values(&out) == [0, 1, 1, 0, 1]);
    thread::sleep(Duration::from_millis(100));
    check(String::new(), uno.log().contains("pins: 13=off 2=on 3=on 4=off 5=on"));

    let out = mbpoll(&uno, "-a 1 -t 4 -r 3", "1234"); // FC06
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(&uno, "-a 1 -t 4 -r 4", "11 22 33"); // FC16
    check(out.clone(), out.contains("Written 3 references"));
    let out = mbpoll(&uno, "-a 1 -t 4 -r 3 -c 4", "");
    check(out.clone(), mbpoll_values(&out) == [1234, 11, 22, 33]);

    // FC17 (0x11) Report Server ID: mbpoll's only other function code, absent without the
    // `diagnostics` feature (`make firmware` builds the examples without it).
    let out = mbpoll(&uno, "-a 1 -u", "");
    check(out.clone(), out.contains("Illegal function"));
    let out = mbpoll(&uno, "-a 1 -t 4 -r 11", "");
    check(out.clone(), out.contains("Illegal data address"));
}

#[test]
fn mbpoll_1000_back_to_back_reads_are_all_answered() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    let script =
        format!("exec stdbuf -oL mbpoll -m rtu -b 19200 -P even -o 1 -a 1 -t 4 -r 1 -l 10 {} 2>&1", uno.port());
    let mut child = Command::new("sh").args(["-c", &script]).stdout(Stdio::piped()).spawn().expect("run mbpoll");
    let start = Instant::now();
    let (mut answered, mut failed, mut log) = (0, 0, String::new());
    for line in BufReader::new(child.stdout.take().unwrap()).lines().map_while(Result::ok) {
        if line.starts_with("[1]:") {
            answered += 1;
        } else if line.contains("failed") {
            failed += 1;
            log.push_str(&(line + "\n"));
        }
        if answered + failed == 1000 || start.elapsed() > Duration::from_secs(120) {
            break;
        }
    }
    let took = start.elapsed();
    let _ = child.kill();
    let _ = child.wait();
    println!(
        "mbpoll: {answered} of {} reads answered ({:.1} %) in {:.1} s ({:.1} ms each)",
        answered + failed,
        100.0 * f64::from(answered) / f64::from((answered + failed).max(1)),
        took.as_secs_f64(),
        took.as_secs_f64() * 1000.0 / f64::from((answered + failed).max(1))
    );
    assert!(answered == 1000 && failed == 0, "{answered} answered, {failed} failed\n{}", transcript(&log, &uno));
}

#[test]
fn mbpoll_with_other_line_settings_gets_no_answer_and_a_warning() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    for (settings, master) in [("-b 9600 -P even", "9600 8"), ("-b 19200 -P odd", "19200 8O1")] {
        let mut cmd = Command::new("mbpoll");
        cmd.args(format!("-m rtu {settings} -o 0.3 -1 -a 1 -t 4 -r 1").split(' ')).arg(uno.port());
        let (_, out) = run(&mut cmd, Duration::from_secs(10));
        let warned = format!("line settings differ: master {master}");
        thread::sleep(Duration::from_millis(50));
        assert!(
            out.contains("Connection timed out") && uno.log().contains(&warned),
            "expected a time-out and `{warned}`\n{}",
            transcript(&out, &uno)
        );
    }
}

// ------------------------------------------------------------------------------------------
// pymodbus and minimalmodbus

/// Runs `demo/SCRIPT PORT --control FIFO ARGS` (killed after `limit`); its transcript.
fn python_check(script: &str, uno: &VirtualUno, args: &str, limit: Duration) -> (bool, String) {
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo").join(script)).arg(uno.port());
    cmd.args(["--control", uno.control.to_str().unwrap()]).args(args.split_whitespace());
    let (ok, out) = run(&mut cmd, limit);
    println!("{out}");
    (ok, out)
}

fn pymodbus(uno: &VirtualUno, args: &str, limit: Duration) {
    let (ok, out) = python_check("pymodbus_check.py", uno, args, limit);
    assert!(ok, "pymodbus_check.py {args} failed (python: {})\n{}", python(), transcript(&out, uno));
}

#[test]
fn pymodbus_runs_every_function_code_exceptions_broadcast_and_1000_reads() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    pymodbus(&uno, "--reads 1000", Duration::from_secs(120));
}

/// Modbus ASCII (examples/ascii.rs, 9600 7E1) through pymodbus's ASCII framer with 7 data
/// bits: a Linux pty passes the characters and keeps the baud rate, but forces 8 data bits
/// and drops PARENB, so the virtual Uno takes the master's 8N1-looking line as 7E1.
#[test]
fn pymodbus_ascii_runs_every_function_code_exceptions_broadcast_and_1000_reads() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("ascii"), &[]);
    pymodbus(&uno, "--board ascii --baud 9600 --parity E --reads 1000", Duration::from_secs(120));
}

/// FC 43 / MEI 14 Read Device Identification (examples/configurable.rs, feature
/// `device-id`) through pymodbus's `ReadDeviceInformationRequest`: codes 01 to 04, each
/// object, exceptions 02 and 03; then 100 reads.
#[test]
fn pymodbus_reads_the_device_identification_of_configurable() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("configurable"), &[]);
    pymodbus(&uno, "--board configurable --reads 100", Duration::from_secs(60));
}

/// examples/meter.rs through pymodbus's BinaryPayloadDecoder and BinaryPayloadBuilder
/// (`demo/pymodbus_wide.py`): a float high word first, a u32 low word first, written and
/// read back; the u32 counter read 500 times, never torn.
#[test]
fn pymodbus_payload_decoder_reads_floats_and_counters_of_meter_in_both_word_orders() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("meter"), &[]);
    let (ok, out) = python_check("pymodbus_wide.py", &uno, "", Duration::from_secs(90));
    assert!(ok, "pymodbus_wide.py failed (python: {})\n{}", python(), transcript(&out, &uno));
}

/// dip_switch preset 5 (pins 10 and 12 closed): 9600 8N1.
#[test]
fn pymodbus_and_libmodbus_at_9600_8n1() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("dip_switch"), &["--pin", "10=0", "--pin", "12=0"]);
    assert!(uno.log().contains("serial: 9600 8N1"), "{}", uno.log());
    pymodbus(&uno, "--board dip_switch --preset 5 --baud 9600 --parity N --reads 100", Duration::from_secs(60));
    libmodbus(&uno, "9600 N 1 100");
}

/// dip_switch preset 6 (pins 11 and 12 closed): 115200 8E1, the USART at +2.12 %.
#[test]
fn pymodbus_and_libmodbus_at_115200_8e1() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("dip_switch"), &["--pin", "11=0", "--pin", "12=0"]);
    assert!(uno.log().contains("serial: 115200 8E1"), "{}", uno.log());
    pymodbus(&uno, "--board dip_switch --preset 6 --baud 115200 --parity E --reads 100", Duration::from_secs(60));
    libmodbus(&uno, "115200 E 1 100");
}

/// minimalmodbus as the tutorials use it (open, then set the line on `instrument.serial`), at
/// parity none: the virtual Uno serves none and even alike, and a pty refuses even (below).
#[test]
fn minimalmodbus_runs_every_function_code_exception_02_broadcast_and_300_reads() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    let (ok, out) = python_check("minimalmodbus_check.py", &uno, "--parity N --reads 300", Duration::from_secs(90));
    assert!(ok, "minimalmodbus_check.py failed (python: {})\n{}", python(), transcript(&out, &uno));
}

/// What docs/masters.md tells Python users: on a Linux pty, setting even parity on an open port
/// (minimalmodbus's way) fails with EINVAL, because the pty drops PARENB and glibc reports a
/// tcsetattr that changed nothing. If this test fails, that guide's advice is out of date.
#[test]
fn minimalmodbus_cannot_set_even_parity_on_a_pty() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    let (ok, out) = python_check("minimalmodbus_check.py", &uno, "--parity E", Duration::from_secs(30));
    assert!(
        !ok && out.contains("FAIL cannot set") && out.contains("(22, 'Invalid argument')"),
        "expected tcsetattr to refuse PARENB with EINVAL\n{}",
        transcript(&out, &uno)
    );
}

// ------------------------------------------------------------------------------------------
// The crate's master against pymodbus's serial server

/// The numbers of the flat JSON array `"key":[...]` in `json` (`null` as -1).
fn json_numbers(json: &str, key: &str) -> Vec<i64> {
    let start = json.find(&format!("\"{key}\":[")).unwrap_or_else(|| panic!("no `{key}` in {json}")) + key.len() + 4;
    let body = &json[start..start + json[start..].find(']').unwrap()];
    body.split(',').filter(|v| !v.is_empty()).map(|v| if v == "null" { -1 } else { v.parse().unwrap() }).collect()
}

/// The arrays of the JSON array of flat arrays `"key":[[...],[...]]` in `json`.
fn json_rows(json: &str, key: &str) -> Vec<Vec<i64>> {
    let start = json.find(&format!("\"{key}\":[")).unwrap_or_else(|| panic!("no `{key}` in {json}")) + key.len() + 4;
    let mut rows = Vec::new();
    let mut rest = &json[start..];
    while let Some(row) = rest.strip_prefix('[').or_else(|| rest.strip_prefix(",[")) {
        let end = row.find(']').unwrap();
        rows.push(row[..end].split(',').filter(|v| !v.is_empty()).map(|v| v.parse().unwrap()).collect());
        rest = &row[end + 1..];
    }
    rows
}

/// examples/master_mirror.rs (feature `master`) polls `demo/pymodbus_server.py`: unit 1 with
/// every function code, unit 2 told each outcome at holding registers 16 × step, and the
/// master's counters at 240-250 (the server logs each write of those). The counters are taken
/// as differences between the first and the last pass the server saw: the master polls from
/// power-on, and times out until the server has opened the port.
#[test]
fn master_mirror_polls_pymodbus_serial_server_with_every_function_code() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("master_mirror"), &[]);
    let started = Instant::now();
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_server.py")).arg(uno.port()).args(["--seconds", "8"]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(40));
    println!("{out}");
    println!("pymodbus_server.py took {:.1} s", started.elapsed().as_secs_f64());
    let fail = |what: &str| -> String { format!("{what} (python: {})\n{}", python(), transcript(&out, &uno)) };
    assert!(ok, "{}", fail("pymodbus_server.py failed"));
    let json = out.lines().find(|l| l.starts_with("{\"")).unwrap_or_else(|| panic!("{}", fail("no JSON line")));
    let unit1 = json_numbers(json, "unit1_holding");
    let unit2 = json_numbers(json, "unit2_holding");
    let coils = json_numbers(json, "unit1_coils");
    let inputs = json_numbers(json, "unit1_inputs");
    let input_registers = json_numbers(json, "unit1_input_registers");
    let broadcast = json.contains("\"broadcast\":true");
    let log = json_rows(json, "counter_log");
    assert!(unit1.len() == 256 && unit2.len() == 256 && coils.len() == 16, "{}", fail("short arrays"));

    // At least 3 passes ended with the server up, so that the last report of step 1 (FC 1)
    // came after a whole pass's writes of steps 2 and 7.
    assert!(log.len() >= 3 && log.iter().all(|row| row.len() == 11), "{}", fail("fewer than 3 passes logged"));
    let (first, last) = (&log[0], &log[log.len() - 1]);
    let delta: Vec<i64> = first.iter().zip(last).map(|(a, b)| (b - a) & 0xFFFF).collect();
    println!("master counters at the first logged pass: {first:?}\n             at the last: {last:?}");
    println!(
        "                 difference: {delta:?} (requests crc uart overruns malformed replies exceptions timeouts \
         retries unexpected pass)"
    );
    assert!(last[10] >= 1 && last == &unit2[240..251], "{}", fail("pass count / counters"));
    let passes = delta[10];
    assert_eq!(
        [delta[1], delta[2], delta[3], delta[4], delta[7], delta[8], delta[9]],
        [0; 7],
        "CRC, UART, overrun or malformed frames, timeouts, retries or unexpected frames while pymodbus served\n{}",
        fail("")
    );
    assert_eq!(delta[6], 3 * passes, "three exceptions (steps 10, 12, 13) a pass\n{}", fail(""));
    assert_eq!(delta[0] - delta[5], passes, "every request answered but the broadcast\n{}", fail(""));
    assert_eq!(&unit1[16..20], &[0x3FC0, 0, 0, 0x3FC0], "unit 1's floats\n{}", fail(""));

    // What unit 1 holds after the master's writes.
    let pattern = |i: usize| i64::from(i.is_multiple_of(2));
    let mut want_coils: Vec<i64> = (0..16).map(pattern).collect();
    want_coils[3..8].copy_from_slice(&[1, 1, 0, 1, 1]); // FC 5 coil 3, FC 15 coils 4-7
    assert_eq!(coils, want_coils, "unit 1's coils\n{}", fail(""));
    let mut want_holding: Vec<i64> = (0..16).map(|i| 0x1000 + i).collect();
    want_holding[10..14].copy_from_slice(&[0x1234, 0x5678, 0xBEEF, 7]); // FC 16, FC 6, FC 23
    if broadcast {
        want_holding[14] = 0x0B0B; // the broadcast FC 6
    }
    assert_eq!(unit1[..16], want_holding[..], "unit 1's holding registers\n{}", fail(""));

    // Each step's report at unit 2, from 16 × step: status, then what was read; zeros after.
    let packed = |bits: &[i64]| bits.iter().enumerate().fold(0, |p, (i, &b)| p | b << i);
    let reports: [Vec<i64>; 15] = [
        [&[0], &unit1[0..4]].concat(),         // FC 3, holding 0-3
        vec![0, packed(&coils[0..10])],        // FC 1, coils 0-9 (as written the pass before)
        vec![0],                               // FC 5
        vec![0],                               // FC 16
        [&[0], &input_registers[..]].concat(), // FC 4, input registers 0-2
        vec![0, packed(&inputs[0..8])],        // FC 2, discrete inputs 0-7
        vec![0],                               // FC 6
        vec![0],                               // FC 15
        vec![0, 0x1234, 0x5678, 0xBEEF, 7],    // FC 23: 13 = 7, then 10-13
        vec![0x300],                           // 126 registers: refused before sending
        vec![2],                               // holding 9999: exception 02
        vec![0],                               // broadcast: no reply awaited
        vec![1],                               // raw FC 0x41: exception 01
        vec![3],                               // raw FC 3 of 0 registers: exception 03
        vec![0, 0x4040, 0, 0x4040, 0],         // 1.5 as f32 both word orders, doubled: 3.0
    ];
    let hex = |values: &[i64]| values.iter().map(|v| format!("{v:#x}")).collect::<Vec<_>>().join(" ");
    let mut wrong = String::new();
    for (step, report) in reports.iter().enumerate() {
        let mut want = report.clone();
        want.resize(16, 0);
        if step == 0 && broadcast {
            want[14] = 0x0B0B; // the broadcast reached unit 2 too
        }
        let got = &unit2[16 * step..16 * step + 16];
        println!("step {step:2}: {}", hex(&got[..report.len()]));
        if got != want {
            wrong += &format!("step {step} (unit 2 from {}): got {}, expected {}\n", 16 * step, hex(got), hex(&want));
        }
    }
    assert!(wrong.is_empty(), "reports differ from pymodbus's data:\n{wrong}{}", fail(""));
    println!("pymodbus executed the broadcasts: {broadcast}; {passes} whole passes without an error");
}

// ------------------------------------------------------------------------------------------
// libmodbus

/// `demo/libmodbus_check.c`, compiled once per test run.
fn libmodbus_check() -> PathBuf {
    static BUILT: Mutex<Option<PathBuf>> = Mutex::new(None);
    let mut built = BUILT.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(exe) = built.as_ref() {
        return exe.clone();
    }
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("libmodbus_check");
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "libmodbus"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or("-I/usr/include/modbus -lmodbus".to_owned(), |o| String::from_utf8_lossy(&o.stdout).into_owned());
    let mut cc = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()));
    cc.arg("-o").arg(&exe).arg(workspace().join("demo/libmodbus_check.c")).args(flags.split_whitespace());
    let (ok, out) = run(&mut cc, Duration::from_secs(60));
    assert!(ok, "cannot build demo/libmodbus_check.c (apt-get install libmodbus-dev):\n{out}");
    *built = Some(exe.clone());
    exe
}

fn libmodbus(uno: &VirtualUno, args: &str) {
    let mut cmd = Command::new(libmodbus_check());
    cmd.arg(uno.port()).args(args.split_whitespace());
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "libmodbus_check {args} failed\n{}", transcript(&out, uno));
}

#[test]
fn libmodbus_runs_every_function_code_exceptions_01_02_03_and_broadcast() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("uno_slave"), &[]);
    libmodbus(&uno, "19200 E 1 200");
}

// ------------------------------------------------------------------------------------------
// several slave ids on one line

/// examples/units.rs (slave ids 1-4, each its own register map) through pymodbus: each id's
/// reading and writes, a broadcast reaching the four, silence from id 5, 200 reads over the
/// four ids in turn.
#[test]
fn pymodbus_polls_the_four_slave_ids_of_units() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("units"), &[]);
    pymodbus(&uno, "--board units --reads 200", Duration::from_secs(60));
}

/// The same through libmodbus (`demo/libmodbus_units_check.c`), switching ids with
/// `modbus_set_slave` as a master polling several slaves does.
#[test]
fn libmodbus_polls_the_four_slave_ids_of_units() {
    let _one = serialise();
    let uno = VirtualUno::start(&firmware("units"), &[]);
    let mut cmd = Command::new(compile("libmodbus_units_check"));
    cmd.arg(uno.port()).args(["19200", "E", "1", "200"]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "libmodbus_units_check failed\n{}", transcript(&out, &uno));
}

/// `demo/NAME.c` compiled against libmodbus into the test's temporary directory.
fn compile(name: &str) -> PathBuf {
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "libmodbus"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or("-I/usr/include/modbus -lmodbus".to_owned(), |o| String::from_utf8_lossy(&o.stdout).into_owned());
    let mut cc = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()));
    cc.arg("-o").arg(&exe).arg(workspace().join(format!("demo/{name}.c"))).args(flags.split_whitespace());
    let (ok, out) = run(&mut cc, Duration::from_secs(60));
    assert!(ok, "cannot build demo/{name}.c (apt-get install libmodbus-dev):\n{out}");
    exe
}

// ------------------------------------------------------------------------------------------
// the binary itself

#[test]
fn a_missing_or_bad_firmware_is_one_line_and_a_failure() {
    let bad = Path::new(env!("CARGO_TARGET_TMPDIR")).join("not-an-elf.elf");
    std::fs::write(&bad, b"hello").unwrap();
    for path in [Path::new("/nonexistent/fw.elf"), bad.as_path()] {
        let out = Command::new(env!("CARGO_BIN_EXE_virtual-uno")).arg(path).stdin(Stdio::null()).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{path:?} accepted");
        assert_eq!(err.lines().count(), 1, "not one line: {err}");
        assert!(err.starts_with("virtual-uno: ") && err.contains(&*path.to_string_lossy()), "{err}");
    }
}

// ------------------------------------------------------------------------------------------
// A whole board: optiboot at every reset, a reset when the port opens, flash and EEPROM kept

/// A fresh directory for a board's `--state`, removed when dropped.
struct State(PathBuf);

impl State {
    fn fresh(name: &str) -> State {
        let dir = std::env::temp_dir().join(format!("vuno-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        State(dir)
    }
}

impl std::ops::Deref for State {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for State {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Flashes `elf` through the board's bootloader with avrdude, as ravedude runs it for an Uno.
fn avrdude(uno: &VirtualUno, elf: &Path) -> String {
    let mut cmd = Command::new("avrdude");
    cmd.args(["-c", "arduino", "-p", "atmega328p", "-b", "115200", "-D", "-P", uno.port(), "-U"])
        .arg(format!("flash:w:{}:e", elf.display()));
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    assert!(ok && out.contains("bytes of flash verified"), "avrdude failed\n{}", transcript(&out, uno));
    out
}

/// Opens the port as a master that keeps it open does, and waits for the reset that causes
/// and for the program to configure `line` after the bootloader.
fn hold_port(uno: &VirtualUno, line: &str) -> std::fs::File {
    let from = uno.log().len();
    let port = std::fs::OpenOptions::new().read(true).write(true).open(uno.port()).expect("open the port");
    let at = uno.wait_for("reset: RESET pin", from, Duration::from_secs(2));
    let at = uno.wait_for("reset: watchdog", at, Duration::from_secs(5));
    uno.wait_for(&format!("serial: {line}"), at, Duration::from_secs(2));
    port
}

#[test]
fn opening_the_port_resets_the_board_into_optiboot_unless_it_is_open_already() {
    let _one = serialise();
    let state = State::fresh("auto-reset");
    let uno = VirtualUno::board(&state, Some(&firmware("uno_slave")));
    // power-on: optiboot leaves it to the program at once
    uno.wait_for("serial: 19200 8E1", 0, Duration::from_secs(2));
    assert_eq!(uno.port_resets(), 0);

    // A master that opens the port for each poll resets the board each time, and its request
    // reaches the bootloader, which has the line for the next 1.4 s.
    let out = mbpoll(&uno, "-a 1 -t 4 -r 1 -c 2", "");
    assert!(out.contains("Connection timed out"), "{}", transcript(&out, &uno));
    assert_eq!(uno.port_resets(), 1);

    // One that keeps it open resets it once; further opens beside it don't.
    let port = hold_port(&uno, "19200 8E1");
    assert_eq!(uno.port_resets(), 2);
    for _ in 0..3 {
        let out = mbpoll(&uno, "-a 1 -t 4 -r 1 -c 2", "");
        assert_eq!(mbpoll_values(&out), [500, 512], "{}", transcript(&out, &uno));
    }
    assert_eq!(uno.port_resets(), 2, "{}", uno.log());

    // Closed, then opened again: a reset again.
    drop(port);
    let out = mbpoll(&uno, "-a 1 -t 4 -r 1 -c 2", "");
    assert!(out.contains("Connection timed out"), "{}", transcript(&out, &uno));
    assert_eq!(uno.port_resets(), 3);
}

/// An Uno fresh from the factory with optiboot and nothing else: optiboot leaves for the
/// erased program, which runs into optiboot again, over and over (tools/sim's boot tests
/// say why nothing else happens on the chip). For 3 s nothing resets it and nothing sets up
/// its USART; flashed through the port, the program starts and answers.
#[test]
fn an_erased_board_neither_resets_nor_sets_up_its_usart_until_flashed() {
    let _one = serialise();
    let state = State::fresh("erased");
    let uno = VirtualUno::board(&state, None);
    assert!(uno.log().contains("program: none (flash erased)"), "{}", uno.log());
    thread::sleep(Duration::from_secs(3));
    let log = uno.log();
    assert!(!log.contains("reset: watchdog") && !log.contains("serial:"), "{log}");
    assert_eq!(log.lines().filter(|l| l.starts_with("reset:")).count(), 1, "the power-on alone:\n{log}");

    let flashed = avrdude(&uno, &firmware("uno_slave"));
    let _port = hold_port(&uno, "19200 8E1");
    let out = mbpoll(&uno, "-a 1 -t 4 -r 1 -c 2", "");
    assert_eq!(mbpoll_values(&out), [500, 512], "{}", transcript(&(flashed + &out), &uno));
}

#[test]
fn configurable_keeps_its_line_settings_in_eeprom_across_a_reflash_and_a_restart() {
    let _one = serialise();
    let state = State::fresh("eeprom");
    let configurable = firmware("configurable");
    let new_line = "-b 9600 -P none -s 2";
    {
        let uno = VirtualUno::board(&state, None);
        assert!(uno.log().contains("program: none (flash erased)"), "{}", uno.log());
        let log = avrdude(&uno, &configurable);
        let port = hold_port(&uno, "19200 8E1");
        let out = mbpoll(&uno, "-a 1 -t 3 -r 1", "");
        assert_eq!(mbpoll_values(&out), [0], "the compiled-in default\n{}", transcript(&(log + &out), &uno));
        // slave 7, 9600 baud, no parity, 2 stop bits, RTU: answered, then in force and stored
        let out = mbpoll(&uno, "-a 1 -t 4 -r 101", "7 96 0 2 0");
        assert!(out.contains("Written 5 references"), "{}", transcript(&out, &uno));
        uno.wait_for("serial: 9600 8N2", 0, Duration::from_secs(2));
        thread::sleep(Duration::from_millis(1200)); // the EEPROM write, then --state's
        drop(port);

        // Flashing again through the bootloader leaves the EEPROM alone.
        let log = avrdude(&uno, &configurable);
        let _port = hold_port(&uno, "9600 8N2");
        let out = mbpoll_at(&uno, new_line, "-a 7 -t 3 -r 1", "");
        assert_eq!(mbpoll_values(&out), [1], "settings from EEPROM\n{}", transcript(&(log + &out), &uno));
    }
    let eeprom = std::fs::read(state.join("eeprom.bin")).unwrap();
    assert_eq!(eeprom.len(), 1024);
    assert!(eeprom[..22].iter().any(|&b| b != 0xFF));

    // A new virtual board on the same state: the flash and the EEPROM are still there.
    let uno = VirtualUno::board(&state, None);
    assert!(!uno.log().contains("program: none"), "{}", uno.log());
    uno.wait_for("serial: 9600 8N2", 0, Duration::from_secs(2));
    let _port = hold_port(&uno, "9600 8N2");
    let out = mbpoll_at(&uno, new_line, "-a 7 -t 3 -r 1", "");
    assert_eq!(mbpoll_values(&out), [1], "{}", transcript(&out, &uno));
}
