//! The DHCP client (feature `dhcp`), RFC 2131 §3.1 (the exchange), §4.3.1 and §4.4 (the
#![cfg_attr(not(any(target_arch = "avr", test)), allow(dead_code))]
//! client's states and timers) and RFC 2132 (the options): DISCOVER, OFFER, REQUEST, ACK or
//! NAK over UDP 68 → 67, the lease renewed at T1 by unicast and rebound at T2 by broadcast.
//!
//! Pure: [`Dhcp`] is driven by two events, a datagram from port 67 ([`Dhcp::receive`]) and a
//! whole second ([`Dhcp::second`]); each says whether a message is due, which
//! [`Dhcp::message`] writes. [`Dhcp::addresses`] says which addresses the chip should have
//! now; [`poll`] runs it all on a chip's UDP socket ([`Udp`]). A datagram is read where it
//! lies (the chip's receive buffer), a few bytes at a time: a few bytes of RAM, however
//! long the options.

pub(crate) use super::network::IP;
use super::network::{Network, ADDRESSES, GATEWAY, MAC, SUBNET};
use super::server::Sockets;

/// The client's port (RFC 2131 §4.1).
pub(crate) const CLIENT_PORT: u16 = 68;
/// The servers' port.
pub(crate) const SERVER_PORT: u16 = 67;
/// A lease that never ends (RFC 2132 §9.2).
pub const INFINITE: u32 = u32::MAX;
/// The longest lease kept, in seconds (18 h 12 min): a longer one is taken as this long,
/// so that it is renewed within it (its T1 and T2 then 0.5 and 0.875 of this). The
/// client's clock is 16 bits: the AVR's arithmetic is half that of 32.
pub(crate) const LONGEST: u16 = u16::MAX - 1;
/// The client's mark of an infinite lease.
const FOREVER: u16 = u16::MAX;

/// The fixed part of a message: op to file (RFC 2131 §2), then the magic cookie.
const FIXED: u16 = 236;
/// Where the options start, past the cookie.
const OPTIONS: u16 = FIXED + 4;
/// The magic cookie (RFC 2132 §2).
const COOKIE: [u8; 4] = [99, 130, 83, 99];
/// The shortest message sent: BOOTP's 300 bytes (RFC 1542 §2.1), which some relays and
/// servers still require.
const SENT_LEN: u16 = 300;

/// Option codes (RFC 2132).
mod option {
    pub(super) const PAD: u8 = 0;
    pub(super) const SUBNET: u8 = 1;
    pub(super) const ROUTER: u8 = 3;
    pub(super) const HOST_NAME: u8 = 12;
    pub(super) const REQUESTED: u8 = 50;
    pub(super) const LEASE: u8 = 51;
    pub(super) const TYPE: u8 = 53;
    pub(super) const SERVER: u8 = 54;
    pub(super) const PARAMETERS: u8 = 55;
    pub(super) const T1: u8 = 58;
    pub(super) const T2: u8 = 59;
    pub(super) const CLIENT_ID: u8 = 61;
    pub(super) const END: u8 = 255;
}

/// Message types, option 53 (RFC 2132 §9.6).
const DISCOVER: u8 = 1;
const OFFER: u8 = 2;
const REQUEST: u8 = 3;
const ACK: u8 = 5;
const NAK: u8 = 6;

/// The longest host name sent (option 12).
pub(crate) const MAX_HOST: usize = 32;
/// The room a message is written from, in pieces: the longest is the host name (34) with
/// the parameters and the end (6). Small, so that the poll's locals stay within the AVR's
/// short reach of its frame (63 bytes).
pub(crate) const MESSAGE_BUF: usize = 40;

/// The client's settings, from [`Network::dhcp`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Settings {
    /// The chip's socket the client runs on.
    pub(crate) socket: u8,
    /// Option 12.
    pub(crate) host: &'static str,
    /// Seconds without a lease before the Network's own addresses are used (0: never).
    pub(crate) fallback_s: u16,
}

