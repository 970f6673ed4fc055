//! Modbus TCP masters nobody here wrote against the firmware's TCP server, on the virtual Uno
//! with its virtual Ethernet shield (`--wiznet w5100|w5500 --tcp 502:PORT`): mbpoll (libmodbus
//! underneath), pymodbus's TCP client (`demo/pymodbus_tcp_check.py`), a raw socket for what
//! no library sends (split requests, pipelined requests, broken headers), libmodbus's own
//! `unit-test-client` against `examples/libmodbus_map.rs`, thousands of one-shot connections,
//! and several masters at once. Each test starts its own virtual board (one at a time: each
//! keeps a core busy) and fails with the master's transcript and the board's log on any
//! mismatch.
//!
//! Needs `make tcp-firmware` (examples/tcp_server.rs for the W5100 and the W5500,
//! examples/libmodbus_map.rs) and what `make setup` installs and checks: mbpoll, Debian's
//! python3-pymodbus (3.0), libmodbus's test programs (`.ci/libmodbus-tests`, under
//! target/libmodbus-tests). `make interop` runs it; `TCP_CONNECTIONS` sets the one-shot
//! connections (100 there, 10000 under `make soak-tcp`).
//!
//! With feature `rtu-over-tcp`, pymodbus's RTU framer over TCP against
//! `examples/sixteen_each_tcp.rs` (`demo/pymodbus_rtu_over_tcp_check.py`, on pymodbus 3.0 or
//! 3.13 as `INTEROP_PYTHON` has it).
//!
//! With feature `write-protect`, two pymodbus clients against `examples/sixteen_each_tcp.rs`,
//! one from 127.0.0.2, which its allow-list lets only read, one from 127.0.0.1, which writes
//! (`demo/pymodbus_read_only_check.py`).
//!
//! mbpoll cannot send a request that gets exception 03: libmodbus refuses a quantity over the
//! spec's limits before sending (`Too many data`), so 03 is checked through pymodbus, the raw
//! socket and libmodbus's crafted requests (`modbus_send_raw_request`).

mod common;

use common::libmodbus::{self, Check, Run};
use common::{collect, python, run, serialise, workspace, Spawned};

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use uno_sim::built::{built, target_dir};

/// `target/chips/DIR/avr-none/release/examples/NAME.elf`, as `make tcp-firmware` builds it.
fn chip_firmware(dir: &str, name: &str) -> PathBuf {
    let elf = target_dir().join("chips").join(dir).join("avr-none/release/examples").join(format!("{name}.elf"));
    built(elf, "make tcp-firmware")
}

/// examples/tcp_server.rs for the Uno with `shield` (`w5100`, `w5500`).
fn tcp_server(shield: &str) -> PathBuf {
    chip_firmware(&format!("atmega328p-{shield}"), "tcp_server")
}

/// A running `virtual-uno` with a shield, stopped with SIGTERM when dropped.
struct Board {
    process: Spawned,
    /// Where the chip's port 502 is on 127.0.0.1.
    port: u16,
}

impl Board {
    /// Starts `firmware` with a `shield` (`w5100`, `w5500`), the chip's port 502 on a port of
    /// 127.0.0.1 the system picks; waits until the firmware listens.
    fn start(firmware: &Path, shield: &str) -> Board {
        Board::on_port(firmware, shield, 0)
    }

    /// The same on 127.0.0.1:`host_port` (0: any).
    fn on_port(firmware: &Path, shield: &str, host_port: u16) -> Board {
        let process = Spawned::start(
            Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
                .args(["--no-stdin", "--wiznet", shield, "--tcp", &format!("502:{host_port}")])
                .arg(firmware),
        );
        let port = process.port_after("tcp: 127.0.0.1:", "the firmware");
        Board { process, port }
    }

    fn log(&self) -> String {
        self.process.log()
    }

    /// A connection to the chip's port 502, replies awaited up to 3 s.
    fn connect(&self) -> TcpStream {
        let stream = TcpStream::connect(("127.0.0.1", self.port)).expect("connect to the bridge");
        stream.set_nodelay(true).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
        stream
    }

    /// Input registers 30001 (seconds) and 30002 (requests answered) on a connection of their
    /// own, as the firmware last set them (once a second).
    fn counters(&self) -> (u16, u16) {
        let mut stream = self.connect();
        stream.write_all(&adu(0x7E57, 0xFF, &[0x04, 0, 0, 0, 2])).unwrap();
        let reply = read_adu(&mut stream).expect("a reply to the read of 30001-30002");
        assert!(reply.len() == 13 && reply[7] == 0x04, "30001-30002: {}", hex(&reply));
        (u16::from_be_bytes([reply[9], reply[10]]), u16::from_be_bytes([reply[11], reply[12]]))
    }

    /// How many lines of the log contain `what`.
    fn count(&self, what: &str) -> usize {
        self.process.count(what)
    }
}

/// What a failed test prints.
fn transcript(master: &str, board: &Board) -> String {
    format!("--- master ---\n{master}--- virtual-uno ---\n{}", board.log())
}

// ------------------------------------------------------------------------------------------
// Raw Modbus TCP

/// An ADU: MBAP header (transaction `tid`, protocol 0, length, `unit`) and `pdu`.
fn adu(tid: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut adu = tid.to_be_bytes().to_vec();
    adu.extend_from_slice(&[0, 0]);
    adu.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes());
    adu.push(unit);
    adu.extend_from_slice(pdu);
    adu
}

