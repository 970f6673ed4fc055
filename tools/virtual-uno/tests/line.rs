//! `virtual-line`: several simulated boards on one RS-485 line. Each test runs the binary
//! unpaced (`--no-pace`) up to a simulated time (`--until`), pressing buttons at simulated
//! times (`--at`), and checks its transcript: frames with their senders, pin changes, the
//! summary. Everything is counted in simulated time, so a slow or busy machine only makes
//! a test take longer.
//!
//! Needs the firmware: `make firmware`, or `cargo uno --example lab_lights --example
//! poll_four --example minimal --features examples` and `cargo uno --example lab_control
//! --features examples,master`; and for the gateway `make chips` (examples/gateway.rs for the
//! ATmega2560), mbpoll and pymodbus (`$INTEROP_PYTHON`, else Debian's python3).

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir, workspace};

/// `$CARGO_TARGET_DIR` (or `<workspace>/target`)`/avr-atmega328p/release/examples/NAME.elf`;
/// missing, it skips these tests or fails them under `make` and in CI (`uno_sim::built`).
fn firmware(name: &str) -> String {
    let elf = target_dir().join("avr-atmega328p/release/examples").join(format!("{name}.elf"));
    built(elf, "make firmware").display().to_string()
}

/// `<target>/chips/BUILD/avr-none/release/examples/NAME.elf`, as `make chips` builds it.
fn chip_firmware(build: &str, name: &str) -> String {
    let elf = target_dir().join("chips").join(build).join("avr-none/release/examples").join(format!("{name}.elf"));
    built(elf, "make chips").display().to_string()
}

/// One printed line: simulated seconds and the text after the time stamp.
#[derive(Debug, Clone)]
struct Event {
    t: f64,
    text: String,
}

/// A finished run of virtual-line.
struct Run {
    out: String,
    events: Vec<Event>,
}

impl Run {
    /// Runs virtual-line with `args` (plus --no-pace --no-stdin) to the end; fails on a
    /// non-zero exit or after `limit` of wall time.
    fn new(args: &[&str], limit: Duration) -> Run {
        let mut child = Command::new(env!("CARGO_BIN_EXE_virtual-line"))
            .args(["--no-pace", "--no-stdin"])
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("virtual-line starts");
        let mut stdout = child.stdout.take().unwrap();
        let mut stderr = child.stderr.take().unwrap();
        let reader = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = stdout.read_to_string(&mut s);
            s
        });
        let err_reader = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = stderr.read_to_string(&mut s);
            s
        });
        let started = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if started.elapsed() > limit {
                let _ = child.kill();
                let _ = child.wait();
                panic!("virtual-line did not finish in {limit:?}:\n{}", reader.join().unwrap());
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let out = reader.join().unwrap();
        let err = err_reader.join().unwrap();
        assert!(status.success(), "virtual-line failed ({status}):\n{out}\n{err}");
        eprintln!("virtual-line {} took {:.1} s", args.join(" "), started.elapsed().as_secs_f64());
        let events = out
            .lines()
            .filter_map(|line| {
                let rest = line.strip_prefix('[')?;
                let (t, text) = rest.split_once("] ")?;
                Some(Event { t: t.trim().parse().ok()?, text: text.to_owned() })
            })
            .collect();
        Run { out, events }
    }

    /// `(t, sender, bytes, notes)` of every frame.
    fn frames(&self) -> Vec<(f64, String, Vec<u8>, String)> {
        self.events
            .iter()
            .filter_map(|e| {
                let rest = e.text.strip_prefix("frame from ")?;
                let (who, rest) = rest.split_once(": ")?;
                let (hex, notes) = rest.split_once(" (").map_or((rest, ""), |(h, n)| (h, n));
                let bytes = hex.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect();
                Some((e.t, who.to_owned(), bytes, notes.to_owned()))
            })
            .collect()
    }

    /// The watched pins of `board` in force at simulated time `t` (the last `pins:` line
    /// printed at or before it), as `"4=on 5=off ..."`.
    fn pins_at(&self, board: &str, t: f64) -> String {
        let prefix = format!("{board} pins: ");
        self.events
            .iter()
            .rev()
            .filter(|e| e.t <= t)
            .find_map(|e| e.text.strip_prefix(&prefix))
            .unwrap_or_else(|| panic!("no pins of {board} by {t} s:\n{}", self.out))
            .to_owned()
    }

    /// Times at which `board`'s pins became `state`.
    fn became(&self, board: &str, state: &str) -> Vec<f64> {
        let line = format!("{board} pins: {state}");
        self.events.iter().filter(|e| e.text == line).map(|e| e.t).collect()
    }

    /// A number from the summary, e.g. `collisions: 3`.
    fn summary(&self, key: &str) -> u64 {
        let line = self.events.iter().find_map(|e| e.text.strip_prefix("summary: ")).expect("a summary");
        let at = line.find(&format!("{key}: ")).unwrap_or_else(|| panic!("no `{key}` in {line}")) + key.len() + 2;
        line[at..].split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
    }
}

