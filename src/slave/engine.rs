//! The RTU slave without hardware, Modbus over Serial Line v1.02 §2.4 (master/slave
//! protocol, broadcast, address check) and §6.1.3 (diagnostic counters).
//!
//! [`Engine`], the slave's protocol state, joins the [`Framer`] to the PDU engine: the AVR layer forwards interrupts to
//! its `on_*` methods, the host tests script the same calls. Data flows one way: bytes →
//! framer → address and CRC check → [`respond`](crate::slave::pdu::respond) → reply in the same buffer.

use crate::link::config::SlaveId;
use crate::link::framer::{FrameError, Framer, UartError, MAX_FRAME};
use crate::slave::counters::SlaveCounters;
use crate::slave::model::DataModel;
use crate::slave::pdu::Answer;
use crate::slave::pdu::{encode_exception, execute, extra, Exception, FunctionCode};

#[cfg(feature = "diagnostics")]
use crate::slave::diagnostics;

/// What the end of a frame (T3.5) led to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EndOfFrame {
    /// No frame was in progress.
    Nothing,
    /// The frame was dropped in silence, and counted.
    Dropped(FrameError),
    /// A good frame for another slave: silence.
    OtherSlave,
    /// A good frame for this slave: call [`Engine::process`], then send [`Engine::reply`].
    /// Its first byte is this slave's address, known before processing.
    Reply,
    /// A good broadcast: call [`Engine::process`] to execute it; nothing is sent.
    Broadcast,
    /// A good frame for this slave that gets no reply: every frame while the slave is in
    /// listen-only mode, and FC 8 sub-function 04 that puts it there (Application
    /// Protocol v1.1b3 §6.8.1). Call [`Engine::process`]; nothing is sent, not even the
    /// address.
    Silent,
}

/// A Modbus RTU slave's protocol state: the frame buffer (of `N` bytes, see
/// [`DataModel::FRAME`]), the address, the counters.
///
/// In declaration order (`repr(C)`): the address, then the framer, whose first fields are
/// the only others that start other than zero (see [`Framer`]).
#[repr(C)]
#[derive(Clone, Debug)]
pub struct Engine<const N: usize = MAX_FRAME> {
    id: SlaveId,
    framer: Framer<N>,
    /// The counters, in the order of [`SlaveCounters`]'s fields (see [`Count`]).
    counts: [u16; COUNTS],
    /// What [`Engine::on_end_deadline`] decided for the frame not yet processed (whose
    /// length the framer keeps, [`Framer::frame_len`]).
    pending: Pending,
    reply_len: usize,
    listen_only: bool,
    /// Writes refused with exception 01 ([`Engine::set_read_only`], feature `write-protect`).
    #[cfg(feature = "write-protect")]
    read_only: bool,
}

/// A frame [`Engine::on_end_deadline`] accepted and [`Engine::process`] has yet to
/// handle: the ends of [`EndOfFrame`] that lead to processing. `None`, 0, is what a
/// slave at rest holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pending {
    None,
    Reply,
    Broadcast,
    Silent,
}

/// A counter's place in [`Engine::counts`]: the order of [`SlaveCounters`]'s fields. A
/// damaged frame's counter is at [`FrameError::counter`], as in the master's.
#[derive(Clone, Copy)]
enum Count {
    Frames,
    CrcErrors,
    UartErrors,
    Overruns,
    Malformed,
    Messages,
    Exceptions,
    Replies,
    Broadcasts,
    NoResponse,
    Events,
    #[cfg(feature = "write-protect")]
    RefusedWrites,
}

/// How many counters there are.
const COUNTS: usize = Count::Events as usize + 1 + cfg!(feature = "write-protect") as usize;

const _: () = {
    use FrameError::*;
    assert!(BadCrc.counter() == Count::CrcErrors as u8 && Uart.counter() == Count::UartErrors as u8);
    assert!(Overrun.counter() == Count::Overruns as u8 && TooLong.counter() == Count::Overruns as u8);
    assert!(TooShort.counter() == Count::Malformed as u8 && Gap.counter() == Count::Malformed as u8);
    #[cfg(feature = "ascii")]
    assert!(Encoding.counter() == Count::Malformed as u8);
};