impl Network {
    /// Takes the addresses from a DHCP server (feature `dhcp`), on the chip's socket
    /// `socket` (0–7, and a socket the W5100 has, 0–3, on an Ethernet Shield R3), telling
    /// the server the host name `host` (1–32 letters, digits and `-`: a router lists the
    /// board by it). The TCP roles serve on the sockets below `socket` (this lowers
    /// [`Network::sockets`] to `socket` when it was more). Until a lease comes the board has
    /// no address (0.0.0.0), unless [`Network::fallback_after`] says otherwise; the address
    /// given to [`Network::new`] is then the fallback. A socket or host name out of these
    /// bounds stops the build.
    pub const fn dhcp(self, socket: u8, host: &'static str) -> Network {
        assert!(socket >= 1 && socket < Network::MAX_SOCKETS, "the DHCP socket is 1-7 (the server's are below it)");
        let bytes = host.as_bytes();
        assert!(!bytes.is_empty() && bytes.len() <= MAX_HOST, "a host name is 1-32 characters");
        let mut i = 0;
        while i < bytes.len() {
            let c = bytes[i];
            assert!(c.is_ascii_alphanumeric() || c == b'-', "a host name has letters, digits and '-' only");
            i += 1;
        }
        let sockets = if self.sockets > socket { socket } else { self.sockets };
        Network { sockets, dhcp: Some(Settings { socket, host, fallback_s: 0 }), ..self }
    }

    /// With [`Network::dhcp`]: when no lease has come `seconds` (1–65535) after the start,
    /// or after a lease was lost, the addresses given to [`Network::new`],
    /// [`Network::subnet`] and [`Network::gateway`] are used until one comes; discovery goes
    /// on meanwhile. Default: no fallback (no address without a lease).
    pub const fn fallback_after(self, seconds: u16) -> Network {
        let Some(settings) = self.dhcp else { panic!("fallback_after comes after dhcp") };
        assert!(seconds >= 1, "at least 1 s");
        Network { dhcp: Some(Settings { fallback_s: seconds, ..settings }), ..self }
    }
}

/// Where the client is (RFC 2131 §4.4, Figure 5).
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DhcpState {
    /// No lease: DISCOVERs sent, waiting for an offer (SELECTING).
    #[default]
    Selecting,
    /// An offer taken, its REQUEST sent, waiting for the ACK (REQUESTING).
    Requesting,
    /// Leased (BOUND).
    Bound,
    /// Past T1: the lease asked again of its server, by unicast (RENEWING).
    Renewing,
    /// Past T2: the lease asked again of any server, by broadcast (REBINDING).
    Rebinding,
}

/// The client's counters, one for each kind of answer refused: what the exchanges came to.
/// Each wraps after 65535.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DhcpCounters {
    /// Leases taken (ACKs of a request, renewals included).
    pub leases: u16,
    /// NAKs taken: the address given up, discovery again.
    pub naks: u16,
    /// Leases that ran out without a renewal: the address given up.
    pub expired: u16,
    /// Messages sent again for want of an answer.
    pub retries: u16,
    /// Refused: shorter than a message's fixed part and cookie (240 bytes), or longer than
    /// the chip holds.
    pub short: u16,
    /// Refused: not a server's reply (op not 2), or not from port 67.
    pub not_reply: u16,
    /// Refused: for another client (hardware type, length or address not this board's).
    pub other_client: u16,
    /// Refused: for another exchange (xid).
    pub other_xid: u16,
    /// Refused: no magic cookie, an option running past the message's end, or an option
    /// of the wrong length.
    pub malformed: u16,
    /// Refused: no message type, or an offer or ACK without its lease time or an offer
    /// without its server id.
    pub missing: u16,
    /// Refused: a lease of 0 seconds.
    pub bad_lease: u16,
    /// Refused: an address that is none (0.0.0.0), broadcast, loopback or multicast, or an
    /// ACK for another address than the one asked.
    pub bad_address: u16,
    /// Refused: a message not awaited now (an offer while requesting, an ACK while bound),
    /// or from another server than the one asked.
    pub unexpected: u16,
}

/// A counter's place in [`Dhcp::counts`]: the order of [`DhcpCounters`]'s fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Count {
    Leases,
    Naks,
    Expired,
    Retries,
    Short,
    NotReply,
    OtherClient,
    OtherXid,
    Malformed,
    Missing,
    BadLease,
    BadAddress,
    Unexpected,
}

const COUNTS: usize = Count::Unexpected as usize + 1;