/// One ADU from the stream: its header, then as many bytes as its length says.
fn read_adu(stream: &mut TcpStream) -> std::io::Result<Vec<u8>> {
    let mut head = [0u8; 6];
    stream.read_exact(&mut head)?;
    let mut rest = vec![0u8; usize::from(u16::from_be_bytes([head[4], head[5]]))];
    stream.read_exact(&mut rest)?;
    Ok([&head[..], &rest].concat())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

/// What the server says to a connection after it was sent something: `Closed` (FIN or RST,
/// no byte), `Silent` (nothing within the wait), or bytes.
#[derive(Debug, PartialEq)]
enum Heard {
    Closed(String),
    Silent,
    Bytes(Vec<u8>),
}

fn listen(stream: &mut TcpStream, wait: Duration) -> Heard {
    stream.set_read_timeout(Some(wait)).unwrap();
    let mut buf = [0u8; 300];
    let heard = match stream.read(&mut buf) {
        Ok(0) => Heard::Closed("FIN".into()),
        Ok(n) => Heard::Bytes(buf[..n].to_vec()),
        Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => Heard::Silent,
        Err(e) => Heard::Closed(e.to_string()),
    };
    stream.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
    heard
}

/// A raw-socket session's transcript, every byte each way.
struct Session<'a> {
    board: &'a Board,
    stream: TcpStream,
    log: String,
}

impl<'a> Session<'a> {
    fn open(board: &'a Board, what: &str) -> Session<'a> {
        let stream = board.connect();
        let log = format!("# {what}: connected from {}\n", stream.local_addr().unwrap());
        Session { board, stream, log }
    }

    fn send(&mut self, bytes: &[u8]) {
        self.log += &format!("-> {}\n", hex(bytes));
        self.stream.write_all(bytes).unwrap();
    }

    fn reply(&mut self) -> Vec<u8> {
        match read_adu(&mut self.stream) {
            Ok(reply) => {
                self.log += &format!("<- {}\n", hex(&reply));
                reply
            }
            Err(e) => self.fail(&format!("no reply: {e}")),
        }
    }

    fn expect(&mut self, what: &str, want: &[u8]) {
        let got = self.reply();
        if got != want {
            self.fail(&format!("{what}: expected {}", hex(want)));
        }
    }

    fn listen(&mut self, wait: Duration) -> Heard {
        let heard = listen(&mut self.stream, wait);
        self.log += &format!("<- {heard:?} (within {wait:?})\n");
        heard
    }

    fn fail(&self, why: &str) -> ! {
        panic!("{why}\n{}", transcript(&self.log, self.board));
    }
}

/// The raw-socket checks on `board` (examples/tcp_server.rs): a request split over segments,
/// requests pipelined in one segment, a bad protocol id, bad lengths, 126 registers, the
/// longest ADUs.
fn raw_socket_checks(board: &Board) -> String {
    let mut all = String::new();
    let pause = Duration::from_millis(300);

    // A request split over four segments (header cut inside the length field and after the
    // unit id), 300 ms apart: nothing comes back before the last, then the one reply.
    let mut s = Session::open(board, "one request in four segments, 300 ms apart");
    let request = adu(0x1234, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x02]);
    for part in [&request[..5], &request[5..7], &request[7..9], &request[9..]] {
        if s.listen(Duration::from_millis(1)) != Heard::Silent {
            s.fail("a reply before the request was whole");
        }
        s.send(part);
        thread::sleep(pause);
    }
    s.expect("the split request's reply", &[0x12, 0x34, 0, 0, 0, 7, 0xFF, 0x03, 4, 0, 0, 0, 0]);
    // Byte by byte, two requests' worth, 20 ms apart.
    let two =
        [adu(0x0001, 1, &[0x06, 0x00, 0x04, 0xBE, 0xEF]), adu(0x0002, 1, &[0x03, 0x00, 0x04, 0x00, 0x01])].concat();
    s.log += "# two requests a byte at a time, 20 ms apart\n";
    for b in &two {
        s.stream.write_all(&[*b]).unwrap();
        thread::sleep(Duration::from_millis(20));
    }
    s.log += &format!("-> {} (a byte at a time)\n", hex(&two));
    s.expect("FC06 40005 = BEEF echoed", &[0, 1, 0, 0, 0, 6, 1, 0x06, 0x00, 0x04, 0xBE, 0xEF]);
    s.expect("FC03 40005", &[0, 2, 0, 0, 0, 5, 1, 0x03, 2, 0xBE, 0xEF]);
    all += &s.log;

