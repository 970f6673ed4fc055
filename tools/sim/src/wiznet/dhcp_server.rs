//! A DHCP server for the tests (RFC 2131 §4.3, RFC 2132), on the network side of the
//! simulated chip: it reads what a client's UDP socket sent to port 67 and answers with an
//! OFFER, an ACK, a NAK or silence, as the test sets it, with the lease times the test
//! chooses. Written from the RFCs, apart from the firmware's client, so that a wrong field
//! on either side shows as a failing test.

use std::net::{Ipv4Addr, SocketAddrV4};

use super::W5x00;

/// Message types (option 53).
pub const DISCOVER: u8 = 1;
/// OFFER.
pub const OFFER: u8 = 2;
/// REQUEST.
pub const REQUEST: u8 = 3;
/// ACK.
pub const ACK: u8 = 5;
/// NAK.
pub const NAK: u8 = 6;

/// A message type's name.
pub fn name(kind: u8) -> &'static str {
    match kind {
        DISCOVER => "DISCOVER",
        OFFER => "OFFER",
        REQUEST => "REQUEST",
        ACK => "ACK",
        NAK => "NAK",
        _ => "another message",
    }
}

/// What the server does with what it hears.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Offers its address to a DISCOVER, acknowledges a REQUEST.
    Serve,
    /// Offers to a DISCOVER, refuses every REQUEST with a NAK.
    Nak,
    /// Answers nothing.
    Silent,
    /// Serves, but ignores the REQUESTs sent to it alone (renewals): only a client that
    /// broadcasts (rebinding) is answered.
    IgnoreRenewals,
}

/// A client's message as the server heard it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Heard {
    /// Where the client sent it (255.255.255.255 or the server).
    pub to: SocketAddrV4,
    /// Option 53.
    pub kind: u8,
    /// The broadcast flag.
    pub broadcast: bool,
    /// ciaddr.
    pub ciaddr: Ipv4Addr,
    /// Option 50, requested address.
    pub requested: Option<Ipv4Addr>,
    /// Option 54, server id.
    pub server_id: Option<Ipv4Addr>,
    /// Option 12, host name.
    pub host_name: Option<String>,
    /// Option 61, client id.
    pub client_id: Option<Vec<u8>>,
    /// The datagram's length.
    pub len: usize,
    /// The simulated time it was heard at, in CPU cycles.
    pub cycle: u64,
    /// The type of the server's answer (OFFER, ACK, NAK), if it answered.
    pub answered: Option<u8>,
}

/// The test's DHCP server.
#[derive(Clone, Debug)]
pub struct DhcpServer {
    /// Its own address (option 54).
    pub id: Ipv4Addr,
    /// The address it gives.
    pub address: Ipv4Addr,
    /// Option 1.
    pub subnet: Ipv4Addr,
    /// Option 3.
    pub router: Ipv4Addr,
    /// Option 51, seconds.
    pub lease: u32,
    /// Options 58 and 59, when set.
    pub t1_t2: Option<(u32, u32)>,
    /// What it does.
    pub mode: Mode,
    /// Everything it heard, in order.
    pub heard: Vec<Heard>,
}

impl DhcpServer {
    /// A server at 192.168.50.1 giving 192.168.50.23/24 (router 192.168.50.254) for
    /// `lease` seconds.
    pub fn new(lease: u32) -> DhcpServer {
        DhcpServer {
            id: Ipv4Addr::new(192, 168, 50, 1),
            address: Ipv4Addr::new(192, 168, 50, 23),
            subnet: Ipv4Addr::new(255, 255, 255, 0),
            router: Ipv4Addr::new(192, 168, 50, 254),
            lease,
            t1_t2: None,
            mode: Mode::Serve,
            heard: Vec::new(),
        }
    }

    /// Takes what the chip's UDP socket on port 68 sent since the last call and answers it
    /// (into that socket, from port 67). Returns how many messages it heard.
    pub fn serve(&mut self, chip: &mut W5x00) -> usize {
        let Some(n) = chip.udp_socket(68) else { return 0 };
        let sent = chip.udp_sent(n);
        let cycle = chip.now();
        for (to, payload) in &sent {
            if to.port() != 67 {
                continue;
            }
            let Some(mut heard) = read(*to, payload, cycle) else { continue };
            let reply = self.answer(&heard, payload);
            heard.answered = reply.as_ref().map(|r| r[242]);
            self.heard.push(heard);
            if let Some(reply) = reply {
                chip.udp_deliver(n, SocketAddrV4::new(self.id, 67), &reply);
            }
        }
        sent.len()
    }

