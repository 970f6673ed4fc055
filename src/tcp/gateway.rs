//! The Modbus TCP to RTU gateway's rules, Implementation Guide v1.0b §4.4.1.2 (unit ids)
//! and §4.4.2.5 (exceptions 0A and 0B), above the TCP server (`super::server`) and the RTU
//! master's engine (through [`RtuSide`]).
//!
//! TCP allows many requests at once, the serial line one. The queue is the chip's: a
//! request stays in its connection's receive buffer until the line is free, then it is
//! read straight into the master's request buffer and sent. The connections take turns
//! (the server looks first at the one after the connection served last); a connection's
//! own requests go in the order they came, each answered before the next is taken. So no
//! RAM holds a queue, no request is ever dropped for lack of room (a full receive buffer
//! closes the TCP window: the master waits), and one buffer of RAM per direction serves
//! every connection.
//!
//! Unit ids: the gateway's own ([`GatewaySettings::own_unit`], 0xFF by default: "the
//! device itself", §4.4.1.2) is answered from its own registers (counters, the slaves'
//! health: [`STATUS_REGISTERS`], [`HEALTH_REGISTERS`]); 0 goes to the line as a broadcast
//! (writes only) and gets no TCP answer, a read to 0 gets 0A (no slave can answer it); any
//! other goes where [`Routes`] says, and one it does not route gets exception 0A (gateway
//! path unavailable).
//!
//! What goes to the line is checked first as the slave's engine checks it (FC 1–6, 15, 16,
//! 22, 23: quantities, byte counts, FC 5's value, the PDU's length; other codes as they
//! come): a request the slave would refuse for its form is answered here with the
//! exception the TCP server gives the same ADU (03, or 02 for a range past 65535), and
//! never reaches the line. The answer awaited has the form the request asks (a read's
//! byte count, a write's echo): an answer from another slave is ignored (the timeout
//! runs on), a damaged or short one ends the try, and the request is sent again while
//! retries are left.
//!
//! A slave that does not answer a request (after the retries) gets 0B (gateway target
//! device failed to respond); after [`GatewaySettings::down_after`] such misses in a row it
//! is taken to be down: its requests get 0B at once, without the line, but for one try
//! every [`GatewaySettings::recheck_ms`], so that a dead slave costs the line at most one
//! response timeout that often and never starves the live ones. Any answer, an exception
//! too, ends the run of misses. The gateway keeps this health for [`TRACKED`] slaves.

use super::health::Health;
use super::mbap::HEADER;
use super::network::Network;
use super::server::{Answered, Handler, Server, Sockets};
use crate::link::crc::Crc16;
use crate::master::request::Shape;
use crate::master::Failure;
use crate::protocol::Exception;
use crate::slave::pdu::{encode_exception, read_write_check, value_check, Request};

/// The serial line as the gateway sees it: the RTU master's request buffer, its start,
/// its outcome. On the AVR each call is a short critical section.
pub trait RtuSide {
    /// True when no request is under way and no outcome waits to be collected.
    fn is_free(&mut self) -> bool;
    /// Writes `bytes` from `at` into the request being built (address, PDU), while free.
    fn put(&mut self, at: usize, bytes: &[u8]);
    /// Sends the request of `len` bytes built with [`RtuSide::put`], with `retries` tries
    /// more, a response timeout of `response_ms` (0: the line's), an answer of `shape`
    /// awaited: false when it is refused (too long).
    fn forward(&mut self, len: usize, retries: u8, response_ms: u16, shape: Shape) -> bool;
    /// The outcome, once there: the answer's PDU bytes after the function code, or why
    /// there is none (a broadcast's outcome is an answer of 0 bytes).
    fn outcome(&mut self) -> Option<Result<usize, Failure>>;
    /// Copies the answer's PDU bytes, from its function code, from `at` into `out`.
    fn reply(&mut self, at: usize, out: &mut [u8]);
    /// The outcome is used: the line is free.
    fn collect(&mut self);
    /// The retries set for the line's requests.
    fn retries(&mut self) -> u8;
    /// The millisecond clock.
    fn now(&mut self) -> u32;
}

