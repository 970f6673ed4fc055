//! The host TCP bridge: each port the firmware listens on, bridged to a port on the host's
//! 127.0.0.1, so that mbpoll, QModMaster or pymodbus reach the simulated chip as a real one;
//! and each port the firmware connects to ([`Bridge::with_outgoing`]), whatever the address,
//! to a port on 127.0.0.1, so that a client firmware reaches a server there (pymodbus's,
//! libmodbus's): the bridge connects when the firmware's SYN goes out, and the socket is
//! established, or closed at once when nothing listens there (as after an RST). And each UDP
//! port ([`Bridge::with_udp`]): a datagram to a host port goes to the chip's socket open in
//! UDP mode on its chip port (from the sender's address, 127.0.0.1 and its port), and each
//! datagram that socket sends to 127.0.0.1 goes from the host port to that address, so a
//! client's question is answered to it.
//!
//! Never blocks: [`Bridge::poll`], called from the simulation loop every few thousand cycles,
//! accepts new host connections, hands each to a socket in SOCK_LISTEN on its chip port (none
//! free: the newcomer waits, as a client's SYN retransmissions would, and is refused with an
//! RST after [`Bridge::with_patience`] simulated cycles), and moves bytes, FINs and RSTs both
//! ways. The host sees host time and the firmware simulated cycles (SIMAVR.md item 12): a
//! latency is measured on the chip's side ([`super::W5x00::sends`]), never here.

use std::fmt;
use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, Shutdown, SocketAddr, SocketAddrV4, TcpListener, TcpStream, UdpSocket};
use std::os::fd::AsRawFd;
use std::str::FromStr;

use super::dhcp_server::{self, DhcpServer};
use super::regs::{sn, state};
use super::W5x00;
use crate::CYCLES_PER_US;

/// A chip port bridged to a host port: `502:1502`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mapping {
    /// The port the firmware listens on (Sn_PORT).
    pub chip_port: u16,
    /// The port on 127.0.0.1 host clients connect to (0: one the system picks).
    pub host_port: u16,
}

impl FromStr for Mapping {
    type Err = String;

    /// `CHIP:HOST` (`502:1502`), or `PORT` for the same number on both sides.
    fn from_str(s: &str) -> Result<Mapping, String> {
        let bad = || format!("`{s}` is no CHIP_PORT:HOST_PORT (e.g. 502:1502)");
        let (chip, host) = s.split_once(':').unwrap_or((s, s));
        let chip_port = chip.trim().parse::<u16>().ok().filter(|&p| p != 0).ok_or_else(bad)?;
        let host_port = host.trim().parse::<u16>().map_err(|_| bad())?;
        Ok(Mapping { chip_port, host_port })
    }
}

