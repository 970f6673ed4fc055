//! Modbus ASCII, Modbus over Serial Line v1.02 §2.5.2, for the model (feature `ascii`): a
//! reference receiver of characters, the LRC and the hex of a frame written from the
//! spec, and the rule that ties ASCII to the RTU model: a whole ASCII frame is executed
//! exactly when its RTU twin (the same address and PDU with a CRC) would be, and answered
//! with the twin's reply, its CRC replaced by the LRC, written out in hex. Anything
//! malformed is silence, and counted.
//!
//! The spec fixes the frame (`:`, address, PDU and LRC as hex pairs, CR LF, at most 513
//! characters), that a `:` always starts a new frame, and that a silence longer than the
//! inter-character timeout inside a frame is an error. Where it leaves a choice (when a
//! broken frame ends, which counter a dropped frame goes to) the model takes the crate's
//! documented one; a dropped frame is counted once, for its first fault, as an RTU frame
//! is.
//!
//! | event | the reference receiver |
//! |-------|------------------------|
//! | `:` | a frame starts; one in progress is dropped, for its fault, or as too short |
//! | a character outside a frame | ignored |
//! | a character in a frame | kept, unless it is the frame's first fault: the 514th character or the 256th byte (too long); after CR anything but LF, CR after an odd number of digits, anything but a hex digit (encoding) |
//! | LF after CR | the frame ends: fewer than 3 bytes is too short, a wrong LRC a CRC error; else it is handed on as its RTU twin |
//! | LF after a fault | the frame ends, dropped for its fault |
//! | a damaged character in a frame | a fault (UART error, or overrun) |
//! | the inter-character timeout in a frame | the frame ends, dropped for its fault, or as a gap |
//! | anything while a reply is pending | ignored |

use avr_modbus::internal::ascii::{encoded_char, encoded_len};
use avr_modbus::internal::{EndOfFrame, Engine, FrameError, UartError};

use super::{check_bank, with_crc, Model, RandomBank, ID};

/// The most characters in a frame, `:` and CR LF included.
pub const MAX_CHARS: usize = 513;
/// The most bytes in a frame: address, PDU and LRC.
pub const MAX_BYTES: usize = 255;
const CR: u8 = b'\r';
const LF: u8 = b'\n';

/// The LRC of §2.5.2.2: the bytes added in an 8-bit register, carries discarded, then the
/// two's complement.
pub fn lrc(bytes: &[u8]) -> u8 {
    let sum = bytes.iter().map(|&b| u32::from(b)).sum::<u32>() % 0x100;
    ((0x100 - sum) % 0x100) as u8
}

/// The characters of the frame of `bytes` (address, PDU and LRC): `:`, each byte as two
/// upper-case hex digits, CR LF.
pub fn encode(bytes: &[u8]) -> Vec<u8> {
    let mut text = String::from(":");
    for byte in bytes {
        text.push_str(&format!("{byte:02X}"));
    }
    text.push_str("\r\n");
    text.into_bytes()
}

/// What a master sends for `frame` (address and PDU): its LRC appended, in upper- or
/// lower-case hex.
pub fn request(frame: &[u8], lower_case: bool) -> Vec<u8> {
    let mut bytes = frame.to_vec();
    bytes.push(lrc(frame));
    let text = encode(&bytes);
    if lower_case {
        text.to_ascii_lowercase()
    } else {
        text
    }
}

/// How a frame ended: its bytes (address, PDU and LRC) when it is whole, or why it was
/// dropped.
pub type Ended = Result<Vec<u8>, FrameError>;

/// A frame in progress: its characters after the `:`, and its first fault.
#[derive(Default)]
struct Frame {
    text: Vec<u8>,
    fault: Option<FrameError>,
}

/// The receiver of the table above.
#[derive(Default)]
pub struct AsciiReceiver {
    frame: Option<Frame>,
    /// A frame was handed on and its reply not yet sent.
    pub busy: bool,
}

impl AsciiReceiver {
    /// A character: `Some` when a frame ends with it.
    pub fn char(&mut self, c: u8) -> Option<Ended> {
        if self.busy {
            return None;
        }
        if c == b':' {
            let dropped = self.frame.take().map(|frame| Err(frame.fault.unwrap_or(FrameError::TooShort)));
            self.frame = Some(Frame::default());
            return dropped;
        }
        let frame = self.frame.as_mut()?;
        if let Some(fault) = frame.fault {
            if c == LF {
                self.frame = None;
                return Some(Err(fault));
            }
            return None;
        }
        // Before a fault the frame's `kept` characters are hex digits, then perhaps a CR.
        let after_cr = frame.text.last() == Some(&CR);
        let kept = frame.text.len();
        frame.text.push(c);
        let too_long = 1 + frame.text.len() > MAX_CHARS;
        if after_cr && c == LF && !too_long {
            let text = self.frame.take()?.text;
            return Some(whole(&text[..kept - 1]));
        }
        frame.fault = if too_long {
            Some(FrameError::TooLong)
        } else if after_cr {
            Some(FrameError::Encoding)
        } else if c == CR {
            (kept % 2 == 1).then_some(FrameError::Encoding)
        } else if c.is_ascii_hexdigit() {
            // Whole bytes so far: pairs of the digits, this one included.
            let bytes = frame.text.len() / 2;
            (bytes > MAX_BYTES).then_some(FrameError::TooLong)
        } else {
            Some(FrameError::Encoding)
        };
        None
    }