/// Where a unit id's requests go: the serial line's slave address, or `None` for
/// exception 0A (gateway path unavailable). The gateway's own unit and 0 (broadcast) never
/// come here.
pub trait Routes {
    /// The slave address (1–247) for `unit` (1–254, never the gateway's own), or `None`;
    /// any other address is taken as `None`.
    fn route(&self, unit: u8) -> Option<u8>;

    /// The response timeout of `unit`'s requests in milliseconds, for a slave slower (or
    /// faster) than the line's timeout allows ([`crate::master::Timeouts::response_ms`]);
    /// `None`, the default, keeps the line's. The retries and the broadcasts' turnaround
    /// stay the line's.
    #[inline(always)]
    fn response_ms(&self, _unit: u8) -> Option<u16> {
        None
    }
}

/// Units 1–247 to the slave of the same address, the others unavailable: the usual
/// gateway.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Direct;

impl Routes for Direct {
    #[inline(always)]
    fn route(&self, unit: u8) -> Option<u8> {
        (1..=247).contains(&unit).then_some(unit)
    }
}

/// The gateway's settings, checked at build time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatewaySettings {
    pub(crate) own_unit: u8,
    pub(crate) down_after: u8,
    pub(crate) recheck_ms: u16,
}

impl Default for GatewaySettings {
    fn default() -> Self {
        GatewaySettings::new()
    }
}

impl GatewaySettings {
    /// The defaults: the gateway's own registers at unit 0xFF, a slave taken to be down
    /// after 3 requests in a row without an answer, and then tried again once a second.
    pub const fn new() -> GatewaySettings {
        GatewaySettings { own_unit: 0xFF, down_after: 3, recheck_ms: 1000 }
    }

    /// The unit id the gateway answers itself, from its own registers (248–255: the ids a
    /// serial slave cannot have).
    pub const fn own_unit(self, unit: u8) -> GatewaySettings {
        assert!(unit >= 248, "the gateway's own unit id is 248-255 (1-247 are the line's)");
        GatewaySettings { own_unit: unit, ..self }
    }

    /// After how many requests in a row without an answer (each after its retries) a
    /// slave is taken to be down: 1–255, or 0 for never (every request then goes to the
    /// line, a dead slave's too). 3 by default: one lost frame, or one request the slave
    /// does not answer, never takes a slave away from every master.
    pub const fn down_after(self, misses: u8) -> GatewaySettings {
        GatewaySettings { down_after: misses, ..self }
    }

    /// How long a slave that is down has its requests answered 0B at once before one
    /// request tries it again (one try, no retry): 1 to 60 000 ms.
    pub const fn recheck_ms(self, ms: u16) -> GatewaySettings {
        assert!(ms >= 1 && ms <= 60_000, "recheck_ms is 1-60000");
        GatewaySettings { recheck_ms: ms, ..self }
    }
}

/// What the gateway counted (each wraps after 65535). The TCP side's own counters are
/// the server's ([`super::TcpCounters`]).
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GatewayCounters {
    /// Requests sent on the serial line (broadcasts and rechecks included, retries not).
    pub forwarded: u16,
    /// Answers from the line passed back, exceptions included.
    pub answers: u16,
    /// Of them, the slaves' exceptions.
    pub exceptions: u16,
    /// Exception 0A sent: a unit not routed.
    pub unavailable: u16,
    /// Exception 0B sent: no answer after the retries, or the slave down.
    pub no_response: u16,
    /// Broadcasts sent (unit 0, writes).
    pub broadcasts: u16,
    /// Answers dropped: their connection closed before they came, or did not take them (its
    /// master does not read).
    pub orphaned: u16,
    /// Requests answered by the gateway with an exception for their form (03, 02), as the
    /// slave would have answered them: never sent on the line.
    pub malformed: u16,
}