impl<const N: usize> Engine<N> {
    /// FC 8 echoes up to 252 bytes of data, FC 17, 23 and 43 reply with up to 255 bytes: with
    /// them the buffer holds the longest frame.
    const CAPACITY: () = assert!(
        N == MAX_FRAME || !cfg!(any(feature = "diagnostics", feature = "extra-fc", feature = "device-id")),
        "features `diagnostics`, `extra-fc` and `device-id` need a 256-byte frame buffer"
    );

    /// A slave with address `id`, just after power-up (waiting for T3.5 of silence).
    pub const fn new(id: SlaveId) -> Self {
        let () = Self::CAPACITY;
        Engine {
            framer: Framer::new(),
            id,
            counts: [0; COUNTS],
            pending: Pending::None,
            reply_len: 0,
            listen_only: false,
            #[cfg(feature = "write-protect")]
            read_only: false,
        }
    }

    /// This slave's address.
    pub fn id(&self) -> SlaveId {
        self.id
    }

    /// The address of the frame [`Engine::on_end_deadline`] accepted and
    /// [`Engine::process`] has yet to handle (0 for a broadcast).
    #[inline(always)]
    pub fn frame_address(&self) -> u8 {
        self.framer.buffer()[0]
    }

    /// Changes this slave's address, from the next frame on.
    pub fn set_id(&mut self, id: SlaveId) {
        self.id = id;
    }

    /// The counters.
    pub fn counters(&self) -> SlaveCounters {
        let [frames, crc_errors, uart_errors, overruns, malformed, messages, exceptions, replies, broadcasts, no_response, events, ..] =
            self.counts;
        SlaveCounters {
            frames,
            crc_errors,
            uart_errors,
            overruns,
            malformed,
            messages,
            exceptions,
            replies,
            broadcasts,
            no_response,
            events,
            #[cfg(feature = "write-protect")]
            refused_writes: self.counts[Count::RefusedWrites as usize],
        }
    }

    /// Refuses every write from now on (`true`) or allows them again (feature
    /// `write-protect`): FC 5, 6, 15 (0x0F), 16 (0x10), 22 (0x16) and 23 (0x17) get exception 01
    /// (Illegal Function) before anything else of the request is checked, change nothing and
    /// are counted ([`SlaveCounters::refused_writes`]); a broadcast write is dropped, as
    /// broadcasts get no reply. Reads, and FC 8's counters, go on. FC 8's restart leaves the
    /// setting as it is.
    #[cfg(feature = "write-protect")]
    pub fn set_read_only(&mut self, on: bool) {
        self.read_only = on;
    }

    /// True while writes are refused ([`Engine::set_read_only`], feature `write-protect`).
    #[cfg(feature = "write-protect")]
    pub fn is_read_only(&self) -> bool {
        self.read_only
    }

    /// One more in `counter`, wrapping (through [`Engine::bump_at`]).
    #[inline(always)]
    fn bump(&mut self, counter: Count) {
        self.bump_at(counter as u8);
    }

    /// One more in the counter at `at` in [`Engine::counts`], wrapping ([`crate::link::bump`]).
    #[inline(always)]
    fn bump_at(&mut self, at: u8) {
        crate::link::bump(&mut self.counts, at);
    }

    /// A character arrived.
    #[inline(always)]
    pub fn on_byte(&mut self, byte: u8) {
        self.framer.on_byte(byte);
    }

    /// An ASCII character arrived (feature `ascii`, in ASCII mode). Returns true when a
    /// frame's outcome is due: call [`Engine::on_end_deadline`] then, and process what it
    /// accepted as after T3.5 (at the LF that ends a frame, and at a `:` that drops the
    /// frame in progress).
    #[cfg(feature = "ascii")]
    pub fn on_char(&mut self, c: u8) -> bool {
        self.framer.on_char(c)
    }

    /// Switches between RTU and ASCII framing (feature `ascii`), from the next frame on.
    #[cfg(feature = "ascii")]
    pub fn set_ascii(&mut self, on: bool) {
        self.framer.set_ascii(on);
    }

