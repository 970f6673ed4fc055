//! The master's protocol state without hardware, Modbus over Serial Line v1.02 §2.4.1
//! (figure 6, the master's state diagram) and §2.5.1.1 (T3.5 between frames).
//!
//! Idle → a request is started: it waits for T3.5 of silence after anything on the line,
//! then goes out → waiting for the reply, the response timeout running (for a broadcast,
//! the turnaround delay, and no reply) → the reply from the slave asked is checked → done,
//! until the application collects the outcome. A frame from another slave is ignored and
//! the timeout keeps running; a damaged frame (or one longer than any answer), or one from
//! the slave asked that does not answer the request, ends the attempt (the spec's
//! "processing error"); a timeout too. An attempt that ended so is sent again while
//! retries are left.
//!
//! The AVR layer forwards its interrupts here as the slave's does: characters and damage
//! to the shared [`Framer`], Timer0's silences, the millisecond clock, the end of the
//! request on the wire. Host tests script the same calls.
//!
//! In ASCII framing (feature `ascii`) the states are the same; what differs, the request's
//! LRC and characters, the receiver's events and when the line is free, is in `ascii`.

use super::reply::{Reply, Verdict};
use super::request::{Expect, Request};
use crate::error::Error;
use crate::link::crc::Crc16;
use crate::link::framer::{FrameError, Framer, UartError, MAX_FRAME};
use crate::link::framing::Framing;
use crate::protocol::Exception;

#[cfg(feature = "ascii")]
mod ascii;

/// How long the master waits, and how often it tries again.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// The response timeout, in milliseconds, from the request's last character on the
    /// wire to the reply's end (it must cover the slave's processing and the reply's own
    /// time on the line: 125 registers take 136 ms at 19200 bps).
    pub response_ms: u16,
    /// After a broadcast, the turnaround delay in milliseconds: no reply is awaited; the
    /// slaves get this long to act before the next request.
    pub turnaround_ms: u16,
    /// How many times a request is sent again after a timeout, a damaged reply or one that
    /// does not answer it.
    pub retries: u8,
}

impl Timeouts {
    /// The defaults: a 1000 ms response timeout, a 100 ms turnaround delay, one retry.
    pub const DEFAULT: Timeouts = Timeouts { response_ms: 1000, turnaround_ms: 100, retries: 1 };
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts::DEFAULT
    }
}

/// Why a request got no answer.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// The slave answered with this exception (Application Protocol §7: 01 Illegal
    /// Function, 02 Illegal Data Address, 03 Illegal Data Value, 04 Server Device
    /// Failure, …; a code the spec does not name comes as it was sent).
    Exception(Exception),
    /// No reply within the response timeout, on the last try.
    Timeout,
    /// The last try ended with a damaged frame (CRC or LRC, parity, a gap over T1.5), or
    /// a frame from the slave asked that does not answer the request.
    BadReply,
}

/// What the master counted since it started (each wraps at 65535). The fields both roles
/// have ([`crate::SlaveCounters`]) count alike: a frame dropped for the same fault goes to
/// the same name.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MasterCounters {
    /// Requests sent, retries included (a broadcast too).
    pub requests: u16,
    /// Frames dropped for a bad CRC (or LRC).
    pub crc_errors: u16,
    /// Frames dropped for a parity or framing error.
    pub uart_errors: u16,
    /// Frames dropped for a lost character (USART overrun) or for being longer than the
    /// master's buffer (no answer to its request is longer).
    pub overruns: u16,
    /// Frames dropped for being shorter than 4 bytes or for a gap over T1.5; in ASCII
    /// framing also for a character that is not a hex digit, an odd number of them, the
    /// inter-character timeout inside a frame, or a frame a `:` cut short.
    pub malformed: u16,
    /// Answers taken: replies that answer their request, exception replies included.
    pub replies: u16,
    /// Exception replies.
    pub exceptions: u16,
    /// Tries that got no reply within the response timeout: a request that is sent once
    /// more after a timeout and times out again counts 2.
    pub timeouts: u16,
    /// Requests sent again (after a timeout, a damaged reply or one that does not answer).
    pub retries: u16,
    /// Good frames that were no answer: from another slave, from the slave asked but not
    /// answering the request (another function code, a wrong byte count or echo, a reply
    /// too short for its byte count), or with no request waiting.
    pub unexpected: u16,
}