/// The client's state as the application reads it.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DhcpStatus {
    /// Where the exchange is.
    pub state: DhcpState,
    /// True while the fallback addresses are used ([`Network::fallback_after`]).
    pub fallback: bool,
    /// Seconds until the lease ends ([`INFINITE`]: never; 0: no lease).
    pub remaining: u32,
    /// The counters.
    pub counters: DhcpCounters,
}

/// A received datagram, read where it lies.
pub(crate) trait Datagram {
    /// Its length.
    fn len(&self) -> u16;
    /// Its bytes from `at` on into `buf` (all within [`Datagram::len`]).
    fn read(&mut self, at: u16, buf: &mut [u8]);
}

/// The options an answer's checks and the lease need, 4 bytes each, at their place in
/// [`Answer::values`] (a router list gives its first); the message type (option 53, 1
/// byte) is kept after them.
const SERVER_ID: usize = 0;
const LEASE: usize = 1;
const T1: usize = 2;
const T2: usize = 3;
const SUBNET_MASK: usize = 4;
const ROUTER: usize = 5;
const KIND: usize = 6;
/// The options kept, at their place.
const KEPT: [u8; KIND + 1] =
    [option::SERVER, option::LEASE, option::T1, option::T2, option::SUBNET, option::ROUTER, option::TYPE];

/// What an answer holds that the client keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Answer {
    /// yiaddr.
    address: [u8; 4],
    /// Bit n: `values[n]` was there.
    seen: u8,
    values: [[u8; 4]; KIND + 1],
}

impl Answer {
    /// True when `values[n]` was there.
    fn has(&self, n: usize) -> bool {
        self.seen & 1 << n != 0
    }

    /// Option 53 (0: none).
    fn kind(&self) -> u8 {
        self.values[KIND][0]
    }
}

/// Seconds given in 4 bytes as the client keeps them: [`FOREVER`] for [`INFINITE`], at
/// most [`LONGEST`] otherwise.
#[inline(never)]
fn seconds(value: [u8; 4]) -> u16 {
    if value == [255; 4] {
        FOREVER
    } else if value[0] | value[1] != 0 {
        LONGEST
    } else {
        u16::from_be_bytes([value[2], value[3]]).min(LONGEST)
    }
}

/// The byte at `at` of a datagram.
fn byte_at(datagram: &mut impl Datagram, at: u16) -> u8 {
    let mut byte = [0];
    datagram.read(at, &mut byte);
    byte[0]
}

/// The DHCP client. In C's order, the fields that start at 0 side by side: made by one
/// fill of zeros.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Dhcp {
    state: DhcpState,
    /// Seconds until the next message (0: at the next second).
    wait: u16,
    /// Messages sent in this state without an answer.
    tries: u8,
    /// Seconds since the lease began.
    age: u16,
    /// The lease, T1 and T2 in seconds (at most [`LONGEST`]; [`FOREVER`]: infinite).
    lease: u16,
    t1: u16,
    t2: u16,
    /// Seconds without a lease (for the fallback), up to 65535.
    without: u16,
    /// The server the lease is asked of.
    server: [u8; 4],
    /// The addresses in the chips' order (gateway, subnet, MAC, IP): the lease's while one
    /// is held, those of an offer while requesting (none before the first offer).
    leased: [u8; ADDRESSES],
    counts: [u16; COUNTS],
    /// The exchange's id.
    xid: [u8; 4],
    /// The Network's own addresses, the fallback.
    fixed: [u8; ADDRESSES],
    settings: Settings,
}

fn put(addresses: &mut [u8; ADDRESSES], at: usize, bytes: [u8; 4]) {
    addresses[at..at + 4].copy_from_slice(&bytes);
}

/// True for an address a host may have: not 0.0.0.0, 255.255.255.255, loopback or
/// multicast.
fn usable(ip: [u8; 4]) -> bool {
    ip[0] != 0 && ip[0] != 127 && ip[0] < 224
}

impl Dhcp {
    /// A client for `network` (which has [`Network::dhcp`]): a DISCOVER at the first second.
    pub(crate) fn new(network: &Network, settings: Settings) -> Dhcp {
        let mac = network.mac();
        Dhcp {
            state: DhcpState::Selecting,
            xid: [mac[2], mac[3], mac[4], mac[5]],
            wait: 0,
            tries: 0,
            age: 0,
            lease: 0,
            t1: 0,
            t2: 0,
            without: 0,
            server: [0; 4],
            leased: [0; ADDRESSES],
            fixed: network.addresses,
            settings,
            counts: [0; COUNTS],
        }
    }