    // Two, then three requests in one segment: answered in order, transaction ids echoed.
    let mut s = Session::open(board, "two and three requests pipelined in one segment");
    s.send(
        &[adu(0xA001, 0xFF, &[0x03, 0x00, 0x04, 0x00, 0x01]), adu(0xA002, 0xFF, &[0x01, 0x00, 0x00, 0x00, 0x10])]
            .concat(),
    );
    s.expect("first of two", &[0xA0, 0x01, 0, 0, 0, 5, 0xFF, 0x03, 2, 0xBE, 0xEF]);
    s.expect("second of two", &[0xA0, 0x02, 0, 0, 0, 5, 0xFF, 0x01, 2, 0, 0]);
    s.send(
        &[
            adu(0xB001, 0xFF, &[0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0x11, 0x11, 0x22, 0x22]),
            adu(0xB002, 0xFF, &[0x0F, 0x00, 0x00, 0x00, 0x0A, 0x02, 0xFF, 0x02]),
            adu(0xB003, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x03]),
        ]
        .concat(),
    );
    s.expect("FC16 of three", &[0xB0, 0x01, 0, 0, 0, 6, 0xFF, 0x10, 0, 0, 0, 2]);
    s.expect("FC15 of three", &[0xB0, 0x02, 0, 0, 0, 6, 0xFF, 0x0F, 0, 0, 0, 0x0A]);
    s.expect(
        "FC03 of three: the FC16's values",
        &[0xB0, 0x03, 0, 0, 0, 9, 0xFF, 0x03, 6, 0x11, 0x11, 0x22, 0x22, 0, 0],
    );
    s.send(&adu(0xB004, 0xFF, &[0x01, 0x00, 0x00, 0x00, 0x0A]));
    s.expect("FC01 coils 1-10 after the FC15", &[0xB0, 0x04, 0, 0, 0, 5, 0xFF, 0x01, 2, 0xFF, 0x02]);
    all += &s.log;

    // A protocol id other than 0: that ADU dropped in silence, the next answered; alone and
    // with the next in the same segment.
    let mut s = Session::open(board, "protocol id 0x0001, then 0xFFFF before a good request in one segment");
    let mut bad = adu(0xC001, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x01]);
    bad[2..4].copy_from_slice(&[0x00, 0x01]);
    s.send(&bad);
    if s.listen(Duration::from_millis(500)) != Heard::Silent {
        s.fail("an answer to protocol id 1");
    }
    s.send(&adu(0xC002, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x01]));
    s.expect("the request after it", &[0xC0, 0x02, 0, 0, 0, 5, 0xFF, 0x03, 2, 0x11, 0x11]);
    bad[0..4].copy_from_slice(&[0xC0, 0x03, 0xFF, 0xFF]);
    s.send(&[bad.clone(), adu(0xC004, 0xFF, &[0x03, 0x00, 0x01, 0x00, 0x01])].concat());
    s.expect("the request behind it in the segment", &[0xC0, 0x04, 0, 0, 0, 5, 0xFF, 0x03, 2, 0x22, 0x22]);
    all += &s.log;

    // Length fields the stream cannot be followed past: the connection closed, no reply.
    for (length, extra) in [(0u16, 6usize), (1, 6), (255, 260), (0xFFFF, 20)] {
        let mut s = Session::open(board, &format!("length field {length}"));
        let mut bytes = vec![0xD0, 0x00, 0x00, 0x00];
        bytes.extend_from_slice(&length.to_be_bytes());
        bytes.push(0xFF);
        bytes.extend_from_slice(&[0x03, 0x00, 0x00, 0x00, 0x01]);
        bytes.resize(7 + extra, 0);
        s.send(&bytes);
        match s.listen(Duration::from_secs(3)) {
            Heard::Closed(_) => {}
            other => s.fail(&format!("length {length}: expected the connection closed, heard {other:?}")),
        }
        all += &s.log;
    }

    // Quantities: 126 registers is exception 03; the longest requests (123 registers, 1968
    // coils: ADUs of 259 and 260 bytes) on this 16-value map are exception 02.
    let mut s = Session::open(board, "126 registers, the longest ADUs");
    s.send(&adu(0xE001, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x7E]));
    s.expect("FC03 126 registers", &[0xE0, 0x01, 0, 0, 0, 3, 0xFF, 0x83, 0x03]);
    s.send(&adu(0xE002, 0xFF, &[0x04, 0x00, 0x00, 0x00, 0x7E]));
    s.expect("FC04 126 registers", &[0xE0, 0x02, 0, 0, 0, 3, 0xFF, 0x84, 0x03]);
    let mut fc16 = vec![0x10, 0x00, 0x00, 0x00, 123, 246];
    fc16.resize(6 + 246, 0x5A);
    let long = adu(0xE003, 0xFF, &fc16);
    s.log += &format!("# FC16 123 registers: an ADU of {} bytes\n", long.len());
    s.send(&long);
    s.expect("FC16 123 registers from 40001", &[0xE0, 0x03, 0, 0, 0, 3, 0xFF, 0x90, 0x02]);
    let mut fc15 = vec![0x0F, 0x00, 0x00, 0x07, 0xB0, 246];
    fc15.resize(6 + 246, 0xA5);
    let longest = adu(0xE004, 0xFF, &fc15);
    s.log += &format!("# FC15 1968 coils: an ADU of {} bytes\n", longest.len());
    s.send(&longest);
    s.expect("FC15 1968 coils from 00001", &[0xE0, 0x04, 0, 0, 0, 3, 0xFF, 0x8F, 0x02]);
    s.send(&adu(0xE005, 0xFF, &[0x03, 0x00, 0x00, 0x00, 0x02]));
    s.expect("FC03 40001-40002 unchanged", &[0xE0, 0x05, 0, 0, 0, 7, 0xFF, 0x03, 4, 0x11, 0x11, 0x22, 0x22]);
    let _ = s.stream.shutdown(Shutdown::Write);
    match s.listen(Duration::from_secs(3)) {
        Heard::Closed(_) => {}
        other => s.fail(&format!("our FIN: expected the server's, heard {other:?}")),
    }
    all += &s.log;
    all
}

#[test]
fn raw_socket_split_pipelined_bad_headers_w5100() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5100"), "w5100");
    let log = raw_socket_checks(&board);
    println!("{log}");
}

#[test]
fn raw_socket_split_pipelined_bad_headers_w5500() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5500"), "w5500");
    let log = raw_socket_checks(&board);
    println!("{log}");
}

// ------------------------------------------------------------------------------------------
// mbpoll

/// `mbpoll -m tcp -p PORT -1 ARGS 127.0.0.1 VALUES`: its output.
fn mbpoll(board: &Board, args: &str, values: &str) -> String {
    let mut cmd = Command::new("mbpoll");
    cmd.args(["-m", "tcp", "-p", &board.port.to_string(), "-1"]).args(args.split_whitespace());
    cmd.arg("127.0.0.1").args(values.split_whitespace());
    let (_, out) = run(&mut cmd, Duration::from_secs(10));
    format!("$ mbpoll -m tcp -p {} -1 {args} 127.0.0.1 {values}\n{out}", board.port)
}

