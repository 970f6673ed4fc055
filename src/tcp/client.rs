//! The Modbus TCP client (features `tcp` and `master`), Implementation Guide v1.0b §4.2.1
//! (the client opens a connection and keeps it) and §3.1.3 (the MBAP header: a reply is
//! paired with its request by the transaction id), above any chip that offers TCP sockets
//! ([`Connect`]).
//!
//! One connection, on socket 0, to one server, opened at the first poll and opened again
//! whenever it drops (at once after a drop, every second while the server refuses or does
//! not answer). One request at a time: the application starts it, the poll sends it once the
//! connection is up, and the outcome waits for the application, as the RTU master's does
//! (the same [`Request`], [`Reply`](crate::master::Reply), [`Failure`], [`Timeouts`] and
//! [`MasterCounters`]). One request at a time keeps the RAM at one request and one reply
//! (what the RTU master holds) and the pairing trivial; a second one in flight would save
//! a round trip only for an application that asks faster than the server answers, and
//! Modbus servers on small devices serve one request at a time anyway.
//!
//! A reply is read only once it is whole in the chip (header first, checked before its
//! length decides anything), so a reply split over segments waits in the chip and the
//! stream never falls out of step by our doing. An ADU with another transaction id (a late
//! reply to an earlier request, a server's mistake) is skipped and the wait goes on; so is
//! one with another unit id. A protocol id other than 0 skips the ADU; a length outside
//! 2–254 closes the connection (the stream cannot be followed) and a new one is opened.

use super::mbap::{Header, Refused, HEADER};
use super::server::Sockets;
use super::wiznet::{command, state};
use crate::error::Error;
use crate::master::reply::{Reply, Verdict};
use crate::master::request::{Expect, Request};
use crate::master::{Failure, MasterCounters, Timeouts};

/// What the client needs of a chip beside the server's [`Sockets`]: a connection of its own.
pub trait Connect: Sockets {
    /// Opens socket `s` for TCP on `local_port` and connects it to `ip`:`port` (a SYN goes
    /// out: `SYNSENT`, then `ESTABLISHED`, or `CLOSED` when refused or timed out).
    fn connect(&mut self, s: u8, local_port: u16, ip: [u8; 4], port: u16);
}

/// The socket the client uses.
const SOCKET: u8 = 0;
/// How long a SYN may go unanswered before the client gives up and tries again
/// (milliseconds): a refusal (an RST) closes the socket at once, a server that is not there
/// would keep it waiting for the chip's own retransmissions (about 31 s on a W5100).
const CONNECT_MS: u32 = 3000;
/// The wait before another connection after one failed (milliseconds).
const RETRY_MS: u32 = 1000;
/// How often the socket's state is read even without an event (milliseconds): an event
/// missed costs at most this.
const SWEEP_MS: u32 = 1000;
/// The first local port; each connection takes the next, up to 0xFFFF, so that a server
/// never mistakes a new connection for the last one.
const FIRST_PORT: u16 = 0xC000;

/// A counter's place in [`Client::counts`]: the order of [`MasterCounters`]'s fields.
#[derive(Clone, Copy)]
enum Count {
    Requests,
    Overruns = 3,
    Malformed,
    Replies,
    Exceptions,
    Timeouts,
    Retries,
    Unexpected,
}

const COUNTS: usize = Count::Unexpected as usize + 1;

/// Where the connection is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Link {
    /// None; another is tried once `link_at` has passed.
    Closed,
    /// A SYN sent; given up at `link_at`.
    Connecting,
    /// Up.
    Connected,
}

/// Where a request is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// No request.
    Idle,
    /// Started (or to be sent again), waiting for the connection and room in the chip.
    Due,
    /// Sent; waiting for its reply.
    Waiting,
    /// The outcome is ready for the application.
    Done,
}

