//! The reference model of the slave, written from the spec and sharing no code with the
//! crate: what the bank holds, what the slave counts, the replies it owes, and the
//! receiver of Serial Line §2.5.1.1. The property tests (`tests/random_frames.rs`) and
//! the coverage-guided fuzz targets (`fuzz/`) both drive the slave and this model with
//! the same inputs and compare everything. It takes the spec's CRC and the frame helpers
//! from `tests/common`, which the including crate declares beside it.
//!
//! The model is a `BTreeMap` of what the bank holds and a straightforward reading of
//! Application Protocol §6–7 and Serial Line §2.4–2.5. It knows the eight core function
//! codes and, when the build has them, the optional ones: FC 22 and 23 (feature
//! `extra-fc`), FC 7, 8, 11 and 17 with the serial-line counters and listen-only mode
//! (feature `diagnostics`), FC 43 / MEI 14 (feature `device-id`, [`device_id`]). With
//! feature `ascii`, [`ascii`] receives characters as Serial Line §2.5.2 frames them and
//! hands each whole frame to the same model as its RTU twin.
#![allow(dead_code)]

use std::collections::BTreeMap;

use avr_modbus::internal::{EndOfFrame, Engine, FrameError, UartError};
use avr_modbus::{Bank, Reference, SlaveCounters, SlaveId, Table};

pub use super::common::{reference_crc, with_crc, ID};

/// A slave at [`ID`], just after power-up.
pub fn slave() -> Engine {
    Engine::new(SlaveId::new(ID))
}

/// `Err` with a message unless `cond`.
macro_rules! check {
    ($cond:expr) => {
        if !$cond {
            return Err(format!("check failed: {}", stringify!($cond)));
        }
    };
    ($cond:expr, $($arg:tt)+) => {
        if !$cond {
            return Err(format!($($arg)+));
        }
    };
}

/// `Err` with both values unless they are equal.
macro_rules! check_eq {
    ($left:expr, $right:expr) => {
        if $left != $right {
            return Err(format!("{:?} != {:?}", $left, $right));
        }
    };
    ($left:expr, $right:expr, $($arg:tt)+) => {
        if $left != $right {
            return Err(format!("{:?} != {:?}: {}", $left, $right, format!($($arg)+)));
        }
    };
}

#[cfg(feature = "ascii")]
pub mod ascii;
pub mod device_id;

/// The bank under test: room for the runs of [`LAYOUT`].
pub type RandomBank = Bank<16, 64, 16>;

/// The runs of the bank under test: holes between them, and the top of the address space.
pub const LAYOUT: [(Table, u16, u16); 10] = [
    (Table::Coils, 0, 10),
    (Table::Coils, 12, 9),
    (Table::Coils, 65530, 6),
    (Table::DiscreteInputs, 0, 16),
    (Table::DiscreteInputs, 100, 8),
    (Table::InputRegisters, 0, 5),
    (Table::InputRegisters, 65535, 1),
    (Table::HoldingRegisters, 0, 10),
    (Table::HoldingRegisters, 11, 4),
    (Table::HoldingRegisters, 65532, 4),
];

/// Addresses near the edges of the runs above.
pub const EDGES: [u16; 20] = [0, 1, 4, 5, 9, 10, 11, 12, 14, 15, 16, 20, 21, 99, 100, 107, 108, 65529, 65532, 65535];

// ---- the reference model ----------------------------------------------------------------

/// What the bank holds, (table, address) → value (0/1 for bits), and what the slave has
/// counted.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    values: BTreeMap<(Table, u16), u16>,
    counts: SlaveCounters,
    listen_only: bool,
    /// The objects FC 43 reports (none: the slave offers no identification).
    identity: Option<&'static device_id::Identity>,
}

pub const DIAGNOSTICS: bool = cfg!(feature = "diagnostics");
pub const EXTRA_FC: bool = cfg!(feature = "extra-fc");
pub const DEVICE_ID: bool = cfg!(feature = "device-id");

pub fn is_bits(table: Table) -> bool {
    matches!(table, Table::Coils | Table::DiscreteInputs)
}

