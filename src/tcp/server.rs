//! The Modbus TCP server's connections and requests, Implementation Guide v1.0b §4.2
//! (connection management) and §4.4 (the server's handling of an ADU), above any chip that
//! offers TCP sockets ([`Sockets`]).
//!
//! Every serving socket listens on the port; a connection is checked against the allow-list
//! as it comes, then served. A request is read only once it is whole in the chip's receive
//! buffer: its header first (checked before its length decides anything), then, when
//! header and body are all there, the body. So a request split over segments waits in the
//! chip, one buffer of RAM serves every socket, and several requests in one segment are
//! answered in order, their replies sent together. A socket whose master does not read its
//! replies keeps its requests until there is room for an answer; the other sockets go on.
//!
//! Once a second the server looks at every socket: connections idle longer than the
//! timeout are closed, and when all sockets hold a connection the one idle longest is
//! closed for a newcomer once it has been idle a while (§4.2.1).
//!
//! With feature `udp`, one more socket ([`Network::udp`]) serves Modbus UDP: each datagram
//! in its receive buffer, behind the chip's 8-byte header (sender's address, port, length),
//! is one ADU, checked as over TCP and answered with a datagram of its own to its sender.
//! A datagram the allow-list refuses costs the read of that header and nothing more.

use super::health::Health;
use super::mbap::{self, Header, Refused, HEADER};
use super::network::Network;
use super::wiznet::{command, state, RECV, SEND_OK};
#[cfg(feature = "udp")]
use super::wiznet::{TIMEOUT, UDP_HEADER};
use crate::link::crc::Crc16;

/// The events that end a SEND: its SEND_OK (and, on a UDP socket, its TIMEOUT: the ARP of
/// the destination went unanswered and nothing was sent).
#[cfg(not(feature = "udp"))]
const SENT: u8 = SEND_OK;
#[cfg(feature = "udp")]
const SENT: u8 = SEND_OK | TIMEOUT;

/// What the server needs of a chip's TCP sockets (the W5100's and W5500's meanings).
pub trait Sockets {
    /// Bit n set: socket n has events.
    fn events(&mut self) -> u8;
    /// Socket `s`'s events (Sn_IR), cleared.
    fn take_events(&mut self, s: u8) -> u8;
    /// Socket `s`'s state (Sn_SR).
    fn status(&mut self, s: u8) -> u8;
    /// Gives socket `s` a command (Sn_CR) and waits until it is taken.
    fn command(&mut self, s: u8, command: u8);
    /// Opens socket `s` for TCP on `port` and listens.
    fn listen(&mut self, s: u8, port: u16);
    /// The address of socket `s`'s peer.
    fn peer(&mut self, s: u8) -> [u8; 4];
    /// The bytes received and not taken.
    fn received(&mut self, s: u8) -> u16;
    /// Where the next received byte is.
    fn rx_pointer(&mut self, s: u8) -> u16;
    /// Reads received bytes from `pointer` on.
    fn read(&mut self, s: u8, pointer: u16, buf: &mut [u8]);
    /// Takes the received bytes up to `pointer`.
    fn take(&mut self, s: u8, pointer: u16);
    /// The room in the transmit buffer.
    fn tx_free(&mut self, s: u8) -> u16;
    /// Where the next byte to send goes.
    fn tx_pointer(&mut self, s: u8) -> u16;
    /// Writes bytes to send from `pointer` on (the bytes may be used as scratch).
    fn write(&mut self, s: u8, pointer: u16, data: &mut [u8]);
    /// Sends the bytes up to `pointer`.
    fn send(&mut self, s: u8, pointer: u16);
    /// Opens socket `s` on `port`: for UDP, or for TCP and listens ([`Sockets::listen`]).
    #[cfg(feature = "udp")]
    fn open(&mut self, s: u8, port: u16, udp: bool);
    /// Where UDP socket `s`'s next SEND goes: address and port (Sn_DIPR, Sn_DPORT), 6
    /// bytes (the bytes may be used as scratch).
    #[cfg(feature = "udp")]
    fn set_peer(&mut self, s: u8, peer: &mut [u8]);
}