/// What the gateway knows of one slave's answers (`TcpGateway::health`, and at
/// [`HEALTH_REGISTERS`]): all zero for a slave it has not asked since it started, or whose
/// record another took ([`TRACKED`]).
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlaveHealth {
    /// Requests it answered (exceptions included; each wraps after 65535).
    pub answers: u16,
    /// Requests it did not answer, after their retries (0B sent).
    pub misses: u16,
    /// Misses since its last answer (up to 255).
    pub misses_in_a_row: u8,
    /// Taken to be down: [`GatewaySettings::down_after`] misses in a row. Its requests get
    /// 0B at once, but for one try every [`GatewaySettings::recheck_ms`].
    pub down: bool,
}

/// How many slaves the gateway keeps the health of ([`SlaveHealth`]). A slave asked when
/// all the records are taken takes the place of the record given longest ago (whose slave,
/// if it was down, is then tried again as a live one).
pub const TRACKED: usize = 8;

/// One slave's record: its address (0: none), its misses in a row, answers and misses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Slot {
    address: u8,
    in_a_row: u8,
    answers: u16,
    misses: u16,
}

/// A counter's place in [`Gateway::counts`].
#[derive(Clone, Copy)]
enum Count {
    Forwarded,
    Answers,
    Exceptions,
    Unavailable,
    NoResponse,
    Broadcasts,
    Orphaned,
    Malformed,
}

const COUNTS: usize = Count::Malformed as usize + 1;

/// The request on the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Flight {
    /// The socket it came on.
    socket: u8,
    /// Its MBAP header's transaction id and unit id (0: a broadcast, unanswered).
    transaction: u16,
    unit: u8,
    function: u8,
    /// The slave's address on the line.
    address: u8,
}

/// The gateway's state: the request on the line, the slaves' health, the counters.
#[derive(Clone, Debug)]
pub struct Gateway {
    flight: Option<Flight>,
    /// The slaves' records, in the order they were given.
    slots: [Slot; TRACKED],
    /// Where the next new record goes (modulo [`TRACKED`]).
    next: u8,
    /// When the next request to a slave that is down goes to the line.
    recheck_at: u32,
    counts: [u16; COUNTS],
}

impl Default for Gateway {
    fn default() -> Self {
        Gateway::new()
    }
}

impl Gateway {
    /// A gateway with nothing on the line and no slave asked yet.
    pub const fn new() -> Gateway {
        const NONE: Slot = Slot { address: 0, in_a_row: 0, answers: 0, misses: 0 };
        Gateway { flight: None, slots: [NONE; TRACKED], next: 0, recheck_at: 0, counts: [0; COUNTS] }
    }

    /// The counters.
    pub fn counters(&self) -> GatewayCounters {
        let [forwarded, answers, exceptions, unavailable, no_response, broadcasts, orphaned, malformed] = self.counts;
        GatewayCounters { forwarded, answers, exceptions, unavailable, no_response, broadcasts, orphaned, malformed }
    }

    fn bump(&mut self, count: Count) {
        crate::link::bump(&mut self.counts, count as u8);
    }

    /// The record of the slave at `address`, if it has one.
    fn slot(&self, address: u8) -> Option<&Slot> {
        self.slots.iter().find(|slot| slot.address == address && address != 0)
    }

    /// What the gateway knows of the slave at `address`.
    pub fn health(&self, address: u8, settings: &GatewaySettings) -> SlaveHealth {
        let Some(slot) = self.slot(address) else { return SlaveHealth::default() };
        SlaveHealth {
            answers: slot.answers,
            misses: slot.misses,
            misses_in_a_row: slot.in_a_row,
            down: settings.down_after != 0 && slot.in_a_row >= settings.down_after,
        }
    }