/// The values of `[ref]: value` lines (`[14]: 65535 (-1)`: 65535).
fn mbpoll_values(out: &str) -> Vec<i64> {
    out.lines()
        .filter(|l| l.starts_with('['))
        .filter_map(|l| l.split(':').nth(1)?.split_whitespace().next()?.parse().ok())
        .collect()
}

/// Every table of examples/tcp_server.rs read and written by mbpoll, exceptions 02, unit ids
/// 1, 0, 0xFF.
fn mbpoll_every_table(board: &Board) {
    let mut log = String::new();
    let mut check = |out: String, ok: bool| {
        log.push_str(&out);
        assert!(ok, "mbpoll step failed\n{}", transcript(&log, board));
    };
    let out = mbpoll(board, "-a 1 -t 0 -r 1 -c 16", ""); // FC01
    check(out.clone(), mbpoll_values(&out) == [0; 16]);
    let out = mbpoll(board, "-a 1 -t 0 -r 2", "1"); // FC05
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(board, "-a 1 -t 0 -r 3", "1 0 1"); // FC15
    check(out.clone(), out.contains("Written 3 references"));
    let out = mbpoll(board, "-a 1 -t 0 -r 9", "1 1 0 0 1 1 0 1"); // FC15, a whole byte
    check(out.clone(), out.contains("Written 8 references"));
    let out = mbpoll(board, "-a 1 -t 0 -r 1 -c 16", "");
    check(out.clone(), mbpoll_values(&out) == [0, 1, 1, 0, 1, 0, 0, 0, 1, 1, 0, 0, 1, 1, 0, 1]);
    let out = mbpoll(board, "-a 1 -t 1 -r 1 -c 16", ""); // FC02
    check(out.clone(), mbpoll_values(&out) == [0; 16]);
    let out = mbpoll(board, "-a 1 -t 3 -r 1 -c 8", ""); // FC04
    let inputs = mbpoll_values(&out);
    check(out.clone(), inputs.len() == 8 && inputs[2..] == [0; 6]);
    let out = mbpoll(board, "-a 1 -t 4 -r 1 -c 16", ""); // FC03
    check(out.clone(), mbpoll_values(&out) == [0; 16]);
    let out = mbpoll(board, "-a 1 -t 4 -r 3", "1234"); // FC06
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(board, "-a 1 -t 4 -r 4", "11 22 33"); // FC16
    check(out.clone(), out.contains("Written 3 references"));
    let out = mbpoll(board, "-a 1 -t 4 -r 14", "65535 32768 7"); // FC16 up to the last register
    check(out.clone(), out.contains("Written 3 references"));
    let out = mbpoll(board, "-a 1 -t 4 -r 1 -c 16", "");
    check(out.clone(), mbpoll_values(&out) == [0, 0, 1234, 11, 22, 33, 0, 0, 0, 0, 0, 0, 0, 65535, 32768, 7]);
    let out = mbpoll(board, "-a 1 -t 4:hex -r 14 -c 2", "");
    check(out.clone(), out.contains("[14]: \t0xFFFF") && out.contains("[15]: \t0x8000"));

    // Unit ids: 0xFF (the device, §4.4.1.2), 0, and mbpoll's address list over one connection.
    for unit in ["255", "0", "1,255,0,17"] {
        let out = mbpoll(board, &format!("-a {unit} -t 4 -r 3"), "");
        check(out.clone(), mbpoll_values(&out) == vec![1234; unit.split(',').count()]);
    }
    let out = mbpoll(board, "-a 255 -t 4 -r 7", "4321"); // FC06 to 0xFF
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(board, "-a 0 -t 0 -r 16", "1"); // FC05 to 0
    check(out.clone(), out.contains("Written 1 references"));
    let out = mbpoll(board, "-a 1 -t 4 -r 7", "");
    check(out.clone(), mbpoll_values(&out) == [4321]);
    let out = mbpoll(board, "-a 1 -t 0 -r 16", "");
    check(out.clone(), mbpoll_values(&out) == [1]);

    // Exception 02: past the map, and ranges that run past its end.
    for args in ["-t 0 -r 17", "-t 0 -r 1 -c 17", "-t 1 -r 17", "-t 1 -r 9 -c 9", "-t 3 -r 9", "-t 3 -r 1 -c 9"] {
        let out = mbpoll(board, &format!("-a 1 {args}"), "");
        check(out.clone(), out.contains("failed: Illegal data address"));
    }
    for args in ["-t 4 -r 17", "-t 4 -r 1 -c 125"] {
        let out = mbpoll(board, &format!("-a 255 {args}"), "");
        check(out.clone(), out.contains("failed: Illegal data address"));
    }
    for (args, values) in [("-t 0 -r 17", "1"), ("-t 0 -r 15", "1 1 1"), ("-t 4 -r 17", "5"), ("-t 4 -r 16", "5 6")] {
        let out = mbpoll(board, &format!("-a 1 {args}"), values);
        check(out.clone(), out.contains("failed: Illegal data address"));
    }
    let out = mbpoll(board, "-a 1 -t 4 -r 16", "");
    check(out.clone(), mbpoll_values(&out) == [7]);

    // Exception 03 is out of mbpoll's reach: libmodbus refuses 126 registers before sending.
    let out = mbpoll(board, "-a 1 -t 4:int -r 1 -c 63", "");
    check(out.clone(), out.contains("failed: Too many data"));
}

#[test]
fn mbpoll_reads_and_writes_every_table_w5100() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5100"), "w5100");
    mbpoll_every_table(&board);
}