/// The TCP server's counters: what its connections and requests came to. Each wraps
/// after 65535.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TcpCounters {
    /// Requests answered (exceptions included).
    pub requests: u16,
    /// Of them, answered with an exception.
    pub exceptions: u16,
    /// ADUs dropped for a protocol id other than 0; their connection goes on.
    pub bad_protocol: u16,
    /// Connections closed for a length field outside 2–254: the stream could not be
    /// followed.
    pub bad_length: u16,
    /// Requests for another unit id than the device's (see [`Network::only_unit`]),
    /// dropped.
    pub other_unit: u16,
    /// Connections accepted.
    pub connections: u16,
    /// Connections refused by the allow-list (with feature `udp`, datagrams too: dropped
    /// unanswered).
    pub refused: u16,
    /// Connections closed after the idle timeout.
    pub idle_closed: u16,
    /// Connections closed, idle, to make room for a newcomer.
    pub evicted: u16,
    /// Times the chip was set up again (reset, addresses, every socket opened again) after
    /// it lost its settings (a brown-out, its reset line) or stopped answering.
    pub chip_resets: u16,
    /// Times the link went down (W5500; always 0 on the W5100, which cannot tell): the
    /// connections were closed then.
    pub link_losses: u16,
    /// RTU over TCP (feature `rtu-over-tcp`): frames dropped for a bad CRC, or bytes that
    /// make no frame (a length past 256 bytes); what the socket held was discarded.
    #[cfg(feature = "rtu-over-tcp")]
    pub bad_frame: u16,
    /// UDP datagrams dropped for their length (feature `udp`): shorter than an MBAP
    /// header, or not the length its header's length field says (one outside 2–254
    /// included). Those of an address the allow-list refuses count in
    /// [`TcpCounters::refused`], those of the right length and another protocol id in
    /// [`TcpCounters::bad_protocol`], those for another unit in [`TcpCounters::other_unit`].
    #[cfg(feature = "udp")]
    pub bad_datagrams: u16,
    /// Writes refused with exception 01 (feature `write-protect`): from a client that may
    /// only read ([`Network::allow_reading`]), or while the whole server is read-only
    /// (`set_read_only`). Each counts in [`TcpCounters::exceptions`] too.
    #[cfg(feature = "write-protect")]
    pub refused_writes: u16,
}

/// A counter's place in [`Server::counts`]: the order of [`TcpCounters`]'s fields.
#[derive(Clone, Copy)]
enum Count {
    Requests,
    Exceptions,
    BadProtocol,
    BadLength,
    OtherUnit,
    Connections,
    Refused,
    IdleClosed,
    Evicted,
    #[cfg(feature = "rtu-over-tcp")]
    BadFrame,
    #[cfg(feature = "udp")]
    BadDatagram,
    #[cfg(feature = "write-protect")]
    RefusedWrites,
}

/// How many counters there are: [`Count`]'s places (the chip's health counts its own).
const COUNTS: usize = Count::Evicted as usize
    + 1
    + cfg!(feature = "rtu-over-tcp") as usize
    + cfg!(feature = "udp") as usize
    + cfg!(feature = "write-protect") as usize;

/// Where a socket is, as the server last saw it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Phase {
    /// Not set up yet, or closed: to be opened.
    #[default]
    Closed,
    /// Listening.
    Listening,
    /// Connected and served.
    Connected,
    /// Closing (a FIN sent, or on its way to closed).
    Closing,
}

/// The server: its sockets' states, its counters and the one buffer of `B` bytes where each
/// request becomes its reply (header and PDU; 260 holds the longest).
pub struct Server<const B: usize = { mbap::MAX_ADU }> {
    /// Each socket's phase.
    phase: [Phase; SOCKETS],
    /// Each socket's whole seconds without a request (or, closing, since it began).
    idle: [u8; SOCKETS],
    /// Bit n: socket n has a SEND on its way, and the next waits for its SEND_OK.
    sending: u8,
    /// Each connected socket's Sn_RX_RD and Sn_TX_WR, read when it connected and kept here
    /// since (only the server moves them): four SPI frames a request fewer on the W5100.
    rx: [u16; SOCKETS],
    tx: [u16; SOCKETS],
    /// Sockets to look at in the next poll whatever their events say: requests left for
    /// lack of room to answer, a socket that must be opened.
    again: u8,
    /// Sockets with a whole request the handler could not take yet ([`Handler::ready`]):
    /// looked at again once [`Server::resume`] is called.
    waiting: u8,
    /// Bit n: socket n's connection changed (closed, or a new one) since it last handed a
    /// request over; an answer that comes later ([`Server::answer`]) is then for a
    /// connection that is gone.
    changed: u8,
    /// The socket looked at first: the one after the socket that last handed a request
    /// over, so that sockets take turns when the handler takes one at a time.
    first: u8,
    /// The counters, in the order of [`TcpCounters`]'s fields.
    counts: [u16; COUNTS],
    /// The chip's and the link's health (`super::health`).
    pub(crate) health: Health,
    /// Bit n: socket n's client may only read (feature `write-protect`, decided when it
    /// connected; the UDP socket's, for the datagram being served).
    #[cfg(feature = "write-protect")]
    readers: u8,
    /// Every client may only read ([`Server::set_read_only`]).
    #[cfg(feature = "write-protect")]
    read_only: bool,
    buf: [u8; B],
}