/// A bank and its model, with starting values derived from `salt`, and the
/// identification its high byte picks ([`device_id::chosen`]), which the bank reports with
/// feature `device-id`.
pub fn fixture(salt: u16) -> (RandomBank, Model) {
    let mut bank = RandomBank::new();
    let chosen = device_id::chosen(salt);
    #[cfg(feature = "device-id")]
    if let Some((identification, _)) = chosen {
        bank.set_identification(identification);
    }
    let mut model = BTreeMap::new();
    for (table, first, count) in LAYOUT {
        bank.add_range(Reference { table, address: first }, count).unwrap();
        for address in first..=first + (count - 1) {
            let mixed = address.wrapping_mul(0x9E37) ^ salt ^ (table as u16).wrapping_mul(0x1F1F);
            let value = if is_bits(table) { mixed >> 7 & 1 } else { mixed };
            bank.set(Reference { table, address }, value).unwrap();
            model.insert((table, address), value);
        }
    }
    let identity = chosen.map(|(_, identity)| identity);
    (bank, Model { values: model, counts: SlaveCounters::new(), listen_only: false, identity })
}

pub fn bump(counter: &mut u16) {
    *counter = counter.wrapping_add(1);
}

impl Model {
    /// 02 unless every address of `start..start + qty` exists (and stays below 65536).
    pub fn check(&self, table: Table, start: u16, qty: u16) -> Result<(), u8> {
        let end = u32::from(start) + u32::from(qty);
        if end > 0x1_0000 {
            return Err(2);
        }
        let all = (u32::from(start)..end).all(|a| self.values.contains_key(&(table, a as u16)));
        if all {
            Ok(())
        } else {
            Err(2)
        }
    }

    pub fn value(&self, table: Table, address: u32) -> u16 {
        self.values[&(table, address as u16)]
    }

