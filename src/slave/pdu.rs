//! The PDU engine, Modbus Application Protocol v1.1b3 §6.1–6.6, §6.11–6.12 (function
//! codes 01–06, 0F, 10), §6.16–6.17 (16, 17, feature `extra-fc`) and §7 (exception
//! responses).
//!
//! [`Request::parse`] borrows the request PDU and applies the checks in the spec's order:
//! function code (01), then quantity, byte count, value and length (03), then the end of
//! the range inside 0–65535 (02). The limits are per table, not per function code
//! ([`max_read`], [`max_write`], [`byte_count`]): a read of bits or registers, a write of
//! coils or registers. [`respond`] runs the request against a [`DataModel`] (which answers
//! 02 for missing addresses and 04 for failures) and writes the response PDU over the
//! request, in the same buffer.
//!
//! The checks are written as comparisons, never as a `match` from a code to a constant:
//! on AVR the compiler would turn such a `match` into a lookup table, and constant tables
//! are copied to RAM at start-up.

use crate::protocol::reference::Table;
use crate::slave::model::{Access, DataModel};

pub mod device_id;
#[cfg(feature = "extra-fc")]
pub mod extra;
pub(crate) mod oversized;

/// Without feature `extra-fc`: FC 22 and 23 answer exception 01.
#[cfg(not(feature = "extra-fc"))]
pub(crate) mod extra {
    use super::Exception;
    use crate::slave::model::DataModel;

    pub(crate) const ENABLED: bool = false;

    pub(crate) fn respond<M: DataModel + ?Sized>(
        _pdu: &mut [u8],
        _len: usize,
        _model: &mut M,
        _reply: bool,
    ) -> Result<usize, Exception> {
        Err(Exception::IllegalFunction)
    }
}

/// What a request the engine handled asks of it beyond counting.
#[cfg_attr(not(feature = "diagnostics"), allow(dead_code))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Answer {
    /// Send this many bytes of reply PDU.
    Reply(usize),
    /// FC 8 sub-function 04: enter listen-only mode, send nothing.
    ListenOnly,
    /// FC 8 sub-functions 01 and 0A: send this many bytes, then clear the counters and
    /// leave listen-only mode.
    Restart(usize),
}

pub use crate::protocol::Exception;
pub use crate::protocol::FunctionCode;

pub use crate::protocol::limits::*;

/// The largest quantity one read of `table` may ask for: FC 1, 2 and FC 3, 4 (and 23's
/// read).
pub const fn max_read(table: Table) -> u16 {
    if table.is_bits() {
        MAX_READ_BITS
    } else {
        MAX_READ_REGISTERS
    }
}

/// The largest quantity one write of `table` may carry: FC 15 and FC 16.
pub const fn max_write(table: Table) -> u16 {
    if table.is_bits() {
        MAX_WRITE_COILS
    } else {
        MAX_WRITE_REGISTERS
    }
}

/// The bytes `qty` values of `table` take in a request or response: packed bits, or two
/// bytes per register. For a quantity already checked against [`max_read`] or
/// [`max_write`] (at most 2000): larger ones wrap.
pub const fn byte_count(table: Table, qty: u16) -> u16 {
    if table.is_bits() {
        qty.div_ceil(8)
    } else {
        qty.wrapping_mul(2)
    }
}

/// FC 05's value for ON.
const COIL_ON: u16 = 0xFF00;
/// FC 05's value for OFF.
const COIL_OFF: u16 = 0x0000;

/// A checked request of FC 1–6, 15 (0x0F) or 16 (0x10): the addresses it reads or writes,
/// and where its data lies in the PDU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// Read by FC 1 (coils), 2 (discrete inputs), 3 (holding registers), 4 (input
    /// registers); written by FC 5 and 15 (coils), 6 and 16 (holding registers).
    pub table: Table,
    /// First address.
    pub start: u16,
    /// Number of bits (1–2000 read, 1–1968 written) or registers (1–125 read, 1–123
    /// written).
    pub qty: u16,
    /// Read or write.
    pub access: Access,
    /// Where the data field starts in the PDU: a write's values as they came on the wire
    /// (FC 05's value byte, 0xFF or 0x00, is one packed coil), or where a read's response
    /// puts them, after the byte count.
    pub data_at: u8,
    /// Bytes of the data field: the quantity's bits packed, or two per register (at most
    /// 250).
    pub data_len: u8,
}