/// The bytes of the usual request, a read or a single write (FC 1-6): header and 5 bytes
/// of PDU. The buffer holds at least these.
const USUAL: usize = HEADER + 5;

/// Feature `rtu-over-tcp`: a socket may frame as RTU ([`Network::is_rtu`]).
const RTU_OVER_TCP: bool = cfg!(feature = "rtu-over-tcp");

/// The sockets the server keeps a state for: the most a chip has.
const SOCKETS: usize = Network::MAX_SOCKETS as usize;

/// What handling one request asks of the server.
pub trait Handler {
    /// Handles the request PDU of `pdu_len` bytes (its first bytes when the buffer is
    /// shorter) that starts at `adu[HEADER]`, writing the reply PDU over it; returns the
    /// reply PDU's length and whether it is an exception. `None`: no reply.
    fn handle(&mut self, adu: &mut [u8], pdu_len: usize) -> Option<(usize, bool)>;

    /// True for a handler that may not take a request at once ([`Handler::ready`]) or
    /// answers later ([`Server::answer`]): the server then takes turns among the sockets
    /// and follows their connections for late answers. A plain server has none of that
    /// code.
    const DEFERS: bool = false;

    /// True for a handler whose replies may be longer than the server's buffer: the
    /// server writes the buffer, then asks [`Handler::more`] for the rest.
    const LONG: bool = false;

    /// The reply's bytes from byte `at` of its ADU on (past the buffer), into `out`.
    #[inline(always)]
    fn more(&mut self, _at: usize, _out: &mut [u8]) {}

    /// True when a request can be taken now. When not, a whole request waits in the chip
    /// until [`Server::resume`] (a gateway whose serial line is busy).
    #[inline(always)]
    fn ready(&mut self) -> bool {
        true
    }

    /// True while a request of socket `s` is under way (its answer comes later, through
    /// [`Server::answer`]): a connection the master closed on its side is kept until then.
    #[inline(always)]
    fn owes(&self, _s: u8) -> bool {
        false
    }

    /// [`Handler::handle`], told where the request came from: socket `s` of `chip`, the
    /// ADU's first byte at `at` in its receive buffer (for a handler that reads more of
    /// it than the buffer holds, or answers later with [`Server::answer`]).
    #[inline(always)]
    fn handle_from<S: Sockets>(
        &mut self,
        adu: &mut [u8],
        pdu_len: usize,
        _chip: &mut S,
        _s: u8,
        _at: u16,
    ) -> Option<(usize, bool)> {
        self.handle(adu, pdu_len)
    }
}

/// What became of an answer given to [`Server::answer`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answered {
    /// Written and sent.
    Sent,
    /// The connection that asked is gone, or does not read: nothing written.
    Gone,
    /// Not now (a SEND on its way): try again at the next poll.
    Later,
}

impl<F: FnMut(&mut [u8], usize) -> Option<(usize, bool)>> Handler for F {
    fn handle(&mut self, adu: &mut [u8], pdu_len: usize) -> Option<(usize, bool)> {
        self(adu, pdu_len)
    }
}

impl<const B: usize> Default for Server<B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const B: usize> Server<B> {
    const FITS: () = assert!(B >= USUAL && B <= mbap::MAX_ADU, "the buffer holds 12 to 260 bytes");

    /// A server with every socket still to open.
    pub const fn new() -> Self {
        let () = Self::FITS;
        Server {
            phase: [Phase::Closed; SOCKETS],
            idle: [0; SOCKETS],
            sending: 0,
            rx: [0; SOCKETS],
            tx: [0; SOCKETS],
            again: 0xFF,
            waiting: 0,
            changed: 0,
            first: 0,
            counts: [0; COUNTS],
            health: Health::new(),
            #[cfg(feature = "write-protect")]
            readers: 0,
            #[cfg(feature = "write-protect")]
            read_only: false,
            buf: [0; B],
        }
    }