    /// A damaged character: a fault of the frame in progress.
    pub fn error(&mut self, error: UartError) {
        if let Some(frame) = self.frame.as_mut() {
            let reason = if error == UartError::Overrun { FrameError::Overrun } else { FrameError::Uart };
            frame.fault = frame.fault.or(Some(reason));
        }
    }

    /// The inter-character timeout: the frame in progress, if any, ends.
    pub fn timeout(&mut self) -> Option<Ended> {
        self.frame.take().map(|frame| Err(frame.fault.unwrap_or(FrameError::Gap)))
    }
}

/// The frame of `digits` (an even number of hex digits, either case), checked.
fn whole(digits: &[u8]) -> Ended {
    let bytes: Vec<u8> = digits
        .chunks(2)
        .map(|pair| u8::from_str_radix(std::str::from_utf8(pair).expect("hex digits"), 16).expect("hex digits"))
        .collect();
    let Some((&check, frame)) = bytes.split_last().filter(|_| bytes.len() >= 3) else {
        return Err(FrameError::TooShort);
    };
    if lrc(frame) != check {
        return Err(FrameError::BadCrc);
    }
    Ok(bytes)
}

/// One event on an ASCII line, or the slave's own.
#[derive(Clone, Debug)]
pub enum AsciiEvent {
    Char(u8),
    /// Characters one after another (a request, or any text).
    Text(Vec<u8>),
    /// The inter-character timeout passed since the last character.
    Timeout,
    Error(UartError),
    ReplySent,
}

/// Feeds `events` to the slave (in ASCII mode), the reference receiver and the model, as
/// the AVR layer does: a frame's outcome is taken from the slave as soon as a character
/// makes it due ([`Engine::on_char`] true) and after the timeout, and what it accepted is
/// processed at once. Compares when each frame ends, how, the reply and its characters,
/// the counters, and the bank after each frame handed on and at the end.
pub fn run_ascii_events(
    slave: &mut Engine,
    bank: &mut RandomBank,
    model: &mut Model,
    events: &[AsciiEvent],
) -> Result<(), String> {
    check!(slave.is_ascii());
    let mut receiver = AsciiReceiver::default();
    for event in events {
        match event {
            AsciiEvent::Char(c) => on_char(slave, bank, model, &mut receiver, *c)?,
            AsciiEvent::Text(text) => {
                for &c in text {
                    on_char(slave, bank, model, &mut receiver, c)?;
                }
            }
            AsciiEvent::Timeout => {
                slave.on_gap_deadline();
                let ended = receiver.timeout();
                frame_end(slave, bank, model, &mut receiver, ended)?;
            }
            AsciiEvent::Error(error) => {
                slave.on_error(*error);
                receiver.error(*error);
            }
            AsciiEvent::ReplySent => {
                slave.on_reply_sent();
                receiver.busy = false;
                check!(slave.reply().is_empty());
            }
        }
    }
    // The bank is compared after each frame handed on, and here once more: a frame
    // dropped can't have changed it.
    check_bank(bank, model)
}

fn on_char(
    slave: &mut Engine,
    bank: &mut RandomBank,
    model: &mut Model,
    receiver: &mut AsciiReceiver,
    c: u8,
) -> Result<(), String> {
    let due = slave.on_char(c);
    let ended = receiver.char(c);
    check_eq!(due, ended.is_some(), "a frame's end at character {:#04X}: {:?}", c, ended);
    if due {
        frame_end(slave, bank, model, receiver, ended)?;
    }
    Ok(())
}

/// The slave reports how a frame ended and processes it; the model expects `ended`.
fn frame_end(
    slave: &mut Engine,
    bank: &mut RandomBank,
    model: &mut Model,
    receiver: &mut AsciiReceiver,
    ended: Option<Ended>,
) -> Result<(), String> {
    let end = slave.on_end_deadline();
    let len = slave.process(bank);
    match ended {
        None => {
            check_eq!(end, EndOfFrame::Nothing);
            check_eq!(len, 0);
        }
        Some(Err(reason)) => {
            model.dropped(reason);
            check_eq!(end, EndOfFrame::Dropped(reason));
            check_eq!(len, 0);
        }
        Some(Ok(bytes)) => {
            // The RTU twin: address and PDU, with a CRC for the LRC.
            let twin = with_crc(&bytes[..bytes.len() - 1]);
            let (expected_end, twin_reply) = model.frame(&twin);
            check_eq!(end, expected_end, "ASCII frame {:02X?}", bytes);
            let expected = match twin_reply.split_last_chunk::<2>() {
                Some((body, _crc)) => {
                    let mut reply = body.to_vec();
                    reply.push(lrc(body));
                    reply
                }
                None => vec![],
            };
            check_eq!(len, expected.len());
            check_eq!(slave.reply(), &expected[..], "ASCII frame {:02X?}", bytes);
            if let Some(&address) = expected.first() {
                check_eq!(address, ID);
                let text: Vec<u8> = (0..encoded_len(expected.len())).map(|i| encoded_char(slave.reply(), i)).collect();
                check_eq!(text, encode(&expected), "the reply's characters");
            }
            receiver.busy = end == EndOfFrame::Reply;
            check_bank(bank, model)?;
        }
    }
    check_eq!(slave.counters(), model.counts);
    check_eq!(slave.is_listen_only(), model.listen_only);
    Ok(())
}