impl MasterCounters {
    /// The counters kept as an array in the order of the fields (a master's engine's, the
    /// TCP client's).
    pub(crate) fn from_counts(counts: [u16; COUNTS]) -> MasterCounters {
        let [requests, crc_errors, uart_errors, overruns, malformed, replies, exceptions, timeouts, retries, unexpected] =
            counts;
        MasterCounters {
            requests,
            crc_errors,
            uart_errors,
            overruns,
            malformed,
            replies,
            exceptions,
            timeouts,
            retries,
            unexpected,
        }
    }
}

/// A counter's place in [`Engine::counts`]: the order of [`MasterCounters`]'s fields. A
/// damaged frame's counter is at [`FrameError::counter`], as in the slave's.
#[derive(Clone, Copy)]
enum Count {
    Requests,
    CrcErrors,
    UartErrors,
    Overruns,
    Malformed,
    Replies,
    Exceptions,
    Timeouts,
    Retries,
    Unexpected,
}

pub(crate) const COUNTS: usize = Count::Unexpected as usize + 1;

const _: () = {
    use FrameError::*;
    assert!(BadCrc.counter() == Count::CrcErrors as u8 && Uart.counter() == Count::UartErrors as u8);
    assert!(Overrun.counter() == Count::Overruns as u8 && TooLong.counter() == Count::Overruns as u8);
    assert!(TooShort.counter() == Count::Malformed as u8 && Gap.counter() == Count::Malformed as u8);
};

/// Where a request is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// No request.
    Idle,
    /// Started, waiting for T3.5 of silence on the line.
    Due,
    /// On the wire.
    Sending,
    /// Sent; waiting for the reply, the response timeout running.
    Waiting,
    /// A broadcast sent; the turnaround delay running.
    Turnaround,
    /// The outcome is ready for the application.
    Done,
}

/// What the AVR layer does after an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Nothing.
    None,
    /// The line has been quiet for T3.5: send the request now, from its first byte.
    Send,
}

/// The master's protocol state: the receive framer (shared with the slave), the request
/// as sent (kept for retries and for checking the reply's echo), the state, the counters.
/// `N` bytes each way.
///
/// In declaration order (`repr(C)`), the fields that start other than zero near the start
/// (no failure, the framer's state): the rest of a new master is one run of zeros, which
/// its start writes in one go.
#[repr(C)]
#[derive(Clone, Debug)]
pub struct Engine<const N: usize = MAX_FRAME> {
    /// The timeouts set, `None` for [`Timeouts::DEFAULT`]: a new master's timeouts are
    /// then zeros too, and its start copies nothing from flash.
    timeouts: Option<Timeouts>,
    /// Why the request failed, once `Done`; `None` when it was answered (the reply stays
    /// in the framer's buffer until collected).
    failure: Option<Failure>,
    /// A reply longer than the buffer is no answer: it is dropped as too long.
    framer: Framer<N, false>,
    request: [u8; N],
    request_len: usize,
    expect: Expect,
    state: State,
    /// Tries left after the current one.
    retries_left: u8,
    /// The request's response timeout, or for a broadcast its turnaround delay
    /// (milliseconds), from the timeouts in use when it was started.
    wait: u16,
    /// When that wait ends (milliseconds): it has passed once the clock reads past it.
    deadline: u32,
    /// T3.5 has passed since the line's last character (or the request's last).
    quiet: bool,
    /// The answer's PDU bytes after the function code (0 after a broadcast).
    answer: u8,
    counts: [u16; COUNTS],
}

impl<const N: usize> Default for Engine<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Engine<N> {
    /// A master just after power-up: it waits for T3.5 of silence before it sends.
    pub const fn new() -> Self {
        Engine {
            framer: Framer::new(),
            request: [0; N],
            request_len: 0,
            expect: Expect::NONE,
            state: State::Idle,
            retries_left: 0,
            timeouts: None,
            wait: 0,
            deadline: 0,
            quiet: false,
            answer: 0,
            failure: None,
            counts: [0; COUNTS],
        }
    }

    /// Sets the response timeout, the turnaround delay and the retries, from the next
    /// request on.
    pub fn set_timeouts(&mut self, timeouts: Timeouts) {
        self.timeouts = Some(timeouts);
    }

    /// The timeouts in use.
    pub fn timeouts(&self) -> Timeouts {
        self.timeouts.unwrap_or(Timeouts::DEFAULT)
    }