    /// The response PDU to `pdu`, or the exception code; applies writes.
    pub fn respond(&mut self, pdu: &[u8]) -> Result<Vec<u8>, u8> {
        let function = pdu[0];
        let word = |i: usize| u16::from_be_bytes([pdu[i], pdu[i + 1]]);
        match function {
            0x01..=0x06 => {
                if pdu.len() != 5 {
                    return Err(3);
                }
                let (a, b) = (word(1), word(3));
                match function {
                    0x01 | 0x02 => {
                        let table = if function == 1 { Table::Coils } else { Table::DiscreteInputs };
                        if b == 0 || b > 2000 {
                            return Err(3);
                        }
                        self.check(table, a, b)?;
                        let mut data = vec![0u8; usize::from(b).div_ceil(8)];
                        for k in 0..usize::from(b) {
                            if self.value(table, u32::from(a) + k as u32) != 0 {
                                data[k / 8] |= 1 << (k % 8);
                            }
                        }
                        let mut out = vec![function, data.len() as u8];
                        out.extend(data);
                        Ok(out)
                    }
                    0x03 | 0x04 => {
                        let table = if function == 3 { Table::HoldingRegisters } else { Table::InputRegisters };
                        if b == 0 || b > 125 {
                            return Err(3);
                        }
                        self.check(table, a, b)?;
                        let mut out = vec![function, (2 * b) as u8];
                        for k in 0..u32::from(b) {
                            out.extend(self.value(table, u32::from(a) + k).to_be_bytes());
                        }
                        Ok(out)
                    }
                    0x05 => {
                        if b != 0x0000 && b != 0xFF00 {
                            return Err(3);
                        }
                        self.check(Table::Coils, a, 1)?;
                        self.values.insert((Table::Coils, a), u16::from(b == 0xFF00));
                        Ok(pdu.to_vec())
                    }
                    _ => {
                        self.check(Table::HoldingRegisters, a, 1)?;
                        self.values.insert((Table::HoldingRegisters, a), b);
                        Ok(pdu.to_vec())
                    }
                }
            }
            0x0F | 0x10 => {
                if pdu.len() < 6 {
                    return Err(3);
                }
                let (start, qty, byte_count) = (word(1), word(3), usize::from(pdu[5]));
                let (table, max, needed) = if function == 0x0F {
                    (Table::Coils, 1968, usize::from(qty).div_ceil(8))
                } else {
                    (Table::HoldingRegisters, 123, 2 * usize::from(qty))
                };
                if qty == 0 || qty > max || byte_count != needed || pdu.len() != 6 + byte_count {
                    return Err(3);
                }
                self.check(table, start, qty)?;
                let data = &pdu[6..];
                for k in 0..usize::from(qty) {
                    let value = if function == 0x0F {
                        u16::from(data[k / 8] >> (k % 8) & 1)
                    } else {
                        u16::from_be_bytes([data[2 * k], data[2 * k + 1]])
                    };
                    self.values.insert((table, start + k as u16), value);
                }
                Ok(pdu[..5].to_vec())
            }
            0x16 if EXTRA_FC => {
                if pdu.len() != 7 {
                    return Err(3);
                }
                let (address, and, or) = (word(1), word(3), word(5));
                self.check(Table::HoldingRegisters, address, 1)?;
                let current = self.value(Table::HoldingRegisters, u32::from(address));
                self.values.insert((Table::HoldingRegisters, address), (current & and) | (or & !and));
                Ok(pdu.to_vec())
            }
            0x17 if EXTRA_FC => {
                if pdu.len() < 10 {
                    return Err(3);
                }
                let (read_start, read_qty, write_start, write_qty) = (word(1), word(3), word(5), word(7));
                let byte_count = usize::from(pdu[9]);
                if !(1..=125).contains(&read_qty)
                    || !(1..=121).contains(&write_qty)
                    || byte_count != 2 * usize::from(write_qty)
                    || pdu.len() != 10 + byte_count
                {
                    return Err(3);
                }
                if u32::from(read_start) + u32::from(read_qty) > 0x1_0000
                    || u32::from(write_start) + u32::from(write_qty) > 0x1_0000
                {
                    return Err(2);
                }
                // Both ranges exist before anything is written; the write comes first.
                self.check(Table::HoldingRegisters, read_start, read_qty)?;
                self.check(Table::HoldingRegisters, write_start, write_qty)?;
                for k in 0..usize::from(write_qty) {
                    let value = u16::from_be_bytes([pdu[10 + 2 * k], pdu[11 + 2 * k]]);
                    self.values.insert((Table::HoldingRegisters, write_start + k as u16), value);
                }
                let mut out = vec![function, (2 * read_qty) as u8];
                for k in 0..u32::from(read_qty) {
                    out.extend(self.value(Table::HoldingRegisters, u32::from(read_start) + k).to_be_bytes());
                }
                Ok(out)
            }
            0x07 | 0x0B | 0x11 if DIAGNOSTICS && pdu.len() != 1 => Err(3),
            // Exception status: the bank's eight bits, all clear here.
            0x07 if DIAGNOSTICS => Ok(vec![0x07, 0x00]),
            0x0B if DIAGNOSTICS => {
                let [hi, lo] = self.counts.events.to_be_bytes();
                Ok(vec![0x0B, 0x00, 0x00, hi, lo])
            }
            // Byte count, slave id, run indicator ON; no device description here.
            0x11 if DIAGNOSTICS => Ok(vec![0x11, 0x02, ID, 0xFF]),
            0x08 if DIAGNOSTICS => self.diagnostics(pdu),
            0x2B if DEVICE_ID => device_id::read_device_id(self.identity, pdu),
            _ => Err(1),
        }
    }

    /// FC 8 (Application Protocol §6.8): the counter sub-functions answer with the count
    /// as it stands when the request is handled (this request already counted as a
    /// message).
    pub fn diagnostics(&self, pdu: &[u8]) -> Result<Vec<u8>, u8> {
        if pdu.len() < 3 {
            return Err(3);
        }
        let sub = u16::from_be_bytes([pdu[1], pdu[2]]);
        if sub == 0x0000 {
            return if pdu.len() % 2 == 1 { Ok(pdu.to_vec()) } else { Err(3) };
        }
        let c = &self.counts;
        let counter = match sub {
            0x01 | 0x04 | 0x0A => None,
            0x0B => Some(c.frames),
            0x0C => Some(c.crc_errors),
            0x0D => Some(c.exceptions),
            0x0E => Some(c.messages),
            0x0F => Some(c.no_response),
            0x10 | 0x11 => Some(0),
            0x12 => Some(c.overruns),
            _ => return Err(1),
        };
        let data = if pdu.len() == 5 { u16::from_be_bytes([pdu[3], pdu[4]]) } else { 1 };
        if pdu.len() != 5 || !(data == 0 || (sub == 0x01 && data == 0xFF00)) {
            return Err(3);
        }
        let mut out = pdu.to_vec();
        if let Some(value) = counter {
            out[3..5].copy_from_slice(&value.to_be_bytes());
        }
        Ok(out)
    }