    /// The counters.
    pub fn counters(&self) -> DhcpCounters {
        let [leases, naks, expired, retries, short, not_reply, other_client, other_xid, malformed, missing, bad_lease, bad_address, unexpected] =
            self.counts;
        DhcpCounters {
            leases,
            naks,
            expired,
            retries,
            short,
            not_reply,
            other_client,
            other_xid,
            malformed,
            missing,
            bad_lease,
            bad_address,
            unexpected,
        }
    }

    /// The state as the application reads it.
    pub fn status(&self) -> DhcpStatus {
        let remaining = match self.holds() {
            false => 0,
            true if self.lease == FOREVER => INFINITE,
            true => u32::from(self.lease - self.age),
        };
        DhcpStatus { state: self.state, fallback: self.fallback(), remaining, counters: self.counters() }
    }

    /// Not inlined: a call is the counter's number, not the counters' place and length too.
    #[inline(never)]
    fn bump(&mut self, count: Count) {
        crate::link::bump(&mut self.counts, count as u8);
    }

    /// True while a lease is held.
    fn holds(&self) -> bool {
        matches!(self.state, DhcpState::Bound | DhcpState::Renewing | DhcpState::Rebinding)
    }

    /// True while the fallback addresses are due.
    fn fallback(&self) -> bool {
        let after = self.settings.fallback_s;
        !self.holds() && after != 0 && self.without >= after
    }

    /// The addresses the chip should have now, in its register order: the lease's, the
    /// fallback, or none (IP 0.0.0.0, the Network's subnet and gateway).
    #[cfg(test)]
    pub(crate) fn addresses(&self) -> [u8; ADDRESSES] {
        let mut addresses = [0; ADDRESSES];
        self.apply(&mut addresses);
        addresses
    }

    /// Makes `addresses` those of [`Dhcp::addresses`], in place: 0 when they were already,
    /// else bit 0 (the gateway, subnet or MAC changed) and bit 1 (the IP changed).
    fn apply(&self, addresses: &mut [u8; ADDRESSES]) -> u8 {
        let holds = self.holds();
        let from = if holds { &self.leased } else { &self.fixed };
        let none = !holds && !self.fallback();
        let mut changed = 0;
        for (i, byte) in addresses.iter_mut().enumerate() {
            let ip = i >= IP;
            let want = if ip && none { 0 } else { from[i] };
            if *byte != want {
                *byte = want;
                changed |= 1 << u8::from(ip);
            }
        }
        changed
    }

    /// Back to discovery, any lease given up: a new exchange, a DISCOVER at the next second.
    /// Not inlined (three places call it), as [`Dhcp::enter`], [`Dhcp::bump`] and
    /// [`Dhcp::receive`] (whose locals then stay out of the poll's frame).
    #[inline(never)]
    fn restart(&mut self) {
        if self.holds() {
            self.without = 0;
        }
        self.state = DhcpState::Selecting;
        // A new xid: its first byte counted on (the rest the MAC's, a board's own).
        self.xid[0] = self.xid[0].wrapping_add(1);
        self.wait = 0;
        self.tries = 0;
    }

    /// A second has passed: the lease's age and the timers. True when a message is due now
    /// ([`Dhcp::message`]).
    pub(crate) fn second(&mut self) -> bool {
        if !self.holds() {
            self.without = self.without.saturating_add(1);
        } else if self.lease != FOREVER {
            self.age += 1;
            if self.age >= self.lease {
                // RFC 2131 §4.4.5: the address is no longer used.
                self.bump(Count::Expired);
                self.restart();
            } else if self.age >= self.t2 && self.state != DhcpState::Rebinding {
                self.enter(DhcpState::Rebinding);
            } else if self.age >= self.t1 && self.state == DhcpState::Bound {
                self.enter(DhcpState::Renewing);
            }
        }
        if self.state == DhcpState::Bound {
            return false;
        }
        if self.wait > 0 {
            self.wait -= 1;
            return false;
        }
        if self.tries != 0 {
            self.bump(Count::Retries);
        }
        self.wait = if self.holds() {
            // Renewing, rebinding: again after half the time left to T2 or to the end, at
            // least 60 s (§4.4.5).
            let end = if self.state == DhcpState::Renewing { self.t2 } else { self.lease };
            ((end - self.age) / 2).max(60)
        } else {
            // Selecting, requesting: after 4, 8, 16, 32, then every 64 s (§4.1); a request
            // unanswered four times, discovery again.
            if self.state == DhcpState::Requesting && self.tries >= 4 {
                self.restart();
            }
            4 << self.tries.min(4)
        } - 1;
        self.tries = self.tries.saturating_add(1);
        true
    }

