//! A serial line on a timer's input capture and output compare units, AltSoftSerial's way
//! (feature `capture-line`): on the Uno, Nano and Pro Mini Timer1 with RX on pin 8 (ICP1)
//! and TX on pin 9 (OC1A); on the Leonardo and Micro Timer3, RX pin 13 (ICP3), TX pin 5
//! (OC3A); on the Megas Timer5, RX pin 48 (ICP5), TX pin 46 (OC5A) (`chips/chips.txt`).
//! ATmega328P datasheet §16 (16-bit Timer/Counter1): §16.6 the input capture unit, §16.7 the
//! output compare units, §16.8 the compare match output unit.
//!
//! The timer runs freely in normal mode at clk/8 (0.5 µs a tick at 16 MHz, 1 µs at 8 MHz).
//! - **Receiving**: the capture unit copies the count into ICRn at each edge of RX, so an
//!   edge's time does not depend on when its interrupt runs. A falling edge on an idle line
//!   starts a character; each later edge says that the bits whose middles it passed had the
//!   level before it. Compare B is set to the middle of the first stop bit: its interrupt
//!   samples the rest, where the USART's receiver sets its receive flag. The edge-select bit
//!   follows the line, so each edge is one interrupt; a character takes as many as it has
//!   level changes (at most 10, 8E1) and one more at its end.
//! - **Sending**: compare A drives TX. Its interrupt runs at each level change the hardware
//!   made, and sets the next one (the time in OCRnA, the level in COMnA1:0); bits of the same
//!   level cost nothing. A character's end is one more match, which starts the next.
//!
//! To the roles this is a USART (`super::usart::Usart` forwards to it for line
//! [`CAPTURE_LINE`]): a received character and its damage (parity, framing, overrun), a
//! one-character transmit buffer, and the same three events, character received, room for the
//! next (data register empty) and transmission complete, which the roles' handlers receive
//! from this module's three interrupts ([`crate::slave!`] and [`crate::master!`] bind them).
//!
//! The silences (T1.5, T3.5) are Timer0's, as on a USART: each character's deadlines count
//! from the compare B interrupt at its first stop bit's middle, a time the capture unit's
//! stamp of its start edge fixed.

use core::cell::UnsafeCell;

use super::chip::CHIP;
use super::reg::Reg;
use super::timer::Exclusive;
use crate::link::config::{Line, Parity, StopBits};
use crate::link::framer::UartError;
use crate::link::timing::CLOCK_HZ;

/// The line number the roles know the capture line by, after the USARTs' 0 to 3.
pub(crate) const CAPTURE_LINE: u8 = 4;

/// Timer ticks per second: the CPU clock / 8.
const TICK_HZ: u32 = CLOCK_HZ / 8;

/// The lowest and highest rates the line runs at: a character at 1200 bps (11 bits, 18 333
/// ticks at 16 MHz) fits in the 16-bit count; at 38 400 a bit is 52 ticks (26 at 8 MHz).
pub(crate) const RATES: (u32, u32) = (1200, 38_400);

/// Whether the line runs at `line`'s rate ([`RATES`]).
pub(crate) const fn runs_at(line: &Line) -> bool {
    line.baud() >= RATES.0 && line.baud() <= RATES.1
}

/// Ticks from the read of the count to the start bit of a character written to an idle
/// transmitter (4 µs at 16 MHz): far enough ahead that the counter has not passed it when
/// OCRnA is written, a few instructions later (a compare value passed waits a whole turn).
const LEAD: u16 = 8;

// TCCRnA
const COMA1: u8 = 1 << 7;
const COMA0: u8 = 1 << 6;
// TCCRnB
const ICNC: u8 = 1 << 7;
const ICES: u8 = 1 << 6;
const CLOCK_DIV_8: u8 = 0b010;
// TCCRnC
const FOCA: u8 = 1 << 7;
// TIMSKn and TIFRn share their bits.
const CAPTURE: u8 = 1 << 5;
const COMPARE_B: u8 = 1 << 2;
const COMPARE_A: u8 = 1 << 1;