#[test]
fn mbpoll_reads_and_writes_every_table_w5500() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5500"), "w5500");
    mbpoll_every_table(&board);
}

/// `TCP_CONNECTIONS` (default 100; `make soak-tcp`: 10000) one-shot `mbpoll -m tcp -1` runs, a
/// connection each, reading 30002 (requests answered): each answered, none refused; then
/// 30002 equals the count.
/// examples/sixteen_each_tcp.rs built with feature `dhcp` (W5100, the client on socket 3)
/// with the virtual Uno playing the network's DHCP server (`--dhcp 6`: 6 s leases, renewed
/// every 3 s): the lease taken, renewed, and mbpoll served meanwhile on one connection after
/// another.
#[test]
fn mbpoll_reads_the_dhcp_firmware_through_its_lease_and_renewals_w5100() {
    let _one = serialise();
    let firmware = chip_firmware("atmega328p-tcp-dhcp", "sixteen_each_tcp");
    let process = Spawned::start(
        Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
            .args(["--no-stdin", "--wiznet", "w5100", "--dhcp", "6", "--tcp", "502:0"])
            .arg(firmware),
    );
    let port = process.port_after("tcp: 127.0.0.1:", "the firmware");
    let board = Board { process, port };
    let acked = "answered ACK 192.168.50.23";
    assert!(board.process.wait_for(acked, Duration::from_secs(10)), "no lease:\n{}", board.log());
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut log = String::new();
    while board.count(acked) < 4 {
        assert!(Instant::now() < deadline, "no renewals:\n{}", transcript(&log, &board));
        let out = mbpoll(&board, "-t 4 -r 1 -c 16", "");
        assert_eq!(mbpoll_values(&out), vec![0; 16], "{}", transcript(&out, &board));
        log.push_str(&out);
    }
    assert_eq!(board.count("dhcp: DISCOVER to 255.255.255.255:67, answered OFFER"), 1, "{}", board.log());
    assert!(
        board.count("dhcp: REQUEST to 192.168.50.1:67, answered ACK") >= 2,
        "renewals by unicast:\n{}",
        board.log()
    );
}

#[test]
fn mbpoll_one_shot_connections_are_all_answered_w5100() {
    let _one = serialise();
    let n: usize = std::env::var("TCP_CONNECTIONS").ok().and_then(|v| v.parse().ok()).unwrap_or(100);
    let board = Board::start(&tcp_server("w5100"), "w5100");
    let port = board.port.to_string();
    let (mut answered, mut failures, mut slow) = (0usize, Vec::new(), 0usize);
    let mut slowest = Duration::ZERO;
    let mut last = 0i64;
    let start = Instant::now();
    for i in 0..n {
        let began = Instant::now();
        let out = Command::new("mbpoll")
            .args(["-m", "tcp", "-p", &port, "-1", "-o", "5", "-a", "1", "-t", "3", "-r", "2", "127.0.0.1"])
            .stdin(Stdio::null())
            .output()
            .expect("run mbpoll");
        let took = began.elapsed();
        slowest = slowest.max(took);
        if took > Duration::from_millis(500) {
            slow += 1;
        }
        let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
        match mbpoll_values(&text).as_slice() {
            [value] if out.status.success() => {
                answered += 1;
                last = *value;
            }
            _ => {
                if failures.len() < 10 {
                    failures.push(format!("connection {i} ({took:?}):\n{text}"));
                } else {
                    failures.push(String::new());
                }
            }
        }
        if (i + 1) % 1000 == 0 {
            println!("  {} connections, {answered} answered, {:.0} s", i + 1, start.elapsed().as_secs_f64());
        }
    }
    let took = start.elapsed();
    thread::sleep(Duration::from_millis(1200)); // the firmware sets 30001-30002 once a second
    let (seconds, requests) = board.counters();
    let refused = board.count("refused");
    println!(
        "mbpoll -m tcp -1: {answered} of {n} one-shot connections answered in {:.1} s ({:.1} ms each, slowest \
         {:.0} ms, {slow} over 500 ms); {refused} refused by the bridge; the firmware: 30001 = {seconds} s, \
         30002 = {requests} requests answered (the last mbpoll read {last})",
        took.as_secs_f64(),
        took.as_secs_f64() * 1000.0 / n.max(1) as f64,
        slowest.as_secs_f64() * 1000.0,
    );
    let shown: String = failures.iter().filter(|f| !f.is_empty()).cloned().collect::<Vec<_>>().join("\n");
    assert!(
        answered == n && refused == 0,
        "{} of {n} connections failed, {refused} refused; the first:\n{shown}\n--- virtual-uno (last 40 lines) ---\n{}",
        n - answered,
        board.log().lines().rev().take(40).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")
    );
    assert_eq!(usize::from(requests), n % 65536, "30002 counts every request answered");
}

// ------------------------------------------------------------------------------------------
// pymodbus

fn pymodbus_script() -> PathBuf {
    workspace().join("demo/pymodbus_tcp_check.py")
}

fn pymodbus_check(board: &Board) {
    let mut cmd = Command::new(python());
    cmd.arg(pymodbus_script()).args(["check", "127.0.0.1", &board.port.to_string()]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "pymodbus_tcp_check.py check failed (python: {})\n{}", python(), transcript(&out, board));
}

#[test]
fn pymodbus_tcp_client_runs_every_function_code_and_exceptions_w5100() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5100"), "w5100");
    pymodbus_check(&board);
}

#[test]
fn pymodbus_tcp_client_runs_every_function_code_and_exceptions_w5500() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5500"), "w5500");
    pymodbus_check(&board);
}