/// Something the bridge did, to report.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BridgeEvent {
    /// The firmware listens on `chip_port` for the first time: clients can connect to `host`.
    Listening {
        /// The chip's port.
        chip_port: u16,
        /// Where host clients connect.
        host: SocketAddr,
    },
    /// A host client was handed to socket `socket`.
    Connected {
        /// The client.
        peer: SocketAddr,
        /// The chip's socket.
        socket: usize,
    },
    /// A host client waited in vain for a listening socket and was refused.
    Refused {
        /// The client.
        peer: SocketAddr,
        /// The chip port it wanted.
        chip_port: u16,
    },
    /// The firmware's socket `socket` connected to `to`, bridged to the host server at `host`.
    Dialed {
        /// The chip's socket.
        socket: usize,
        /// Where the firmware connected (Sn_DIPR, Sn_DPORT).
        to: SocketAddrV4,
        /// The host server.
        host: SocketAddr,
    },
    /// The firmware's socket `socket` connected to `to`, and nothing listened at `host`: the
    /// socket was closed as after an RST.
    DialRefused {
        /// The chip's socket.
        socket: usize,
        /// Where the firmware connected.
        to: SocketAddrV4,
        /// The host address tried.
        host: SocketAddr,
    },
    /// Bytes that went through a bridged connection (only with [`Bridge::with_traffic`]).
    Bytes {
        /// The client.
        peer: SocketAddr,
        /// The chip's socket.
        socket: usize,
        /// True from the client to the chip, false from the chip to the client.
        to_chip: bool,
        /// The bytes, as read from one side (a TCP stream: not cut at messages).
        bytes: Vec<u8>,
    },
    /// The firmware opened a UDP socket on `chip_port` for the first time: clients can send
    /// to `host`.
    UdpOpen {
        /// The chip's port.
        chip_port: u16,
        /// Where host clients send.
        host: SocketAddr,
    },
    /// A datagram that went through a UDP port (only with [`Bridge::with_traffic`]).
    Datagram {
        /// The host client (the sender, or the destination).
        peer: SocketAddr,
        /// The chip's socket.
        socket: usize,
        /// True from the client to the chip, false from the chip to the client.
        to_chip: bool,
        /// The datagram's payload.
        bytes: Vec<u8>,
    },
    /// A datagram the chip dropped or could not be given: no socket open in UDP mode on the
    /// port, no room in its RX buffer, or one the firmware sent somewhere else than 127.0.0.1.
    UdpDropped {
        /// The host client, or where the firmware sent it.
        peer: SocketAddr,
        /// The chip's port.
        chip_port: u16,
        /// Why.
        why: &'static str,
    },
    /// The bridge's DHCP server ([`Bridge::with_dhcp`]) heard a client's message and
    /// answered it (or not).
    Dhcp {
        /// The message heard (DISCOVER, REQUEST) and where it was sent.
        heard: &'static str,
        /// Its destination.
        to: SocketAddrV4,
        /// The answer (OFFER, ACK, NAK) and the address it gives, if any.
        answer: Option<(&'static str, Ipv4Addr)>,
    },
    /// A bridged connection ended.
    Closed {
        /// The client.
        peer: SocketAddr,
        /// The chip's socket.
        socket: usize,
        /// How: `"closed"`, `"reset by the chip"`, `"reset by the client"`, `"timed out"`.
        how: &'static str,
    },
}

impl fmt::Display for BridgeEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BridgeEvent::Listening { chip_port, host } => write!(f, "tcp: {host} (the chip's port {chip_port})"),
            BridgeEvent::Connected { peer, socket } => write!(f, "tcp: {peer} connected to socket {socket}"),
            BridgeEvent::Refused { peer, chip_port } => {
                write!(f, "tcp: {peer} refused: no socket listened on port {chip_port} in time")
            }
            BridgeEvent::Dialed { socket, to, host } => {
                write!(f, "tcp: socket {socket} connected to {to}, bridged to {host}")
            }
            BridgeEvent::DialRefused { socket, to, host } => {
                write!(f, "tcp: socket {socket} connected to {to}: refused, nothing listens on {host}")
            }
            BridgeEvent::Bytes { peer, socket, to_chip, bytes } => {
                let way = if *to_chip { "to the chip" } else { "from the chip" };
                write!(f, "tcp: {peer} on socket {socket}: {} bytes {way}", bytes.len())
            }
            BridgeEvent::Closed { peer, socket, how } => write!(f, "tcp: {peer} on socket {socket}: {how}"),
            BridgeEvent::UdpOpen { chip_port, host } => write!(f, "udp: {host} (the chip's port {chip_port})"),
            BridgeEvent::Datagram { peer, socket, to_chip, bytes } => {
                let way = if *to_chip { "from" } else { "to" };
                write!(f, "udp: socket {socket}: a datagram of {} bytes {way} {peer}", bytes.len())
            }
            BridgeEvent::UdpDropped { peer, chip_port, why } => {
                write!(f, "udp: a datagram of {peer} on the chip's port {chip_port} dropped: {why}")
            }
            BridgeEvent::Dhcp { heard, to, answer: Some((kind, address)) } => {
                write!(f, "dhcp: {heard} to {to}, answered {kind} {address}")
            }
            BridgeEvent::Dhcp { heard, to, answer: None } => write!(f, "dhcp: {heard} to {to}, not answered"),
        }
    }
}