    /// The counters.
    pub fn counters(&self) -> TcpCounters {
        let [requests, exceptions, bad_protocol, bad_length, other_unit, connections, refused, idle_closed, evicted, ..] =
            self.counts;
        TcpCounters {
            requests,
            exceptions,
            bad_protocol,
            bad_length,
            other_unit,
            connections,
            refused,
            idle_closed,
            evicted,
            chip_resets: self.health.restarts(),
            link_losses: self.health.losses(),
            #[cfg(feature = "rtu-over-tcp")]
            bad_frame: self.counts[Count::BadFrame as usize],
            #[cfg(feature = "udp")]
            bad_datagrams: self.counts[Count::BadDatagram as usize],
            #[cfg(feature = "write-protect")]
            refused_writes: self.counts[Count::RefusedWrites as usize],
        }
    }

    /// Refuses every client's writes from now on (`true`), or gives the clients of
    /// [`Network::allow`] theirs back (feature `write-protect`): while a local panel holds a
    /// setpoint, say. Writes get exception 01 (Illegal Function), change nothing and are
    /// counted ([`TcpCounters::refused_writes`]); reads go on.
    #[cfg(feature = "write-protect")]
    pub fn set_read_only(&mut self, on: bool) {
        self.read_only = on;
    }

    /// True while every client's writes are refused ([`Server::set_read_only`]).
    #[cfg(feature = "write-protect")]
    pub fn is_read_only(&self) -> bool {
        self.read_only
    }

    /// True when a client at `peer` may connect to socket `s` (or send it a datagram); with
    /// feature `write-protect`, whether it may write is kept for the socket.
    #[cfg(not(feature = "write-protect"))]
    #[inline(always)]
    fn admits(&mut self, net: &Network, _s: u8, peer: [u8; 4]) -> bool {
        net.allows(peer)
    }

    /// True when a client at `peer` may connect to socket `s`; with feature
    /// `write-protect`, whether it may write is kept for the socket.
    #[cfg(feature = "write-protect")]
    #[inline(always)]
    fn admits(&mut self, net: &Network, s: u8, peer: [u8; 4]) -> bool {
        admits(&mut self.readers, net, s, peer)
    }

    /// The exception 01 for the request in the buffer when it writes and socket `s` may
    /// not (counted); `None` for any other, which the handler gets.
    #[cfg(feature = "write-protect")]
    fn refused_write(&mut self, s: u8) -> Option<(usize, bool)> {
        let refused =
            (self.read_only || self.readers & (1 << s) != 0) && crate::slave::pdu::is_write_code(self.buf[HEADER]);
        if !refused {
            return None;
        }
        self.bump(Count::RefusedWrites);
        let pdu = &mut self.buf[HEADER..];
        Some((crate::slave::pdu::encode_exception(pdu, crate::protocol::Exception::IllegalFunction), true))
    }

    /// Without feature `write-protect` every client writes.
    #[cfg(not(feature = "write-protect"))]
    #[inline(always)]
    fn refused_write(&mut self, _s: u8) -> Option<(usize, bool)> {
        None
    }

    /// One more in `counter`, wrapping ([`crate::link::bump`], not inlined).
    fn bump(&mut self, counter: Count) {
        crate::link::bump(&mut self.counts, counter as u8);
    }

    /// True when no socket waits to be looked at again (what the chip says aside).
    pub fn is_quiet(&self) -> bool {
        self.again == 0
    }

    /// Serves what the chip has: the sockets with events, and those left to look at again;
    /// with `second`, every socket, and the idle connections' time counted. Call it often
    /// (the AVR layer: every Timer0 overflow, 1.024 ms) and with `second` once a second.
    pub fn poll<S: Sockets, H: Handler>(&mut self, chip: &mut S, net: &Network, handler: &mut H, second: bool) {
        let serving = net.sockets.min(Network::MAX_SOCKETS);
        let mut look = chip.events() | core::mem::take(&mut self.again);
        if second {
            look = 0xFF;
        }
        // A plain server looks at its sockets in order; one whose handler defers takes
        // turns, from the socket after the one served last.
        #[cfg(not(feature = "udp"))]
        let slots = serving;
        // The UDP socket takes its turn after the TCP ones.
        #[cfg(feature = "udp")]
        let slots = serving + u8::from(net.udp != super::network::NO_UDP);
        let mut s = if H::DEFERS { self.first } else { 0 };
        for _ in 0..slots {
            if H::DEFERS && s >= slots {
                s = 0;
            }
            #[cfg(not(feature = "udp"))]
            let socket = s;
            #[cfg(feature = "udp")]
            let socket = if s == serving { net.udp } else { s };
            if look & (1 << socket) != 0 {
                self.service(chip, net, handler, socket, second);
            }
            s += 1;
        }
        if second {
            self.tick(chip, net, serving);
        }
    }