/// The timer's registers, from the chip's table.
const TCCRA: Reg = Reg::at(CHIP.capture.block);
const TCCRB: Reg = Reg::at(CHIP.capture.block + 1);
const TCCRC: Reg = Reg::at(CHIP.capture.block + 2);
const TCNT: usize = CHIP.capture.block + 4;
const ICR: usize = CHIP.capture.block + 6;
const OCRA: usize = CHIP.capture.block + 8;
const OCRB: usize = CHIP.capture.block + 10;
const TIMSK: Reg = Reg::at(CHIP.capture.timsk);
const TIFR: Reg = Reg::at(CHIP.capture.tifr);
/// The port with both pins: PINx, DDRx, PORTx.
const PIN: Reg = Reg::at(CHIP.capture.port);
const DDR: Reg = Reg::at(CHIP.capture.port + 1);
const PORT: Reg = Reg::at(CHIP.capture.port + 2);
const RX: u8 = 1 << CHIP.capture.rx;
const TX: u8 = 1 << CHIP.capture.tx;

/// Reads a 16-bit timer register: low byte first, which latches the high one (§16.3).
/// Interrupts must be disabled (the latch is the timer's one TEMP register).
#[inline(always)]
fn read16(address: usize) -> u16 {
    let low = Reg::at(address).read();
    let high = Reg::at(address + 1).read();
    u16::from_le_bytes([low, high])
}

/// Writes a 16-bit timer register: high byte first, into TEMP; the low byte's write moves both
/// (§16.3). Interrupts must be disabled.
#[inline(always)]
fn write16(address: usize, value: u16) {
    let [low, high] = value.to_le_bytes();
    Reg::at(address + 1).write(high);
    Reg::at(address).write(low);
}

/// `later` is after `earlier` on the wrapping 16-bit count (within half a turn, 16 ms).
#[inline(always)]
fn after(later: u16, earlier: u16) -> bool {
    (later.wrapping_sub(earlier) as i16) > 0
}

/// The receiver between characters.
const IDLE: u8 = u8::MAX;

/// The line's format and state, all bytes and words so that it starts all zero, in `.bss`;
/// a role's start configures it. Touched only with interrupts disabled.
struct State {
    /// Ticks per bit, rounded.
    bit: u16,
    /// Ticks from a start edge to the middle of the first stop bit, rounded up.
    stop_middle: u16,
    /// Data bits: 8, or 7 in ASCII framing.
    data_bits: u8,
    /// The bit after the last data bit, where the parity bit goes, the first stop bit's
    /// index when there is none (1 + data bits + parity bits).
    stop_index: u8,
    /// The parity the data and parity bits add up to: 0 even, 1 odd, [`NO_PARITY`] none.
    parity: u8,
    /// Ones from the bit after the data on: the parity bit (cleared where it is to be 0), the
    /// stop bits and the idle line after them, of a character sent.
    stop_ones: u16,
    /// The parity bit of a character sent, in place.
    parity_bit: u16,
    /// Bits a character sent takes after its start bit: data, parity and stop bits.
    tx_bits: u8,
    /// The receiver: bits sampled of the character coming in ([`IDLE`] between characters)
    /// and the time of the next one's middle; the bits so far, the latest in bit 15; the
    /// character's damage so far ([`FRAMING`] for a missed edge).
    sampled: u8,
    next_middle: u16,
    shift: u16,
    damage: u8,
    /// A character received and not yet read ([`RECEIVED`]) and its damage, or none: the
    /// USART's UDRn and error flags.
    received: u8,
    received_data: u8,
    /// The role is busy (the slave answering a request with interrupts enabled): characters
    /// received wait, without the receive event.
    held: bool,
    /// A character received is for the role at the next compare B interrupt.
    deliver: bool,
    /// Compare B's flag was up for the last character when an edge after its first stop
    /// bit's middle completed it and began the next: the match is that character's (its
    /// sampled bits and damage), not this one's first stop bit.
    early: bool,
    early_bits: (u16, u8),
    /// The transmitter: the bits of the character going out still to send (the next in bit
    /// 0) and how many, whether its end is the next match, whether a character is going out.
    frame: u16,
    left: u8,
    ending: bool,
    sending: bool,
    /// The transmit buffer: the next character, when `next_full`.
    next: u8,
    next_full: bool,
    /// The events the role asked for: [`FEED`], [`DONE`].
    events: u8,
}