/// Bytes the bridge holds for a host client before the chip's peer stops taking more.
const HOST_BUFFER: usize = 64 * 1024;
/// Bytes read from a host client at most per poll.
const READ_CHUNK: usize = 4096;

struct Listener {
    mapping: Mapping,
    socket: TcpListener,
    announced: bool,
}

/// The largest datagram the bridge takes from a host client (a W5500 socket's RX buffer is at
/// most 16 KB).
const MAX_DATAGRAM: usize = 16 * 1024;

/// A host UDP port bridged to a chip port.
struct UdpPort {
    mapping: Mapping,
    socket: UdpSocket,
    announced: bool,
}

/// One host client.
struct HostConn {
    stream: TcpStream,
    peer: SocketAddr,
    chip_port: u16,
    /// The cycle it was accepted.
    since: u64,
    /// The chip's socket and connection id, once handed over.
    attached: Option<(usize, u64)>,
    /// From the client, not delivered yet (the chip's RX buffer was full).
    to_chip: Vec<u8>,
    /// From the chip, not written yet (the client is slow).
    to_host: Vec<u8>,
    host_eof: bool,
    fin_delivered: bool,
    host_shut: bool,
}

/// Bridges chip ports to host ports (see the module docs).
pub struct Bridge {
    listeners: Vec<Listener>,
    /// Ports the firmware connects to (`chip_port`), bridged to 127.0.0.1:`host_port`.
    outgoing: Vec<Mapping>,
    conns: Vec<HostConn>,
    udp: Vec<UdpPort>,
    /// The network's DHCP server, if the bridge plays it.
    dhcp: Option<DhcpServer>,
    patience: u64,
    traffic: bool,
}

impl fmt::Debug for Bridge {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Bridge").field("ports", &self.ports()).field("clients", &self.conns.len()).finish()
    }
}

impl Bridge {
    /// Listens on 127.0.0.1 for each mapping's host port.
    pub fn bind(mappings: &[Mapping]) -> io::Result<Bridge> {
        let listeners = mappings
            .iter()
            .map(|&mapping| {
                let socket = TcpListener::bind((Ipv4Addr::LOCALHOST, mapping.host_port))?;
                socket.set_nonblocking(true)?;
                Ok(Listener { mapping, socket, announced: false })
            })
            .collect::<io::Result<Vec<_>>>()?;
        Ok(Bridge {
            listeners,
            outgoing: Vec::new(),
            conns: Vec::new(),
            udp: Vec::new(),
            dhcp: None,
            patience: 3_000_000 * CYCLES_PER_US,
            traffic: false,
        })
    }

    /// Also bridges the firmware's connections: one to any address on a mapping's
    /// `chip_port` goes to 127.0.0.1:`host_port` (`502:1502`: a client firmware that
    /// connects to port 502 reaches the server on the host's port 1502).
    pub fn with_outgoing(self, mappings: &[Mapping]) -> Bridge {
        Bridge { outgoing: mappings.to_vec(), ..self }
    }

    /// Also plays the network's DHCP server (RFC 2131), [`DhcpServer::new`]`(lease)`: it
    /// answers what the chip's UDP socket on port 68 broadcasts or sends to it with an
    /// OFFER and an ACK of 192.168.50.23/24 for `lease` seconds (`virtual-uno --dhcp`).
    pub fn with_dhcp(self, lease: u32) -> Bridge {
        Bridge { dhcp: Some(DhcpServer::new(lease)), ..self }
    }

