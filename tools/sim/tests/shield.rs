//! The Ethernet shield on the simulated board: a W5100 or W5500 ([`uno_sim::wiznet`]) on the
//! SPI port, driven by a TCP echo server (tests/fw/wiz.c), reached through its network side and
//! through the host TCP bridge.

mod common;

use std::io::{ErrorKind, Read, Write};
use std::net::{Ipv4Addr, SocketAddrV4, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use common::{compile, scratch};
use uno_sim::wiznet::regs::{int, state};
use uno_sim::wiznet::{Bridge, BridgeEvent, Mapping};
use uno_sim::{us_to_cycles, Options, Uno, Wiznet};

fn echo_elf(chip: Wiznet) -> PathBuf {
    static ELFS: Mutex<Vec<(Wiznet, PathBuf)>> = Mutex::new(Vec::new());
    let mut elfs = ELFS.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((_, path)) = elfs.iter().find(|(c, _)| *c == chip) {
        return path.clone();
    }
    let out = scratch(&format!("wiz-{chip}.elf"));
    let defines: Vec<String> = if chip == Wiznet::W5500 { vec!["W5500".into()] } else { vec![] };
    compile(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fw/wiz.c"), "atmega328p", &defines, &out);
    elfs.push((chip, out.clone()));
    out
}

/// The echo server on a board with `chip`, run until its sockets listen.
fn board(chip: Wiznet) -> Uno {
    let mut uno = Uno::load_with(echo_elf(chip), Options::new().wiznet(chip)).unwrap();
    while uno.read_symbol("ready").unwrap() != [1] {
        assert!(uno.now() < us_to_cycles(100_000), "the firmware never got ready");
        uno.run_for(1000).unwrap();
    }
    uno
}

fn peer() -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10), 40000)
}

#[test]
fn the_firmware_reads_the_chips_registers_over_spi() {
    assert_eq!(board(Wiznet::W5100).read_symbol("version").unwrap(), [0x55], "W5100 TMSR after reset");
    assert_eq!(board(Wiznet::W5500).read_symbol("version").unwrap(), [0x04], "W5500 VERSIONR");
}

#[test]
fn every_socket_listens_on_port_7() {
    for chip in [Wiznet::W5100, Wiznet::W5500] {
        let uno = board(chip);
        let w = uno.wiznet().unwrap();
        assert_eq!(w.listening_ports(), [7], "{chip}");
        assert!((0..4).all(|n| w.status(n) == state::LISTEN), "{chip}");
        assert_eq!(uno.wiznet_cs(), Some(('B', 2)));
    }
}

fn echo_once(chip: Wiznet) {
    let mut uno = board(chip);
    let n = uno.wiznet_mut().unwrap().connect(7, peer()).unwrap();
    uno.run_for(us_to_cycles(500)).unwrap();
    assert_eq!(uno.wiznet().unwrap().status(n), state::ESTABLISHED);
    assert_eq!(uno.wiznet_mut().unwrap().deliver(n, b"hello"), 5);
    uno.run_for(us_to_cycles(2000)).unwrap();
    let w = uno.wiznet_mut().unwrap();
    assert_eq!(w.take_sent(n), b"hello", "{chip}");
    let sends = w.sends(n);
    assert_eq!(sends.len(), 1);
    let latency = sends[0].cycle - w.last_delivery(n).unwrap();
    assert!(latency > 100 && latency < us_to_cycles(2000), "{chip}: {latency} cycles");
    assert_eq!(w.interrupts(n) & int::SEND_OK, 0, "the firmware cleared SEND_OK");
}

#[test]
fn a_w5100_echoes() {
    echo_once(Wiznet::W5100);
}

#[test]
fn a_w5500_echoes() {
    echo_once(Wiznet::W5500);
}