/// The big-endian word at `at`, 0 past the end (the length checks decide what that means).
pub(crate) fn word(pdu: &[u8], at: usize) -> u16 {
    match pdu.get(at..at + 2) {
        Some(&[hi, lo]) => crate::slave::words::from_be(hi, lo),
        _ => 0,
    }
}

/// True for the function codes that change data: 5, 6, 15 (0x0F), 16 (0x10), 22 (0x16)
/// and 23 (0x17, which reads too and is refused whole). What a port that may only read
/// (feature `write-protect`) answers with exception 01 (Application Protocol v1.1b3 §7:
/// "not an allowable action for the server"), before anything else of the request is
/// checked, as 01 comes first in the spec's order. Comparisons, no lookup table.
#[cfg(feature = "write-protect")]
pub(crate) fn is_write_code(code: u8) -> bool {
    code.wrapping_sub(FunctionCode::WriteSingleCoil.code()) < 2
        || code.wrapping_sub(FunctionCode::WriteMultipleCoils.code()) < 2
        || code.wrapping_sub(FunctionCode::MaskWriteRegister.code()) < 2
}

/// 03 unless `ok`.
pub(crate) fn value_check(ok: bool) -> Result<(), Exception> {
    if ok {
        Ok(())
    } else {
        Err(Exception::IllegalDataValue)
    }
}

/// 03 unless `qty` is 1–`max`.
pub(crate) fn quantity_check(qty: u16, max: u16) -> Result<(), Exception> {
    value_check(qty != 0 && qty <= max)
}

/// 02 unless `start..start + qty` (`qty` ≥ 1) stays inside 0–65535: the last address,
/// `start + qty - 1`, must not pass 65535 (16-bit arithmetic: `!start` is `65535 - start`).
pub(crate) fn range_check(start: u16, qty: u16) -> Result<(), Exception> {
    if qty.wrapping_sub(1) > !start {
        Err(Exception::IllegalDataAddress)
    } else {
        Ok(())
    }
}

/// The checks of FC 23 (0x17, Read/Write Multiple Registers) that need no data model, in a
/// PDU of `len` bytes of which `pdu` holds at least the first 10: read quantity 1–125, write
/// quantity 1–121, the byte count twice the write quantity and equal to the bytes that
/// follow (03), then both ranges inside 0–65535 (02). Returns the read's first address and
/// quantity. The slave's FC 23 and the gateway's check of what it forwards.
#[cfg(any(feature = "extra-fc", all(feature = "tcp", feature = "master")))]
pub(crate) fn read_write_check(pdu: &[u8], len: usize) -> Result<(u16, u16), Exception> {
    let (start, qty) = (word(pdu, 1), word(pdu, 3));
    let (write_start, write_qty) = (word(pdu, 5), word(pdu, 7));
    // Every 03 comes before any 02.
    quantity_check(qty, MAX_READ_REGISTERS)?;
    quantity_check(write_qty, MAX_READ_WRITE_REGISTERS)?;
    // The byte count (byte 9): twice the write quantity, and the bytes that follow it.
    let bytes = 2 * write_qty;
    value_check(pdu.get(9).map(|&count| u16::from(count)) == Some(bytes) && len == 10 + usize::from(bytes))?;
    range_check(start, qty)?;
    range_check(write_start, write_qty)?;
    Ok((start, qty))
}

impl Request {
    /// Parses a request PDU (function code and data, no address or CRC) of FC 1–6, 15 or
    /// 16 of `len` bytes, of which `pdu` holds at least the first 7 (the header; a request
    /// longer than the frame buffer is checked from it); other codes are exception 01.
    ///
    /// FC 15 (0x0F) and 16 (0x10) write what FC 5 and 6 write, many values at once: the
    /// checks work on the code of the single write and the kind of request, one path for
    /// all eight codes (the order of the 03 checks among themselves makes no difference).
    pub fn parse(pdu: &[u8], len: usize) -> Result<Self, Exception> {
        let code = pdu.first().copied().unwrap_or(0);
        let b = word(pdu, 3);
        let multiple = code.wrapping_sub(FunctionCode::WriteMultipleCoils.code()) < 2;
        let single = if multiple { code - 10 } else { code };
        if single.wrapping_sub(FunctionCode::ReadCoils.code()) > 5 {
            return Err(Exception::IllegalFunction);
        }
        let coil = single == FunctionCode::WriteSingleCoil.code();
        let (access, table, max) = if single < FunctionCode::WriteSingleCoil.code() {
            let table = read_table(single);
            (Access::Read, table, max_read(table))
        } else {
            let table = if coil { Table::Coils } else { Table::HoldingRegisters };
            (Access::Write, table, max_write(table))
        };
        // FC 5 and 6 write one value, given where the others give the quantity.
        let (qty, data_at) = match access {
            Access::Write if !multiple => (1, 3),
            _ => (b, if multiple { 6 } else { 2 }),
        };
        quantity_check(qty, max)?;
        // At most 250: 2000 bits, 125 registers.
        let data_len = byte_count(table, qty) as u8;
        let length_ok =
            if multiple { pdu.get(5) == Some(&data_len) && len == 6 + usize::from(data_len) } else { len == 5 };
        value_check(length_ok && (!coil || multiple || b == COIL_ON || b == COIL_OFF))?;
        // Read only here: the first address matters to the last check alone.
        let start = word(pdu, 1);
        range_check(start, qty)?;
        Ok(Request { table, start, qty, access, data_at, data_len })
    }