    /// A broadcast read (or anything else but a write) as far as parsing goes: length,
    /// quantity, and the range inside 0–65535; the addresses are never looked up.
    pub fn parse_read(pdu: &[u8]) -> Result<(), u8> {
        let max = match pdu[0] {
            0x01 | 0x02 => 2000,
            0x03 | 0x04 => 125,
            _ => return Err(1),
        };
        if pdu.len() != 5 {
            return Err(3);
        }
        let (start, qty) = (u16::from_be_bytes([pdu[1], pdu[2]]), u16::from_be_bytes([pdu[3], pdu[4]]));
        if qty == 0 || qty > max {
            return Err(3);
        }
        if u32::from(start) + u32::from(qty) > 0x1_0000 {
            return Err(2);
        }
        Ok(())
    }

    /// FC 8 sub-function 04 with data 0000: listen-only mode, never answered.
    pub fn forces_listen_only(pdu: &[u8]) -> bool {
        DIAGNOSTICS && pdu == [0x08, 0x00, 0x04, 0x00, 0x00]
    }

    /// FC 8 sub-functions 01 (restart) and 0A (clear counters): counters cleared after the
    /// reply.
    pub fn clears_counters(pdu: &[u8]) -> bool {
        DIAGNOSTICS && ((pdu.len() == 5 && pdu[..3] == [0x08, 0x00, 0x01]) || pdu == [0x08, 0x00, 0x0A, 0x00, 0x00])
    }

    /// The counts of a frame dropped for `reason`.
    pub fn dropped(&mut self, reason: FrameError) {
        bump(&mut self.counts.frames);
        bump(match reason {
            FrameError::BadCrc => &mut self.counts.crc_errors,
            FrameError::Uart => &mut self.counts.uart_errors,
            FrameError::Overrun | FrameError::TooLong => &mut self.counts.overruns,
            FrameError::TooShort | FrameError::Gap => &mut self.counts.malformed,
            #[cfg(feature = "ascii")]
            FrameError::Encoding => &mut self.counts.malformed,
        });
    }

    /// What a whole frame (with correct timing) should lead to, and the reply if any.
    pub fn frame(&mut self, frame: &[u8]) -> (EndOfFrame, Vec<u8>) {
        let n = frame.len();
        if n == 0 {
            return (EndOfFrame::Nothing, vec![]);
        }
        let reason = if n > 256 {
            Some(FrameError::TooLong)
        } else if n < 4 {
            Some(FrameError::TooShort)
        } else {
            let crc = reference_crc(&frame[..n - 2]);
            (frame[n - 2..] != [crc as u8, (crc >> 8) as u8]).then_some(FrameError::BadCrc)
        };
        if let Some(reason) = reason {
            self.dropped(reason);
            return (EndOfFrame::Dropped(reason), vec![]);
        }
        self.good_frame(frame)
    }