    /// Into `state`, its first message at the next second.
    #[inline(never)]
    fn enter(&mut self, state: DhcpState) {
        self.state = state;
        self.wait = 0;
        self.tries = 0;
    }

    /// Where the message due goes: the server while renewing, everyone otherwise.
    pub(crate) fn destination(&self) -> [u8; 4] {
        if self.state == DhcpState::Renewing {
            self.server
        } else {
            [255; 4]
        }
    }

    /// The message due in this state, written to `out` in pieces (each at its place from
    /// the message's start; the places between them zeros), with `buf` as their room;
    /// returns its length.
    pub(crate) fn message(&self, buf: &mut [u8; MESSAGE_BUF], out: &mut dyn FnMut(u16, &mut [u8])) -> u16 {
        // Zeros over the whole message first (chaddr's padding, sname, file, past the end
        // option to 300 bytes).
        *buf = [0; MESSAGE_BUF];
        let mut at = 0;
        while at < SENT_LEN {
            out(at, buf);
            at += MESSAGE_BUF as u16;
        }
        // The fixed part: op 1 (request), htype 1 (Ethernet), hlen 6, hops 0, xid, secs 0,
        // flags with the broadcast bit (the chip takes no unicast for an address it does
        // not have yet), ciaddr while renewing and rebinding; chaddr after.
        buf[..4].copy_from_slice(&[1, 1, 6, 0]);
        buf[4..8].copy_from_slice(&self.xid);
        buf[10] = 0x80;
        if self.holds() {
            buf[12..16].copy_from_slice(&self.leased[IP..]);
        }
        out(0, &mut buf[..16]);
        // The options: the type, the client id (61: hardware type 1, the MAC), while
        // requesting the address asked (50) and its server (54); then the host name (12),
        // the parameters asked (55: subnet, router, lease), the end.
        let kind = if self.state == DhcpState::Selecting { DISCOVER } else { REQUEST };
        buf[..10].copy_from_slice(&[99, 130, 83, 99, option::TYPE, 1, kind, option::CLIENT_ID, 7, 1]);
        buf[10..16].copy_from_slice(&self.fixed[MAC..MAC + 6]);
        out(28, &mut buf[10..16]);
        let mut n = 16;
        if self.state == DhcpState::Requesting {
            buf[16..18].copy_from_slice(&[option::REQUESTED, 4]);
            buf[18..22].copy_from_slice(&self.leased[IP..]);
            buf[22..24].copy_from_slice(&[option::SERVER, 4]);
            buf[24..28].copy_from_slice(&self.server);
            n = 28;
        }
        out(FIXED, &mut buf[..n]);
        let at = FIXED + n as u16;
        let host = self.settings.host.as_bytes();
        let len = host.len().min(MAX_HOST);
        buf[0] = option::HOST_NAME;
        buf[1] = len as u8;
        buf[2..2 + len].copy_from_slice(&host[..len]);
        buf[2 + len..8 + len].copy_from_slice(&[
            option::PARAMETERS,
            3,
            option::SUBNET,
            option::ROUTER,
            option::LEASE,
            option::END,
        ]);
        out(at, &mut buf[..8 + len]);
        SENT_LEN.max(at + 8 + len as u16)
    }

    /// A datagram from a server's port 67: taken, or refused and counted. True when a
    /// message is due now (the REQUEST for an offer taken).
    #[inline(never)]
    pub(crate) fn receive(&mut self, datagram: &mut impl Datagram) -> bool {
        let mut answer = Answer::default();
        match self.check(datagram, &mut answer).and_then(|()| self.take(&answer)) {
            Ok(due) => due,
            Err(count) => {
                self.bump(count);
                false
            }
        }
    }