    /// True in ASCII mode (feature `ascii`).
    #[cfg(feature = "ascii")]
    pub fn is_ascii(&self) -> bool {
        self.framer.is_ascii()
    }

    /// A damaged character arrived.
    pub fn on_error(&mut self, error: UartError) {
        self.framer.on_error(error);
    }

    /// The inter-character gap deadline passed.
    pub fn on_gap_deadline(&mut self) {
        self.framer.on_gap_deadline();
    }

    /// T3.5 of silence passed: checks the frame's CRC and address and counts.
    pub fn on_end_deadline(&mut self) -> EndOfFrame {
        self.end_of_frame(|engine, address| address == engine.id.get())
    }

    /// [`Engine::on_end_deadline`] for a slave serving `model`: with a model of several
    /// slave ids ([`DataModel::UNITS`]) the model says which addresses are this slave's
    /// ([`DataModel::select`], which also picks the unit that [`Engine::process`] serves);
    /// with any other, the slave id alone.
    #[inline(always)]
    pub fn on_end_deadline_for<M: DataModel + ?Sized>(&mut self, model: &mut M) -> EndOfFrame {
        if M::UNITS {
            self.end_of_frame(|_, address| model.select(address))
        } else {
            self.on_end_deadline()
        }
    }

    /// The end of a frame, its address (not the broadcast address) this slave's when
    /// `ours` says so (asked only then, and given the engine: the slave id is read there).
    #[inline(always)]
    fn end_of_frame(&mut self, ours: impl FnOnce(&Self, u8) -> bool) -> EndOfFrame {
        let Some(result) = self.framer.on_end_deadline() else {
            return EndOfFrame::Nothing;
        };
        self.bump(Count::Frames);
        let len = match result {
            Ok(len) => len,
            Err(e) => {
                self.bump_at(e.counter());
                return EndOfFrame::Dropped(e);
            }
        };
        let address = self.framer.buffer()[0];
        let broadcast = address == SlaveId::BROADCAST;
        if !broadcast && !ours(self, address) {
            self.framer.release();
            return EndOfFrame::OtherSlave;
        }
        self.bump(Count::Messages);
        if broadcast {
            self.bump(Count::Broadcasts);
        }
        // Whether anything will be sent is decided here, before the first byte could
        // leave: the AVR layer starts the reply with the address as soon as this returns.
        let (pending, end) = if self.is_silent(broadcast, len) {
            (Pending::Silent, EndOfFrame::Silent)
        } else if broadcast {
            (Pending::Broadcast, EndOfFrame::Broadcast)
        } else {
            (Pending::Reply, EndOfFrame::Reply)
        };
        if pending != Pending::Reply {
            self.bump(Count::NoResponse);
        }
        self.pending = pending;
        end
    }

    /// The request PDU of the frame of `len` bytes (with address and CRC) in the buffer.
    fn request(&self, len: usize) -> &[u8] {
        self.framer.buffer().get(1..len.saturating_sub(2).max(1)).unwrap_or(&[])
    }

    /// True for a frame that gets no reply at all: every frame in listen-only mode, and
    /// FC 8 sub-function 04 with data 0000, which enters it (only with feature
    /// `diagnostics`; without it the slave is never listen-only).
    fn is_silent(&self, broadcast: bool, len: usize) -> bool {
        diagnostics::ENABLED && (self.listen_only || (!broadcast && diagnostics::forces_listen_only(self.request(len))))
    }

    /// Executes the frame that [`Engine::on_end_deadline`] accepted and writes the reply
    /// (address, PDU, CRC; in ASCII mode address, PDU, LRC, which the sender writes out in
    /// hex) over it. Returns the reply's length; 0 when nothing is to be sent
    /// (a broadcast, listen-only mode), and then the buffer is released at once.
    ///
    /// Not inlined: the T3.5 interrupt that calls it then saves only the registers a call
    /// may change, and its first reply byte leaves that much sooner.
    #[inline(never)]
    pub fn process<M: DataModel + ?Sized>(&mut self, model: &mut M) -> usize {
        let body = self.prepare(model);
        if body == 0 {
            return 0;
        }
        // The reply always leaves room for a CRC (the framer's buffer holds the request's).
        let framing = self.framer.framing();
        self.reply_len = framing.seal(self.framer.buffer_mut(), body);
        self.reply_len
    }