/// `State::parity` when there is no parity bit.
const NO_PARITY: u8 = 2;
/// A character waits in the receive buffer (`State::received`); the damage bits follow.
const RECEIVED: u8 = 1 << 0;
/// Damage: a low stop bit, or an edge missed.
const FRAMING: u8 = 1 << 1;
/// Damage: the parity does not add up.
const PARITY: u8 = 1 << 2;
/// Damage: characters were lost before this one (the last was not read).
const OVERRUN: u8 = 1 << 3;

/// The role wants the next character when the buffer is empty (UDRIEn).
pub(crate) const FEED: u8 = 1 << 0;
/// The role wants to know when the last character has left the wire (TXCIEn).
pub(crate) const DONE: u8 = 1 << 1;

static STATE: Exclusive<State> = Exclusive(UnsafeCell::new(State {
    bit: 0,
    stop_middle: 0,
    data_bits: 0,
    stop_index: 0,
    parity: 0,
    stop_ones: 0,
    parity_bit: 0,
    tx_bits: 0,
    sampled: 0,
    next_middle: 0,
    shift: 0,
    damage: 0,
    received: 0,
    received_data: 0,
    held: false,
    deliver: false,
    early: false,
    early_bits: (0, 0),
    frame: 0,
    left: 0,
    ending: false,
    sending: false,
    next: 0,
    next_full: false,
    events: 0,
}));

/// Runs `f` on the line's state.
///
/// # Safety
/// Interrupts disabled, and `f` does not reach the state again.
#[inline(always)]
unsafe fn with<R>(f: impl FnOnce(&mut State) -> R) -> R {
    // SAFETY: the caller's promise.
    unsafe { STATE.with(f) }
}

/// What the transmitter asks of the role after a compare A interrupt.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Transmit {
    /// Nothing.
    Nothing,
    /// The buffer is empty and the role asked to feed it: the data-register-empty event.
    Feed,
    /// The last character has left the wire: the transmit-complete event.
    Done,
}

/// Configures the timer, the pins and the format for `line`: TX high (idle), RX an input with
/// its pull-up, the receiver waiting for a start bit, the capture interrupt on. Interrupts must
/// be disabled.
#[inline(always)]
pub(crate) fn configure(line: &Line) {
    // `start` refuses other rates; settings written at run time (feature `eeprom-settings`)
    // that name one run the line at the nearest it takes, never at a bit the count can't hold.
    let baud = line.baud().clamp(RATES.0, RATES.1);
    let bit = (TICK_HZ + baud / 2) / baud;
    #[cfg(feature = "ascii")]
    let data_bits = line.data_bits() as u8;
    #[cfg(not(feature = "ascii"))]
    let data_bits = 8;
    let (parity, parity_bits) = match line.parity() {
        Parity::None => (NO_PARITY, 0),
        Parity::Even => (0, 1),
        Parity::Odd => (1, 1),
    };
    let stop_bits = if line.stop_bits() == StopBits::Two { 2 } else { 1 };
    let stop_index = 1 + data_bits + parity_bits;
    // SAFETY: interrupts are disabled (the caller's promise); nothing else holds the state.
    unsafe {
        with(|s| {
            // All zero first (no character coming or going, nothing received or asked for),
            // as at power-up, then the format.
            // SAFETY: every field is an integer or a bool, for which zero is a value.
            *s = core::mem::zeroed();
            s.bit = bit as u16;
            // (1 + data + parity + 1/2) bits, in ticks rounded up: never before the middle.
            s.stop_middle = ((2 * u32::from(stop_index) + 1) * TICK_HZ).div_ceil(2 * baud) as u16;
            s.data_bits = data_bits;
            s.stop_index = stop_index;
            s.parity = parity;
            s.stop_ones = u16::MAX << data_bits;
            s.parity_bit = 1 << data_bits;
            s.tx_bits = data_bits + parity_bits + stop_bits;
            s.sampled = IDLE;
        })
    };
    TIMSK.write(0);
    // TX: OCnA set (high) at once, then the pin its output; RX: an input, pulled up.
    TCCRA.write(COMA1 | COMA0);
    TCCRC.write(FOCA);
    PORT.modify(|bits| bits | TX | RX);
    DDR.modify(|bits| (bits | TX) & !RX);
    // Normal mode, clk/8, the noise canceller on, the capture on a falling edge.
    TCCRB.write(ICNC | CLOCK_DIV_8);
    TIFR.write(CAPTURE | COMPARE_A | COMPARE_B);
    TIMSK.write(CAPTURE);
}