    /// Also bridges UDP: a datagram to 127.0.0.1:`host_port` goes to the chip's socket open in
    /// UDP mode on `chip_port`, and what that socket sends to 127.0.0.1 goes back from
    /// `host_port` (see the module docs).
    pub fn with_udp(self, mappings: &[Mapping]) -> io::Result<Bridge> {
        let mut udp = self.udp;
        for &mapping in mappings {
            let socket = UdpSocket::bind((Ipv4Addr::LOCALHOST, mapping.host_port))?;
            socket.set_nonblocking(true)?;
            udp.push(UdpPort { mapping, socket, announced: false });
        }
        Ok(Bridge { udp, ..self })
    }

    /// Each chip UDP port and the host address bridged to it.
    pub fn udp_ports(&self) -> Vec<(u16, SocketAddr)> {
        self.udp.iter().filter_map(|u| Some((u.mapping.chip_port, u.socket.local_addr().ok()?))).collect()
    }

    /// Reports the bytes each connection carries, both ways, as [`BridgeEvent::Bytes`]
    /// (before its other events of the same round), for a tool that prints the messages.
    pub fn with_traffic(self) -> Bridge {
        Bridge { traffic: true, ..self }
    }

    /// How long (simulated cycles) a client waits for a listening socket before it is refused;
    /// 3 s by default, as a client's first SYN retransmissions.
    pub fn with_patience(self, cycles: u64) -> Bridge {
        Bridge { patience: cycles, ..self }
    }

    /// Each chip port and the host address bridged to it.
    pub fn ports(&self) -> Vec<(u16, SocketAddr)> {
        self.listeners.iter().filter_map(|l| Some((l.mapping.chip_port, l.socket.local_addr().ok()?))).collect()
    }

    /// Host clients connected (waiting or handed over).
    pub fn clients(&self) -> usize {
        self.conns.len()
    }

    /// One round, at the chip's clock: new clients, hand-overs, bytes, closes. Never blocks.
    pub fn poll(&mut self, chip: &mut W5x00) -> Vec<BridgeEvent> {
        let now = chip.now();
        let mut events = Vec::new();
        for l in &mut self.listeners {
            if !l.announced && chip.listening(l.mapping.chip_port).is_some() {
                l.announced = true;
                if let Ok(host) = l.socket.local_addr() {
                    events.push(BridgeEvent::Listening { chip_port: l.mapping.chip_port, host });
                }
            }
            while let Ok((stream, peer)) = l.socket.accept() {
                if stream.set_nonblocking(true).is_err() {
                    continue;
                }
                let _ = stream.set_nodelay(true);
                self.conns.push(HostConn {
                    stream,
                    peer,
                    chip_port: l.mapping.chip_port,
                    since: now,
                    attached: None,
                    to_chip: Vec::new(),
                    to_host: Vec::new(),
                    host_eof: false,
                    fin_delivered: false,
                    host_shut: false,
                });
            }
        }
        for (n, to) in chip.connecting() {
            let Some(mapping) = self.outgoing.iter().find(|m| m.chip_port == to.port()) else { continue };
            let host = SocketAddr::from((Ipv4Addr::LOCALHOST, mapping.host_port));
            // A connection to 127.0.0.1 is made or refused at once: no wait here.
            let stream = TcpStream::connect(host).and_then(|s| s.set_nonblocking(true).map(|()| s));
            let Ok(stream) = stream else {
                chip.refuse_connect(n);
                events.push(BridgeEvent::DialRefused { socket: n, to, host });
                continue;
            };
            let _ = stream.set_nodelay(true);
            chip.accept_connect(n);
            let id = chip.connection(n).map_or(0, |conn| conn.id());
            chip.set_peer_window(n, Some(HOST_BUFFER));
            self.conns.push(HostConn {
                stream,
                peer: host,
                chip_port: to.port(),
                since: now,
                attached: Some((n, id)),
                to_chip: Vec::new(),
                to_host: Vec::new(),
                host_eof: false,
                fin_delivered: false,
                host_shut: false,
            });
            events.push(BridgeEvent::Dialed { socket: n, to, host });
        }
        for u in &mut self.udp {
            udp_step(u, chip, self.traffic, &mut events);
        }
        if let Some(server) = &mut self.dhcp {
            let before = server.heard.len();
            server.serve(chip);
            for heard in &server.heard[before..] {
                let answer = heard.answered.map(|kind| (dhcp_server::name(kind), server.address));
                events.push(BridgeEvent::Dhcp { heard: dhcp_server::name(heard.kind), to: heard.to, answer });
            }
        }
        let (patience, traffic) = (self.patience, self.traffic);
        self.conns.retain_mut(|c| match step(c, chip, now, patience, traffic.then_some(&mut events)) {
            Step::Keep(None) => true,
            Step::Keep(Some(e)) => {
                events.push(e);
                true
            }
            Step::Drop(e) => {
                events.push(e);
                false
            }
        });
        events
    }
}