    /// The counters.
    pub fn counters(&self) -> MasterCounters {
        MasterCounters::from_counts(self.counts)
    }

    /// One more in `count`, wrapping ([`crate::link::bump`]).
    #[inline(always)]
    fn count(&mut self, count: Count) {
        crate::link::bump(&mut self.counts, count as u8);
    }

    /// True from [`Engine::start`] until the outcome is collected ([`Engine::collect`]).
    pub fn is_busy(&self) -> bool {
        self.state != State::Idle
    }

    /// True from [`Engine::start`] until the outcome is ready.
    pub fn is_under_way(&self) -> bool {
        !matches!(self.state, State::Idle | State::Done)
    }

    /// Starts `request` to `slave` (0: broadcast): checked and built now, sent as soon as
    /// the line has been quiet for T3.5 ([`Action::Send`]: at once). A request while one is
    /// under way, or before the last outcome is collected, is [`Error::Busy`]: no request
    /// and no outcome is ever dropped. Nothing changes when the request is refused.
    pub fn start(&mut self, slave: u8, request: &Request<'_>) -> Result<Action, Error> {
        let action = self.begin(slave, request)?;
        self.seal();
        Ok(action)
    }

    /// [`Engine::start`] without the CRC, so that the first byte can go out while it is
    /// worked out: call [`Engine::seal`] before anything reads past the request's PDU (on
    /// the AVR, before interrupts are enabled again).
    pub fn begin(&mut self, slave: u8, request: &Request<'_>) -> Result<Action, Error> {
        if self.is_busy() {
            return Err(Error::Busy);
        }
        let (len, expect) = request.encode(slave, &mut self.request, N)?;
        self.request_len = len;
        self.expect = expect;
        let timeouts = self.timeouts();
        self.retries_left = timeouts.retries;
        self.wait = if expect.is_broadcast() { timeouts.turnaround_ms } else { timeouts.response_ms };
        // A broadcast's outcome carries no data.
        self.answer = 0;
        // Idle, the framer holds no frame: an answer stays until `collect`, which frees it.
        self.state = State::Due;
        Ok(self.send_if_quiet())
    }

    /// The request buffer, to build a frame to forward in it (address, PDU) for
    /// [`Engine::forward`]; `None` while a request is under way or its outcome waits.
    #[cfg(feature = "tcp")]
    pub fn request_mut(&mut self) -> Option<&mut [u8; N]> {
        (!self.is_busy()).then_some(&mut self.request)
    }

    /// Starts the frame of `len` bytes (address, PDU) built in the request buffer
    /// ([`Engine::request_mut`]), sealed, with `retries` tries more after the first and a
    /// response timeout of `response_ms` (0: the one set): a gateway's request, passed on
    /// as it came. Its answer is a frame from its address with its function code and of
    /// `shape`, or that code's exception; address 0 is a broadcast. As [`Engine::start`]
    /// otherwise; [`Error::TooLong`] for a frame outside 2 to `N` − 2 bytes,
    /// [`Error::Busy`] as there.
    #[cfg(feature = "tcp")]
    pub fn forward(
        &mut self,
        len: usize,
        retries: u8,
        response_ms: u16,
        shape: crate::master::request::Shape,
    ) -> Result<Action, Error> {
        if self.is_busy() {
            return Err(Error::Busy);
        }
        if len < 2 || len + 2 > N {
            return Err(Error::TooLong);
        }
        let (slave, function) = (self.request[0], self.request[1]);
        self.request_len = len;
        self.expect = Expect { slave, function, shape, quantity: 0 };
        let timeouts = self.timeouts();
        self.retries_left = retries;
        self.wait = match (slave, response_ms) {
            (0, _) => timeouts.turnaround_ms,
            (_, 0) => timeouts.response_ms,
            (_, ms) => ms,
        };
        self.answer = 0;
        self.state = State::Due;
        self.seal();
        Ok(self.send_if_quiet())
    }

    /// The answer's PDU, function code first, once the request is done and answered:
    /// what a gateway passes back.
    #[cfg(feature = "tcp")]
    pub fn answer_pdu(&self) -> Option<&[u8]> {
        (self.state == State::Done && self.failure.is_none())
            .then(|| self.framer.buffer().get(1..2 + usize::from(self.answer)))
            .flatten()
    }