    /// A frame whose CRC is right.
    pub fn good_frame(&mut self, frame: &[u8]) -> (EndOfFrame, Vec<u8>) {
        let n = frame.len();
        bump(&mut self.counts.frames);
        let pdu = &frame[1..n - 2];
        let (address, broadcast) = (frame[0], frame[0] == 0);
        if address != ID && !broadcast {
            return (EndOfFrame::OtherSlave, vec![]);
        }
        bump(&mut self.counts.messages);
        if broadcast {
            bump(&mut self.counts.broadcasts);
        }
        if self.listen_only || (!broadcast && Self::forces_listen_only(pdu)) {
            // Listen-only (Application Protocol §6.8.1): nothing executed, nothing sent;
            // only a restart addressed to this slave ends it.
            bump(&mut self.counts.no_response);
            if !self.listen_only {
                self.listen_only = true;
            } else if !broadcast
                && pdu.len() == 5
                && pdu[..3] == [0x08, 0x00, 0x01]
                && (pdu[3] == 0 || pdu[3] == 0xFF)
                && pdu[4] == 0
            {
                self.counts = SlaveCounters::new();
                self.listen_only = false;
            }
            return (EndOfFrame::Silent, vec![]);
        }
        if broadcast {
            bump(&mut self.counts.no_response);
            let writes = [0x05, 0x06, 0x0F, 0x10].contains(&pdu[0]) || (EXTRA_FC && [0x16, 0x17].contains(&pdu[0]));
            // Writes are carried out; reads are only parsed (and may fail), never read.
            let checked = (DIAGNOSTICS && [0x07, 0x08, 0x0B, 0x11].contains(&pdu[0])) || (DEVICE_ID && pdu[0] == 0x2B);
            let result = if writes {
                self.respond(pdu).map(|_| ())
            } else if checked {
                // Diagnostics and FC 43: checked as the same request to this slave would
                // be, never acted on.
                self.clone().respond(pdu).map(|_| ())
            } else {
                Self::parse_read(pdu)
            };
            match result {
                Ok(()) if pdu[0] == 0x0B && DIAGNOSTICS => {}
                Ok(()) => bump(&mut self.counts.events),
                Err(_) => bump(&mut self.counts.exceptions),
            }
            return (EndOfFrame::Broadcast, vec![]);
        }
        let result = self.respond(pdu);
        match &result {
            Ok(_) if pdu[0] != 0x0B || !DIAGNOSTICS => bump(&mut self.counts.events),
            Ok(_) => {}
            Err(_) => bump(&mut self.counts.exceptions),
        }
        bump(&mut self.counts.replies);
        if result.is_ok() && Self::clears_counters(pdu) {
            self.counts = SlaveCounters::new();
        }
        let reply_pdu = result.unwrap_or_else(|code| vec![pdu[0] | 0x80, code]);
        let mut reply = vec![ID];
        reply.extend(reply_pdu);
        (EndOfFrame::Reply, with_crc(&reply))
    }
}

// ---- checks --------------------------------------------------------------------------

/// A reply is empty, or: CRC correct (low byte first), address = ID, and the function code
/// of the request echoed, or with bit 7 set followed by an exception code 1–4.
pub fn check_well_formed(reply: &[u8], request_function: Option<u8>) -> Result<(), String> {
    if reply.is_empty() {
        return Ok(());
    }
    let n = reply.len();
    check!((5..=256).contains(&n), "reply length {n}");
    let crc = reference_crc(&reply[..n - 2]);
    check_eq!(&reply[n - 2..], &[crc as u8, (crc >> 8) as u8][..], "reply CRC");
    check_eq!(reply[0], ID);
    if let Some(function) = request_function {
        if n == 5 && reply[1] == function | 0x80 {
            check!((1..=4).contains(&reply[2]), "exception code {}", reply[2]);
        } else {
            check_eq!(reply[1], function);
        }
    } else if reply[1] & 0x80 != 0 {
        check_eq!(n, 5);
        check!((1..=4).contains(&reply[2]), "exception code {}", reply[2]);
    }
    Ok(())
}

/// The bank holds exactly the model's values, and nothing next to its runs.
pub fn check_bank(bank: &RandomBank, model: &Model) -> Result<(), String> {
    for (&(table, address), &value) in &model.values {
        check_eq!(
            bank.get(Reference { table, address }),
            Ok::<u16, avr_modbus::Error>(value),
            "{:?} {}",
            table,
            address
        );
    }
    for (table, first, count) in LAYOUT {
        if let Some(before) = first.checked_sub(1) {
            check_eq!(bank.contains(Reference { table, address: before }), model.values.contains_key(&(table, before)));
        }
        if let Some(after) = first.checked_add(count) {
            check_eq!(bank.contains(Reference { table, address: after }), model.values.contains_key(&(table, after)));
        }
    }
    Ok(())
}

/// Sends one frame to the slave and to the model and compares everything.
pub fn exchange(slave: &mut Engine, bank: &mut RandomBank, model: &mut Model, frame: &[u8]) -> Result<(), String> {
    let (expected_end, expected_reply) = model.frame(frame);
    let end = slave.handle_frame(frame, bank);
    let reply = slave.reply().to_vec();
    check_well_formed(&reply, frame.get(1).copied())?;
    check_eq!(end, expected_end, "frame {:02X?}", frame);
    check_eq!(&reply, &expected_reply, "frame {:02X?}", frame);
    if end != EndOfFrame::Reply {
        check!(reply.is_empty());
    }
    check_eq!(slave.counters(), model.counts, "frame {:02X?}", frame);
    check_eq!(slave.is_listen_only(), model.listen_only);
    check_bank(bank, model)
}