    /// Socket `s`: its events taken, its state followed, its requests answered. A
    /// connection whose only news is data (or a SEND done) is taken to be still connected
    /// without asking the chip, but in the once-a-second `sweep`: a close or a reset comes
    /// with its own event.
    fn service<S: Sockets, H: Handler>(&mut self, chip: &mut S, net: &Network, handler: &mut H, s: u8, sweep: bool) {
        let at = usize::from(s) % SOCKETS;
        let events = chip.take_events(s);
        if events & SENT != 0 {
            self.sending &= !(1 << s);
        }
        let phase = self.phase[at];
        let data_only = events & RECV != 0 && events & !(RECV | SEND_OK) == 0;
        let status = if data_only && phase == Phase::Connected && !sweep { state::ESTABLISHED } else { chip.status(s) };
        // The UDP socket is served as a connection is, but for what a connection's beginning
        // and end ask.
        #[cfg(not(feature = "udp"))]
        const UDP: u8 = state::ESTABLISHED;
        #[cfg(feature = "udp")]
        const UDP: u8 = state::UDP;
        match status {
            // Closed (reset, timed out, or never opened), or opened and not listening.
            state::CLOSED | state::INIT => self.open(chip, net, s),
            state::LISTEN => {}
            #[allow(unreachable_patterns)]
            status @ (state::ESTABLISHED | state::CLOSE_WAIT | UDP) => {
                #[cfg(not(feature = "udp"))]
                if phase != Phase::Connected {
                    if !self.admits(net, s, chip.peer(s)) {
                        self.bump(Count::Refused);
                        self.close(chip, net, s);
                        return;
                    }
                    self.enter(s, Phase::Connected);
                    self.rx[at] = chip.rx_pointer(s);
                    self.tx[at] = chip.tx_pointer(s);
                    self.bump(Count::Connections);
                }
                // The UDP socket just opened: no peer to check, no connection to count.
                #[cfg(feature = "udp")]
                if phase != Phase::Connected {
                    if s != net.udp {
                        if !self.admits(net, s, chip.peer(s)) {
                            self.bump(Count::Refused);
                            self.close(chip, net, s);
                            return;
                        }
                        self.bump(Count::Connections);
                    }
                    self.enter(s, Phase::Connected);
                    self.rx[at] = chip.rx_pointer(s);
                    self.tx[at] = chip.tx_pointer(s);
                }
                let left = self.serve(chip, handler, net, s);
                if status == state::CLOSE_WAIT && !left {
                    if H::DEFERS && handler.owes(s) {
                        // Its last answer is still to come: looked at again once it is
                        // sent (`resume`), and closed then.
                        self.waiting |= 1 << s;
                    } else {
                        // The master closed its side and every request it sent is answered.
                        chip.command(s, command::DISCON);
                        self.enter(s, Phase::Closing);
                        self.again |= 1 << s;
                    }
                }
            }
            // SYN received, FIN_WAIT, CLOSING, TIME_WAIT, LAST_ACK: on their way, looked at
            // again each poll (the chip says nothing when the last ACK comes and the socket
            // is closed), so that it listens again at once; one that stays is closed by
            // `tick`.
            _ => {
                if phase != Phase::Closing {
                    self.enter(s, Phase::Closing);
                }
                self.again |= 1 << s;
            }
        }
    }

    /// Socket `s` enters `phase`: its idle time from zero, no SEND on its way, its
    /// connection changed for answers to come.
    #[inline(never)]
    fn enter(&mut self, s: u8, phase: Phase) {
        let at = usize::from(s) % SOCKETS;
        self.phase[at] = phase;
        self.idle[at] = 0;
        self.sending &= !(1 << s);
        self.changed |= 1 << s;
    }

    /// The sockets left waiting for the handler ([`Handler::ready`]) are looked at in the
    /// next poll.
    pub fn resume(&mut self) {
        self.again |= core::mem::take(&mut self.waiting);
    }

    /// How many sockets hold a whole request the handler has not taken yet.
    pub fn waiting(&self) -> u8 {
        self.waiting.count_ones() as u8
    }