    /// Like [`Engine::process`] but leaves the CRC to the sender: returns the length of
    /// address and PDU, and [`Engine::reply`] holds just those, for a sender that computes
    /// the CRC itself as the bytes go out.
    pub fn prepare<M: DataModel + ?Sized>(&mut self, model: &mut M) -> usize {
        // Read here, not kept from `on_end_deadline`: the T3.5 interrupt then holds no length
        // across its calls.
        let len = self.framer.frame_len();
        match core::mem::replace(&mut self.pending, Pending::None) {
            pending @ (Pending::Reply | Pending::Broadcast) => self.answer(len, model, pending == Pending::Reply),
            // Without feature `diagnostics` no frame is ever silent (`Engine::is_silent`).
            Pending::Silent if diagnostics::ENABLED => {
                self.stay_silent(len);
                0
            }
            Pending::Silent | Pending::None => 0,
        }
    }

    /// The one dispatch on the function code: FC 7, 8, 11 (0x0B) and 17 (0x11) go to the
    /// diagnostics (exception 01 without feature `diagnostics`), FC 22 (0x16) and 23 (0x17)
    /// to the extra codes (exception 01 without feature `extra-fc`), every other code to
    /// the PDU engine. The reply PDU is written over the request. A broadcast (`unicast`
    /// false) only checks a read and executes a write.
    fn handle<M: DataModel + ?Sized>(&mut self, len: usize, model: &mut M, unicast: bool) -> Result<Answer, Exception> {
        // The PDU sits between the address and the CRC (a frame handed on has at least 4
        // bytes, `MIN_FRAME`, so either subtraction gives the same; each is the smaller code
        // where it is used).
        let pdu_len = if diagnostics::ENABLED { len.saturating_sub(3) } else { len.wrapping_sub(3) };
        #[cfg(feature = "write-protect")]
        if self.read_only && crate::slave::pdu::is_write_code(self.framer.buffer()[1]) {
            self.bump(Count::RefusedWrites);
            return Err(Exception::IllegalFunction);
        }
        let counters = if diagnostics::ENABLED { self.counters() } else { SlaveCounters::new() };
        // With several ids, the one addressed (FC 17 reports it).
        let id = if M::UNITS { self.address() } else { self.id.get() };
        let (_, pdu) = self.framer.buffer_mut().split_at_mut(1);
        dispatch(pdu, pdu_len, model, &counters, id, unicast)
    }

    /// Counts a handled request: an exception, or an event (FC 11 (0x0B) excepted, which
    /// reads the event counter).
    fn count(&mut self, result: &Result<Answer, Exception>) {
        match result {
            Err(_) => self.bump(Count::Exceptions),
            Ok(_) => {
                let code = self.framer.buffer().get(1).copied();
                if !diagnostics::ENABLED || code != Some(FunctionCode::GetCommEventCounter.code()) {
                    self.bump(Count::Events);
                }
            }
        }
    }