/// One UDP port's round: the host's datagrams to the chip's socket, its datagrams to the host.
fn udp_step(u: &mut UdpPort, chip: &mut W5x00, traffic: bool, events: &mut Vec<BridgeEvent>) {
    let chip_port = u.mapping.chip_port;
    let target = chip.udp_socket(chip_port);
    if !u.announced && target.is_some() {
        u.announced = true;
        if let Ok(host) = u.socket.local_addr() {
            events.push(BridgeEvent::UdpOpen { chip_port, host });
        }
    }
    let mut buf = vec![0u8; MAX_DATAGRAM];
    loop {
        let (k, peer) = match u.socket.recv_from(&mut buf) {
            Ok(got) => got,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            // WouldBlock, or an ICMP error of an earlier send: nothing more this round
            Err(_) => break,
        };
        let from = match peer {
            SocketAddr::V4(v4) => v4,
            SocketAddr::V6(v6) => SocketAddrV4::new(Ipv4Addr::LOCALHOST, v6.port()),
        };
        let bytes = &buf[..k];
        match target {
            Some(n) if chip.udp_deliver(n, from, bytes) => {
                if traffic {
                    events.push(BridgeEvent::Datagram { peer, socket: n, to_chip: true, bytes: bytes.to_vec() });
                }
            }
            Some(_) => events.push(BridgeEvent::UdpDropped { peer, chip_port, why: "no room in the socket" }),
            None => events.push(BridgeEvent::UdpDropped { peer, chip_port, why: "no UDP socket on the port" }),
        }
    }
    for n in 0..chip.socket_count() {
        if chip.status(n) != state::UDP || chip.socket_register16(n, sn::PORT) != chip_port {
            continue;
        }
        for (to, bytes) in chip.udp_sent(n) {
            let peer = SocketAddr::V4(to);
            if !to.ip().is_loopback() {
                events.push(BridgeEvent::UdpDropped { peer, chip_port, why: "sent beyond 127.0.0.1" });
                continue;
            }
            // A loopback datagram is taken whole or not at all; a lost one is UDP's way.
            let _ = u.socket.send_to(&bytes, to);
            if traffic {
                events.push(BridgeEvent::Datagram { peer, socket: n, to_chip: false, bytes });
            }
        }
    }
}

enum Step {
    Keep(Option<BridgeEvent>),
    Drop(BridgeEvent),
}