    /// True for the requests that change data (the ones a broadcast executes).
    pub fn is_write(&self) -> bool {
        self.access == Access::Write
    }
}

/// The table FC 1–4 read (`code` is one of them): bit 1 of the code tells the second of
/// each pair (discrete inputs, holding registers), codes past 2 read registers. Bit tests,
/// no lookup table.
fn read_table(code: u8) -> Table {
    let second = code & 0b10 != 0;
    if code > FunctionCode::ReadDiscreteInputs.code() {
        if second {
            Table::HoldingRegisters
        } else {
            Table::InputRegisters
        }
    } else if second {
        Table::DiscreteInputs
    } else {
        Table::Coils
    }
}

/// Handles the request PDU `pdu[..len]` of FC 1–6, 15 or 16 and writes the response PDU
/// over it, from `pdu[0]`. Returns the response length, or the exception; on an exception
/// `pdu` holds the request unchanged (see [`encode_exception`]). `pdu` must have room for
/// the longest response, 252 bytes (FC 03 × 125); with less, a read whose response does not
/// fit answers 02 when an address is missing, else 04.
pub fn respond<M: DataModel + ?Sized>(pdu: &mut [u8], len: usize, model: &mut M) -> Result<usize, Exception> {
    execute(pdu, len, model, true)
}

/// [`respond`], or for a broadcast (`reply` false) the same checks and writes with no
/// read and no response (returns 0 for a read). `pdu` may hold only the first bytes of a
/// request of `len` bytes (at least 7): one longer than the buffer gets the exception a
/// whole one would.
pub(crate) fn execute<M: DataModel + ?Sized>(
    pdu: &mut [u8],
    len: usize,
    model: &mut M,
    reply: bool,
) -> Result<usize, Exception> {
    let request = Request::parse(pdu, len)?;
    if !reply && !request.is_write() {
        return Ok(0);
    }
    let Request { table, start, qty, access, data_at, data_len } = request;
    let (at, bytes) = (usize::from(data_at), usize::from(data_len));
    let data = pdu.get_mut(at..at + bytes).ok_or_else(|| oversized::range_exception(model, table, start, qty))?;
    model.transfer(access, table, start, qty, data)?;
    if request.is_write() {
        // The response of a write is the first five bytes of its request: an echo for
        // FC 5 / 6, function code, start and quantity for FC 15 / 16.
        return Ok(5);
    }
    if let Some(count) = pdu.get_mut(1) {
        *count = data_len;
    }
    Ok(2 + bytes)
}

/// Reads `qty` values of `table` from `start` into a read response: byte count at
/// `pdu[1]`, data from `pdu[2]`. Returns the response length.
#[cfg(feature = "extra-fc")]
pub(crate) fn read_response<M: DataModel + ?Sized>(
    pdu: &mut [u8],
    model: &mut M,
    table: Table,
    start: u16,
    qty: u16,
) -> Result<usize, Exception> {
    let bytes = usize::from(byte_count(table, qty));
    let data = pdu.get_mut(2..2 + bytes).ok_or_else(|| oversized::range_exception(model, table, start, qty))?;
    model.transfer(Access::Read, table, start, qty, data)?;
    if let Some(count) = pdu.get_mut(1) {
        *count = bytes as u8;
    }
    Ok(2 + bytes)
}

/// Writes the exception response (function code | 0x80, exception code) at `pdu[0..2]`;
/// returns its length, 2.
pub fn encode_exception(pdu: &mut [u8], exception: Exception) -> usize {
    if let [code, ex, ..] = pdu {
        *code |= 0x80;
        *ex = exception.code();
    }
    2
}