/// One event on the line, or the slave's own.
#[derive(Clone, Debug)]
pub enum Event {
    Byte(u8),
    Gap,
    End,
    Error(UartError),
    ReplySent,
    /// A whole good request, byte by byte.
    Request(Vec<u8>),
}

/// The receiver of Serial Line §2.5.1.1 (figure 14), written out for the test.
#[derive(Default)]
pub struct ReferenceReceiver {
    listening: bool,
    /// A frame was handed out and its reply not yet sent.
    pub busy: bool,
    bytes: Vec<u8>,
    late: bool,
    broken: Option<FrameError>,
}

impl ReferenceReceiver {
    pub fn byte(&mut self, byte: u8) {
        if !self.listening || self.busy || self.broken.is_some() {
            return;
        }
        if self.late {
            self.broken = Some(FrameError::Gap);
        } else if self.bytes.len() == 256 {
            self.broken = Some(FrameError::TooLong);
        } else {
            self.bytes.push(byte);
        }
    }

    pub fn error(&mut self, error: UartError) {
        if self.listening && !self.busy && self.broken.is_none() {
            self.broken = Some(if error == UartError::Overrun { FrameError::Overrun } else { FrameError::Uart });
        }
    }

    pub fn gap(&mut self) {
        if !self.bytes.is_empty() {
            self.late = true;
        }
    }

    /// T3.5: `Some(frame)` when a whole frame (any CRC) ended, `Err` when it was broken.
    pub fn end(&mut self) -> Option<Result<Vec<u8>, FrameError>> {
        if !self.listening {
            self.listening = true;
            return None;
        }
        if self.busy {
            return None;
        }
        let bytes = std::mem::take(&mut self.bytes);
        self.late = false;
        match self.broken.take() {
            Some(reason) => Some(Err(reason)),
            None if bytes.is_empty() => None,
            None => Some(Ok(bytes)),
        }
    }
}

/// Feeds `events` to the slave, the reference receiver and the model, and compares what
/// each T3.5 leads to: the end of frame, the reply, the counters and the bank.
pub fn run_events(
    slave: &mut Engine,
    bank: &mut RandomBank,
    model: &mut Model,
    events: &[Event],
) -> Result<(), String> {
    let mut receiver = ReferenceReceiver::default();
    for event in events {
        match event {
            Event::Byte(byte) => {
                slave.on_byte(*byte);
                receiver.byte(*byte);
            }
            Event::Request(frame) => {
                for &byte in frame {
                    slave.on_byte(byte);
                    receiver.byte(byte);
                }
            }
            Event::Gap => {
                slave.on_gap_deadline();
                receiver.gap();
            }
            Event::Error(error) => {
                slave.on_error(*error);
                receiver.error(*error);
            }
            Event::ReplySent => {
                slave.on_reply_sent();
                receiver.busy = false;
                check!(slave.reply().is_empty());
            }
            Event::End => {
                let end = slave.on_end_deadline();
                match receiver.end() {
                    None => check_eq!(end, EndOfFrame::Nothing),
                    Some(Err(reason)) => {
                        model.dropped(reason);
                        check_eq!(end, EndOfFrame::Dropped(reason));
                    }
                    Some(Ok(frame)) => {
                        let (expected_end, expected_reply) = model.frame(&frame);
                        check_eq!(end, expected_end, "frame {:02X?}", frame);
                        if matches!(end, EndOfFrame::Reply | EndOfFrame::Broadcast | EndOfFrame::Silent) {
                            let len = slave.process(bank);
                            check_eq!(len, expected_reply.len());
                            check_well_formed(slave.reply(), frame.get(1).copied())?;
                            check_eq!(slave.reply(), &expected_reply[..], "frame {:02X?}", frame);
                            receiver.busy = end == EndOfFrame::Reply;
                        }
                    }
                }
                check_eq!(slave.counters(), model.counts);
                check_eq!(slave.is_listen_only(), model.listen_only);
                check_bank(bank, model)?;
            }
        }
    }
    Ok(())
}
