//! The firmware's Modbus TCP client against servers nobody here wrote: pymodbus 3.0's TCP
//! server and libmodbus 3.1.6's `unit-test-server tcp`, with its replies meant to trip a
//! client (register 0x171: a reply with another transaction id; 0x172: a reply 500 ms late;
//! 0x173: a reply sent a byte every 5 ms). The firmware (`examples/tcp_client_check.rs`) runs
//! on a simulated Uno with a simulated shield, paced to real time, its connections to port
//! 502 bridged to the server's port on 127.0.0.1 (the bridge `virtual-uno --connect 502:PORT`
//! has); the test commands it and reads its outcomes through its RAM.
//!
//! Needs `make tcp-firmware` and what `make setup` installs: Debian's python3-pymodbus (3.0),
//! libmodbus's test programs (`.ci/libmodbus-tests`, under target/libmodbus-tests). `make
//! interop` runs it.

mod common;

use common::libmodbus;
use common::{collect, python, serialise, stop};

use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::{built, target_dir};
use uno_sim::wiznet::{Bridge, Mapping};
use uno_sim::{cycles_to_us, us_to_cycles, Options, Uno, Wiznet};

/// examples/tcp_client_check.rs for the Uno and `chip`, as `make tcp-firmware` builds it.
fn firmware(chip: Wiznet) -> PathBuf {
    let dir = if chip == Wiznet::W5500 { "atmega328p-tcp-client-w5500" } else { "atmega328p-tcp-client" };
    let elf = target_dir().join("chips").join(dir).join("avr-none/release/examples/tcp_client_check.elf");
    built(elf, "make tcp-firmware")
}

/// The simulated board, its connections to port 502 bridged to 127.0.0.1:`port`, paced to
/// real time.
struct Rig {
    uno: Uno,
    bridge: Bridge,
    /// The wall clock and the simulated cycle at the start.
    start: (Instant, u64),
    log: String,
}

impl Rig {
    fn new(chip: Wiznet, port: u16) -> Rig {
        let uno = Uno::load_with(firmware(chip), Options::new().wiznet(chip)).unwrap();
        let bridge = Bridge::bind(&[]).unwrap().with_outgoing(&[Mapping { chip_port: 502, host_port: port }]);
        let start = (Instant::now(), uno.now());
        Rig { uno, bridge, start, log: String::new() }
    }

    /// Simulated time since the start, in ms.
    fn ms(&self) -> f64 {
        cycles_to_us(self.uno.now() - self.start.1) / 1000.0
    }

    /// Runs `ms` of simulated time in steps of 250 µs, the bridge polled after each, never
    /// ahead of the wall clock.
    fn run(&mut self, ms: u64) {
        for _ in 0..ms * 4 {
            self.uno.run_for(us_to_cycles(250)).unwrap();
            for event in self.bridge.poll(self.uno.wiznet_mut().unwrap()) {
                self.log += &format!("{:9.1} ms {event}\n", self.ms());
            }
            let simulated = Duration::from_micros(cycles_to_us(self.uno.now() - self.start.1) as u64);
            if let Some(ahead) = simulated.checked_sub(self.start.0.elapsed()) {
                thread::sleep(ahead);
            }
        }
    }

    fn outcome(&self) -> Vec<u8> {
        self.uno.read_symbol("TCP_OUTCOME").unwrap()
    }

    /// Runs until connected, for at most `limit_ms`.
    fn until_connected(&mut self, connections: u8, limit_ms: u64) {
        for _ in 0..limit_ms {
            if self.outcome()[3] == 1 && self.outcome()[4] == connections {
                return;
            }
            self.run(1);
        }
        panic!("not connected ({connections}) in {limit_ms} ms:\n{}", self.log);
    }

    /// Reads `quantity` holding registers from `address` of unit 0xFF with a response
    /// timeout of `response_ms`, no retry; returns the kind of outcome (1 the registers,
    /// 2 timeout, 3 bad reply, 4 exception), the registers and the simulated ms it took.
    fn read(&mut self, seq: u8, address: u16, quantity: u8, response_ms: u16) -> (u8, Vec<u16>, f64) {
        let [a0, a1] = address.to_be_bytes();
        let [t0, t1] = response_ms.to_be_bytes();
        self.uno.write_symbol("TCP_COMMAND", &[seq, a0, a1, quantity, t0, t1, 0, 0xFF]).unwrap();
        let asked = self.ms();
        for _ in 0..u64::from(response_ms) + 1000 {
            let out = self.outcome();
            if out[0] == seq {
                let values = out[11..11 + 2 * usize::from(quantity)]
                    .chunks(2)
                    .map(|p| u16::from_be_bytes([p[0], p[1]]))
                    .collect();
                let took = self.ms() - asked;
                self.log +=
                    &format!("{:9.1} ms read {address:#06x} x{quantity}: kind {}, {took:.0} ms\n", self.ms(), out[1]);
                return (out[1], values, took);
            }
            self.run(1);
        }
        panic!("no outcome for {address:#x}:\n{}", self.log);
    }

    /// The counters' low bytes: requests, replies, timeouts, retries, unexpected, 2 ms on (the
    /// main loop writes them after the outcome).
    fn counters(&mut self) -> Vec<u8> {
        self.run(2);
        self.outcome()[5..10].to_vec()
    }
}

/// A child killed when dropped, a failed test's included.
struct Stopped(Child);