const RED: &str = "4=on 5=off 6=off 7=off";
const GREEN: &str = "4=off 5=on 6=off 7=off";

/// The lab: lab_control (master, DE on pin 2), lab_lights as the button box (device 1) and
/// as the light tower (device 2, pin 12 jumpered low), DE on pin 10. The tower shows RED;
/// START (pin 2 pressed for 0.3 s) turns it GREEN; STOP (pin 3) RED again.
#[test]
fn lab_start_turns_the_tower_green_and_stop_red() {
    let (control, lights) = (firmware("lab_control"), firmware("lab_lights"));
    #[rustfmt::skip]
    let args: &[&str] = &[
        "--board", &format!("master={control}"), "de=2", "watch=13",
        "--board", &format!("box={lights}"), "de=10", "watch=2,3",
        "--board", &format!("tower={lights}"), "de=10", "pin12=low", "watch=4,5,6,7",
        "--at", "1.5", "set box pin2 low", "--at", "1.8", "set box pin2 z",
        "--at", "2.5", "set box pin3 low", "--at", "2.8", "set box pin3 z",
        "--until", "3.5",
    ];
    let run = Run::new(args, Duration::from_secs(180));
    let out = &run.out;
    // RED from the first write on, until START.
    assert_eq!(run.pins_at("tower", 0.2), RED, "RED at start:\n{out}");
    assert_eq!(run.pins_at("tower", 1.5), RED, "RED until START:\n{out}");
    // GREEN within 200 ms of START, kept until STOP.
    let green: Vec<f64> = run.became("tower", GREEN);
    assert_eq!(green.len(), 1, "GREEN once:\n{out}");
    assert!(green[0] > 1.5 && green[0] < 1.7, "GREEN {:.3} s after START:\n{out}", green[0] - 1.5);
    assert_eq!(run.pins_at("tower", 2.5), GREEN, "GREEN until STOP:\n{out}");
    // RED within 200 ms of STOP, to the end.
    let red: Vec<f64> = run.became("tower", RED);
    assert_eq!(red.len(), 2, "RED at start and after STOP:\n{out}");
    assert!(red[1] > 2.5 && red[1] < 2.7, "RED {:.3} s after STOP:\n{out}", red[1] - 2.5);
    assert_eq!(run.pins_at("tower", 3.5), RED, "RED to the end:\n{out}");
    // The alarm LED (a device not answering) never lit.
    assert!(run.became("master", "13=on").is_empty(), "the master's alarm LED lit:\n{out}");

    // The line: all three talk, nothing collides, every CRC is good.
    let frames = run.frames();
    for who in ["master", "box", "tower"] {
        assert!(frames.iter().any(|f| f.1 == who), "no frame from {who}:\n{out}");
    }
    assert!(frames.iter().all(|f| f.3.is_empty()), "a frame with a remark:\n{out}");
    assert_eq!(run.summary("collisions"), 0, "{out}");
    assert_eq!(run.summary("bad CRC"), 0, "{out}");
    assert_eq!(run.summary("cut by DE"), 0, "{out}");
    assert_eq!(run.summary("sent with DE low"), 0, "{out}");
    assert_eq!(run.summary("DE high over another's characters"), 0, "{out}");
    // The box answers the master's reads with START and STOP as pressed.
    let answers: Vec<&(f64, String, Vec<u8>, String)> = frames.iter().filter(|f| f.1 == "box").collect();
    let pressed = |from: f64, to: f64, bits: u8| {
        answers.iter().filter(|f| f.0 > from && f.0 < to).all(|f| f.2[..4] == [0x01, 0x02, 0x01, bits])
    };
    assert!(pressed(0.1, 1.5, 0) && pressed(1.51, 1.8, 1) && pressed(1.81, 2.5, 0) && pressed(2.51, 2.8, 2), "{out}");
}