/// The client: the connection's state, the request as sent (kept for retries and for
/// checking the reply), the reply, the counters. `N` bytes each for the request and the
/// reply, counted as the RTU master counts them (unit id, PDU and two bytes the TCP framing
/// does not use): the same `N` serves both masters.
pub struct Client<const N: usize> {
    ip: [u8; 4],
    port: u16,
    timeouts: Option<Timeouts>,
    failure: Option<Failure>,
    link: Link,
    /// When the link may try again (`Closed`) or gives up (`Connecting`), milliseconds.
    link_at: u32,
    local_port: u16,
    connections: u16,
    /// When the socket's state is next read whatever its events say, milliseconds.
    sweep_at: u32,
    state: State,
    transaction: u16,
    /// The request: unit id and PDU, as [`Request::encode`] writes an RTU frame.
    request: [u8; N],
    request_len: usize,
    expect: Expect,
    /// The reply: unit id and PDU.
    reply: [u8; N],
    /// The answer's PDU bytes after the function code.
    answer: u8,
    retries_left: u8,
    /// When the current try times out, milliseconds.
    deadline: u32,
    counts: [u16; COUNTS],
}

/// True once the clock reads `at` or later (by less than half its range).
fn reached(now: u32, at: u32) -> bool {
    now.wrapping_sub(at) as i32 >= 0
}

impl<const N: usize> Client<N> {
    /// A client of the server at `ip`:`port`, not connected yet: the first [`Client::poll`]
    /// connects.
    pub const fn new(ip: [u8; 4], port: u16) -> Self {
        Client {
            ip,
            port,
            timeouts: None,
            failure: None,
            link: Link::Closed,
            link_at: 0,
            local_port: 0,
            connections: 0,
            sweep_at: 0,
            state: State::Idle,
            transaction: 0,
            request: [0; N],
            request_len: 0,
            expect: Expect::NONE,
            reply: [0; N],
            answer: 0,
            retries_left: 0,
            deadline: 0,
            counts: [0; COUNTS],
        }
    }

    /// Sets the response timeout and the retries, from the next request on (the turnaround
    /// delay is the serial line's broadcast's: unused here).
    pub fn set_timeouts(&mut self, timeouts: Timeouts) {
        self.timeouts = Some(timeouts);
    }

    /// The timeouts in use.
    pub fn timeouts(&self) -> Timeouts {
        self.timeouts.unwrap_or(Timeouts::DEFAULT)
    }

    /// The counters: `crc_errors` and `uart_errors` stay 0 (TCP checks the bytes);
    /// `malformed` counts ADUs with a protocol id other than 0 or a length outside 2–254,
    /// `overruns` replies longer than the buffer, `unexpected` ADUs with another transaction
    /// or unit id, with no request waiting, or that do not answer the request.
    pub fn counters(&self) -> MasterCounters {
        // CRC and UART errors stay 0: no count of this client's goes there.
        MasterCounters::from_counts(self.counts)
    }

    /// Connections made so far (wrapping): one more after each drop.
    pub fn connections(&self) -> u16 {
        self.connections
    }

    /// True while the connection is up.
    pub fn is_connected(&self) -> bool {
        self.link == Link::Connected
    }

    /// True while there is nothing to do but watch the connection: connected, and no request
    /// under way. A poll that finds the chip without events then changes nothing until the
    /// sweep is due, and a caller may leave it out (at least once a second).
    pub fn is_quiet(&self) -> bool {
        self.link == Link::Connected && matches!(self.state, State::Idle | State::Done)
    }

    /// True from [`Client::start`] until the outcome is collected ([`Client::collect`]).
    pub fn is_busy(&self) -> bool {
        self.state != State::Idle
    }

    fn count(&mut self, count: Count) {
        crate::link::bump(&mut self.counts, count as u8);
    }

    /// Starts `request` to unit `unit` (0xFF: the server itself, Guide §4.4.1.2; any id is
    /// sent as given and its reply awaited) at `now` (milliseconds): built now, sent at the
    /// next poll. [`Error::NotConnected`] while the connection is down (the request is not
    /// kept: ask again later), [`Error::Busy`] while a request is under way or its outcome
    /// waits; a request refused leaves everything as it was.
    pub fn start(&mut self, unit: u8, request: &Request<'_>, now: u32) -> Result<(), Error> {
        if self.is_busy() {
            return Err(Error::Busy);
        }
        if self.link != Link::Connected {
            return Err(Error::NotConnected);
        }
        // Built as to slave 1 (never a broadcast), then the unit id put in its place.
        let (len, mut expect) = request.encode(1, &mut self.request, N)?;
        self.request[0] = unit;
        expect.slave = unit;
        self.request_len = len;
        self.expect = expect;
        self.transaction = self.transaction.wrapping_add(1);
        self.retries_left = self.timeouts().retries;
        self.due(now);
        Ok(())
    }