/// TIMERn_CAPT: an edge on RX. It calls nothing, so that its handler saves few registers: a
/// character it completes (it came after the first stop bit's middle, before that
/// interrupt ran) reaches the role from compare B's interrupt, whose flag is up already.
///
/// # Safety
/// Only from the capture interrupt handler, interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn on_edge() {
    let at = read16(ICR);
    let select = TCCRB.read();
    let rising = select & ICES != 0;
    // The next edge is the other way; a flag the switch raised is cleared (§16.6.3).
    TCCRB.write(select ^ ICES);
    TIFR.write(CAPTURE);
    let missed = (PIN.read() & RX != 0) != rising && TIFR.read() & CAPTURE == 0;
    // SAFETY: interrupts are disabled (the caller's promise).
    unsafe { with(|s| s.edge(at, rising, missed)) };
}

/// TIMERn_COMPB: the middle of the first stop bit of the character coming in, or a
/// character complete already to hand on (`State::deliver`, `State::early`). Its bits are
/// taken with interrupts disabled; then `arrived` (the role's silences, which count from
/// here, as from a USART's receive flag) runs, and the character is decoded and handed to
/// `received` (the role's receive handler) with interrupts enabled but for the role's own:
/// this line's transmitter and the role's Timer0 compare unit (`unit`, its bit in TIMSK0)
/// wait masked, so that nothing reaches the role meanwhile, while the edge interrupt catches
/// the next character's first edges, which come half a bit after this stop bit's middle (at
/// 38 400 bps, 208 cycles: less than decoding and handing on take).
///
/// # Safety
/// Only from the compare B interrupt handler, interrupts disabled; `arrived` and `received`
/// reach the role and its unit's deadlines, nothing the line's or another role's handlers
/// reach.
#[inline(always)]
pub(crate) unsafe fn on_stop_bit(unit: u8, arrived: impl FnOnce(), received: impl FnOnce()) {
    use super::reg::{self, TIMSK0};
    // The line's level now: low while the next edge to catch is a rising one.
    let level = TCCRB.read() & ICES == 0;
    // SAFETY: interrupts are disabled (the caller's promise).
    let (bits, format, held, withheld) = unsafe {
        with(|s| {
            let bits = if core::mem::take(&mut s.early) {
                // A match for a character an edge completed; the next one may have begun.
                Some(s.early_bits)
            } else if s.sampled != IDLE {
                // Half a turn on: every bit still to sample, the first stop bit's middle
                // being now.
                s.sample(s.next_middle.wrapping_add(i16::MAX as u16), level);
                s.sampled = IDLE;
                Some((s.shift, s.damage))
            } else {
                None
            };
            if s.sampled == IDLE {
                TIMSK.modify(|b| b & !COMPARE_B);
            }
            (bits, s.format(), s.held, core::mem::take(&mut s.deliver))
        })
    };
    if held {
        // The role is busy with interrupts enabled (its slave's request): the character
        // waits for it (`hold`).
        if let Some(bits) = bits {
            format.decode_into_buffer(bits);
        }
        return;
    }
    if bits.is_none() && !withheld {
        return;
    }
    arrived();
    let sending = TIMSK.read() & COMPARE_A;
    TIMSK.modify(|b| b & !COMPARE_A);
    TIMSK0.modify(|b| b & !unit);
    // SAFETY: the handlers that reach the role are masked (above); the others reach what is
    // not borrowed here, and return with interrupts disabled.
    unsafe { reg::enable_interrupts() };
    if let Some(bits) = bits {
        format.decode_into_buffer(bits);
    }
    received();
    // SAFETY: the handler goes on as it began, interrupts disabled.
    unsafe { reg::disable_interrupts() };
    TIMSK0.modify(|b| b | unit);
    TIMSK.modify(|b| b | sending);
}