/// A master and one slave: frames alternate master, slave; each reply answers the request
/// before it (same slave id, same function or its exception), at least 3.5 characters
/// after it.
#[test]
fn pair_replies_alternate_with_requests_and_answer_them() {
    #[rustfmt::skip]
    let args: &[&str] = &[
        "--board", &format!("master={}", firmware("poll_four")),
        "--board", &format!("slave={}", firmware("minimal")),
        "--until", "1.05",
    ];
    let run = Run::new(args, Duration::from_secs(60));
    let out = &run.out;
    let frames = run.frames();
    assert!(frames.len() >= 18, "10 requests a second, each answered:\n{out}");
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f.1, if i % 2 == 0 { "master" } else { "slave" }, "frame {i}:\n{out}");
        assert!(f.3.is_empty(), "frame {i} has a remark:\n{out}");
        if i % 2 == 1 {
            let request = &frames[i - 1].2;
            let reply = &f.2;
            assert_eq!(reply[0], request[0], "frame {i} is another slave's:\n{out}");
            assert_eq!(reply[1] & 0x7F, request[1], "frame {i} answers another function:\n{out}");
            // 1.75 ms at least after the request's start plus its characters (573 us each).
            let request_end = frames[i - 1].0 + request.len() as f64 * 11.0 / 19200.0;
            assert!(f.0 - request_end >= 3.5 * 11.0 / 19200.0 - 1e-6, "frame {i} too early:\n{out}");
            assert!(f.0 - request_end < 0.02, "frame {i} too late:\n{out}");
        }
    }
    assert_eq!(run.summary("collisions"), 0, "{out}");
    assert_eq!(run.summary("bad CRC"), 0, "{out}");
}

/// Two `minimal` boards, both slave 1, answer one request at once: counted as collisions,
/// and no clean reply reaches the master.
#[test]
fn two_slaves_with_one_id_collide() {
    let slave = firmware("minimal");
    #[rustfmt::skip]
    let args: &[&str] = &[
        "--board", &format!("master={}", firmware("poll_four")),
        "--board", &format!("a={slave}"),
        "--board", &format!("b={slave}"),
        "--until", "0.5",
    ];
    let run = Run::new(args, Duration::from_secs(60));
    let out = &run.out;
    let frames = run.frames();
    let collided: Vec<_> = frames.iter().filter(|f| f.1 == "a+b" || f.1 == "b+a").collect();
    assert!(collided.len() >= 4, "replies collided:\n{out}");
    assert!(collided.iter().all(|f| f.3.starts_with("COLLISION")), "{out}");
    assert!(!frames.iter().any(|f| f.1 == "a" || f.1 == "b"), "a clean reply:\n{out}");
    assert_eq!(run.summary("collisions") as usize, collided.len(), "{out}");
}