    /// A try begins at `now`: sent as soon as the connection allows, its timeout running.
    fn due(&mut self, now: u32) {
        self.state = State::Due;
        self.deadline = now.wrapping_add(u32::from(self.timeouts().response_ms));
    }

    /// The current try ended without an answer: again while retries are left (with the same
    /// transaction id: a late reply to an earlier try answers the same request), else the
    /// outcome is `failure`.
    fn attempt_failed(&mut self, failure: Failure, now: u32) {
        if self.retries_left == 0 {
            self.finish(Some(failure));
        } else {
            self.retries_left -= 1;
            self.count(Count::Retries);
            self.due(now);
        }
    }

    fn finish(&mut self, failure: Option<Failure>) {
        self.failure = failure;
        self.state = State::Done;
    }

    /// Connects, sends, receives and times out: call it often (the AVR layer: every Timer0
    /// overflow, 1.024 ms) with the clock's milliseconds.
    pub fn poll<S: Connect>(&mut self, chip: &mut S, now: u32) {
        match self.link {
            Link::Closed => {
                if reached(now, self.link_at) {
                    self.local_port = self.local_port.wrapping_add(1) | FIRST_PORT;
                    chip.connect(SOCKET, self.local_port, self.ip, self.port);
                    self.link = Link::Connecting;
                    self.link_at = now.wrapping_add(CONNECT_MS);
                }
            }
            Link::Connecting => match chip.status(SOCKET) {
                state::ESTABLISHED => {
                    self.link = Link::Connected;
                    self.connections = self.connections.wrapping_add(1);
                }
                state::SYNSENT if !reached(now, self.link_at) => {}
                _ => self.close(chip, now.wrapping_add(RETRY_MS)),
            },
            Link::Connected => {
                // One register read when nothing happened: the socket has no event (data,
                // a close, a timeout), and no sweep is due.
                let sweep = reached(now, self.sweep_at);
                if chip.events() & 1 << SOCKET == 0 && !sweep {
                    return self.tick(chip, now);
                }
                if sweep {
                    self.sweep_at = now.wrapping_add(SWEEP_MS);
                }
                chip.take_events(SOCKET);
                let status = chip.status(SOCKET);
                if status == state::ESTABLISHED || status == state::CLOSE_WAIT {
                    // What the server sent before it closed is still read.
                    self.receive(chip, now);
                }
                if self.link == Link::Connected && status != state::ESTABLISHED {
                    // The server closed (FIN), reset, or the chip gave up: a new connection
                    // at once.
                    self.close(chip, now);
                }
            }
        }
        self.tick(chip, now);
    }

    /// The request's timeout checked, and a request due sent.
    fn tick<S: Sockets>(&mut self, chip: &mut S, now: u32) {
        if matches!(self.state, State::Due | State::Waiting) && now.wrapping_sub(self.deadline) as i32 > 0 {
            self.count(Count::Timeouts);
            self.attempt_failed(Failure::Timeout, now);
        }
        if self.state == State::Due && self.link == Link::Connected {
            self.transmit(chip);
        }
    }

    /// The connection dropped and made again at the next poll: the chip was set up again
    /// (`super::health`), or the link went. A request under way is sent again on the new
    /// connection, or times out as usual.
    pub fn reconnect<S: Sockets>(&mut self, chip: &mut S, now: u32) {
        self.close(chip, now);
    }

    /// Closes the socket (an RST to a connected server); another connection at `retry_at`.
    fn close<S: Sockets>(&mut self, chip: &mut S, retry_at: u32) {
        chip.command(SOCKET, command::CLOSE);
        self.link = Link::Closed;
        self.link_at = retry_at;
    }