/// The frame format a received character is decoded in, copied out of the line's state so
/// that the decoding runs with interrupts enabled.
#[derive(Clone, Copy)]
struct Format {
    stop_index: u8,
    data_bits: u8,
    parity: u8,
}

impl Format {
    /// [`Format::decode`], then the character into the receive buffer (`State::store`), in a
    /// critical section of its own: once in the firmware for both of `on_stop_bit`'s paths.
    #[inline(never)]
    fn decode_into_buffer(self, bits: (u16, u8)) {
        let (data, damage) = self.decode(bits);
        // SAFETY: interrupts are disabled for the store, and enabled again as they were.
        super::reg::free(|| unsafe { with(|s| s.store(data, damage)) });
    }

    /// A character's data and damage from its sampled bits (the first stop bit in bit 15 of
    /// `shift`) and the damage seen on the way (an edge missed): that, a low stop bit, a
    /// parity that does not add up.
    #[inline(always)]
    fn decode(self, (shift, damage): (u16, u8)) -> (u8, u8) {
        // Bit 0 the start bit, then the data bits, the parity bit, the first stop bit.
        let frame = shift >> (15 - self.stop_index);
        let mut damage = damage;
        if frame >> self.stop_index & 1 == 0 {
            damage |= FRAMING;
        }
        let data = (frame >> 1) as u8;
        if self.parity != NO_PARITY {
            // The data bits and the parity bit after them, folded into bit 0.
            let bits = (frame >> 1) & !(u16::MAX << (self.data_bits + 1));
            let mut ones = (bits as u8) ^ ((bits >> 8) as u8);
            ones ^= ones >> 4;
            ones ^= ones >> 2;
            ones ^= ones >> 1;
            if ones & 1 != self.parity {
                damage |= PARITY;
            }
        }
        (if self.data_bits == 8 { data } else { data & 0x7F }, damage)
    }
}

/// TIMERn_COMPA: the transmitter's match. What the role is to do.
///
/// # Safety
/// Only from the compare A interrupt handler, interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn on_transmit() -> Transmit {
    // SAFETY: interrupts are disabled (the caller's promise).
    unsafe { with(State::transmit) }
}

/// After the role's handler for a [`Transmit`] event: with nothing going out, the compare A
/// interrupt stops.
///
/// # Safety
/// Interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn settle() {
    // SAFETY: the caller's promise.
    if !unsafe { with(|s| s.sending) } {
        TIMSK.modify(|bits| bits & !COMPARE_A);
    }
}

/// The character received, or its damage: what the USART's UDRn and error flags give (an
/// overrun when there is none). In a critical section of its own: the role's receive
/// handler reads it with interrupts enabled (`on_stop_bit`).
///
/// # Safety
/// None beyond a role's: kept `unsafe` as the line's other calls.
#[inline(always)]
pub(crate) unsafe fn read() -> Result<u8, UartError> {
    // SAFETY: interrupts are disabled for the access.
    let (received, data) = super::reg::free(|| unsafe {
        with(|s| {
            let received = s.received;
            s.received = 0;
            (received, s.received_data)
        })
    });
    if received & !RECEIVED == 0 && received != 0 {
        Ok(data)
    } else if received & (OVERRUN | FRAMING) == FRAMING {
        Err(UartError::Framing)
    } else if received & PARITY != 0 {
        Err(UartError::Parity)
    } else {
        Err(UartError::Overrun)
    }
}

/// True when a character waits to be read.
///
/// # Safety
/// Interrupts disabled.
pub(crate) unsafe fn has_data() -> bool {
    // SAFETY: the caller's promise.
    unsafe { with(|s| s.received != 0) }
}