/// A board whose DE pin is not the one its firmware drives never reaches the line: its
/// replies are reported as sent with DE low, and the master's requests go unanswered.
#[test]
fn a_board_with_de_low_is_not_heard() {
    #[rustfmt::skip]
    let args: &[&str] = &[
        "--board", &format!("master={}", firmware("lab_control")), "de=2", "watch=13",
        "--board", &format!("box={}", firmware("lab_lights")), "de=9",
        "--until", "0.5",
    ];
    let run = Run::new(args, Duration::from_secs(60));
    let out = &run.out;
    assert!(run.summary("sent with DE low") > 0, "{out}");
    assert!(!run.frames().iter().any(|f| f.1 == "box"), "{out}");
    assert!(out.contains("box sent with DE low (not on the line): 01 02 01 00 A1 88"), "{out}");
    // lab_control lights its alarm LED when a device does not answer.
    assert!(!run.became("master", "13=on").is_empty(), "{out}");
}

/// An outside master on a pty: mbpoll (Debian) reads the button box's inputs and sets the
/// tower's lamps through the line, paced to the wall clock (mbpoll times out in wall time).
#[test]
fn mbpoll_on_a_pty_reads_the_box_and_lights_the_tower() {
    let lights = firmware("lab_lights");
    let link = std::env::temp_dir().join(format!("vline-{}-mbpoll", std::process::id()));
    let mut child = Command::new(env!("CARGO_BIN_EXE_virtual-line"))
        .args(["--no-stdin", "--until", "60"])
        .args(["--board", &format!("box={lights}"), "de=10", "pin2=low", "watch=2,3"])
        .args(["--board", &format!("tower={lights}"), "de=10", "pin12=low", "watch=4,5,6,7"])
        .args(["--pty", &format!("mbpoll={}", link.display())])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("virtual-line starts");
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let started = Instant::now();
    while std::fs::read_link(&link).is_err() && started.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let mbpoll = |args: &str| {
        let out = Command::new("mbpoll")
            .args("-m rtu -b 19200 -P even -o 1 -1".split(' '))
            .args(args.split_whitespace().take_while(|a| *a != "--"))
            .arg(&link)
            .args(args.split_whitespace().skip_while(|a| *a != "--").skip(1))
            .output()
            .expect("mbpoll runs (apt-get install mbpoll)");
        format!("$ mbpoll {args}\n{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
    };
    // START held (pin 2 low from the start), STOP not.
    let inputs = mbpoll("-a 1 -t 1 -r 1 -c 2");
    // GREEN and BLUE on.
    let coils = mbpoll("-a 2 -t 0 -r 1 -- 0 1 0 1");
    std::thread::sleep(Duration::from_millis(300));
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.id() as i32), nix::sys::signal::Signal::SIGTERM).unwrap();
    let _ = child.wait();
    let out = reader.join().unwrap();
    let transcript = format!("{inputs}\n{coils}\n{out}");
    assert!(inputs.contains("[1]: \t1") && inputs.contains("[2]: \t0"), "{transcript}");
    assert!(coils.contains("Written 4 references"), "{transcript}");
    assert!(out.contains("frame from mbpoll: 01 02 00 00 00 02 F9 CB"), "{transcript}");
    assert!(out.contains("frame from box: 01 02 01 01 60 48"), "{transcript}");
    assert!(out.contains("frame from tower: 02 0F 00 00 00 04 54 3B"), "{transcript}");
    assert!(out.contains("tower pins: 4=off 5=on 6=off 7=on"), "{transcript}");
    assert!(out.contains("collisions: 0"), "{transcript}");
}