    /// True when the slave at `address` is taken to be down.
    pub fn is_down(&self, address: u8, settings: &GatewaySettings) -> bool {
        self.health(address, settings).down
    }

    /// The slave at `address` is asked: it gets a record if it has none, in the place of
    /// the record given longest ago when all are taken.
    fn asked(&mut self, address: u8) {
        if self.slot(address).is_none() {
            self.slots[usize::from(self.next) % TRACKED] = Slot { address, ..Slot::default() };
            self.next = self.next.wrapping_add(1);
        }
    }

    /// True while a request is on the line (its answer not yet passed back).
    pub fn is_forwarding(&self) -> bool {
        self.flight.is_some()
    }

    /// Passes the line's outcome back to the connection that asked, once it is there (in
    /// its socket's framing, `net`'s): true when the line is free for the next request (the
    /// caller then resumes the server's waiting connections).
    pub fn deliver<S: Sockets, L: RtuSide, const B: usize>(
        &mut self,
        server: &mut Server<B>,
        chip: &mut S,
        line: &mut L,
        settings: &GatewaySettings,
        net: &Network,
    ) -> bool {
        let Some(flight) = self.flight else { return false };
        let Some(outcome) = line.outcome() else { return false };
        if flight.unit != 0 {
            // The answer's PDU (function code and data, as the slave sent it, exceptions
            // too) or, when it did not answer, exception 0B.
            let (pdu, code) = match outcome {
                Ok(len) => (1 + len, 0),
                Err(Failure::Exception(exception)) => (2, exception.code()),
                Err(Failure::Timeout | Failure::BadReply) => (2, Exception::GatewayTargetDeviceFailedToRespond.code()),
            };
            let [t0, t1] = flight.transaction.to_be_bytes();
            let head = [t0, t1, 0, 0, 0, pdu as u8 + 1, flight.unit, flight.function | 0x80, code];
            // To a socket of RTU over TCP (feature `rtu-over-tcp`) the answer goes as an RTU
            // frame: from the unit id's place on (the request's address), then a CRC.
            let rtu = net.is_rtu(flight.socket);
            let len = if rtu { pdu + 3 } else { HEADER + pdu };
            let answered = server.answer(chip, flight.socket, len as u16, code != 0, |chip, at, buf| {
                let rtu = net.is_rtu(flight.socket);
                let from = if rtu { HEADER - 1 } else { 0 };
                let Some(first) = buf.get_mut(..head.len()) else { return };
                first.copy_from_slice(&head);
                let lead = if code != 0 { HEADER + 2 } else { HEADER };
                let mut crc = Crc16::new();
                if rtu {
                    crc = crc.update_slice(&first[from..lead]);
                }
                chip.write(flight.socket, at, &mut first[from..lead]);
                // The answer's bytes, a buffer at a time.
                let mut done = 0;
                while lead + done < HEADER + pdu {
                    let n = (HEADER + pdu - lead - done).min(buf.len());
                    let chunk = &mut buf[..n];
                    line.reply(done, chunk);
                    if rtu {
                        crc = crc.update_slice(chunk);
                    }
                    chip.write(flight.socket, at.wrapping_add((lead - from + done) as u16), chunk);
                    done += n;
                }
                if rtu {
                    let mut tail = crc.to_wire();
                    chip.write(flight.socket, at.wrapping_add((HEADER + pdu - from) as u16), &mut tail);
                }
            });
            match answered {
                // Cannot last: a request is handed over only while its socket has no SEND on
                // its way, and nothing else is sent on it until its answer.
                Answered::Later => return false,
                Answered::Gone => self.bump(Count::Orphaned),
                Answered::Sent => {}
            }
            match outcome {
                Ok(_) => self.bump(Count::Answers),
                Err(Failure::Exception(_)) => {
                    self.bump(Count::Answers);
                    self.bump(Count::Exceptions);
                }
                Err(_) => self.bump(Count::NoResponse),
            }
            if let Some(slot) = self.slots.iter_mut().find(|slot| slot.address == flight.address) {
                if matches!(outcome, Err(Failure::Timeout | Failure::BadReply)) {
                    slot.misses = slot.misses.wrapping_add(1);
                    slot.in_a_row = slot.in_a_row.saturating_add(1);
                    if settings.down_after != 0 && slot.in_a_row == settings.down_after {
                        self.recheck_at = line.now().wrapping_add(u32::from(settings.recheck_ms));
                    }
                } else {
                    slot.answers = slot.answers.wrapping_add(1);
                    slot.in_a_row = 0;
                }
            }
        }
        line.collect();
        self.flight = None;
        true
    }
}

