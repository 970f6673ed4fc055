//! The firmware's link and chip health against mbpoll (libmodbus underneath) on the virtual
//! Uno with its virtual W5500 (`--wiznet w5500 --tcp 502:PORT`): the faults typed into the
//! board's `--control` FIFO while it runs (`link down`, `link up`, `chip reset`,
//! `chip hang ff`, `chip unhang`), mbpoll answered again after each, the time it took printed.
//! Wall-clock times: the simulation is paced to real time.
//!
//! Needs `make tcp-firmware` (examples/tcp_server.rs for the W5500) and mbpoll (`make setup`);
//! `make interop` runs it.

mod common;

use common::{serialise, Spawned};

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};

/// examples/tcp_server.rs for the Uno with a W5500, as `make tcp-firmware` builds it.
fn tcp_server() -> PathBuf {
    let elf = target_dir().join("chips/atmega328p-w5500/avr-none/release/examples/tcp_server.elf");
    built(elf, "make tcp-firmware")
}

/// One mbpoll read of 30001 (the seconds the main loop counted), a 0.5 s response timeout:
/// whether it was answered.
fn answered(port: u16) -> bool {
    Command::new("mbpoll")
        .args(["-m", "tcp", "-p", &port.to_string(), "-a", "1", "-t", "3", "-r", "1", "-c", "1", "-1", "-o", "0.5"])
        .arg("127.0.0.1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Polls every 100 ms until mbpoll is answered (at most `limit`); the time it took.
fn until_answered(port: u16, limit: Duration, what: &str, board: &Spawned) -> Duration {
    let start = Instant::now();
    while !answered(port) {
        assert!(start.elapsed() < limit, "{what}: mbpoll not answered within {limit:?}\n{}", board.log());
        thread::sleep(Duration::from_millis(100));
    }
    start.elapsed()
}

/// Writes a command line into the board's control FIFO.
fn command(fifo: &Path, line: &str) {
    let mut f = OpenOptions::new().write(true).open(fifo).expect("the control FIFO");
    writeln!(f, "{line}").unwrap();
}

#[test]
fn mbpoll_is_answered_again_after_a_lost_link_a_chip_reset_and_a_hung_chip_w5500() {
    let _one = serialise();
    let fifo = std::env::temp_dir().join(format!("virtual-uno-health-{}", std::process::id()));
    let board = Spawned::start(
        Command::new(env!("CARGO_BIN_EXE_virtual-uno"))
            .args(["--no-stdin", "--control"])
            .arg(&fifo)
            .args(["--wiznet", "w5500", "--tcp", "502:0"])
            .arg(tcp_server()),
    );
    let port = board.port_after("tcp: 127.0.0.1:", "the firmware");
    until_answered(port, Duration::from_secs(10), "at start", &board);
    for (fault, end, hold) in [("link down", "link up", 5), ("chip hang ff", "chip unhang", 3), ("chip reset", "", 0)] {
        command(&fifo, fault);
        assert!(board.wait_for(&format!("set: {fault}"), Duration::from_secs(2)), "{fault}: not taken");
        if hold > 0 {
            thread::sleep(Duration::from_secs(hold));
            assert!(!answered(port), "{fault}: answered meanwhile");
            command(&fifo, end);
            assert!(board.wait_for(&format!("set: {end}"), Duration::from_secs(2)), "{end}: not taken");
        }
        let took = until_answered(port, Duration::from_secs(5), fault, &board);
        eprintln!(
            "mbpoll (w5500), {fault} for {hold} s: answered again {:.2} s after {}",
            took.as_secs_f64(),
            if hold > 0 { end } else { fault }
        );
    }
}