/// examples/sixteen_each_tcp.rs built with feature `rtu-over-tcp` on a W5100 (MBAP on 502,
/// RTU over TCP on socket 3, port 5020), with both ports bridged: the board, and where the
/// chip's port 5020 is on 127.0.0.1.
fn rtu_over_tcp_board() -> (Board, u16) {
    let firmware = chip_firmware("atmega328p-tcp-rtu", "sixteen_each_tcp");
    let process = Spawned::start(
        Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
            .args(["--no-stdin", "--wiznet", "w5100", "--tcp", "502:0", "--tcp", "5020:0"])
            .arg(&firmware),
    );
    let port = process.port_after("tcp: 127.0.0.1:", "the firmware");
    let deadline = Instant::now() + Duration::from_secs(10);
    let rtu_port = loop {
        let log = process.log();
        let line = log.lines().find(|line| line.ends_with("(the chip's port 5020)"));
        if let Some(port) =
            line.and_then(|l| l.split(['.', ':', ' ']).find_map(|w| w.parse::<u16>().ok().filter(|&p| p > 1024)))
        {
            break port;
        }
        assert!(Instant::now() < deadline, "port 5020 never listened:\n{log}");
        thread::sleep(Duration::from_millis(20));
    };
    (Board { process, port }, rtu_port)
}

/// pymodbus's TCP client with its RTU framer (Home Assistant's `type: rtuovertcp`):
/// `demo/pymodbus_rtu_over_tcp_check.py` against the RTU over TCP port (reads and writes of
/// every table at two addresses, exceptions 02 and 01), then an MBAP read on port 502 of
/// what it wrote.
#[test]
fn pymodbus_rtu_framer_over_tcp_reads_writes_and_exceptions() {
    let _one = serialise();
    let (board, rtu_port) = rtu_over_tcp_board();
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_rtu_over_tcp_check.py")).args([
        "check",
        "127.0.0.1",
        &rtu_port.to_string(),
    ]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "pymodbus_rtu_over_tcp_check.py failed (python: {})\n{}", python(), transcript(&out, &board));
    let mut mbap = board.connect();
    mbap.write_all(&adu(1, 1, &[0x03, 0, 0, 0, 4])).unwrap();
    let reply = read_adu(&mut mbap).expect("an MBAP reply on port 502");
    assert_eq!(reply, adu(1, 1, &[0x03, 8, 0, 17, 0x12, 0x34, 0xBE, 0xEF, 0, 7]), "{}", transcript(&out, &board));
}

/// Two pymodbus TCP clients against `examples/sixteen_each_tcp.rs` built with feature
/// `write-protect` (`demo/pymodbus_read_only_check.py`): the one from 127.0.0.2, which the
/// allow-list lets only read, gets exception 01 for FC 5, 6, 15 and 16 and changes nothing;
/// the one from 127.0.0.1 writes.
#[test]
fn pymodbus_reading_client_gets_01_for_its_writes_and_a_writing_client_writes() {
    let _one = serialise();
    let board = Board::start(&chip_firmware("atmega328p-tcp-read-only", "sixteen_each_tcp"), "w5100");
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_read_only_check.py")).args(["check", "127.0.0.1", &board.port.to_string()]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(60));
    println!("{out}");
    assert!(ok, "pymodbus_read_only_check.py failed (python: {})\n{}", python(), transcript(&out, &board));
}

/// A master: `pymodbus_tcp_check.py poll` in a process of its own.
struct Master {
    name: String,
    child: Child,
    out: Arc<Mutex<String>>,
}

impl Master {
    fn start(board: &Board, name: &str, args: &str) -> Master {
        let mut child = Command::new(python())
            .arg(pymodbus_script())
            .args(["poll", "127.0.0.1", &board.port.to_string()])
            .args(args.split_whitespace())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start pymodbus_tcp_check.py poll");
        let out = Arc::new(Mutex::new(String::new()));
        let stdout: ChildStdout = child.stdout.take().unwrap();
        collect(stdout, out.clone());
        collect(child.stderr.take().unwrap(), out.clone());
        Master { name: name.to_owned(), child, out }
    }

    fn out(&self) -> String {
        self.out.lock().unwrap().clone()
    }

    /// Waits up to `limit` for `line` in its output.
    fn wait_for(&self, line: &str, limit: Duration, board: &Board) {
        let deadline = Instant::now() + limit;
        while !self.out().lines().any(|l| l == line) {
            assert!(
                Instant::now() < deadline,
                "{}: no `{line}` in {limit:?}\n{}",
                self.name,
                transcript(&self.out(), board)
            );
            thread::sleep(Duration::from_millis(20));
        }
    }

    fn signal(&self, signal: Signal) {
        kill(Pid::from_raw(self.child.id() as i32), signal).expect("signal the master");
    }

    /// Waits for it to end (killed after `limit`); its summary.
    fn finish(mut self, limit: Duration) -> Summary {
        let deadline = Instant::now() + limit;
        while self.child.try_wait().unwrap().is_none() {
            if Instant::now() > deadline {
                let _ = self.child.kill();
                break;
            }
            thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.wait();
        thread::sleep(Duration::from_millis(50));
        Summary::parse(&self.name, &self.out())
    }
}

impl Drop for Master {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// What a master's JSON line says.
#[derive(Debug, Default)]
struct Summary {
    name: String,
    answered: i64,
    failed: i64,
    first_seconds: Option<i64>,
    last_seconds: Option<i64>,
    slowest_ms: f64,
    connections: i64,
    out: String,
}

impl Summary {
    fn parse(name: &str, out: &str) -> Summary {
        let json = out.lines().find(|l| l.starts_with("{\"")).unwrap_or("");
        let field = |key: &str| -> Option<&str> {
            let at = json.find(&format!("\"{key}\": "))? + key.len() + 4;
            let rest = &json[at..];
            Some(rest[..rest.find([',', '}']).unwrap_or(rest.len())].trim())
        };
        let int = |key: &str| field(key).and_then(|v| v.parse::<i64>().ok());
        Summary {
            name: name.to_owned(),
            answered: int("answered").unwrap_or(-1),
            failed: int("failed").unwrap_or(-1),
            first_seconds: int("first_seconds"),
            last_seconds: int("last_seconds"),
            slowest_ms: field("slowest_ms").and_then(|v| v.parse().ok()).unwrap_or(-1.0),
            connections: int("connections").unwrap_or(-1),
            out: out.to_owned(),
        }
    }

