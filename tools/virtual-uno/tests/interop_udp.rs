//! Modbus UDP clients nobody here wrote against the firmware's server with feature `udp`
//! (`examples/tcp_server.rs` as `make tcp-firmware` builds it: UDP on the chip's socket 3),
//! on the virtual Uno with its virtual shield bridged to host ports (`--udp 502:PORT`):
//! pymodbus's UDP client (`demo/pymodbus_udp_check.py`: every function code and exception,
//! then several clients at once, each from its own port), and a raw socket for what no
//! library sends (datagrams whose length is not their header's, an empty one). Each test
//! starts its own board (one at a time) and fails with the client's transcript and the
//! board's log.
//!
//! And the gateway (`examples/tcp_gateway.rs` with the feature) on the virtual line
//! (`virtual-line --board gateway=… udp=502:PORT`), pymodbus's serial server behind it.
//!
//! Needs `make tcp-firmware` and `make setup`'s Python (`INTEROP_PYTHON`, pymodbus 3.0, and
//! python3-serial-asyncio for the serial server).

mod common;

use common::{python, run, serialise, workspace, Spawned};

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use uno_sim::built::{built, target_dir};

/// examples/tcp_server.rs with Modbus UDP, for `shield` (`w5100`, `w5500`).
fn udp_server(shield: &str) -> PathBuf {
    let elf = target_dir()
        .join("chips")
        .join(format!("atmega328p-{shield}-udp"))
        .join("avr-none/release/examples/tcp_server.elf");
    built(elf, "make tcp-firmware")
}

/// A running `virtual-uno` with its chip's UDP port 502 on a port of 127.0.0.1.
struct Board {
    process: Spawned,
    /// Where the chip's UDP port 502 is.
    port: u16,
}

impl Board {
    fn start(firmware: &Path, shield: &str) -> Board {
        let process = Spawned::start(
            Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
                .args(["--no-stdin", "--wiznet", shield, "--udp", "502:0", "--messages"])
                .arg(firmware),
        );
        let port = process.port_after("udp: 127.0.0.1:", "the firmware's UDP socket");
        Board { process, port }
    }
}

fn transcript(client: &str, board: &Board) -> String {
    format!("--- client ---\n{client}--- virtual-uno ---\n{}", board.process.log())
}

fn pymodbus(board: &Board, args: &[&str]) {
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("demo/pymodbus_udp_check.py")).arg(args[0]).args(["127.0.0.1", &board.port.to_string()]);
    cmd.args(&args[1..]);
    let (ok, out) = run(&mut cmd, Duration::from_secs(90));
    println!("{out}");
    assert!(ok, "pymodbus_udp_check.py {} failed (python: {})\n{}", args[0], python(), transcript(&out, board));
}

#[test]
fn pymodbus_udp_client_runs_every_function_code_and_exceptions_w5100() {
    let _one = serialise();
    let board = Board::start(&udp_server("w5100"), "w5100");
    pymodbus(&board, &["check"]);
}

#[test]
fn pymodbus_udp_client_runs_every_function_code_and_exceptions_w5500() {
    let _one = serialise();
    let board = Board::start(&udp_server("w5500"), "w5500");
    pymodbus(&board, &["check"]);
}

#[test]
fn pymodbus_udp_clients_at_once_each_get_their_own_answers() {
    let _one = serialise();
    let board = Board::start(&udp_server("w5100"), "w5100");
    pymodbus(&board, &["senders", "--clients", "4", "--rounds", "50"]);
}

/// FC 3, one register from `start`, as an ADU.
fn read(transaction: u16, start: u8) -> Vec<u8> {
    vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, 6, 1, 0x03, 0, start, 0, 1]
}

#[test]
fn datagrams_that_are_no_adu_get_no_answer_and_the_next_one_does() {
    let _one = serialise();
    let board = Board::start(&udp_server("w5100"), "w5100");
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.connect(("127.0.0.1", board.port)).unwrap();
    socket.set_read_timeout(Some(Duration::from_millis(1500))).unwrap();
    let mut longer = read(0x0101, 0);
    longer.push(0);
    let mut protocol = read(0x0102, 0);
    protocol[3] = 1;
    let header_only = read(0x0103, 0)[..7].to_vec();
    for bad in [&longer, &protocol, &header_only, &Vec::new(), &read(0x0104, 0)[..11].to_vec()] {
        socket.send(bad).unwrap();
    }
    socket.send(&read(0x0200, 2)).unwrap();
    let mut buf = [0; 300];
    let n = socket.recv(&mut buf).unwrap_or_else(|e| panic!("no answer: {e}\n{}", transcript("", &board)));
    assert_eq!(buf[..n], [0x02, 0x00, 0, 0, 0, 5, 1, 0x03, 2, 0, 0], "{}", transcript("", &board));
    assert!(socket.recv(&mut buf).is_err(), "one answer only\n{}", transcript("", &board));
}

/// examples/tcp_gateway.rs with Modbus UDP (W5100).
fn udp_gateway() -> PathBuf {
    built(
        target_dir().join("chips/atmega328p-tcp-gateway-udp/avr-none/release/examples/tcp_gateway.elf"),
        "make tcp-firmware",
    )
}

#[test]
fn pymodbus_udp_client_through_the_gateway_to_pymodbus_serial_server() {
    let _one = serialise();
    let tty = format!("/tmp/ttyGW-udp-{}", std::process::id());
    let process = Spawned::start(
        Command::new(env!("CARGO_BIN_EXE_virtual-line"))
            .arg("--no-stdin")
            .arg("--board")
            .arg(format!("gateway={}", udp_gateway().display()))
            .args(["de=3", "wiznet=w5100", "udp=502:0", "watch=none", "--pty", &format!("plant={tty}")]),
    );
    let port = process.port_after("gateway udp: 127.0.0.1:", "the gateway's UDP socket");
    let slave =
        Spawned::start(Command::new(python()).arg(workspace().join("demo/plant_slave.py")).args([&tty, "--unit", "3"]));
    assert!(slave.wait_for("plant_slave: unit 3 on", Duration::from_secs(10)), "{}", slave.log());
    let board = Board { process, port };
    pymodbus(&board, &["gateway"]);
}
