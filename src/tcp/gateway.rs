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
//! device itself", §4.4.1.2) is answered from its own registers (counters, the slaves
//! down: [`STATUS_REGISTERS`]); 0 goes to the line as a
//! broadcast (writes only) and gets no TCP answer; any other goes where [`Routes`] says,
//! and one it does not route gets exception 0A (gateway path unavailable). A slave that
//! does not answer (after the retries) gets 0B (gateway target device failed to respond)
//! and is taken to be down: its requests get 0B at once, without the line, but for one
//! try every [`GatewaySettings::recheck_ms`], so that a dead slave costs the line at most
//! one response timeout that often and never starves the live ones. Its first answer
//! brings it back.

use super::mbap::HEADER;
use super::server::{Answered, Handler, Server, Sockets};
use crate::master::Failure;
use crate::protocol::Exception;
use crate::slave::pdu::encode_exception;

/// The serial line as the gateway sees it: the RTU master's request buffer, its start,
/// its outcome. On the AVR each call is a short critical section.
pub trait RtuSide {
    /// True when no request is under way and no outcome waits to be collected.
    fn is_free(&mut self) -> bool;
    /// Writes `bytes` from `at` into the request being built (address, PDU), while free.
    fn put(&mut self, at: usize, bytes: &[u8]);
    /// Sends the request of `len` bytes built with [`RtuSide::put`], with `retries` tries
    /// more: false when it is refused (too long).
    fn forward(&mut self, len: usize, retries: u8) -> bool;
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
    /// The slave address (1–247) for `unit`, or `None`.
    fn route(&self, unit: u8) -> Option<u8>;
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
    pub(crate) recheck_ms: u16,
}

impl Default for GatewaySettings {
    fn default() -> Self {
        GatewaySettings::new()
    }
}

impl GatewaySettings {
    /// The defaults: the gateway's own registers at unit 0xFF, a slave that failed to
    /// answer tried again once a second.
    pub const fn new() -> GatewaySettings {
        GatewaySettings { own_unit: 0xFF, recheck_ms: 1000 }
    }

    /// The unit id the gateway answers itself, from its own registers (248–255: the ids a
    /// serial slave cannot have).
    pub const fn own_unit(self, unit: u8) -> GatewaySettings {
        assert!(unit >= 248, "the gateway's own unit id is 248-255 (1-247 are the line's)");
        GatewaySettings { own_unit: unit, ..self }
    }

    /// How long a slave that failed to answer is taken to be down (its requests answered
    /// 0B at once) before one request tries it again: 1 to 60 000 ms.
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
}

const COUNTS: usize = Count::Orphaned as usize + 1;

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

/// The gateway's state: the request on the line, the slaves down, the counters.
#[derive(Clone, Debug)]
pub struct Gateway {
    flight: Option<Flight>,
    /// Bit `u` of the 256: unit `u` failed to answer and is taken to be down.
    down: [u8; 32],
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
    /// A gateway with nothing on the line and every slave taken to be up.
    pub const fn new() -> Gateway {
        Gateway { flight: None, down: [0; 32], recheck_at: 0, counts: [0; COUNTS] }
    }

    /// The counters.
    pub fn counters(&self) -> GatewayCounters {
        let [forwarded, answers, exceptions, unavailable, no_response, broadcasts, orphaned] = self.counts;
        GatewayCounters { forwarded, answers, exceptions, unavailable, no_response, broadcasts, orphaned }
    }

    fn bump(&mut self, count: Count) {
        crate::link::bump(&mut self.counts, count as u8);
    }

    /// True when the slave at `address` failed to answer its last request.
    pub fn is_down(&self, address: u8) -> bool {
        self.down[usize::from(address / 8)] & 1 << (address % 8) != 0
    }

    fn set_down(&mut self, address: u8, down: bool) {
        let byte = &mut self.down[usize::from(address / 8)];
        let bit = 1 << (address % 8);
        if down {
            *byte |= bit;
        } else {
            *byte &= !bit;
        }
    }

    /// True while a request is on the line (its answer not yet passed back).
    pub fn is_forwarding(&self) -> bool {
        self.flight.is_some()
    }