    /// Appends the CRC (in ASCII framing the LRC) to the request [`Engine::begin`] built.
    pub fn seal(&mut self) {
        // `begin` left room for the CRC: the bound only lets the compiler see it.
        let len = self.request_len.min(N - 2);
        self.request_len = match self.framer.framing() {
            // The same CRC as `Framing::seal`'s, written as the request's fixed buffer lets
            // the compiler place it in 14 B less (the slave's reply buffer the other way).
            Framing::Rtu => {
                let crc = Crc16::new().update_slice(self.request.get(..len).unwrap_or_default());
                if let Some(slot) = self.request.get_mut(len..len + 2) {
                    slot.copy_from_slice(&crc.to_wire());
                }
                len + 2
            }
            #[cfg(feature = "ascii")]
            framing => framing.seal(&mut self.request, len),
        };
    }

    /// True when a request may go out: T3.5 of silence has passed (in ASCII framing, the
    /// receiver is outside a frame).
    #[inline(always)]
    fn line_free(&self) -> bool {
        #[cfg(feature = "ascii")]
        if self.framer.is_ascii() {
            return self.ascii_line_free();
        }
        self.quiet
    }

    /// True when the frame just dropped was cut short by a `:` that started the next one
    /// (ASCII framing): a fragment, which ends no attempt (the reply may be the frame that
    /// follows). Never in RTU.
    #[inline(always)]
    fn cut_short(&self) -> bool {
        #[cfg(feature = "ascii")]
        return self.framer.is_ascii() && self.framer.is_in_frame();
        #[cfg(not(feature = "ascii"))]
        false
    }

    /// From `Due`: sends when the line is quiet. Out of line: a request, T3.5 and the
    /// clock's turns all end here.
    #[inline(never)]
    fn send_if_quiet(&mut self) -> Action {
        if self.state == State::Due && self.line_free() {
            // What the line carries while the request goes out (`Sending`) is the request
            // itself (a transceiver that hears its own transmitter echoes it) or a
            // collision: no reply, ignored.
            self.state = State::Sending;
            self.quiet = false;
            self.count(Count::Requests);
            Action::Send
        } else {
            Action::None
        }
    }

    /// The request's bytes as sent (address to CRC; in ASCII framing address to LRC, before
    /// they are written out in hex).
    pub fn request(&self) -> &[u8] {
        self.request.get(..self.request_len).unwrap_or_default()
    }

    /// Character `index` on the wire of the request: what the framing makes of its bytes.
    #[inline(always)]
    pub fn request_char(&self, index: usize) -> u8 {
        self.framer.framing().char_at(&self.request, self.request_len, index)
    }

    /// Characters of the request on the wire.
    #[inline(always)]
    pub fn request_chars(&self) -> usize {
        self.framer.framing().chars(self.request_len)
    }

    /// The framing the master runs.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    #[inline(always)]
    pub(crate) fn framing(&self) -> crate::link::framing::Framing {
        self.framer.framing()
    }

    /// The request's length in bytes.
    #[inline(always)]
    pub fn request_len(&self) -> usize {
        self.request_len
    }

    /// A character arrived.
    #[inline(always)]
    pub fn on_byte(&mut self, byte: u8) {
        if self.hears() {
            self.framer.on_byte(byte);
        }
    }

    /// A damaged character arrived.
    pub fn on_error(&mut self, error: UartError) {
        if self.hears() {
            self.framer.on_error(error);
        }
    }

    /// A character arrived, damaged or not: the line is no longer quiet, and the character
    /// is for the framer unless the request is going out (it is then its echo, or a
    /// collision).
    #[inline(always)]
    fn hears(&mut self) -> bool {
        self.quiet = false;
        self.state != State::Sending
    }

    /// The gap deadline (T1.5) passed since the last character.
    pub fn on_gap_deadline(&mut self) {
        self.framer.on_gap_deadline();
    }

    /// The request's last character has left the wire, at `now` (milliseconds, rounded
    /// down): the response timeout starts (for a broadcast, the turnaround delay). The
    /// caller starts the silence deadlines from here, so that the next request waits T3.5.
    /// From here on characters are heard: a slave should wait T3.5 before it answers, but
    /// many answer sooner (pymodbus's server, for one), and their replies are taken.
    pub fn on_sent(&mut self, now: u32) {
        if self.state == State::Sending {
            self.state = if self.expect.is_broadcast() { State::Turnaround } else { State::Waiting };
            self.deadline = now.wrapping_add(u32::from(self.wait));
        }
    }