#[test]
fn a_request_split_across_segments_is_echoed_whole() {
    let mut uno = board(Wiznet::W5100);
    let n = uno.wiznet_mut().unwrap().connect(7, peer()).unwrap();
    let t = uno.now();
    let w = uno.wiznet_mut().unwrap();
    w.deliver_at(n, b"abc", t + us_to_cycles(300));
    w.deliver_at(n, b"defg", t + us_to_cycles(900));
    uno.run_for(us_to_cycles(600)).unwrap();
    assert_eq!(uno.wiznet().unwrap().queued(n), 4, "the second piece waits for its time");
    uno.run_for(us_to_cycles(3000)).unwrap();
    let w = uno.wiznet_mut().unwrap();
    assert_eq!(w.take_sent(n), b"abcdefg");
    assert_eq!(w.last_delivery(n), Some(t + us_to_cycles(900)), "the last piece landed when due");
}

#[test]
fn the_peers_fin_is_answered_with_the_firmwares() {
    let mut uno = board(Wiznet::W5500);
    let n = uno.wiznet_mut().unwrap().connect(7, peer()).unwrap();
    uno.run_for(us_to_cycles(300)).unwrap();
    uno.wiznet_mut().unwrap().peer_fin(n);
    uno.run_for(us_to_cycles(1000)).unwrap();
    let w = uno.wiznet().unwrap();
    let conn = w.connection(n).unwrap();
    assert!(conn.fin_from_chip() && conn.closed(), "{conn:?}");
    assert_eq!(w.status(n), state::LISTEN, "the firmware listens again");
}

#[test]
fn a_board_reset_resets_the_chip_and_its_connections() {
    let mut uno = board(Wiznet::W5100);
    let n = uno.wiznet_mut().unwrap().connect(7, peer()).unwrap();
    uno.run_for(us_to_cycles(300)).unwrap();
    uno.hard_reset(uno_sim::ResetCause::External);
    let w = uno.wiznet().unwrap();
    assert!(w.connection(n).unwrap().reset_by_chip());
    assert_eq!(w.status(n), state::CLOSED);
}

/// Runs the board and the bridge until `done` says so (at most 200 ms simulated).
fn bridge_until(
    uno: &mut Uno,
    bridge: &mut Bridge,
    events: &mut Vec<BridgeEvent>,
    mut done: impl FnMut(&Bridge) -> bool,
) {
    for _ in 0..800 {
        uno.run_for(4000).unwrap();
        events.extend(bridge.poll(uno.wiznet_mut().unwrap()));
        if done(bridge) {
            return;
        }
    }
    panic!("not done; events {events:?}");
}

#[test]
fn a_host_client_reaches_the_echo_server_through_the_bridge() {
    let mut uno = board(Wiznet::W5100);
    let mut bridge = Bridge::bind(&[Mapping { chip_port: 7, host_port: 0 }]).unwrap();
    let host = bridge.ports()[0].1;
    let mut events = bridge.poll(uno.wiznet_mut().unwrap());
    assert_eq!(events, [BridgeEvent::Listening { chip_port: 7, host }]);
    let mut client = TcpStream::connect(host).unwrap();
    client.set_nonblocking(true).unwrap();
    client.write_all(b"ping").unwrap();
    let mut got = Vec::new();
    bridge_until(&mut uno, &mut bridge, &mut events, |_| {
        let mut buf = [0; 16];
        match client.read(&mut buf) {
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) => assert_eq!(e.kind(), ErrorKind::WouldBlock),
        }
        got.len() >= 4
    });
    assert_eq!(got, b"ping");
    assert!(matches!(events[1], BridgeEvent::Connected { socket: 0, .. }), "{events:?}");

    // the client closes: the firmware answers the FIN with its own, the client reads EOF
    client.shutdown(std::net::Shutdown::Write).unwrap();
    let mut eof = false;
    bridge_until(&mut uno, &mut bridge, &mut events, |bridge| {
        let mut buf = [0; 16];
        eof |= matches!(client.read(&mut buf), Ok(0));
        eof && bridge.clients() == 0
    });
    assert!(matches!(events.last(), Some(BridgeEvent::Closed { how: "closed", .. })), "{events:?}");
}