/// A board whose DE stays high (here the tower's "DE" is its RED lamp, pin 4, lit from its
/// first reply on) drives the line while the others talk: the master's requests are
/// garbled, and the tower, its receiver off, hears nothing more.
#[test]
fn a_board_holding_de_high_garbles_the_others() {
    let lights = firmware("lab_lights");
    #[rustfmt::skip]
    let args: &[&str] = &[
        "--board", &format!("master={}", firmware("lab_control")), "de=2", "watch=13",
        "--board", &format!("box={lights}"), "de=10", "watch=none",
        "--board", &format!("tower={lights}"), "de=4", "pin12=low", "watch=4,5,6,7",
        "--until", "0.2",
    ];
    let run = Run::new(args, Duration::from_secs(60));
    let out = &run.out;
    // The reply's first character went out before the lamp lit: not on the line.
    assert!(out.contains("tower sent with DE low (not on the line): 02"), "{out}");
    assert!(out.contains("frame from tower: 0F 00 00 00 04 54 3B (bad CRC)"), "{out}");
    let garbled = run.frames().into_iter().filter(|f| f.1 == "master" && f.3.contains("tower (DE high")).count();
    assert!(garbled >= 2, "{out}");
    // Both of the master's frames garbled whole: the lamps (10 characters), the buttons (8).
    assert!(run.summary("DE high over another's characters") >= 18, "{out}");
    assert!(!run.frames().iter().any(|f| f.1 == "box"), "the box heard a garbled request:\n{out}");
}