/// The handler the server calls for each request: the gateway's rules over the line and
/// the routes, and its own registers.
pub struct Gate<'a, L, R> {
    /// The gateway's state.
    pub gateway: &'a mut Gateway,
    /// The serial line.
    pub line: &'a mut L,
    /// The routes.
    pub routes: &'a R,
    /// The settings.
    pub settings: &'a GatewaySettings,
    /// Connections waiting for the line as the poll began (a status register).
    pub waiting: u8,
    /// The chip's and the link's health as the poll began (status registers 9-11).
    pub health: Health,
    /// The first register of the read of its own registers being answered.
    pub first: u16,
}

/// The gateway's own registers, at its own unit: input registers (FC 4) that FC 3 reads
/// too. 0–7 the counters in [`GatewayCounters`]' order, 8 the connections waiting for the
/// line, 9 the chip's resets and 10 the link's losses ([`super::TcpCounters`]' `chip_resets`,
/// `link_losses`), 11 1 while the link is up; the slaves' health from [`HEALTH_REGISTERS`]
/// on.
pub const STATUS_REGISTERS: u16 = 12;

/// Where the slaves' health starts among the gateway's own registers: four registers for
/// address n from `HEALTH_REGISTERS + 4 × n` (1000 + 4 × n): its answers, its misses, its
/// misses in a row, 1 while it is down ([`SlaveHealth`]); n is 0–255, so they end at 2023.
/// A round number a SCADA's user can work out (slave 17's are 1068–1071), and clear of the
/// addresses test clients ask a device at its own unit (libmodbus's unit tests use 0x100–0x1FF:
/// there it reads 02, as a device without them answers).
pub const HEALTH_REGISTERS: u16 = 1000;

/// The last of the slaves' health registers.
const HEALTH_END: u16 = HEALTH_REGISTERS + 4 * 256 - 1;

/// The TCP side's buffer for the gateway: the MBAP header and the first bytes of a PDU,
/// enough for every check of a request's form (FC 23's: 10 bytes); requests, answers and
/// the gateway's own registers pass through it a buffer at a time.
pub const BUFFER: usize = 32;

const _: () = assert!(BUFFER >= HEADER + 10);

/// The write function codes a broadcast may carry (Serial Line §2.1: a broadcast is a
/// write): 5, 6, 15, 16, 22.
fn broadcastable(function: u8) -> bool {
    matches!(function, 0x05 | 0x06 | 0x0F | 0x10 | 0x16)
}

/// Checks the request PDU of `len` bytes (its first bytes in `pdu`, 10 at least) with the
/// slave engine's own checks ([`Request::parse`], FC 22's length, FC 23's
/// [`read_write_check`]: 03 for a quantity, byte count, FC 5 value or length that does not
/// fit the function code, then 02 for a range past 65535), and returns the form of its
/// answer: a read's byte count, a write's echo. A function code the engine does not know
/// goes as it came.
fn form(pdu: &[u8], len: usize) -> Result<Shape, Exception> {
    match pdu.first() {
        Some(0x16) => value_check(len == 7).map(|()| Shape::Any),
        Some(0x17) => read_write_check(pdu, len).map(|(_, qty)| Shape::Count((2 * qty) as u8)),
        _ => match Request::parse(pdu, len) {
            Ok(request) if request.is_write() => Ok(Shape::Echo),
            Ok(request) => Ok(Shape::Count(request.data_len)),
            Err(Exception::IllegalFunction) => Ok(Shape::Any),
            Err(exception) => Err(exception),
        },
    }
}

