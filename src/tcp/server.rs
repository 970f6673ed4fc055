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

use super::health::Health;
use super::mbap::{self, Header, Refused, HEADER};
use super::network::Network;
use super::wiznet::{command, state, RECV, SEND_OK};

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
    /// Connections refused by the allow-list.
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
}

/// How many counters there are.
const COUNTS: usize = Count::Evicted as usize + 1;

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
    buf: [u8; B],
}

/// The bytes of the usual request, a read or a single write (FC 1-6): header and 5 bytes
/// of PDU. The buffer holds at least these.
const USUAL: usize = HEADER + 5;

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
            buf: [0; B],
        }
    }

    /// The counters.
    pub fn counters(&self) -> TcpCounters {
        let [requests, exceptions, bad_protocol, bad_length, other_unit, connections, refused, idle_closed, evicted] =
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
        }
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
        let mut s = if H::DEFERS { self.first } else { 0 };
        for _ in 0..serving {
            if H::DEFERS && s >= serving {
                s = 0;
            }
            if look & (1 << s) != 0 {
                self.service(chip, net, handler, s, second);
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
        if events & SEND_OK != 0 {
            self.sending &= !(1 << s);
        }
        let phase = self.phase[at];
        let data_only = events & RECV != 0 && events & !(RECV | SEND_OK) == 0;
        let status = if data_only && phase == Phase::Connected && !sweep { state::ESTABLISHED } else { chip.status(s) };
        match status {
            // Closed (reset, timed out, or never opened), or opened and not listening.
            state::CLOSED | state::INIT => self.open(chip, net, s),
            state::LISTEN => {}
            status @ (state::ESTABLISHED | state::CLOSE_WAIT) => {
                if phase != Phase::Connected {
                    if !net.allows(chip.peer(s)) {
                        self.bump(Count::Refused);
                        self.close(chip, net, s);
                        return;
                    }
                    self.enter(s, Phase::Connected);
                    self.rx[at] = chip.rx_pointer(s);
                    self.tx[at] = chip.tx_pointer(s);
                    self.bump(Count::Connections);
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
        chip.listen(s, net.port);
        self.enter(s, Phase::Listening);
    }

    /// Closes socket `s` at once (an RST to its peer) and listens again.
    fn close<S: Sockets>(&mut self, chip: &mut S, net: &Network, s: u8) {
        chip.command(s, command::CLOSE);
        self.open(chip, net, s);
    }

    /// Answers the whole requests socket `s` holds, in order, their replies sent with one
    /// SEND. True when requests are left (no room to answer, or a SEND on its way).
    fn serve<S: Sockets, H: Handler>(&mut self, chip: &mut S, handler: &mut H, net: &Network, s: u8) -> bool {
        if self.sending & (1 << s) != 0 {
            // Looked at again until its SEND_OK (which need not reach the INT line).
            self.again |= 1 << s;
            return true;
        }
        let mut received = chip.received(s);
        if received < HEADER as u16 {
            return false;
        }
        let at = usize::from(s) % SOCKETS;
        let rx_start = self.rx[at];
        let mut rx = rx_start;
        let mut free = chip.tx_free(s);
        let tx_start = self.tx[at];
        let mut tx = tx_start;
        let mut left = false;
        while received >= HEADER as u16 {
            if H::DEFERS && !handler.ready() {
                // Taken when the handler is ready (`resume`).
                self.waiting |= 1 << s;
                left = true;
                break;
            }
            // The header and, in the same transfer, the body of the usual request (FC 1-6:
            // 12 bytes in all); a longer one's rest below.
            let first = usize::from(received).min(USUAL);
            chip.read(s, rx, &mut self.buf[..first]);
            let (head, body) = self.buf.split_at_mut(HEADER);
            let head: &mut [u8; HEADER] = head.try_into().unwrap_or_else(|_| unreachable!());
            let header = match Header::parse(head) {
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
            let adu = header.adu_len();
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
                left = true;
                break;
            }
            let pdu_len = usize::from(header.length - 1);
            let kept = pdu_len.min(body.len());
            if kept > first - HEADER {
                chip.read(s, rx.wrapping_add(first as u16), &mut body[first - HEADER..kept]);
            }
            let from = rx;
            rx = rx.wrapping_add(adu);
            received -= adu;
            if H::DEFERS {
                self.changed &= !(1 << s);
                self.first = s + 1;
            }
            let Some((reply, exception)) = handler.handle_from(&mut self.buf, pdu_len, chip, s, from) else {
                continue;
            };
            self.bump(Count::Requests);
            if exception {
                self.bump(Count::Exceptions);
            }
            let len = if H::LONG { HEADER + reply } else { (HEADER + reply).min(B) };
            mbap::seal(&mut self.buf, len - HEADER);
            chip.write(s, tx, &mut self.buf[..len.min(B)]);
            // A long reply's rest, a buffer at a time.
            let mut done = B;
            while H::LONG && done < len {
                let chunk = &mut self.buf[..(len - done).min(B)];
                handler.more(done, chunk);
                chip.write(s, tx.wrapping_add(done as u16), chunk);
                done += chunk.len();
            }
            tx = tx.wrapping_add(len as u16);
            free -= len as u16;
            self.idle[usize::from(s) % SOCKETS] = 0;
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

#[cfg(test)]
mod tests;