    /// T3.5 of silence passed since the last character: a frame that ended is judged, and
    /// a request that waited for the silence goes out.
    pub fn on_end_deadline(&mut self) -> Action {
        self.quiet = true;
        match self.framer.on_end_deadline() {
            None => {}
            Some(Ok(len)) => self.on_frame(len),
            Some(Err(error)) => {
                crate::link::bump(&mut self.counts, error.counter());
                if self.state == State::Waiting && !self.cut_short() {
                    self.attempt_failed(Failure::BadReply);
                }
            }
        }
        self.send_if_quiet()
    }

    /// A good frame of `len` bytes ended.
    fn on_frame(&mut self, len: usize) {
        if self.state != State::Waiting {
            self.count(Count::Unexpected);
            self.framer.release();
            return;
        }
        // The framer drops a frame longer than its buffer: `len` is at most `N`.
        match self.expect.check(&self.request, self.framer.buffer(), len) {
            Verdict::Answer => {
                self.count(Count::Replies);
                // An answer is 4 to `N` bytes long.
                self.answer = len.wrapping_sub(4) as u8;
                self.finish(None);
                // The framer keeps the reply until it is collected.
                return;
            }
            Verdict::Exception(code) => {
                self.count(Count::Replies);
                self.count(Count::Exceptions);
                self.finish(Some(Failure::Exception(code)));
            }
            Verdict::OtherSlave => self.count(Count::Unexpected),
            Verdict::Mismatch => {
                self.count(Count::Unexpected);
                self.attempt_failed(Failure::BadReply);
            }
        }
        self.framer.release();
    }

    #[inline(never)]
    fn finish(&mut self, failure: Option<Failure>) {
        self.failure = failure;
        self.state = State::Done;
    }

    /// The current try ended without an answer: again while retries are left (once the
    /// line is quiet), else the outcome is `failure`.
    #[inline(never)]
    fn attempt_failed(&mut self, failure: Failure) {
        if self.retries_left == 0 {
            self.finish(Some(failure));
        } else {
            self.retries_left -= 1;
            self.count(Count::Retries);
            self.state = State::Due;
        }
    }

    /// True while a response timeout or a turnaround delay runs: [`Engine::on_tick`] has
    /// something to check.
    #[inline(always)]
    pub fn is_timing(&self) -> bool {
        matches!(self.state, State::Waiting | State::Turnaround)
    }

    /// The clock reads `now` (milliseconds, rounded down): the response timeout or the
    /// turnaround delay may have passed. Called at least once a millisecond or so (Timer0's
    /// turn). Both clock readings are rounded down, so a wait ends only once the count has
    /// gone one past the setting: never shorter than it, at most 2 ms longer.
    pub fn on_tick(&mut self, now: u32) -> Action {
        // Past the deadline: `now` is later than it, by less than half the clock's range.
        if self.is_timing() && (now.wrapping_sub(self.deadline) as i32) > 0 {
            if self.state == State::Waiting {
                self.count(Count::Timeouts);
                self.attempt_failed(Failure::Timeout);
            } else {
                self.finish(None);
            }
        }
        self.send_if_quiet()
    }

    /// The outcome, once the request is done: the reply, read in place, or why there is
    /// none. `None` while a request is under way or when there is none.
    pub fn outcome(&self) -> Option<Result<Reply<'_>, Failure>> {
        if self.state != State::Done {
            return None;
        }
        Some(match self.failure {
            Some(failure) => Err(failure),
            None => Ok(Reply::new(self.framer.buffer(), self.answer, &self.expect)),
        })
    }

    /// The outcome was collected: the master is idle and listens again.
    pub fn collect(&mut self) {
        if self.state == State::Done {
            self.state = State::Idle;
            self.framer.release();
        }
    }
}

impl<const N: usize> crate::link::Receive for Engine<N> {
    #[inline(always)]
    fn on_byte(&mut self, byte: u8) {
        Engine::on_byte(self, byte);
    }

    #[inline(always)]
    fn on_error(&mut self, error: UartError) {
        Engine::on_error(self, error);
    }

    #[inline(always)]
    fn framing(&self) -> crate::link::framing::Framing {
        self.framer.framing()
    }

    #[cfg(feature = "ascii")]
    #[inline(always)]
    fn on_char(&mut self, c: u8) -> bool {
        Engine::on_char(self, c)
    }
}