    /// Passes the line's outcome back to the connection that asked, once it is there:
    /// true when the line is free for the next request (the caller then resumes the
    /// server's waiting connections).
    pub fn deliver<S: Sockets, L: RtuSide, const B: usize>(
        &mut self,
        server: &mut Server<B>,
        chip: &mut S,
        line: &mut L,
        settings: &GatewaySettings,
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
            let answered = server.answer(chip, flight.socket, (HEADER + pdu) as u16, code != 0, |chip, at, buf| {
                let Some(first) = buf.get_mut(..head.len()) else { return };
                first.copy_from_slice(&head);
                let lead = if code != 0 { HEADER + 2 } else { HEADER };
                chip.write(flight.socket, at, &mut first[..lead]);
                // The answer's bytes, a buffer at a time.
                let mut done = 0;
                while lead + done < HEADER + pdu {
                    let n = (HEADER + pdu - lead - done).min(buf.len());
                    let chunk = &mut buf[..n];
                    line.reply(done, chunk);
                    chip.write(flight.socket, at.wrapping_add((lead + done) as u16), chunk);
                    done += n;
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
            let down = matches!(outcome, Err(Failure::Timeout | Failure::BadReply));
            if down {
                self.recheck_at = line.now().wrapping_add(u32::from(settings.recheck_ms));
            }
            self.set_down(flight.address, down);
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
}

/// The gateway's own registers, at its own unit: input registers (FC 4) that FC 3 reads
/// too. 0–6 the counters in [`GatewayCounters`]' order, 7 the connections waiting for the
/// line, 8–23 the slaves down (register 8 + n / 16, bit n % 16 for address n).
pub const STATUS_REGISTERS: u16 = 24;

/// The TCP side's buffer for the gateway: the MBAP header and the longest answer of its
/// own registers (all 24), or more.
pub const BUFFER: usize = 64;

const _: () = assert!(BUFFER >= HEADER + 2 + 2 * STATUS_REGISTERS as usize);

/// The write function codes a broadcast may carry (Serial Line §2.1: a broadcast is a
/// write): 5, 6, 15, 16, 22.
fn broadcastable(function: u8) -> bool {
    matches!(function, 0x05 | 0x06 | 0x0F | 0x10 | 0x16)
}

impl<L: RtuSide, R: Routes> Gate<'_, L, R> {
    /// Status register `index` (below [`STATUS_REGISTERS`]).
    fn status(&self, index: u8) -> u16 {
        match index {
            0..=6 => self.gateway.counts[usize::from(index)],
            7 => u16::from(self.waiting),
            _ => {
                let at = usize::from(index - 8) * 2 % 32;
                u16::from_le_bytes([self.gateway.down[at], self.gateway.down[at + 1]])
            }
        }
    }

    /// Answers a request for the gateway's own unit in `adu`: reads of its registers (FC 3
    /// or 4), exception 01 for any other function, 03 for a quantity outside 1–125, 02 past
    /// the last register.
    fn own(&self, adu: &mut [u8], pdu_len: usize) -> (usize, bool) {
        let pdu = &mut adu[HEADER..];
        let [function, first_high, first, count_high, count, ..] = *pdu else { return (0, false) };
        let exception = if !matches!(function, 0x03 | 0x04) {
            Exception::IllegalFunction
        } else if pdu_len != 5 || count_high != 0 || !(1..=125).contains(&count) {
            Exception::IllegalDataValue
        } else if first_high != 0 || u16::from(first) + u16::from(count) > STATUS_REGISTERS {
            Exception::IllegalDataAddress
        } else {
            pdu[1] = count * 2;
            for i in 0..count {
                let at = 2 + 2 * usize::from(i);
                pdu[at..at + 2].copy_from_slice(&self.status(first + i).to_be_bytes());
            }
            return (2 + 2 * usize::from(count), false);
        };
        (encode_exception(pdu, exception), true)
    }

    /// Sends the request in `adu` (its first PDU bytes there, the rest in socket `s` from
    /// `at`) to the slave `address`, with `retries`: true when it went out.
    fn forward<S: Sockets>(
        &mut self,
        adu: &mut [u8],
        pdu_len: usize,
        chip: &mut S,
        s: u8,
        at: u16,
        (address, retries): (u8, u8),
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
        self.line.forward(1 + pdu_len, retries)
    }
}

impl<L: RtuSide, R: Routes> Handler for Gate<'_, L, R> {
    const DEFERS: bool = true;

    fn handle(&mut self, adu: &mut [u8], pdu_len: usize) -> Option<(usize, bool)> {
        Some(self.own(adu, pdu_len))
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
        if unit == 0 {
            // A broadcast: no answer over TCP either (§4.4.1.2); a read is no broadcast.
            if broadcastable(function) && self.forward(adu, pdu_len, chip, s, at, (0, 0)) {
                self.gateway.flight = Some(flight);
                self.gateway.bump(Count::Forwarded);
                self.gateway.bump(Count::Broadcasts);
            }
            return None;
        }
        let exception = match self.routes.route(unit) {
            None => {
                self.gateway.bump(Count::Unavailable);
                Exception::GatewayPathUnavailable
            }
            Some(address) => {
                let mut retries = self.line.retries();
                if self.gateway.is_down(address) {
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
                if self.forward(adu, pdu_len, chip, s, at, (address, retries)) {
                    flight.address = address;
                    self.gateway.flight = Some(flight);
                    self.gateway.bump(Count::Forwarded);
                    return None;
                }
                self.gateway.bump(Count::Unavailable);
                Exception::GatewayPathUnavailable
            }
        };
        Some((encode_exception(&mut adu[HEADER..], exception), true))
    }
}

#[cfg(test)]
mod tests;