/// One client's round; with `traffic`, the bytes it moved are pushed there.
fn step(
    c: &mut HostConn,
    chip: &mut W5x00,
    now: u64,
    patience: u64,
    mut traffic: Option<&mut Vec<BridgeEvent>>,
) -> Step {
    let Some((n, id)) = c.attached else {
        let peer = match c.peer {
            SocketAddr::V4(v4) => v4,
            SocketAddr::V6(v6) => SocketAddrV4::new(Ipv4Addr::LOCALHOST, v6.port()),
        };
        if let Some(n) = chip.connect(c.chip_port, peer) {
            let id = chip.connection(n).map_or(0, |conn| conn.id());
            c.attached = Some((n, id));
            chip.set_peer_window(n, Some(HOST_BUFFER));
            return Step::Keep(Some(BridgeEvent::Connected { peer: c.peer, socket: n }));
        }
        if now.saturating_sub(c.since) > patience {
            reset(&c.stream);
            return Step::Drop(BridgeEvent::Refused { peer: c.peer, chip_port: c.chip_port });
        }
        return Step::Keep(None);
    };
    let peer = c.peer;
    let closed = |how| Step::Drop(BridgeEvent::Closed { peer, socket: n, how });
    let Some(conn) = chip.connection(n).filter(|conn| conn.id() == id) else {
        reset(&c.stream);
        return closed("reset by the chip");
    };
    if conn.reset_by_chip() {
        reset(&c.stream);
        return closed("reset by the chip");
    }

    // client -> chip
    if !c.host_eof && c.to_chip.len() < READ_CHUNK {
        let mut buf = [0u8; READ_CHUNK];
        match c.stream.read(&mut buf) {
            Ok(0) => c.host_eof = true,
            Ok(k) => {
                c.to_chip.extend_from_slice(&buf[..k]);
                if let Some(events) = traffic.as_deref_mut() {
                    events.push(BridgeEvent::Bytes { peer, socket: n, to_chip: true, bytes: buf[..k].to_vec() });
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => {
                chip.peer_reset(n);
                return closed("reset by the client");
            }
        }
    }
    if !c.to_chip.is_empty() {
        let k = chip.deliver(n, &c.to_chip);
        c.to_chip.drain(..k);
    }
    if c.host_eof && c.to_chip.is_empty() && !c.fin_delivered {
        c.fin_delivered = true;
        chip.peer_fin(n);
    }

    // chip -> client
    let mut sent = chip.take_sent(n);
    c.to_host.extend_from_slice(&sent);
    if write_some(c).is_err() {
        chip.peer_reset(n);
        return closed("reset by the client");
    }
    chip.set_peer_window(n, Some(HOST_BUFFER.saturating_sub(c.to_host.len())));
    let more = chip.take_sent(n);
    c.to_host.extend_from_slice(&more);
    if let Some(events) = traffic {
        sent.extend(more);
        if !sent.is_empty() {
            events.push(BridgeEvent::Bytes { peer, socket: n, to_chip: false, bytes: sent });
        }
    }

    let Some(conn) = chip.connection(n) else { return Step::Keep(None) };
    if conn.fin_from_chip() && c.to_host.is_empty() && !c.host_shut {
        c.host_shut = true;
        let _ = c.stream.shutdown(Shutdown::Write);
    }
    if conn.closed() && c.to_host.is_empty() {
        if conn.fin_from_chip() || conn.fin_from_peer() && c.host_shut {
            return closed("closed");
        }
        reset(&c.stream);
        return closed(if conn.reset_by_peer() { "reset by the client" } else { "timed out" });
    }
    Step::Keep(None)
}

/// Writes what the client takes without blocking.
fn write_some(c: &mut HostConn) -> io::Result<()> {
    while !c.to_host.is_empty() {
        match c.stream.write(&c.to_host) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(k) => {
                c.to_host.drain(..k);
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Makes the coming close of `stream` an RST (SO_LINGER with a zero timeout).
fn reset(stream: &TcpStream) {
    let linger = libc::linger { l_onoff: 1, l_linger: 0 };
    // SAFETY: the descriptor is `stream`'s, open for the call; `linger` is a valid
    // `struct linger` whose size is passed with it.
    unsafe {
        libc::setsockopt(
            stream.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            std::ptr::from_ref(&linger).cast(),
            std::mem::size_of::<libc::linger>() as libc::socklen_t,
        );
    }
}

/// [`reset`], for the tests to play a client that resets.
#[cfg(test)]
pub(crate) fn reset_for_tests(stream: &TcpStream) {
    reset(stream);
}