    /// Sends a reply of `len` bytes (header and PDU) on socket `s`, for a request it
    /// handed over earlier ([`Handler::handle_from`] returned `None`): `fill` writes the
    /// bytes into the chip from the pointer it gets, with the server's buffer as scratch.
    /// [`Answered::Gone`] when that connection has closed or another has taken the socket
    /// since, or its transmit buffer lacks room (its master does not read), and nothing is
    /// written; [`Answered::Later`] while a SEND is on its way. `exception`: the reply is one (counted).
    pub fn answer<S: Sockets>(
        &mut self,
        chip: &mut S,
        s: u8,
        len: u16,
        exception: bool,
        fill: impl FnOnce(&mut S, u16, &mut [u8]),
    ) -> Answered {
        let at = usize::from(s) % SOCKETS;
        // A datagram's answer goes to its sender, still in Sn_DIPR and Sn_DPORT (`serve`).
        if self.changed & (1 << s) != 0 || self.phase[at] != Phase::Connected {
            return Answered::Gone;
        }
        if self.sending & (1 << s) != 0 {
            self.again |= 1 << s;
            return Answered::Later;
        }
        if chip.tx_free(s) < len {
            // The master does not read its answers: this one is not kept waiting (it would
            // hold up whatever waits for it).
            return Answered::Gone;
        }
        let tx = self.tx[at];
        fill(chip, tx, &mut self.buf);
        let tx = tx.wrapping_add(len);
        chip.send(s, tx);
        self.tx[at] = tx;
        self.sending |= 1 << s;
        self.idle[at] = 0;
        self.bump(Count::Requests);
        if exception {
            self.bump(Count::Exceptions);
        }
        Answered::Sent
    }

    /// Opens socket `s` and listens on the port.
    fn open<S: Sockets>(&mut self, chip: &mut S, net: &Network, s: u8) {
        #[cfg(not(feature = "udp"))]
        chip.listen(s, net.port_of(s));
        // The UDP socket: opened, then taken up as a connection is (`service`).
        #[cfg(feature = "udp")]
        chip.open(s, net.port_of(s), s == net.udp);
        self.enter(s, Phase::Listening);
    }

    /// Closes socket `s` at once (an RST to its peer) and listens again.
    fn close<S: Sockets>(&mut self, chip: &mut S, net: &Network, s: u8) {
        chip.command(s, command::CLOSE);
        self.open(chip, net, s);
    }