    /// Reads a datagram into `answer`, if it is a reply to this client's exchange, whole
    /// and sound.
    fn check(&self, datagram: &mut impl Datagram, answer: &mut Answer) -> Result<(), Count> {
        let len = datagram.len();
        if len < OPTIONS {
            return Err(Count::Short);
        }
        // Read in pieces into a few bytes: the poll's locals stay within the AVR's short
        // reach of its frame.
        let mut head = [0; 8];
        datagram.read(0, &mut head);
        let [op, htype, hlen, _, xid @ ..] = head;
        let mut mac = [0; 6];
        datagram.read(28, &mut mac);
        if op != 2 {
            return Err(Count::NotReply);
        }
        if htype != 1 || hlen != 6 || mac[..] != self.fixed[MAC..MAC + 6] {
            return Err(Count::OtherClient);
        }
        if xid != self.xid {
            return Err(Count::OtherXid);
        }
        datagram.read(16, &mut answer.address);
        let mut word = [0; 4];
        datagram.read(FIXED, &mut word);
        if word != COOKIE {
            return Err(Count::Malformed);
        }
        let mut at = OPTIONS;
        while at < len {
            let code = byte_at(datagram, at);
            if code == option::END {
                break;
            }
            at += 1;
            if code == option::PAD {
                continue;
            }
            if at >= len {
                return Err(Count::Malformed);
            }
            let n = byte_at(datagram, at);
            at += 1;
            let end = at + u16::from(n);
            if end > len {
                return Err(Count::Malformed);
            }
            let Some(i) = KEPT.iter().position(|&kept| kept == code) else {
                at = end;
                continue;
            };
            // The type in 1 byte; the others in 4, or a list of them for the routers.
            let room = if i == KIND { 1 } else { 4 };
            if n != room && (i != ROUTER || n == 0 || n & 3 != 0) {
                return Err(Count::Malformed);
            }
            datagram.read(at, &mut answer.values[i][..room as usize]);
            answer.seen |= 1 << i;
            at = end;
        }
        Ok(())
    }

    /// Takes an answer whole and sound if it fits the state: the kind awaited, from the
    /// server asked, with what a lease needs. Ok(true) when a message is due now.
    fn take(&mut self, answer: &Answer) -> Result<bool, Count> {
        let kind = answer.kind();
        let asking = matches!(self.state, DhcpState::Requesting | DhcpState::Renewing);
        let awaited = match kind {
            0 => return Err(Count::Missing),
            OFFER => self.state == DhcpState::Selecting,
            ACK | NAK => asking || self.state == DhcpState::Rebinding,
            _ => false,
        };
        // While rebinding any server may answer; otherwise the one asked.
        let server = answer.values[SERVER_ID];
        if !awaited || (asking && answer.has(SERVER_ID) && server != self.server) {
            return Err(Count::Unexpected);
        }
        if kind == NAK {
            self.bump(Count::Naks);
            self.restart();
            return Ok(false);
        }
        if !answer.has(LEASE) || (kind == OFFER && !answer.has(SERVER_ID)) {
            return Err(Count::Missing);
        }
        if answer.values[LEASE] == [0; 4] {
            return Err(Count::BadLease);
        }
        if !usable(answer.address) || (kind == ACK && answer.address[..] != self.leased[IP..]) {
            return Err(Count::BadAddress);
        }
        // An offer's or an ACK's addresses: the server asked from now on, the address, and
        // the subnet and router when given (else the Network's).
        if answer.has(SERVER_ID) {
            self.server = server;
        }
        if kind == OFFER {
            self.leased = self.fixed;
        }
        put(&mut self.leased, IP, answer.address);
        if answer.has(SUBNET_MASK) {
            put(&mut self.leased, SUBNET, answer.values[SUBNET_MASK]);
        }
        if answer.has(ROUTER) {
            put(&mut self.leased, GATEWAY, answer.values[ROUTER]);
        }
        if kind == OFFER {
            self.enter(DhcpState::Requesting);
            self.tries = 1;
            self.wait = 3;
            return Ok(true);
        }
        self.bump(Count::Leases);
        let lease = seconds(answer.values[LEASE]);
        self.lease = lease;
        // T1 and T2 as given when they are in order (T1 ≤ T2 ≤ lease) and the lease is kept
        // whole, else 0.5 and 0.875 of the lease (RFC 2131 §4.4.5).
        let (t1, t2) = (seconds(answer.values[T1]), seconds(answer.values[T2]));
        (self.t1, self.t2) = if answer.has(T1) && answer.has(T2) && t1 <= t2 && t2 <= lease && lease < LONGEST {
            (t1, t2)
        } else {
            (lease / 2, lease - lease / 8)
        };
        self.age = 0;
        self.enter(DhcpState::Bound);
        Ok(false)
    }
}