impl<L: RtuSide, R: Routes> Gate<'_, L, R> {
    /// Own register `index`: `None` where there is none.
    fn status(&self, index: u16) -> Option<u16> {
        let gateway = &*self.gateway;
        Some(match index {
            0..=7 => gateway.counts[usize::from(index)],
            8 => u16::from(self.waiting),
            9 => self.health.restarts(),
            10 => self.health.losses(),
            11 => u16::from(self.health.link_up()),
            HEALTH_REGISTERS..=HEALTH_END => {
                let at = index - HEALTH_REGISTERS;
                let health = gateway.health((at / 4) as u8, self.settings);
                match at % 4 {
                    0 => health.answers,
                    1 => health.misses,
                    2 => u16::from(health.misses_in_a_row),
                    _ => u16::from(health.down),
                }
            }
            _ => return None,
        })
    }

    /// Answers a request for the gateway's own unit in `adu`: reads of its registers (FC 3
    /// or 4), exception 01 for any other function, 03 for a quantity outside 1–125, 02
    /// where a register is missing. The values past the buffer come through
    /// [`Handler::more`].
    fn own(&mut self, adu: &mut [u8], pdu_len: usize) -> (usize, bool) {
        let pdu = &mut adu[HEADER..];
        let [function, first_high, first_low, count_high, count, ..] = *pdu else { return (0, false) };
        let first = u16::from_be_bytes([first_high, first_low]);
        let exception = if !matches!(function, 0x03 | 0x04) {
            Exception::IllegalFunction
        } else if pdu_len != 5 || count_high != 0 || !(1..=125).contains(&count) {
            Exception::IllegalDataValue
        } else if self.status(first).is_none() || self.status(first.wrapping_add(u16::from(count) - 1)).is_none() {
            // Both ends there: so is every register between (the gap between the two
            // ranges is longer than 125 registers).
            Exception::IllegalDataAddress
        } else {
            pdu[1] = count * 2;
            self.first = first;
            let end = (HEADER + 2 + 2 * usize::from(count)).min(adu.len());
            self.more(HEADER + 2, &mut adu[HEADER + 2..end]);
            return (2 + 2 * usize::from(count), false);
        };
        (encode_exception(pdu, exception), true)
    }

    /// Sends the request in `adu` (its first PDU bytes there, the rest in socket `s` from
    /// `at`) to the slave `address`, with `retries`, its response timeout and the form of
    /// its answer: true when it went out.
    #[allow(clippy::too_many_arguments)]
    fn forward<S: Sockets>(
        &mut self,
        adu: &mut [u8],
        pdu_len: usize,
        chip: &mut S,
        s: u8,
        at: u16,
        (address, retries, response_ms): (u8, u8, u16),
        shape: Shape,
    ) -> bool {
        let kept = pdu_len.min(adu.len() - HEADER);
        // The unit id's place becomes the slave's address: the frame, then, as it goes.
        adu[HEADER - 1] = address;
        self.line.put(0, &adu[HEADER - 1..HEADER + kept]);
        // The rest of a PDU longer than the buffer, through it.
        let mut done = kept;
        while done < pdu_len {
            let n = (pdu_len - done).min(adu.len());
            let chunk = &mut adu[..n];
            chip.read(s, at.wrapping_add((HEADER + done) as u16), chunk);
            self.line.put(1 + done, chunk);
            done += n;
        }
        self.line.forward(1 + pdu_len, retries, response_ms, shape)
    }
}