impl Drop for Stopped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A free port on 127.0.0.1.
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// pymodbus 3.0's TCP server on 127.0.0.1:`port`, holding registers 0–31 = 0x1000 + address.
fn pymodbus_server(port: u16, out: &Arc<Mutex<String>>) -> Child {
    let script = "
import asyncio, sys
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.server import StartAsyncTcpServer
hr = ModbusSequentialDataBlock(0, [0x1000 + i for i in range(32)])
context = ModbusServerContext(slaves=ModbusSlaveContext(hr=hr, zero_mode=True), single=True)
asyncio.run(StartAsyncTcpServer(context=context, address=('127.0.0.1', int(sys.argv[1]))))
";
    let mut child = Command::new(python())
        .args(["-c", script, &port.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 with pymodbus");
    collect(child.stdout.take().unwrap(), out.clone());
    collect(child.stderr.take().unwrap(), out.clone());
    let deadline = Instant::now() + Duration::from_secs(10);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "pymodbus did not listen in 10 s:\n{}", out.lock().unwrap());
        thread::sleep(Duration::from_millis(50));
    }
    child
}

fn pymodbus_reads_and_reconnects(chip: Wiznet) {
    let _one = serialise();
    let port = free_port();
    let out = Arc::new(Mutex::new(String::new()));
    let mut server = Stopped(pymodbus_server(port, &out));
    let mut rig = Rig::new(chip, port);
    rig.until_connected(1, 3000);
    let expected: Vec<u16> = (0..8).map(|i| 0x1010 + i).collect();
    // Every 100 ms, as examples/tcp_poll.rs does.
    let mut seq = 0u8;
    for _ in 0..20 {
        seq += 1;
        let (kind, values, took) = rig.read(seq, 0x10, 8, 1000);
        assert_eq!((kind, &values), (1, &expected), "{chip}\n{}", rig.log);
        rig.run(100u64.saturating_sub(took as u64));
    }
    // The server goes away and comes back: the client connects again by itself.
    stop(&mut server.0);
    rig.run(200);
    assert_eq!(rig.outcome()[3], 0, "{chip}: still connected after the server quit\n{}", rig.log);
    let _server = Stopped(pymodbus_server(port, &out));
    rig.until_connected(2, 3000);
    seq += 1;
    let (kind, values, _) = rig.read(seq, 0x10, 8, 1000);
    assert_eq!((kind, &values), (1, &expected), "{chip} after the reconnection\n{}", rig.log);
    let counters = rig.counters();
    println!(
        "{chip} against pymodbus: {} reads answered, {} timeouts; {}",
        counters[1],
        counters[2],
        rig.log.lines().count()
    );
    assert_eq!((counters[1], counters[2]), (21, 0), "{chip}\n{}", rig.log);
}

#[test]
fn pymodbus_tcp_server_read_every_100_ms_and_again_after_it_restarts_w5100() {
    pymodbus_reads_and_reconnects(Wiznet::W5100);
}

#[test]
fn pymodbus_tcp_server_read_every_100_ms_and_again_after_it_restarts_w5500() {
    pymodbus_reads_and_reconnects(Wiznet::W5500);
}

#[test]
fn libmodbus_unit_test_server_wrong_id_late_and_byte_by_byte_replies_w5100() {
    libmodbus_unit_test_server(Wiznet::W5100);
}

#[test]
fn libmodbus_unit_test_server_wrong_id_late_and_byte_by_byte_replies_w5500() {
    libmodbus_unit_test_server(Wiznet::W5500);
}

fn libmodbus_unit_test_server(chip: Wiznet) {
    let _one = serialise();
    let _server = libmodbus::TcpServer::start();
    let mut rig = Rig::new(chip, 1502);
    rig.until_connected(1, 3000);
    // Transaction 1: the registers at 0x160 (UT_REGISTERS_ADDRESS), zeros.
    assert_eq!(rig.read(1, 0x160, 3, 1000).0, 1, "{}", rig.log);
    // Transaction 2, 0x171: the server answers with its own next id (1), never taken.
    let (kind, _, took) = rig.read(2, 0x171, 1, 1000);
    assert_eq!(kind, 2, "the reply with another id was taken\n{}", rig.log);
    assert!(took >= 1000.0, "{took} ms");
    assert_eq!(rig.counters()[4], 1, "one ADU skipped as unexpected");
    // 0x172, answered 500 ms late: taken within a 2000 ms timeout ...
    let (kind, _, late) = rig.read(3, 0x172, 1, 2000);
    assert_eq!(kind, 1, "{}", rig.log);
    assert!((450.0..1000.0).contains(&late), "{late} ms");
    // ... timed out with a 200 ms one, and the late reply skipped when it comes.
    let (kind, _, took) = rig.read(4, 0x172, 1, 200);
    assert_eq!(kind, 2, "{}", rig.log);
    assert!((200.0..260.0).contains(&took), "{took} ms");
    rig.run(600);
    assert_eq!(rig.counters()[4], 2, "the late reply skipped");
    // 0x173: the reply a byte every 5 ms (11 bytes), reassembled.
    let (kind, values, took) = rig.read(5, 0x173, 1, 1000);
    assert_eq!((kind, values[0]), (1, 0), "{}", rig.log);
    assert!(took >= 50.0, "{took} ms: not a byte every 5 ms");
    // The stream is still in step.
    assert_eq!(rig.read(6, 0x160, 3, 1000).0, 1, "{}", rig.log);
    println!("libmodbus 3.1.6 unit-test-server tcp against the TCP client ({chip}):\n{}", rig.log);
}