/// What the client needs of a chip beyond its TCP sockets: a UDP socket, and its
/// addresses set while it runs.
pub(crate) trait Udp: Sockets {
    /// Opens socket `s` for UDP on `port`.
    fn open_udp(&mut self, s: u8, port: u16);
    /// Sends the bytes up to `pointer` to `ip`:`port`.
    fn send_to(&mut self, s: u8, ip: [u8; 4], port: u16, pointer: u16);
    /// Takes the received bytes up to `pointer`, the chip's count updated on return.
    fn take_now(&mut self, s: u8, pointer: u16);
    /// Writes the chip's gateway, subnet, MAC and IP.
    /// (`addresses` mutable so that they go to the chip without a copy: only read.)
    fn set_addresses(&mut self, addresses: &mut [u8; ADDRESSES]);
}

/// A datagram in socket `s`'s receive buffer.
struct InChip<'a, U> {
    chip: &'a mut U,
    s: u8,
    at: u16,
    len: u16,
}

impl<U: Udp> Datagram for InChip<'_, U> {
    fn len(&self) -> u16 {
        self.len
    }

    #[inline(never)]
    fn read(&mut self, at: u16, buf: &mut [u8]) {
        self.chip.read(self.s, self.at.wrapping_add(at), buf);
    }
}

/// The most datagrams taken in one poll.
const PER_POLL: u8 = 4;

/// Runs the client on `chip`: its socket kept open, the datagrams that came taken, with
/// `second` the timers, the message due sent, and the addresses the chip should have
/// written to it and to `network`. When the IP changes, the connections of the sockets
/// below the client's are closed (they were the old address's; the role opens them again). Returns true when the
/// addresses changed.
pub(crate) fn poll<U: Udp>(dhcp: &mut Dhcp, chip: &mut U, network: &mut Network, second: bool) -> bool {
    let s = dhcp.settings.socket;
    let _ = chip.take_events(s);
    let mut due = false;
    if chip.status(s) != super::wiznet::state::UDP {
        chip.command(s, super::wiznet::command::CLOSE);
        chip.open_udp(s, CLIENT_PORT);
    } else {
        for _ in 0..PER_POLL {
            let received = chip.received(s);
            if received < 8 {
                break;
            }
            // The chip's header: source IP, port, length.
            let at = chip.rx_pointer(s);
            let mut header = [0; 8];
            chip.read(s, at, &mut header);
            let port = u16::from_be_bytes([header[4], header[5]]);
            let len = u16::from_be_bytes([header[6], header[7]]);
            let whole = len <= received - 8;
            if !whole {
                dhcp.bump(Count::Short);
            } else if port != SERVER_PORT {
                dhcp.bump(Count::NotReply);
            } else {
                due |= dhcp.receive(&mut InChip { chip, s, at: at.wrapping_add(8), len });
            }
            chip.take_now(s, at.wrapping_add(if whole { 8 + len } else { received }));
        }
    }
    if second {
        due |= dhcp.second();
    }
    if due && chip.tx_free(s) >= SENT_LEN + 2 * MESSAGE_BUF as u16 {
        let start = chip.tx_pointer(s);
        let mut buf = [0; MESSAGE_BUF];
        let len = dhcp.message(&mut buf, &mut |at, piece| chip.write(s, start.wrapping_add(at), piece));
        chip.send_to(s, dhcp.destination(), SERVER_PORT, start.wrapping_add(len));
    }
    let changed = dhcp.apply(&mut network.addresses);
    if changed == 0 {
        return false;
    }
    chip.set_addresses(&mut network.addresses);
    if changed & 2 != 0 {
        // The connections were the old address's; the listening sockets go on.
        for t in 0..s {
            if chip.status(t) != super::wiznet::state::LISTEN {
                chip.command(t, super::wiznet::command::CLOSE);
            }
        }
    }
    true
}

#[cfg(test)]
mod tests;