    /// Answers the whole requests socket `s` holds, in order, their replies sent with one
    /// SEND. True when requests are left (no room to answer, or a SEND on its way). A socket
    /// of RTU over TCP ([`Network::is_rtu`], feature `rtu-over-tcp`) differs in three places
    /// only: how a frame is found (`Server::frame_rtu`, server/rtu.rs: its address at the unit id's
    /// place, its PDU where an MBAP request's is), no answer to address 0, and the reply
    /// sent from the address on with a CRC after it.
    fn serve<S: Sockets, H: Handler>(&mut self, chip: &mut S, handler: &mut H, net: &Network, s: u8) -> bool {
        if self.sending & (1 << s) != 0 {
            // Looked at again until its SEND_OK (which need not reach the INT line).
            self.again |= 1 << s;
            return true;
        }
        let rtu = RTU_OVER_TCP && net.is_rtu(s);
        // Where the bytes sent start in the buffer: the header, or an RTU frame's address.
        let start = if rtu { HEADER - 1 } else { 0 };
        let least = if rtu { rtu::MIN_FRAME } else { HEADER as u16 };
        let mut received = chip.received(s);
        if received < least {
            return false;
        }
        #[cfg(feature = "udp")]
        let udp = s == net.udp;
        let at = usize::from(s) % SOCKETS;
        let rx_start = self.rx[at];
        let mut rx = rx_start;
        let mut free = chip.tx_free(s);
        let tx_start = self.tx[at];
        let mut tx = tx_start;
        let mut left = false;
        while received >= least {
            if H::DEFERS && !handler.ready() {
                // Taken when the handler is ready (`resume`).
                self.waiting |= 1 << s;
                left = true;
                break;
            }
            let (header, adu, first) = if rtu {
                // Whole and its CRC good, or left (a bad one discarded).
                let len = self.frame_rtu(chip, s, &mut rx, &mut received);
                if len == 0 {
                    break;
                }
                let header = Header { transaction: 0, length: len - 2, unit: self.buf[start] };
                (header, len, (start + usize::from(len)).min(B))
            } else {
                // A datagram: the chip's header (sender, length), then one ADU of that length.
                #[cfg(feature = "udp")]
                let mut datagram = 0;
                #[cfg(feature = "udp")]
                if udp {
                    if received < UDP_HEADER as u16 {
                        break;
                    }
                    // The chip's header, at the buffer's front (the ADU's read overwrites it).
                    let head = &mut self.buf[..UDP_HEADER];
                    chip.read(s, rx, head);
                    datagram = u16::from_be_bytes([head[6], head[7]]);
                    if received - (UDP_HEADER as u16) < datagram {
                        // Not all there (the count read as a datagram landed): the next poll.
                        break;
                    }
                    rx = rx.wrapping_add(UDP_HEADER as u16);
                    received -= UDP_HEADER as u16;
                    // An address not allowed costs this header's read and nothing more.
                    #[cfg(not(feature = "write-protect"))]
                    let admitted = net.allows([head[0], head[1], head[2], head[3]]);
                    // The sender's right to write, kept for this datagram.
                    #[cfg(feature = "write-protect")]
                    let admitted = admits(&mut self.readers, net, s, [head[0], head[1], head[2], head[3]]);
                    if !admitted {
                        self.bump(Count::Refused);
                        rx = rx.wrapping_add(datagram);
                        received -= datagram;
                        continue;
                    }
                    // Its answer's destination. Sn_DIPR and Sn_DPORT keep it while the
                    // request is under way: no other datagram is read before it is answered.
                    chip.set_peer(s, &mut head[..6]);
                }
                // The header and, in the same transfer, the body of the usual request (FC
                // 1-6: 12 bytes in all); a longer one's rest below.
                let first = usize::from(received).min(USUAL);
                chip.read(s, rx, &mut self.buf[..first]);
                let (head, _) = self.buf.split_at_mut(HEADER);
                let head: &mut [u8; HEADER] = head.try_into().unwrap_or_else(|_| unreachable!());
                let parsed = Header::parse(head);
                // A datagram is one ADU, its length the header's: else it is dropped whole,
                // counted for its protocol id when its length is right (one shorter than a
                // header has none: what was read past it is not its own).
                #[cfg(feature = "udp")]
                if udp && !matches!(parsed, Ok(header) if header.adu_len() == datagram) {
                    let whole = Header::skip(head) == Some(datagram);
                    self.bump(if whole { Count::BadProtocol } else { Count::BadDatagram });
                    rx = rx.wrapping_add(datagram);
                    received -= datagram;
                    continue;
                }
                let header = match parsed {
                    Ok(header) => header,
                    Err(Refused::Protocol) => {
                        let skip = Header::skip(head).unwrap_or(0);
                        if received < skip {
                            left = true;
                            break;
                        }
                        self.bump(Count::BadProtocol);
                        rx = rx.wrapping_add(skip);
                        received -= skip;
                        continue;
                    }
                    Err(Refused::Length) => {
                        self.bump(Count::BadLength);
                        self.close(chip, net, s);
                        return false;
                    }
                };
                (header, header.adu_len(), first)
            };
            if received < adu {
                // The rest is on its way.
                break;
            }
            if !net.answers(header.unit) {
                self.bump(Count::OtherUnit);
                rx = rx.wrapping_add(adu);
                received -= adu;
                continue;
            }
            if usize::from(free) < if H::LONG { mbap::MAX_ADU } else { B } {
                // No room for the longest reply: the master is not reading. Its requests
                // wait; the other sockets go on.
                #[cfg(feature = "udp")]
                if udp {
                    // The datagram's chip header too.
                    rx = rx.wrapping_sub(UDP_HEADER as u16);
                }
                left = true;
                break;
            }
            let pdu_len = usize::from(header.length - 1);
            let body = &mut self.buf[HEADER..];
            let kept = pdu_len.min(body.len());
            if kept > first - HEADER {
                chip.read(s, rx.wrapping_add(first as u16), &mut body[first - HEADER..kept]);
            }
            // Where the ADU starts in the chip (an RTU frame's PDU where an ADU's would be).
            let from = rx.wrapping_sub(start as u16);
            rx = rx.wrapping_add(adu);
            received -= adu;
            if H::DEFERS {
                self.changed &= !(1 << s);
                self.first = s + 1;
            }
            // A write from a client that may only read is answered here: no handler sees it.
            let answer = match self.refused_write(s) {
                Some(refused) => Some(refused),
                None => handler.handle_from(&mut self.buf, pdu_len, chip, s, from),
            };
            let Some((reply, exception)) = answer else {
                continue;
            };
            if rtu && header.unit == 0 {
                // A broadcast (Serial Line §2.1): done, unanswered.
                continue;
            }
            self.bump(Count::Requests);
            if exception {
                self.bump(Count::Exceptions);
            }
            let len = if H::LONG { HEADER + reply } else { (HEADER + reply).min(B) };
            mbap::seal(&mut self.buf, len - HEADER);
            let mut crc = Crc16::new();
            if rtu {
                crc = crc.update_slice(&self.buf[start..len.min(B)]);
            }
            chip.write(s, tx, &mut self.buf[start..len.min(B)]);
            // A long reply's rest, a buffer at a time.
            let mut done = B;
            while H::LONG && done < len {
                let chunk = &mut self.buf[..(len - done).min(B)];
                handler.more(done, chunk);
                if rtu {
                    crc = crc.update_slice(chunk);
                }
                chip.write(s, tx.wrapping_add((done - start) as u16), chunk);
                done += chunk.len();
            }
            let mut len = len - start;
            if rtu {
                let mut tail = crc.to_wire();
                chip.write(s, tx.wrapping_add(len as u16), &mut tail);
                len += 2;
            }
            tx = tx.wrapping_add(len as u16);
            free -= len as u16;
            self.idle[usize::from(s) % SOCKETS] = 0;
            // One datagram, one SEND: the next after its SEND_OK.
            #[cfg(feature = "udp")]
            if udp {
                left = received != 0;
                break;
            }
        }
        // The replies' SEND first: the request's bytes are taken after it.
        if tx != tx_start {
            chip.send(s, tx);
            self.sending |= 1 << s;
            self.tx[at] = tx;
        }
        if rx != rx_start {
            chip.take(s, rx);
            self.rx[at] = rx;
        }
        if left && (!H::DEFERS || self.waiting & (1 << s) == 0) {
            self.again |= 1 << s;
        }
        left
    }