    /// A request to this slave (`unicast`) or a broadcast: handled and counted. A request
    /// to this slave leaves its reply (address and PDU) in the buffer; returns the reply's
    /// length.
    ///
    /// A broadcast: writes are executed, nothing is answered (returns 0, the buffer is
    /// released). Reads and diagnostics are only checked, and counted as the same request
    /// sent to this slave would be: an event when valid (FC 11 (0x0B) excepted), an
    /// exception when not. Nothing is acted on: a broadcast FC 8 neither clears the
    /// counters nor enters listen-only mode.
    ///
    /// One call of [`Engine::handle`] for both, so that it is inlined here.
    fn answer<M: DataModel + ?Sized>(&mut self, len: usize, model: &mut M, unicast: bool) -> usize {
        let result = if M::UNITS && !unicast { self.each_unit(len, model) } else { self.handle(len, model, unicast) };
        self.count(&result);
        if !unicast {
            self.framer.release();
            return 0;
        }
        let reply_pdu = match result {
            Ok(Answer::Reply(n) | Answer::Restart(n)) => n,
            // Classified as silent by `on_end_deadline`, so never met here; were it met,
            // the request would still be answered, as an echo.
            Ok(Answer::ListenOnly) => {
                self.listen_only = true;
                len.saturating_sub(3)
            }
            Err(exception) => encode_exception(self.framer.buffer_mut().get_mut(1..).unwrap_or(&mut []), exception),
        };
        self.bump(Count::Replies);
        if let Ok(Answer::Restart(_)) = result {
            self.restart();
        }
        // The longest reply PDU is 252 bytes, so address, PDU and CRC always fit. Set after
        // the calls above, so that it is not read back from memory.
        self.reply_len = 1 + reply_pdu;
        self.reply_len
    }

    /// A broadcast to a model of several slave ids ([`DataModel::UNITS`]): handled once for
    /// each id the model answers, in order, so that a write is made in each unit's model or
    /// window. The request stays as it came for the next unit (a broadcast only writes; what
    /// a diagnostic writes over it is never acted on). Counted once, as one request to this
    /// slave: valid when it was for any unit.
    fn each_unit<M: DataModel + ?Sized>(&mut self, len: usize, model: &mut M) -> Result<Answer, Exception> {
        let mut result = Err(Exception::IllegalFunction);
        // Every slave id (Serial Line §2.2: 1–247).
        for unit in 1..=247 {
            if model.select(unit) {
                result = result.or(self.handle(len, model, false));
            }
        }
        result
    }

    /// The address of the frame in the buffer: the slave id a reply carries.
    #[inline(always)]
    pub(crate) fn address(&self) -> u8 {
        self.framer.buffer()[0]
    }

    /// A frame that gets no reply. FC 8 sub-function 04 enters listen-only mode; in it,
    /// only FC 8 sub-function 01 (restart communications) is acted on, and even that is
    /// not answered. Nothing else is executed, broadcasts included.
    fn stay_silent(&mut self, len: usize) {
        let pdu = self.request(len);
        if !self.listen_only {
            self.listen_only = diagnostics::forces_listen_only(pdu);
        } else if diagnostics::restarts_communications(pdu) && self.framer.buffer()[0] != SlaveId::BROADCAST {
            self.restart();
        }
        self.framer.release();
    }

    /// FC 8 sub-function 01 or 0A: the counters cleared, listen-only mode left.
    fn restart(&mut self) {
        self.counts = [0; COUNTS];
        self.listen_only = false;
    }

    /// True while FC 8 sub-function 04 keeps the slave silent.
    pub fn is_listen_only(&self) -> bool {
        self.listen_only
    }

    /// The reply built by [`Engine::process`], valid until [`Engine::on_reply_sent`].
    pub fn reply(&self) -> &[u8] {
        self.framer.buffer().get(..self.reply_len).unwrap_or(&[])
    }

    /// Character `i` on the wire of the reply built by [`Engine::process`], for the sender:
    /// what the framing makes of its bytes.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    #[inline(always)]
    pub(crate) fn reply_char(&self, i: usize) -> u8 {
        self.framer.framing().char_at(self.framer.buffer(), self.reply_len, i)
    }

    /// The framing this slave runs.
    #[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
    #[inline(always)]
    pub(crate) fn framing(&self) -> crate::link::framing::Framing {
        self.framer.framing()
    }

    /// The reply's last byte left the USART: listen again.
    #[inline(always)]
    pub fn on_reply_sent(&mut self) {
        // A frame accepted but never processed is abandoned with the buffer.
        self.pending = Pending::None;
        self.reply_len = 0;
        self.framer.release_here();
    }