/// `mbpoll -m rtu -b 19200 -P even -o 1 -1 ARGS PORT`: its output, after the command line.
fn mbpoll_on(port: &Path, args: &str) -> String {
    let out = Command::new("mbpoll")
        .args("-m rtu -b 19200 -P even -o 1 -1".split(' '))
        .args(args.split_whitespace())
        .arg(port)
        .output()
        .expect("mbpoll runs (apt-get install mbpoll)");
    format!("$ mbpoll {args}\n{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// The values of mbpoll's `[ref]: value` lines.
fn mbpoll_values(out: &str) -> Vec<i64> {
    out.lines().filter(|l| l.starts_with('[')).filter_map(|l| l.split(':').nth(1)?.trim().parse().ok()).collect()
}

/// The numbers of the flat JSON array `"key":[...]` in `json` (`null` as -1).
fn json_numbers(json: &str, key: &str) -> Vec<i64> {
    let start = json.find(&format!("\"{key}\":[")).unwrap_or_else(|| panic!("no `{key}` in {json}")) + key.len() + 4;
    let body = &json[start..start + json[start..].find(']').unwrap()];
    body.split(',').filter(|v| !v.is_empty()).map(|v| if v == "null" { -1 } else { v.parse().unwrap() }).collect()
}

/// The Mega gateway (examples/gateway.rs as `make chips` builds it): its master on USART1 on
/// the line, DE on PB7 (the Mega's pin 13), polls a field device, pymodbus's serial server
/// (`demo/pymodbus_server.py`, unit 1: holding registers 0x1000 + i) on a pty of the line;
/// its slave on USART0, on a pty of its own, is polled by mbpoll meanwhile. mbpoll reads
/// 40001-40010 as pymodbus holds them, and the gateway's answer counter (30001) goes up
/// between mbpoll's reads while its failure counter (30002) stands still. Paced to the wall
/// clock: mbpoll and pymodbus time out in wall time.
#[test]
fn mbpoll_reads_the_gateways_mirror_of_a_pymodbus_field_device_while_it_polls() {
    let gateway = chip_firmware("atmega2560-gateway", "gateway");
    let tmp = std::env::temp_dir();
    let (scada, field) = (
        tmp.join(format!("vline-{}-gateway", std::process::id())),
        tmp.join(format!("vline-{}-field", std::process::id())),
    );
    let mut child = Command::new(env!("CARGO_BIN_EXE_virtual-line"))
        .args(["--no-stdin", "--until", "120"])
        .args(["--board", &format!("gw={gateway}"), "usart=1", "de=PB7"])
        .arg(format!("usart0=pty:{}", scada.display()))
        .args(["--pty", &format!("field={}", field.display())])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("virtual-line starts");
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let started = Instant::now();
    while (std::fs::read_link(&scada).is_err() || std::fs::read_link(&field).is_err())
        && started.elapsed() < Duration::from_secs(10)
    {
        std::thread::sleep(Duration::from_millis(50));
    }
    let python = std::env::var("INTEROP_PYTHON").unwrap_or_else(|_| "/usr/bin/python3".into());
    let server = Command::new(&python)
        .arg(workspace().join("demo/pymodbus_server.py"))
        .arg(&field)
        .args(["--seconds", "12"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pymodbus_server.py starts");

    // The gateway's first answer from the field device (its requests time out until pymodbus
    // has opened the port), then three rounds of reads.
    let mut transcript = String::new();
    let deadline = Instant::now() + Duration::from_secs(8);
    loop {
        let out = mbpoll_on(&scada, "-a 1 -t 3 -r 1 -c 3");
        transcript += &out;
        if mbpoll_values(&out).first().is_some_and(|&answers| answers > 0) || Instant::now() > deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let mut rounds = Vec::new();
    for _ in 0..3 {
        let counters = mbpoll_on(&scada, "-a 1 -t 3 -r 1 -c 3");
        let holding = mbpoll_on(&scada, "-a 1 -t 4 -r 1 -c 10");
        rounds.push((mbpoll_values(&counters), mbpoll_values(&holding)));
        transcript += &(counters + &holding);
        std::thread::sleep(Duration::from_millis(700));
    }
    let server = server.wait_with_output().expect("pymodbus_server.py ends");
    let served = String::from_utf8_lossy(&server.stdout).into_owned();
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.id() as i32), nix::sys::signal::Signal::SIGTERM).unwrap();
    let _ = child.wait();
    let out = reader.join().unwrap();
    let transcript = format!(
        "{transcript}--- pymodbus_server.py ---\n{served}{}\n--- virtual-line ---\n{out}",
        String::from_utf8_lossy(&server.stderr)
    );
    assert!(server.status.success(), "pymodbus_server.py failed (python: {python}):\n{transcript}");
    let json = served.lines().find(|l| l.starts_with("{\"")).unwrap_or_else(|| panic!("no JSON:\n{transcript}"));
    let held = &json_numbers(json, "unit1_holding")[..10];

    // Every round: all ten mirrored values are pymodbus's, and the counters were answered.
    for (i, (counters, holding)) in rounds.iter().enumerate() {
        assert_eq!(counters.len(), 3, "round {i}: 30001-30003 unanswered:\n{transcript}");
        assert_eq!(holding[..], held[..], "round {i}: 40001-40010 are not the field device's:\n{transcript}");
    }
    // The gateway kept polling between mbpoll's reads (every 100 ms of simulated time; the
    // reads are 1.4 s of wall time apart, however slowly a busy machine simulates), and none
    // of those polls failed.
    let (first, last) = (&rounds[0].0, &rounds[2].0);
    assert!(last[0].wrapping_sub(first[0]) & 0xFFFF >= 1, "answers {first:?} -> {last:?}:\n{transcript}");
    assert_eq!(last[1], first[1], "field failures while mbpoll read:\n{transcript}");

    // The line: the gateway's reads of 10 registers and pymodbus's answers, clean.
    assert!(out.contains("frame from gw: 01 03 00 00 00 0A C5 CD"), "{transcript}");
    assert!(out.contains("frame from field: 01 03 14 10 00 10 01 10 02"), "{transcript}");
    assert!(out.contains("gw serial: 19200 8E1 (USART0, on its pty)"), "{transcript}");
    assert!(out.contains("collisions: 0"), "{transcript}");
    assert!(out.contains("cut by DE: 0; sent with DE low: 0"), "{transcript}");
    assert!(out.contains("DE of gw (PB7): high"), "{transcript}");
    let side = out.lines().find(|l| l.contains("gw USART0 on its pty")).unwrap_or_else(|| panic!("{transcript}"));
    assert!(!side.contains(" 0 bytes"), "{transcript}");
}