    /// A second passed: idle connections' time counted, those past the timeout closed, the
    /// one idle longest closed for a newcomer when no socket listens, sockets stuck on
    /// their way to closed closed.
    fn tick<S: Sockets>(&mut self, chip: &mut S, net: &Network, serving: u8) {
        let mut listening = false;
        let mut oldest: Option<(u8, u8)> = None;
        for s in 0..serving {
            let at = usize::from(s) % SOCKETS;
            let idle = self.idle[at].saturating_add(1);
            self.idle[at] = idle;
            match self.phase[at] {
                Phase::Connected if net.idle_timeout_s != 0 && idle >= net.idle_timeout_s => {
                    self.bump(Count::IdleClosed);
                    self.close(chip, net, s);
                    listening = true;
                }
                Phase::Connected => {
                    if oldest.map_or(true, |(_, most)| idle > most) {
                        oldest = Some((s, idle));
                    }
                }
                Phase::Closing if idle >= 2 => {
                    self.close(chip, net, s);
                    listening = true;
                }
                Phase::Listening | Phase::Closed => listening = true,
                Phase::Closing => {}
            }
        }
        if let (false, Some((s, idle))) = (listening, oldest) {
            if idle >= net.evict_after_s {
                self.bump(Count::Evicted);
                self.close(chip, net, s);
            }
        }
    }
}

/// True when a client at `peer` may connect to socket `s` (or send it a datagram), and its
/// right to write kept in `readers` (bit `s` set: it may only read). Feature `write-protect`.
#[cfg(feature = "write-protect")]
#[inline(always)]
fn admits(readers: &mut u8, net: &Network, s: u8, peer: [u8; 4]) -> bool {
    use super::network::Rights;
    let rights = net.rights(peer);
    if rights == Rights::Write {
        *readers &= !(1 << s);
    } else {
        *readers |= 1 << s;
    }
    rights != Rights::None
}

/// RTU over TCP's sockets served (feature `rtu-over-tcp`).
#[cfg(feature = "rtu-over-tcp")]
mod rtu;

/// Without feature `rtu-over-tcp` no socket frames as RTU ([`Network::is_rtu`]).
#[cfg(not(feature = "rtu-over-tcp"))]
mod rtu {
    use super::{Server, Sockets};

    /// The fewest bytes a frame has.
    pub(super) const MIN_FRAME: u16 = 4;

    impl<const B: usize> Server<B> {
        /// Never called: no socket frames as RTU.
        #[inline(always)]
        pub(super) fn frame_rtu<S: Sockets>(
            &mut self,
            _chip: &mut S,
            _s: u8,
            _rx: &mut u16,
            _received: &mut u16,
        ) -> u16 {
            0
        }
    }
}
#[cfg(test)]
mod tests;
#[cfg(all(test, feature = "udp"))]
mod udp_tests;
