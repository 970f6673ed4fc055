//! The bridge between real loopback sockets and a chip whose sockets the test opens and
//! serves itself (no firmware): hand-over, bytes both ways, closes, resets, refusals.

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

use super::regs::{cmd, mode, sn, state};
use super::{Bridge, BridgeEvent, Mapping, W5x00, Wiznet};

/// A chip with socket 0 listening on 502, a bridge to an ephemeral host port, a client.
struct Rig {
    chip: W5x00,
    bridge: Bridge,
    events: Vec<BridgeEvent>,
}

fn listen(chip: &mut W5x00, n: usize) {
    chip.sockets[n].write(sn::MR, mode::TCP);
    chip.sockets[n].write(sn::PORT, 0x01);
    chip.sockets[n].write(sn::PORT + 1, 0xF6);
    chip.command(n, cmd::OPEN);
    chip.command(n, cmd::LISTEN);
}

impl Rig {
    fn new() -> Rig {
        let mut chip = W5x00::new(Wiznet::W5100);
        listen(&mut chip, 0);
        let bridge = Bridge::bind(&[Mapping { chip_port: 502, host_port: 0 }]).unwrap().with_patience(1_000_000);
        Rig { chip, bridge, events: Vec::new() }
    }

    fn client(&self) -> TcpStream {
        let s = TcpStream::connect(self.bridge.ports()[0].1).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        s
    }