    /// The reply to a client's message, if any.
    pub fn answer(&self, heard: &Heard, request: &[u8]) -> Option<Vec<u8>> {
        let renewal = heard.to.ip() == &self.id;
        let kind = match (self.mode, heard.kind) {
            (Mode::Silent, _) => return None,
            (Mode::IgnoreRenewals, REQUEST) if renewal => return None,
            (_, DISCOVER) => OFFER,
            (Mode::Nak, REQUEST) => NAK,
            (Mode::Serve | Mode::IgnoreRenewals, REQUEST) => {
                let asked = heard.requested.unwrap_or(heard.ciaddr);
                if asked != self.address {
                    NAK
                } else {
                    ACK
                }
            }
            _ => return None,
        };
        Some(self.reply(kind, request))
    }

    /// A reply of type `kind` to `request` (its xid, flags and chaddr copied).
    pub fn reply(&self, kind: u8, request: &[u8]) -> Vec<u8> {
        let mut m = vec![0; 240];
        m[0] = 2; // op BOOTREPLY
        m[1] = 1; // htype Ethernet
        m[2] = 6; // hlen
        m[4..8].copy_from_slice(&request[4..8]); // xid
        m[10..12].copy_from_slice(&request[10..12]); // flags
        if kind != NAK {
            m[16..20].copy_from_slice(&self.address.octets()); // yiaddr
            m[20..24].copy_from_slice(&self.id.octets()); // siaddr
        }
        m[28..44].copy_from_slice(&request[28..44]); // chaddr
        m[236..240].copy_from_slice(&[99, 130, 83, 99]);
        let mut option = |code: u8, value: &[u8]| {
            m.push(code);
            m.push(value.len() as u8);
            m.extend_from_slice(value);
        };
        option(53, &[kind]);
        option(54, &self.id.octets());
        if kind != NAK {
            option(51, &self.lease.to_be_bytes());
            option(1, &self.subnet.octets());
            option(3, &self.router.octets());
            if let Some((t1, t2)) = self.t1_t2 {
                option(58, &t1.to_be_bytes());
                option(59, &t2.to_be_bytes());
            }
        }
        m.push(255);
        m
    }

    /// The messages of type `kind` heard.
    pub fn heard(&self, kind: u8) -> Vec<&Heard> {
        self.heard.iter().filter(|h| h.kind == kind).collect()
    }
}

/// A client's message, if it is one (op 1, the cookie, option 53).
fn read(to: SocketAddrV4, m: &[u8], cycle: u64) -> Option<Heard> {
    if m.len() < 240 || m[0] != 1 || m[236..240] != [99, 130, 83, 99] {
        return None;
    }
    let mut heard = Heard {
        to,
        kind: 0,
        broadcast: m[10] & 0x80 != 0,
        ciaddr: Ipv4Addr::new(m[12], m[13], m[14], m[15]),
        requested: None,
        server_id: None,
        host_name: None,
        client_id: None,
        len: m.len(),
        cycle,
        answered: None,
    };
    let mut at = 240;
    while at < m.len() && m[at] != 255 {
        if m[at] == 0 {
            at += 1;
            continue;
        }
        let n = usize::from(*m.get(at + 1)?);
        let value = m.get(at + 2..at + 2 + n)?;
        let ip = || (n == 4).then(|| Ipv4Addr::new(value[0], value[1], value[2], value[3]));
        match m[at] {
            53 => heard.kind = *value.first()?,
            50 => heard.requested = ip(),
            54 => heard.server_id = ip(),
            12 => heard.host_name = Some(String::from_utf8_lossy(value).into_owned()),
            61 => heard.client_id = Some(value.to_vec()),
            _ => {}
        }
        at += 2 + n;
    }
    (heard.kind != 0).then_some(heard)
}