/// Writes a character: it starts at once on an idle transmitter, else waits in the buffer
/// (which a role only writes when it is empty, as a USART's).
///
/// # Safety
/// Interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn write(byte: u8) {
    // SAFETY: the caller's promise.
    unsafe {
        with(|s| {
            if s.sending {
                s.next = byte;
                s.next_full = true;
            } else {
                s.begin(byte);
            }
        })
    }
}

/// Sets the events the role wants ([`FEED`] and [`DONE`] bits) with `f`. Asked for the next
/// character while nothing goes out, the transmitter makes a match at once for it (the
/// USART's data-register-empty interrupt comes at once too).
///
/// # Safety
/// Interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn set_events(f: impl FnOnce(u8) -> u8) {
    // SAFETY: the caller's promise.
    unsafe {
        with(|s| {
            s.events = f(s.events);
            if s.events & FEED != 0 && !s.sending {
                // An end of character with no character: the match asks for the next.
                s.sending = true;
                s.ending = true;
                s.schedule(read16(TCNT).wrapping_add(LEAD), true);
                TIFR.write(COMPARE_A);
                TIMSK.modify(|bits| bits | COMPARE_A);
            }
        })
    }
}

/// True while the role wants an event of the transmitter (a reply or request going out).
///
/// # Safety
/// Interrupts disabled.
#[cfg(feature = "eeprom-settings")]
pub(crate) unsafe fn is_sending() -> bool {
    // SAFETY: the caller's promise.
    unsafe { with(|s| s.events != 0) }
}

/// Holds received characters back from the role (`true`: it is busy with interrupts enabled)
/// or lets them through again (`false`): a character that came in meanwhile then reaches
/// the role from a compare B interrupt made at once, as if its stop bit's middle were now
/// (unless another character starts first: then it is lost, an overrun).
///
/// # Safety
/// Interrupts disabled.
#[inline(always)]
pub(crate) unsafe fn hold(on: bool) {
    // SAFETY: the caller's promise.
    unsafe {
        with(|s| {
            s.held = on;
            if !on && s.received != 0 && s.sampled == IDLE {
                s.deliver = true;
                write16(OCRB, read16(TCNT).wrapping_add(LEAD));
                TIFR.write(COMPARE_B);
                TIMSK.modify(|bits| bits | COMPARE_B);
            }
        })
    }
}

impl State {
    /// An edge at `at`, rising or falling; `missed` when the line had already moved on.
    #[inline(always)]
    fn edge(&mut self, at: u16, rising: bool, missed: bool) {
        let mut late = false;
        if self.sampled != IDLE {
            // The bits whose middles passed before the edge had the level before it.
            let index = self.sample(at, !rising);
            if index == 0 && rising {
                // Back up before the start bit's middle: a glitch, not a start bit (the
                // USART's receiver checks the start bit at its middle and drops it too).
                self.idle();
            } else if index > self.stop_index {
                // The edge came after the first stop bit's middle and before its interrupt
                // ran: the character is complete, left to that interrupt, whose flag is up,
                // and a falling edge starts the next.
                (self.early, self.early_bits) = (true, (self.shift, self.damage));
                self.sampled = IDLE;
                late = true;
            }
        }
        if self.sampled == IDLE && !rising {
            self.start(at, late);
        }
        if missed {
            self.damage = FRAMING;
            // The edge select follows the line as it is now.
            let select = TCCRB.read();
            TCCRB.write(if PIN.read() & RX != 0 { select & !ICES } else { select | ICES });
            TIFR.write(CAPTURE);
        }
    }

    /// Samples at `level` the bits of the character coming in whose middles come before
    /// `until` (all of them, up to the first stop bit, for `until` past its middle), into
    /// `shift` (the latest in bit 15): one shift a bit, decoded once the character is complete
    /// (`State::finish`). Returns the next bit's index.
    #[inline(always)]
    fn sample(&mut self, until: u16, level: bool) -> u8 {
        let (mut index, mut shift, mut next) = (self.sampled, self.shift, self.next_middle);
        let bit = u16::from(level) << 15;
        while index <= self.stop_index && after(until, next) {
            shift = (shift >> 1) | bit;
            index += 1;
            next = next.wrapping_add(self.bit);
        }
        (self.sampled, self.shift, self.next_middle) = (index, shift, next);
        index
    }