    /// Handles one whole frame as if it had arrived with correct timing: T3.5 of silence,
    /// the frame's bytes, T3.5 of silence (in ASCII mode the frame's characters, each frame
    /// in them handled at its end). The ADU layer in one call, for tests and for
    /// links that deliver frames ready-made. Afterwards [`Engine::reply`] holds the reply,
    /// if the result is [`EndOfFrame::Reply`].
    ///
    /// It can be mixed with the event methods ([`Engine::on_byte`] and the rest): as on
    /// the wire, the silence before the frame first ends whatever they fed, which is then
    /// handled as the AVR layer would (counted, executed if it is a good frame for this
    /// slave; its reply is discarded), and a reply not yet sent is abandoned.
    pub fn handle_frame<M: DataModel + ?Sized>(&mut self, frame: &[u8], model: &mut M) -> EndOfFrame {
        self.complete(model);
        self.on_reply_sent();
        #[cfg(feature = "ascii")]
        if self.is_ascii() {
            // ASCII frames end by themselves, at their LF: each one is handled there.
            let mut end = EndOfFrame::Nothing;
            for &c in frame {
                if self.on_char(c) {
                    self.on_reply_sent();
                    end = self.complete(model);
                }
            }
            return end;
        }
        for &byte in frame {
            self.on_byte(byte);
        }
        self.complete(model)
    }

    /// T3.5 of silence: ends the frame in progress and executes it if it is one to
    /// execute (also ends the power-up wait).
    fn complete<M: DataModel + ?Sized>(&mut self, model: &mut M) -> EndOfFrame {
        let end = self.on_end_deadline_for(model);
        self.process(model);
        end
    }
}

/// The one dispatch on the function code, for a request PDU of `pdu_len` bytes at the start
/// of `pdu` (its first bytes, when the buffer is shorter): FC 7, 8, 11 (0x0B) and 17 (0x11)
/// go to the diagnostics (exception 01 without feature `diagnostics`), FC 22 (0x16) and 23
/// (0x17) to the extra codes (exception 01 without feature `extra-fc`), FC 43 (0x2B) to the
/// device identification, every other code to the PDU engine. The reply PDU is written over
/// the request. A broadcast (`unicast` false) only checks a read and executes a write. The
/// RTU slave's and the TCP server's.
#[inline(always)]
pub(crate) fn dispatch<M: DataModel + ?Sized>(
    pdu: &mut [u8],
    pdu_len: usize,
    model: &mut M,
    counters: &SlaveCounters,
    id: u8,
    unicast: bool,
) -> Result<Answer, Exception> {
    // Without their features, the optional codes fall through to `execute`, which
    // answers 01 for every code it doesn't know: no comparison is left for them.
    let code = FunctionCode::from_code(pdu.first().copied().unwrap_or(0));
    let result = match code {
        _ if diagnostics::ENABLED && code.is_diagnostic() => {
            return diagnostics::respond(pdu, pdu_len, model, counters, id)
        }
        FunctionCode::MaskWriteRegister | FunctionCode::ReadWriteMultipleRegisters if extra::ENABLED => {
            extra::respond(pdu, pdu_len, model, unicast)
        }
        #[cfg(feature = "device-id")]
        FunctionCode::EncapsulatedInterface => {
            crate::slave::pdu::device_id::respond(pdu, pdu_len, model.identification(), unicast)
        }
        _ => execute(pdu, pdu_len, model, unicast),
    };
    result.map(Answer::Reply)
}

/// Without feature `diagnostics`: FC 7, 8, 11 and 17 answer exception 01 and the slave is
/// never listen-only.
#[cfg(not(feature = "diagnostics"))]
mod diagnostics {
    use crate::slave::counters::SlaveCounters;
    use crate::slave::model::DataModel;
    use crate::slave::pdu::Answer;
    use crate::slave::pdu::Exception;

    pub(crate) const ENABLED: bool = false;

    pub(crate) fn respond<M: DataModel + ?Sized>(
        _pdu: &mut [u8],
        _len: usize,
        _model: &M,
        _counters: &SlaveCounters,
        _slave_id: u8,
    ) -> Result<Answer, Exception> {
        Err(Exception::IllegalFunction)
    }

    pub(crate) fn forces_listen_only(_pdu: &[u8]) -> bool {
        false
    }

    pub(crate) fn restarts_communications(_pdu: &[u8]) -> bool {
        false
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