    /// Sends the request with its MBAP header, once the chip has room for it.
    fn transmit<S: Sockets>(&mut self, chip: &mut S) {
        let len = self.request_len.min(N);
        let adu = (HEADER - 1 + len) as u16;
        if chip.tx_free(SOCKET) < adu {
            return;
        }
        let [t0, t1] = self.transaction.to_be_bytes();
        let [l0, l1] = (len as u16).to_be_bytes();
        // Transaction id, protocol id 0, length (unit id and PDU): the request's unit id
        // follows, as its first byte.
        let mut head = [t0, t1, 0, 0, l0, l1];
        let at = chip.tx_pointer(SOCKET);
        chip.write(SOCKET, at, &mut head);
        // The chip's `write` leaves the bytes as they are: the request stays for a retry.
        chip.write(SOCKET, at.wrapping_add(6), &mut self.request[..len]);
        chip.send(SOCKET, at.wrapping_add(adu));
        self.count(Count::Requests);
        self.state = State::Waiting;
    }

    /// Takes every whole ADU the chip holds: the reply, when it is there; anything else
    /// skipped and counted.
    fn receive<S: Sockets>(&mut self, chip: &mut S, now: u32) {
        let mut received = chip.received(SOCKET);
        if received < HEADER as u16 {
            return;
        }
        let start = chip.rx_pointer(SOCKET);
        let mut rx = start;
        while received >= HEADER as u16 {
            let mut head = [0; HEADER];
            chip.read(SOCKET, rx, &mut head);
            let header = match Header::parse(&head) {
                Ok(header) => header,
                Err(Refused::Protocol) => {
                    let skip = Header::skip(&head).unwrap_or(u16::MAX);
                    if received < skip {
                        break;
                    }
                    self.count(Count::Malformed);
                    rx = rx.wrapping_add(skip);
                    received -= skip;
                    continue;
                }
                Err(Refused::Length) => {
                    // The stream cannot be followed: a new connection, and the try failed.
                    self.count(Count::Malformed);
                    self.close(chip, now);
                    if self.state == State::Waiting {
                        self.attempt_failed(Failure::BadReply, now);
                    }
                    return;
                }
            };
            let adu = header.adu_len();
            if received < adu {
                // The rest is on its way.
                break;
            }
            let pdu_at = rx.wrapping_add(HEADER as u16);
            rx = rx.wrapping_add(adu);
            received -= adu;
            if self.state != State::Waiting || header.transaction != self.transaction {
                self.count(Count::Unexpected);
                continue;
            }
            // Unit id, PDU, and the two bytes of an RTU frame's CRC that `Expect` counts.
            let pdu_len = usize::from(header.length - 1);
            let len = pdu_len + 3;
            let Some(pdu) = self.reply.get_mut(1..pdu_len + 1).filter(|_| len <= N) else {
                self.count(Count::Overruns);
                self.attempt_failed(Failure::BadReply, now);
                continue;
            };
            chip.read(SOCKET, pdu_at, pdu);
            self.reply[0] = header.unit;
            match self.expect.check(&self.request, &self.reply, len) {
                Verdict::Answer => {
                    self.count(Count::Replies);
                    self.answer = (pdu_len - 1) as u8;
                    self.finish(None);
                }
                Verdict::Exception(code) => {
                    self.count(Count::Replies);
                    self.count(Count::Exceptions);
                    self.finish(Some(Failure::Exception(code)));
                }
                Verdict::OtherSlave => self.count(Count::Unexpected),
                Verdict::Mismatch => {
                    self.count(Count::Unexpected);
                    self.attempt_failed(Failure::BadReply, now);
                }
            }
        }
        if rx != start {
            chip.take(SOCKET, rx);
        }
    }

    /// The outcome, once the request is done: the reply, read in place, or why there is
    /// none. `None` while a request is under way or when there is none.
    pub fn outcome(&self) -> Option<Result<Reply<'_>, Failure>> {
        if self.state != State::Done {
            return None;
        }
        Some(match self.failure {
            Some(failure) => Err(failure),
            None => Ok(Reply::new(&self.reply, self.answer, &self.expect)),
        })
    }

    /// The outcome was collected: the client takes the next request.
    pub fn collect(&mut self) {
        if self.state == State::Done {
            self.state = State::Idle;
        }
    }
}

#[cfg(test)]
mod tests;