    /// A start bit began at `at`: its middle is the first sample, compare B waits for the
    /// first stop bit's middle. `early`: compare B's flag is up for the character before,
    /// complete, which its interrupt hands on first.
    #[inline(always)]
    fn start(&mut self, at: u16, early: bool) {
        self.sampled = 0;
        self.damage = 0;
        self.next_middle = at.wrapping_add(self.bit / 2);
        write16(OCRB, at.wrapping_add(self.stop_middle));
        if early {
            self.early = true;
        } else {
            TIFR.write(COMPARE_B);
        }
        TIMSK.modify(|bits| bits | COMPARE_B);
    }

    /// Between characters: compare B off.
    #[inline(always)]
    fn idle(&mut self) {
        self.sampled = IDLE;
        TIMSK.modify(|bits| bits & !COMPARE_B);
    }

    /// The format received characters are decoded in.
    #[inline(always)]
    fn format(&self) -> Format {
        Format { stop_index: self.stop_index, data_bits: self.data_bits, parity: self.parity }
    }

    /// A character decoded into the receive buffer (an overrun when the last one was not
    /// read), for the role now unless it is held.
    #[inline(always)]
    fn store(&mut self, data: u8, damage: u8) {
        let damage = if self.received != 0 { OVERRUN } else { damage };
        self.received = RECEIVED | damage;
        self.received_data = data;
        self.deliver = !self.held;
    }

    /// Sends `byte`: its start bit [`LEAD`] ticks from now, the rest from the compare A
    /// interrupt.
    #[inline(never)]
    fn begin(&mut self, byte: u8) {
        let data = if self.data_bits == 8 { byte } else { byte & 0x7F };
        let mut frame = u16::from(data) | self.stop_ones;
        if self.parity != NO_PARITY {
            // The data's parity, folded into bit 0.
            let mut parity = data ^ (data >> 4);
            parity ^= parity >> 2;
            parity ^= parity >> 1;
            if parity & 1 == self.parity {
                frame &= !self.parity_bit;
            }
        }
        self.frame = frame;
        self.left = self.tx_bits;
        self.sending = true;
        self.ending = false;
        self.schedule(read16(TCNT).wrapping_add(LEAD), false);
        // A match of the old value, while nothing went out, left the flag up.
        TIFR.write(COMPARE_A);
        TIMSK.modify(|bits| bits | COMPARE_A);
    }

    /// The next match of compare A at `at`, setting TX to `level` there.
    #[inline(always)]
    fn schedule(&mut self, at: u16, level: bool) {
        write16(OCRA, at);
        TCCRA.write(if level { COMA1 | COMA0 } else { COMA1 });
    }

    /// Compare A matched: TX took the level set for it. The next change is set, or after
    /// the last bit the character's end; at the end, the next character starts or the role
    /// hears of the empty buffer.
    #[inline(always)]
    fn transmit(&mut self) -> Transmit {
        if self.ending {
            self.ending = false;
            self.sending = false;
            if self.next_full {
                self.next_full = false;
                self.begin(self.next);
                return Transmit::Nothing;
            }
            if self.events & FEED != 0 {
                return Transmit::Feed;
            }
            if self.events & DONE != 0 {
                return Transmit::Done;
            }
            return Transmit::Nothing;
        }
        let level = TCCRA.read() & COMA0 != 0;
        let mut next = read16(OCRA);
        loop {
            next = next.wrapping_add(self.bit);
            if self.left == 0 {
                self.ending = true;
                self.schedule(next, true);
                return Transmit::Nothing;
            }
            let bit = self.frame & 1 != 0;
            self.frame >>= 1;
            self.left -= 1;
            if bit != level {
                self.schedule(next, bit);
                return Transmit::Nothing;
            }
        }
    }
}