    /// Polls (the chip's clock 4000 cycles on each time) until `done`, for at most 2 s.
    fn until(&mut self, mut done: impl FnMut(&mut Rig) -> bool) {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(2) {
            let now = self.chip.now() + 4000;
            self.chip.advance(now);
            let events = self.bridge.poll(&mut self.chip);
            self.events.extend(events);
            if done(self) {
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        panic!("not done; events {:?}", self.events);
    }

    /// The firmware's side: socket 0's received bytes, taken with RECV.
    fn receive(&mut self) -> Vec<u8> {
        let s = &self.chip.sockets[0];
        let (rd, len) = (s.reg16(sn::RX_RD), s.rx_received());
        let rx = &self.chip.rx_mem[self.chip.rx_layout[0].clone()];
        let data = (0..len).map(|i| rx[usize::from(rd.wrapping_add(i)) & (rx.len() - 1)]).collect();
        let rd = rd.wrapping_add(len).to_be_bytes();
        self.chip.sockets[0].write(sn::RX_RD, rd[0]);
        self.chip.sockets[0].write(sn::RX_RD + 1, rd[1]);
        self.chip.command(0, cmd::RECV);
        data
    }

    /// The firmware's side: `data` sent on socket 0.
    fn send(&mut self, data: &[u8]) {
        let wr = self.chip.sockets[0].tx_wr();
        let range = self.chip.tx_layout[0].clone();
        for (i, &b) in data.iter().enumerate() {
            self.chip.tx_mem[range.start + (usize::from(wr) + i) % range.len()] = b;
        }
        let wr = wr.wrapping_add(data.len() as u16).to_be_bytes();
        self.chip.sockets[0].write(sn::TX_WR, wr[0]);
        self.chip.sockets[0].write(sn::TX_WR + 1, wr[1]);
        self.chip.command(0, cmd::SEND);
    }
}

fn read_some(client: &mut TcpStream) -> Result<Vec<u8>, ErrorKind> {
    let mut buf = [0; 4096];
    match client.read(&mut buf) {
        Ok(k) => Ok(buf[..k].to_vec()),
        Err(e) => Err(e.kind()),
    }
}

#[test]
fn bytes_go_both_ways_and_the_listening_port_is_announced() {
    let mut rig = Rig::new();
    let host = rig.bridge.ports()[0].1;
    let mut client = rig.client();
    client.write_all(b"request").unwrap();
    let mut got = Vec::new();
    rig.until(|r| {
        got.extend(r.receive());
        got.len() >= 7
    });
    assert_eq!(got, b"request");
    assert_eq!(rig.events[0], BridgeEvent::Listening { chip_port: 502, host });
    assert!(matches!(rig.events[1], BridgeEvent::Connected { socket: 0, .. }));
    rig.send(b"reply");
    let mut back = Vec::new();
    rig.until(|_| {
        back.extend(read_some(&mut client).unwrap_or_default());
        back.len() >= 5
    });
    assert_eq!(back, b"reply");
}

#[test]
fn a_client_waits_for_a_listening_socket_then_is_refused() {
    let mut rig = Rig::new();
    let _first = rig.client();
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    let mut second = rig.client();
    // within the patience (1 000 000 cycles) it waits; socket 1 listening takes it
    rig.until(|r| r.chip.now() > 200_000);
    assert_eq!(rig.bridge.clients(), 2);
    listen(&mut rig.chip, 1);
    rig.until(|r| r.chip.status(1) == state::ESTABLISHED);
    // a third finds nobody listening and is refused once the patience runs out
    let mut third = rig.client();
    rig.until(|r| r.events.iter().any(|e| matches!(e, BridgeEvent::Refused { .. })));
    assert_eq!(read_some(&mut third), Err(ErrorKind::ConnectionReset));
    assert_eq!(read_some(&mut second), Err(ErrorKind::WouldBlock), "the second is still connected");
}

#[test]
fn the_clients_close_is_a_fin_and_the_firmwares_discon_closes_the_client() {
    let mut rig = Rig::new();
    let mut client = rig.client();
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    client.shutdown(Shutdown::Write).unwrap();
    rig.until(|r| r.chip.status(0) == state::CLOSE_WAIT);
    rig.chip.command(0, cmd::DISCON);
    rig.until(|r| r.bridge.clients() == 0);
    assert_eq!(read_some(&mut client), Ok(Vec::new()), "EOF");
    assert!(matches!(rig.events.last(), Some(BridgeEvent::Closed { how: "closed", .. })), "{:?}", rig.events);
}

#[test]
fn the_firmwares_close_resets_the_client() {
    let mut rig = Rig::new();
    let mut client = rig.client();
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    rig.chip.command(0, cmd::CLOSE);
    rig.until(|r| r.bridge.clients() == 0);
    assert_eq!(read_some(&mut client), Err(ErrorKind::ConnectionReset));
}

#[test]
fn the_clients_reset_resets_the_socket() {
    let mut rig = Rig::new();
    let client = rig.client();
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    super::bridge::reset_for_tests(&client);
    drop(client);
    rig.until(|r| r.chip.status(0) == state::CLOSED);
    assert!(rig.chip.connection(0).unwrap().reset_by_peer());
}

#[test]
fn a_client_that_does_not_read_fills_the_chips_tx_buffer() {
    let mut rig = Rig::new();
    let client = rig.client();
    client.set_nonblocking(true).unwrap();
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    // far more than the client's socket buffers and the bridge's 64 KB hold
    let chunk = [0x55u8; 1024];
    let mut stuck = false;
    for _ in 0..20_000 {
        if rig.chip.sockets[0].tx_free() >= 1024 {
            rig.send(&chunk);
        }
        rig.events.extend(rig.bridge.poll(&mut rig.chip));
        if rig.chip.tx_pending(0) >= 1024 && rig.chip.sockets[0].tx_free() < 1024 {
            stuck = true;
            break;
        }
    }
    assert!(stuck, "the TX buffer never filled");
    drop(client);
}

#[test]
fn mappings_parse() {
    assert_eq!("502:1502".parse(), Ok(Mapping { chip_port: 502, host_port: 1502 }));
    assert_eq!("80".parse(), Ok(Mapping { chip_port: 80, host_port: 80 }));
    assert!("502:".parse::<Mapping>().is_err());
    assert!("x".parse::<Mapping>().is_err());
}

/// Socket 0 of `chip` connecting to `ip`:`port` (OPEN, Sn_DIPR, Sn_DPORT, CONNECT).
fn dial(chip: &mut W5x00, ip: [u8; 4], port: u16) {
    chip.sockets[0].write(sn::MR, mode::TCP);
    chip.command(0, cmd::OPEN);
    for (i, b) in ip.iter().enumerate() {
        chip.sockets[0].write(sn::DIPR + i as u16, *b);
    }
    chip.sockets[0].write(sn::DPORT, (port >> 8) as u8);
    chip.sockets[0].write(sn::DPORT + 1, port as u8);
    chip.command(0, cmd::CONNECT);
}

#[test]
fn a_firmware_connection_to_a_mapped_port_reaches_the_host_server_both_ways() {
    let server = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let host_port = server.local_addr().unwrap().port();
    let mut chip = W5x00::new(Wiznet::W5100);
    dial(&mut chip, [192, 168, 1, 10], 502);
    assert_eq!(chip.connecting().len(), 1);
    let bridge = Bridge::bind(&[]).unwrap().with_outgoing(&[Mapping { chip_port: 502, host_port }]);
    let mut rig = Rig { chip, bridge, events: Vec::new() };
    rig.until(|r| r.chip.status(0) == state::ESTABLISHED);
    assert!(matches!(rig.events[0], BridgeEvent::Dialed { socket: 0, .. }), "{:?}", rig.events);
    let (mut accepted, _) = server.accept().unwrap();
    accepted.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    rig.send(b"request");
    rig.until(|r| r.chip.tx_pending(0) == 0);
    let mut got = [0; 7];
    accepted.read_exact(&mut got).unwrap();
    assert_eq!(&got, b"request");
    accepted.write_all(b"reply").unwrap();
    rig.until(|r| r.chip.sockets[0].rx_received() == 5);
    assert_eq!(rig.receive(), b"reply");
    // The server closes: the socket sees the FIN.
    drop(accepted);
    rig.until(|r| r.chip.status(0) == state::CLOSE_WAIT);
}

#[test]
fn a_firmware_connection_to_a_port_where_nothing_listens_is_closed_at_once() {
    let free = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let host_port = free.local_addr().unwrap().port();
    drop(free);
    let mut chip = W5x00::new(Wiznet::W5100);
    dial(&mut chip, [10, 0, 0, 1], 502);
    let bridge = Bridge::bind(&[]).unwrap().with_outgoing(&[Mapping { chip_port: 502, host_port }]);
    let mut rig = Rig { chip, bridge, events: Vec::new() };
    rig.until(|r| r.chip.status(0) == state::CLOSED);
    assert!(matches!(rig.events[0], BridgeEvent::DialRefused { socket: 0, .. }), "{:?}", rig.events);
    assert_ne!(rig.chip.interrupts(0) & 0x08, 0, "TIMEOUT");
}

#[test]
fn a_firmware_connection_to_an_unmapped_port_stays_unanswered() {
    let mut chip = W5x00::new(Wiznet::W5100);
    dial(&mut chip, [10, 0, 0, 1], 503);
    let mut bridge = Bridge::bind(&[]).unwrap().with_outgoing(&[Mapping { chip_port: 502, host_port: 1 }]);
    for _ in 0..10 {
        assert!(bridge.poll(&mut chip).is_empty());
    }
    assert_eq!(chip.status(0), state::SYNSENT);
}

#[test]
fn with_traffic_the_bytes_of_each_way_are_reported_as_they_pass() {
    let mut rig = Rig::new();
    rig.bridge = Bridge::bind(&[Mapping { chip_port: 502, host_port: 0 }]).unwrap().with_traffic();
    let mut client = rig.client();
    client.write_all(b"request").unwrap();
    let mut got = Vec::new();
    rig.until(|r| {
        got.extend(r.receive());
        got.len() >= 7
    });
    rig.send(b"reply");
    let mut back = Vec::new();
    rig.until(|_| {
        back.extend(read_some(&mut client).unwrap_or_default());
        back.len() >= 5
    });
    let moved = |way: bool| -> Vec<u8> {
        rig.events
            .iter()
            .filter_map(|e| match e {
                BridgeEvent::Bytes { socket: 0, to_chip, bytes, .. } if *to_chip == way => Some(bytes.clone()),
                _ => None,
            })
            .flatten()
            .collect()
    };
    assert_eq!((moved(true), moved(false)), (b"request".to_vec(), b"reply".to_vec()));
    // Without it, none.
    let mut quiet = Rig::new();
    let mut client = quiet.client();
    client.write_all(b"x").unwrap();
    quiet.until(|r| !r.receive().is_empty());
    assert!(!quiet.events.iter().any(|e| matches!(e, BridgeEvent::Bytes { .. })), "{:?}", quiet.events);
}

/// A chip with socket 0 open in UDP mode on 502, its UDP port bridged to an ephemeral host
/// port, with the traffic reported.
fn udp_rig() -> (Rig, std::net::UdpSocket) {
    let mut chip = W5x00::new(Wiznet::W5500);
    chip.sockets[0].write(sn::MR, mode::UDP);
    chip.sockets[0].write(sn::PORT, 0x01);
    chip.sockets[0].write(sn::PORT + 1, 0xF6);
    chip.command(0, cmd::OPEN);
    let bridge = Bridge::bind(&[]).unwrap().with_udp(&[Mapping { chip_port: 502, host_port: 0 }]).unwrap();
    let rig = Rig { chip, bridge: bridge.with_traffic(), events: Vec::new() };
    let client = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    client.connect(rig.bridge.udp_ports()[0].1).unwrap();
    client.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    (rig, client)
}

impl Rig {
    /// The firmware's side of UDP: `data` sent on socket 0 to `to`.
    fn send_to(&mut self, to: std::net::SocketAddrV4, data: &[u8]) {
        for (i, b) in to.ip().octets().into_iter().enumerate() {
            self.chip.sockets[0].write(sn::DIPR + i as u16, b);
        }
        self.chip.sockets[0].write(sn::DPORT, (to.port() >> 8) as u8);
        self.chip.sockets[0].write(sn::DPORT + 1, to.port() as u8);
        self.send(data);
    }
}

#[test]
fn datagrams_go_to_the_udp_socket_and_its_answers_to_their_sender() {
    let (mut rig, client) = udp_rig();
    let other = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    other.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    let me = match client.local_addr().unwrap() {
        std::net::SocketAddr::V4(a) => a,
        a => panic!("{a}"),
    };
    let them = match other.local_addr().unwrap() {
        std::net::SocketAddr::V4(a) => a,
        a => panic!("{a}"),
    };
    client.send(b"one").unwrap();
    other.send_to(b"", rig.bridge.udp_ports()[0].1).unwrap();
    let mut got = Vec::new();
    rig.until(|r| {
        got.extend(r.receive());
        got.len() >= 11 + 8
    });
    let header = |from: std::net::SocketAddrV4, len: u16| {
        let mut h = from.ip().octets().to_vec();
        h.extend(from.port().to_be_bytes());
        h.extend(len.to_be_bytes());
        h
    };
    let mut want = header(me, 3);
    want.extend(b"one");
    want.extend(header(them, 0));
    assert_eq!(got, want, "each behind its header with its sender");
    let host = rig.bridge.udp_ports()[0].1;
    assert_eq!(rig.events[0], BridgeEvent::UdpOpen { chip_port: 502, host });
    rig.send_to(them, b"to them");
    rig.send_to(me, b"to me");
    let mut back = [Vec::new(), Vec::new()];
    rig.until(|_| {
        let mut buf = [0; 64];
        if let Ok(k) = client.recv(&mut buf) {
            back[0] = buf[..k].to_vec();
        }
        if let Ok((k, from)) = other.recv_from(&mut buf) {
            assert_eq!(from, host, "from the bridged port");
            back[1] = buf[..k].to_vec();
        }
        !back[0].is_empty() && !back[1].is_empty()
    });
    assert_eq!(back, [b"to me".to_vec(), b"to them".to_vec()]);
    let moved: Vec<_> = rig
        .events
        .iter()
        .filter_map(|e| match e {
            BridgeEvent::Datagram { to_chip, bytes, .. } => Some((*to_chip, bytes.len())),
            _ => None,
        })
        .collect();
    assert_eq!(moved, [(true, 3), (true, 0), (false, 7), (false, 5)]);
}

#[test]
fn a_datagram_with_no_socket_or_no_room_is_dropped_and_reported() {
    let (mut rig, client) = udp_rig();
    client.send(&[1; 2100]).unwrap();
    rig.until(|r| r.events.iter().any(|e| matches!(e, BridgeEvent::UdpDropped { why: "no room in the socket", .. })));
    assert_eq!(rig.receive(), b"", "nothing of it landed");
    rig.chip.command(0, cmd::CLOSE);
    client.send(b"x").unwrap();
    rig.until(|r| {
        r.events.iter().any(|e| matches!(e, BridgeEvent::UdpDropped { why: "no UDP socket on the port", .. }))
    });
    let far = std::net::SocketAddrV4::new(std::net::Ipv4Addr::new(192, 0, 2, 1), 502);
    rig.chip.command(0, cmd::OPEN);
    rig.send_to(far, b"far");
    rig.until(|r| r.events.iter().any(|e| matches!(e, BridgeEvent::UdpDropped { why: "sent beyond 127.0.0.1", .. })));
}