    fn line(&self) -> String {
        format!(
            "{}: {} answered, {} failed, 30001 {:?} -> {:?}, slowest {:.1} ms, {} connection(s)",
            self.name,
            self.answered,
            self.failed,
            self.first_seconds,
            self.last_seconds,
            self.slowest_ms,
            self.connections
        )
    }

    /// Every request answered, and 30001 counted at least `seconds` meanwhile.
    fn all_answered(&self, seconds: i64) -> bool {
        self.answered > 0
            && self.failed == 0
            && matches!((self.first_seconds, self.last_seconds), (Some(a), Some(b)) if b - a >= seconds)
    }
}

fn report(summaries: &[&Summary]) -> String {
    summaries.iter().map(|s| format!("{}\n{}", s.line(), s.out)).collect()
}

/// `n` masters reading back to back for 10 s at once: each request answered on the
/// connection it started with, and 30001 counting. The main loop's `delay(1000)` counts CPU
/// cycles, and the server answers from interrupts: under back-to-back requests the loop gets
/// what the interrupts leave of the CPU, so its seconds come slower than the wall's (printed
/// as the loop's share).
fn masters_at_once(shield: &str, n: usize) {
    let board = Board::start(&tcp_server(shield), shield);
    let (seconds_before, _) = board.counters();
    let started = Instant::now();
    let masters: Vec<Master> =
        (0..n).map(|i| Master::start(&board, &format!("master {}", i + 1), "--seconds 4")).collect();
    let summaries: Vec<Summary> = masters.into_iter().map(|m| m.finish(Duration::from_secs(30))).collect();
    let wall = started.elapsed();
    thread::sleep(Duration::from_millis(1200));
    let (seconds, requests) = board.counters();
    let counted = i64::from(seconds) - i64::from(seconds_before);
    let total: i64 = summaries.iter().map(|s| s.answered).sum();
    for s in &summaries {
        println!("{}", s.line());
    }
    println!(
        "{n} masters at once on the {shield}, back to back: {total} requests answered in 4 s ({:.0}/s); 30001 \
         counted {counted} s in {:.1} s of wall time (the main loop's share of the CPU: {:.0} %); 30002 = {requests}",
        total as f64 / 10.0,
        wall.as_secs_f64() + 1.2,
        100.0 * counted as f64 / (wall.as_secs_f64() + 1.2),
    );
    let all: Vec<&Summary> = summaries.iter().collect();
    assert!(
        summaries.iter().all(|s| s.answered > 0 && s.failed == 0 && s.connections == 1),
        "a master lost a request or its connection\n{}",
        transcript(&report(&all), &board)
    );
    assert!(counted >= 2, "30001 stopped counting: {counted} s\n{}", transcript(&report(&all), &board));
    assert_eq!(i64::from(requests), total + 1, "30002: every request answered, the first read of 30001 too");
    assert_eq!(board.count("refused"), 0, "{}", board.log());
}

#[test]
fn four_masters_at_once_are_all_answered_w5100() {
    let _one = serialise();
    masters_at_once("w5100", 4);
}

#[test]
fn eight_masters_at_once_are_all_answered_w5500() {
    let _one = serialise();
    masters_at_once("w5500", 8);
}

/// The W5100's four sockets all held by busy masters (each polling every 20 ms, so that the
/// main loop keeps its pace: 30001 counts the wall's seconds): a fifth waits and is refused (the
/// bridge gives up after 3 s, as a client's SYNs would). Once one of the four goes quiet, the
/// server closes it after 1-2 s (`Network::evict_after(2)`, counted in whole seconds; whether
/// or not anybody waits: the chip does not say), and the newcomer gets in.
#[test]
fn a_fifth_master_on_the_w5100_waits_until_one_of_four_goes_quiet() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5100"), "w5100");
    let busy: Vec<Master> =
        (1..=3).map(|i| Master::start(&board, &format!("busy {i}"), "--seconds 16 --interval 0.02")).collect();
    let quiet = Master::start(&board, "quiet", "--seconds 16 --interval 0.02 --quiet-after 7");
    for m in busy.iter().chain([&quiet]) {
        m.wait_for("first answer", Duration::from_secs(10), &board);
    }
    let refused_before = board.count("refused");
    let fifth = Master::start(&board, "fifth, all four busy", "--seconds 3 --timeout 5 --interval 0.02")
        .finish(Duration::from_secs(20));
    let refused = board.count("refused") - refused_before;
    let evicted_before = board.count("reset by the chip");
    quiet.wait_for("quiet", Duration::from_secs(10), &board);
    thread::sleep(Duration::from_millis(1000));
    let newcomer = Master::start(&board, "fifth, one gone quiet", "--seconds 3 --timeout 5 --interval 0.02");
    let newcomer = newcomer.finish(Duration::from_secs(20));
    let evicted = board.count("reset by the chip") - evicted_before;
    let busy: Vec<Summary> = busy.into_iter().map(|m| m.finish(Duration::from_secs(30))).collect();
    let quiet = quiet.finish(Duration::from_secs(30));
    for s in busy.iter().chain([&quiet, &fifth, &newcomer]) {
        println!("{}", s.line());
    }
    println!("the bridge refused {refused} connection(s) of the fifth; the server closed {evicted} for the newcomer");
    let all: Vec<&Summary> = busy.iter().chain([&quiet, &fifth, &newcomer]).collect();
    let fail = |why: &str| -> String { format!("{why}\n{}", transcript(&report(&all), &board)) };
    assert!(busy.iter().all(|s| s.all_answered(13) && s.connections == 1), "{}", fail("a busy master lost out"));
    assert!(quiet.answered > 0 && quiet.failed == 0, "{}", fail("the quiet master, before it went quiet"));
    assert!(fifth.answered == 0 && refused >= 1, "{}", fail("the fifth got in while all four were busy"));
    assert!(newcomer.answered > 0 && newcomer.failed == 0 && evicted == 1, "{}", fail("the newcomer did not get in"));
}

/// Every master polling every 20 ms. A master killed with SIGKILL while it holds a connection (its system closes the socket):
/// the socket comes back, and a new master gets in beside three busy ones. A master frozen
/// with SIGSTOP (no FIN, no RST: a peer that vanished) is closed once idle 2 s when a
/// newcomer needs its socket.
#[test]
fn a_killed_or_frozen_master_gives_its_socket_back_w5100() {
    let _one = serialise();
    let board = Board::start(&tcp_server("w5100"), "w5100");
    let busy: Vec<Master> =
        (1..=3).map(|i| Master::start(&board, &format!("busy {i}"), "--seconds 20 --interval 0.02")).collect();
    let victim = Master::start(&board, "killed", "--seconds 60 --interval 0.02");
    for m in busy.iter().chain([&victim]) {
        m.wait_for("first answer", Duration::from_secs(10), &board);
    }
    victim.signal(Signal::SIGKILL);
    let killed = victim.finish(Duration::from_secs(5));
    let after_kill = Master::start(&board, "after the kill", "--seconds 2 --timeout 5 --interval 0.02")
        .finish(Duration::from_secs(20));
    let frozen = Master::start(&board, "frozen", "--seconds 60 --interval 0.02");
    frozen.wait_for("first answer", Duration::from_secs(10), &board);
    let evicted_before = board.count("reset by the chip");
    frozen.signal(Signal::SIGSTOP);
    let after_freeze = Master::start(&board, "after the freeze", "--seconds 4 --timeout 6 --interval 0.02")
        .finish(Duration::from_secs(20));
    let evicted = board.count("reset by the chip") - evicted_before;
    frozen.signal(Signal::SIGKILL);
    let frozen = frozen.finish(Duration::from_secs(5));
    let busy: Vec<Summary> = busy.into_iter().map(|m| m.finish(Duration::from_secs(30))).collect();
    for s in busy.iter().chain([&killed, &after_kill, &frozen, &after_freeze]) {
        println!("{}", s.line());
    }
    let all: Vec<&Summary> = busy.iter().chain([&killed, &after_kill, &frozen, &after_freeze]).collect();
    let fail = |why: &str| -> String { format!("{why}\n{}", transcript(&report(&all), &board)) };
    assert!(busy.iter().all(|s| s.all_answered(17) && s.connections == 1), "{}", fail("a busy master lost out"));
    assert!(
        after_kill.answered > 0 && after_kill.failed == 0,
        "{}",
        fail("the killed master's socket did not come back")
    );
    assert!(
        after_freeze.answered > 0 && after_freeze.failed == 0 && evicted == 1,
        "{}",
        fail("the frozen master's socket was not taken back")
    );
    assert_eq!(board.count("refused"), 0, "{}", fail("a connection was refused"));
}

// ------------------------------------------------------------------------------------------
// libmodbus's own unit-test-client

/// The checks of libmodbus 3.1.6's unit-test-client.c (by line) that only libmodbus's own
/// unit-test-server passes, and why: it misbehaves on purpose there.
const ONLY_LIBMODBUS_SERVER: [Check; 5] = [
    (519, "3/3 read 0x171: its server answers with a wrong transaction id on purpose; ours answers right"),
    (590, "5/6 read 0x172 with a 0.2 s timeout: its server sleeps 0.5 s first; ours answers at once"),
    (623, "1/2 read 0x173 with a 3 ms byte timeout: its server sends a byte every 5 ms; ours sends the reply whole"),
    (650, "bad response: its server answers a read of 2 registers with 1 on purpose; ours with 2"),
    (659, "manual exception: its server answers 0x170 with exception 06 (busy); ours reads the register"),
];

#[test]
fn libmodbus_unit_test_client_against_libmodbus_map_w5100() {
    let _one = serialise();
    let client = libmodbus::program("unit-test-client-all");
    let firmware = chip_firmware("atmega328p-w5100-libmodbus", "libmodbus_map");
    let reference = libmodbus::reference(&client);

    // The firmware, its port 502 on 127.0.0.1:1502, where the client talks.
    let board = Board::on_port(&firmware, "w5100", 1502);
    let run = Run::tcp(&client);
    println!("{}", run.out);
    println!(
        "libmodbus 3.1.6 unit-test-client tcp against examples/libmodbus_map.rs: {} checks OK, {} failed, {:.1} s",
        run.passed,
        run.failed.len(),
        run.took.as_secs_f64()
    );
    if let Err(why) = libmodbus::judge(&run, &reference, &ONLY_LIBMODBUS_SERVER, &[]) {
        panic!("unit-test-client against libmodbus_map: {why}\n{}", transcript(&run.out, &board));
    }
}