impl<L: RtuSide, R: Routes> Handler for Gate<'_, L, R> {
    const DEFERS: bool = true;
    const LONG: bool = true;

    fn handle(&mut self, adu: &mut [u8], pdu_len: usize) -> Option<(usize, bool)> {
        Some(self.own(adu, pdu_len))
    }

    /// The bytes of a reply of its own registers from byte `at` of the ADU on.
    fn more(&mut self, at: usize, out: &mut [u8]) {
        for (i, byte) in out.iter_mut().enumerate() {
            let k = at + i - (HEADER + 2);
            let [high, low] = self.status(self.first.wrapping_add((k / 2) as u16)).unwrap_or(0).to_be_bytes();
            *byte = if k % 2 == 0 { high } else { low };
        }
    }

    fn ready(&mut self) -> bool {
        self.gateway.flight.is_none() && self.line.is_free()
    }

    /// The request on the line came from `s` (a broadcast too: its connection is kept
    /// until the turnaround ends).
    fn owes(&self, s: u8) -> bool {
        self.gateway.flight.is_some_and(|f| f.socket == s)
    }

    fn handle_from<S: Sockets>(
        &mut self,
        adu: &mut [u8],
        pdu_len: usize,
        chip: &mut S,
        s: u8,
        at: u16,
    ) -> Option<(usize, bool)> {
        let unit = *adu.get(HEADER - 1)?;
        let function = *adu.get(HEADER)?;
        if unit == self.settings.own_unit {
            return self.handle(adu, pdu_len);
        }
        let transaction = u16::from_be_bytes([adu[0], adu[1]]);
        let mut flight = Flight { socket: s, transaction, unit, function, address: 0 };
        let route = if unit == 0 {
            // A broadcast (§4.4.1.2) is a write; a read has nobody to answer it: 0A.
            broadcastable(function).then_some(0)
        } else {
            // A route elsewhere than 1-247 is none.
            self.routes.route(unit).filter(|address| address.wrapping_sub(1) < 247)
        };
        let Some(address) = route else {
            self.gateway.bump(Count::Unavailable);
            return Some((encode_exception(&mut adu[HEADER..], Exception::GatewayPathUnavailable), true));
        };
        let shape = match form(&adu[HEADER..], pdu_len) {
            Ok(shape) => shape,
            Err(exception) => {
                // As the slave would answer it; a broadcast, nobody.
                self.gateway.bump(Count::Malformed);
                return (unit != 0).then(|| (encode_exception(&mut adu[HEADER..], exception), true));
            }
        };
        if unit == 0 {
            // No answer over TCP either (§4.4.1.2).
            if self.forward(adu, pdu_len, chip, s, at, (0, 0, 0), shape) {
                self.gateway.flight = Some(flight);
                self.gateway.bump(Count::Forwarded);
                self.gateway.bump(Count::Broadcasts);
            }
            return None;
        }
        let mut retries = self.line.retries();
        if self.gateway.is_down(address, self.settings) {
            let now = self.line.now();
            if (now.wrapping_sub(self.gateway.recheck_at) as i32) < 0 {
                self.gateway.bump(Count::NoResponse);
                let exception = Exception::GatewayTargetDeviceFailedToRespond;
                return Some((encode_exception(&mut adu[HEADER..], exception), true));
            }
            // Tried once, and the next try of a slave down waits again.
            self.gateway.recheck_at = now.wrapping_add(u32::from(self.settings.recheck_ms));
            retries = 0;
        }
        let response_ms = self.routes.response_ms(unit).unwrap_or(0);
        if self.forward(adu, pdu_len, chip, s, at, (address, retries, response_ms), shape) {
            self.gateway.asked(address);
            flight.address = address;
            self.gateway.flight = Some(flight);
            self.gateway.bump(Count::Forwarded);
            return None;
        }
        self.gateway.bump(Count::Unavailable);
        Some((encode_exception(&mut adu[HEADER..], Exception::GatewayPathUnavailable), true))
    }
}

#[cfg(test)]
mod tests;
