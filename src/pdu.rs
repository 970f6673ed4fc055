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

use crate::model::DataModel;
use crate::reference::Table;

/// A function code, Application Protocol §5.1: every code this crate answers, and the
/// rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FunctionCode {
    /// 0x01 Read Coils, §6.1.
    ReadCoils,
    /// 0x02 Read Discrete Inputs, §6.2.
    ReadDiscreteInputs,
    /// 0x03 Read Holding Registers, §6.3.
    ReadHoldingRegisters,
    /// 0x04 Read Input Registers, §6.4.
    ReadInputRegisters,
    /// 0x05 Write Single Coil, §6.5.
    WriteSingleCoil,
    /// 0x06 Write Single Register, §6.6.
    WriteSingleRegister,
    /// 0x07 Read Exception Status, §6.7 (feature `diagnostics`).
    ReadExceptionStatus,
    /// 0x08 Diagnostics, §6.8 (feature `diagnostics`).
    Diagnostics,
    /// 0x0B Get Comm Event Counter, §6.9 (feature `diagnostics`).
    GetCommEventCounter,
    /// 0x0F Write Multiple Coils, §6.11.
    WriteMultipleCoils,
    /// 0x10 Write Multiple Registers, §6.12.
    WriteMultipleRegisters,
    /// 0x11 Report Server ID, §6.13 (feature `diagnostics`).
    ReportServerId,
    /// 0x16 Mask Write Register, §6.16 (feature `extra-fc`).
    MaskWriteRegister,
    /// 0x17 Read/Write Multiple Registers, §6.17 (feature `extra-fc`).
    ReadWriteMultipleRegisters,
    /// Any other code: answered with exception 01.
    Unknown(u8),
}

impl FunctionCode {
    /// The code for a byte.
    pub const fn from_u8(code: u8) -> Self {
        match code {
            0x01 => FunctionCode::ReadCoils,
            0x02 => FunctionCode::ReadDiscreteInputs,
            0x03 => FunctionCode::ReadHoldingRegisters,
            0x04 => FunctionCode::ReadInputRegisters,
            0x05 => FunctionCode::WriteSingleCoil,
            0x06 => FunctionCode::WriteSingleRegister,
            0x07 => FunctionCode::ReadExceptionStatus,
            0x08 => FunctionCode::Diagnostics,
            0x0B => FunctionCode::GetCommEventCounter,
            0x0F => FunctionCode::WriteMultipleCoils,
            0x10 => FunctionCode::WriteMultipleRegisters,
            0x11 => FunctionCode::ReportServerId,
            0x16 => FunctionCode::MaskWriteRegister,
            0x17 => FunctionCode::ReadWriteMultipleRegisters,
            other => FunctionCode::Unknown(other),
        }
    }

    /// The byte for a code.
    pub const fn value(self) -> u8 {
        match self {
            FunctionCode::ReadCoils => 0x01,
            FunctionCode::ReadDiscreteInputs => 0x02,
            FunctionCode::ReadHoldingRegisters => 0x03,
            FunctionCode::ReadInputRegisters => 0x04,
            FunctionCode::WriteSingleCoil => 0x05,
            FunctionCode::WriteSingleRegister => 0x06,
            FunctionCode::ReadExceptionStatus => 0x07,
            FunctionCode::Diagnostics => 0x08,
            FunctionCode::GetCommEventCounter => 0x0B,
            FunctionCode::WriteMultipleCoils => 0x0F,
            FunctionCode::WriteMultipleRegisters => 0x10,
            FunctionCode::ReportServerId => 0x11,
            FunctionCode::MaskWriteRegister => 0x16,
            FunctionCode::ReadWriteMultipleRegisters => 0x17,
            FunctionCode::Unknown(other) => other,
        }
    }

    /// True for the serial-line diagnostics, FC 7, 8, 11 (0x0B) and 17 (0x11).
    pub const fn is_diagnostic(self) -> bool {
        matches!(
            self,
            FunctionCode::ReadExceptionStatus
                | FunctionCode::Diagnostics
                | FunctionCode::GetCommEventCounter
                | FunctionCode::ReportServerId
        )
    }
}

/// An exception code, Application Protocol §7: the reply is the function code with bit 7
/// set, then this code.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exception {
    /// 0x01 Illegal Function: the function code is not supported.
    IllegalFunction = 0x01,
    /// 0x02 Illegal Data Address: an address of the range does not exist.
    IllegalDataAddress = 0x02,
    /// 0x03 Illegal Data Value: quantity, byte count, value or length is wrong.
    IllegalDataValue = 0x03,
    /// 0x04 Server Device Failure: the request was valid but could not be carried out.
    ServerDeviceFailure = 0x04,
}

/// Largest quantity of bits in one read (FC 1, 2): 2000.
pub const MAX_READ_BITS: u16 = 0x07D0;
/// Largest quantity of registers in one read (FC 3, 4): 125.
pub const MAX_READ_REGISTERS: u16 = 0x007D;
/// Largest quantity of coils in one write (FC 15): 1968.
pub const MAX_WRITE_COILS: u16 = 0x07B0;
/// Largest quantity of registers in one write (FC 16): 123.
pub const MAX_WRITE_REGISTERS: u16 = 0x007B;
/// Largest quantity of registers written by FC 23 (Read/Write Multiple): 121.
pub const MAX_READ_WRITE_REGISTERS: u16 = 0x0079;

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
/// bytes per register.
pub const fn byte_count(table: Table, qty: u16) -> u16 {
    if table.is_bits() {
        qty.div_ceil(8)
    } else {
        qty.saturating_mul(2)
    }
}

/// FC 05's value for ON.
const COIL_ON: u16 = 0xFF00;
/// FC 05's value for OFF.
const COIL_OFF: u16 = 0x0000;

/// A parsed request, borrowing its data from the request PDU. The written values stay
/// as they came on the wire: FC 05's value byte 0xFF or 0x00 is a packed coil (bit 0),
/// FC 06's value a big-endian register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request<'a> {
    /// FC 1–4.
    Read {
        /// Coils (FC 1), discrete inputs (2), holding (3) or input registers (4).
        table: Table,
        /// First address.
        start: u16,
        /// Number of bits, 1–2000, or registers, 1–125.
        qty: u16,
    },
    /// FC 5 and 15 (0x0F).
    WriteCoils {
        /// First address.
        start: u16,
        /// Number of coils, 1–1968 (1 for FC 5).
        qty: u16,
        /// The states, packed LSB first, `qty.div_ceil(8)` bytes.
        packed: &'a [u8],
    },
    /// FC 6 and 16 (0x10).
    WriteRegisters {
        /// First address.
        start: u16,
        /// The values, big-endian, 2–246 bytes.
        values: &'a [u8],
    },
    /// FC 22 (0x16): the register becomes `(current & and_mask) | (or_mask & !and_mask)`.
    #[cfg(feature = "extra-fc")]
    MaskWriteRegister {
        /// Address.
        address: u16,
        /// AND mask.
        and_mask: u16,
        /// OR mask.
        or_mask: u16,
    },
    /// FC 23 (0x17): the write happens first, then the read.
    #[cfg(feature = "extra-fc")]
    ReadWriteMultipleRegisters {
        /// First address read.
        read_start: u16,
        /// Number of registers read, 1–125.
        read_qty: u16,
        /// First address written.
        write_start: u16,
        /// The values written, big-endian, 2–242 bytes.
        values: &'a [u8],
    },
}

/// The big-endian word at `at`, 0 past the end (the length checks decide what that means).
pub(crate) fn word(pdu: &[u8], at: usize) -> u16 {
    match pdu.get(at..at + 2) {
        Some(&[hi, lo]) => u16::from_be_bytes([hi, lo]),
        _ => 0,
    }
}

/// 03 unless `ok`.
fn value_check(ok: bool) -> Result<(), Exception> {
    if ok {
        Ok(())
    } else {
        Err(Exception::IllegalDataValue)
    }
}

/// 03 unless `qty` is 1–`max`; then 02 unless `start..start + qty` stays inside 0–65535.
fn check_quantity(start: u16, qty: u16, max: u16) -> Result<(), Exception> {
    value_check(qty != 0 && qty <= max)?;
    if u32::from(start) + u32::from(qty) > 0x1_0000 {
        Err(Exception::IllegalDataAddress)
    } else {
        Ok(())
    }
}

impl<'a> Request<'a> {
    /// Parses a request PDU (function code and data, no address or CRC).
    pub fn parse(pdu: &'a [u8]) -> Result<Self, Exception> {
        let (a, b) = (word(pdu, 1), word(pdu, 3));
        let single = pdu.len() == 5;
        match FunctionCode::from_u8(pdu.first().copied().unwrap_or(0)) {
            code @ (FunctionCode::ReadCoils
            | FunctionCode::ReadDiscreteInputs
            | FunctionCode::ReadHoldingRegisters
            | FunctionCode::ReadInputRegisters) => {
                let table = read_table(code);
                value_check(single)?;
                check_quantity(a, b, max_read(table))?;
                Ok(Request::Read { table, start: a, qty: b })
            }
            FunctionCode::WriteSingleCoil => {
                value_check(single && (b == COIL_ON || b == COIL_OFF))?;
                Ok(Request::WriteCoils { start: a, qty: 1, packed: pdu.get(3..4).unwrap_or(&[]) })
            }
            FunctionCode::WriteSingleRegister => {
                value_check(single)?;
                Ok(Request::WriteRegisters { start: a, values: pdu.get(3..5).unwrap_or(&[]) })
            }
            FunctionCode::WriteMultipleCoils => {
                let packed = Self::write_data(pdu, Table::Coils, 6, a, b)?;
                Ok(Request::WriteCoils { start: a, qty: b, packed })
            }
            FunctionCode::WriteMultipleRegisters => {
                let values = Self::write_data(pdu, Table::HoldingRegisters, 6, a, b)?;
                Ok(Request::WriteRegisters { start: a, values })
            }
            #[cfg(feature = "extra-fc")]
            FunctionCode::MaskWriteRegister => {
                value_check(pdu.len() == 7)?;
                Ok(Request::MaskWriteRegister { address: a, and_mask: b, or_mask: word(pdu, 5) })
            }
            #[cfg(feature = "extra-fc")]
            FunctionCode::ReadWriteMultipleRegisters => Self::parse_read_write(pdu, a, b),
            _ => Err(Exception::IllegalFunction),
        }
    }

    /// FC 15 / 16 (and 23's write): quantity in range, byte count at `at - 1` as the
    /// quantity requires and equal to the data that follows (03), then the range (02);
    /// returns the data.
    fn write_data(pdu: &'a [u8], table: Table, at: usize, start: u16, qty: u16) -> Result<&'a [u8], Exception> {
        let bytes = byte_count(table, qty);
        let byte_count = pdu.get(at - 1).copied().map(u16::from);
        value_check(byte_count == Some(bytes) && pdu.len() == at + usize::from(bytes))?;
        // FC 23 writes fewer registers than FC 16.
        let max = if at == 6 { max_write(table) } else { MAX_READ_WRITE_REGISTERS };
        check_quantity(start, qty, max)?;
        Ok(pdu.get(at..).unwrap_or(&[]))
    }

    /// FC 23: read quantity 1–125, write quantity 1–121, byte count twice the write
    /// quantity and equal to the data that follows (03); both ranges inside 0–65535 (02).
    #[cfg(feature = "extra-fc")]
    fn parse_read_write(pdu: &'a [u8], read_start: u16, read_qty: u16) -> Result<Self, Exception> {
        let (write_start, write_qty) = (word(pdu, 5), word(pdu, 7));
        // Every 03 comes before any 02.
        value_check(read_qty != 0 && read_qty <= MAX_READ_REGISTERS)?;
        value_check(write_qty != 0 && write_qty <= MAX_READ_WRITE_REGISTERS)?;
        let bytes = byte_count(Table::HoldingRegisters, write_qty);
        value_check(pdu.get(9).copied().map(u16::from) == Some(bytes) && pdu.len() == 10 + usize::from(bytes))?;
        check_quantity(read_start, read_qty, MAX_READ_REGISTERS)?;
        let values = Self::write_data(pdu, Table::HoldingRegisters, 10, write_start, write_qty)?;
        Ok(Request::ReadWriteMultipleRegisters { read_start, read_qty, write_start, values })
    }

    /// True for the requests that change data (the ones a broadcast executes).
    pub fn is_write(&self) -> bool {
        !matches!(self, Request::Read { .. })
    }

    /// Carries out a write request; a read does nothing here.
    pub fn write<M: DataModel + ?Sized>(&self, model: &mut M) -> Result<(), Exception> {
        match *self {
            Request::Read { .. } => Ok(()),
            Request::WriteCoils { start, qty, packed } => model.write_coils(start, qty, packed),
            Request::WriteRegisters { start, values } => model.write_registers(start, values),
            #[cfg(feature = "extra-fc")]
            Request::MaskWriteRegister { address, and_mask, or_mask } => {
                let mut current = [0; 2];
                model.read_registers(Table::HoldingRegisters, address, &mut current)?;
                let value = (u16::from_be_bytes(current) & and_mask) | (or_mask & !and_mask);
                model.write_registers(address, &value.to_be_bytes())
            }
            #[cfg(feature = "extra-fc")]
            Request::ReadWriteMultipleRegisters { read_start, read_qty, write_start, values } => {
                // All or nothing: the read range must exist before anything is written.
                if !model.has_range(Table::HoldingRegisters, read_start, read_qty) {
                    return Err(Exception::IllegalDataAddress);
                }
                model.write_registers(write_start, values)
            }
        }
    }
}

/// The table FC 1–4 read (`code` is one of them). Two comparisons, no lookup table.
fn read_table(code: FunctionCode) -> Table {
    let registers = !matches!(code, FunctionCode::ReadCoils | FunctionCode::ReadDiscreteInputs);
    let second = matches!(code, FunctionCode::ReadDiscreteInputs | FunctionCode::ReadHoldingRegisters);
    if registers {
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

/// Handles the request PDU `pdu[..len]` and writes the response PDU over it, from
/// `pdu[0]`. Returns the response length, or the exception; on an exception `pdu` holds
/// the request unchanged (see [`encode_exception`]). `pdu` must have room for the
/// longest response, 252 bytes (FC 03 × 125); with less, a read answers 04.
pub fn respond<M: DataModel + ?Sized>(pdu: &mut [u8], len: usize, model: &mut M) -> Result<usize, Exception> {
    let request = Request::parse(pdu.get(..len).ok_or(Exception::ServerDeviceFailure)?)?;
    request.write(model)?;
    let (table, start, qty) = match request {
        Request::Read { table, start, qty } => (table, start, qty),
        #[cfg(feature = "extra-fc")]
        Request::ReadWriteMultipleRegisters { read_start, read_qty, .. } => {
            (Table::HoldingRegisters, read_start, read_qty)
        }
        // FC 22's response is its request (7 bytes).
        #[cfg(feature = "extra-fc")]
        Request::MaskWriteRegister { .. } => return Ok(7),
        // Every other write's response is the first five bytes of its request: an echo
        // for FC 5 / 6, function code, start and quantity for FC 15 / 16.
        _ => return Ok(5),
    };
    let bytes = usize::from(byte_count(table, qty));
    let data = pdu.get_mut(2..2 + bytes).ok_or(Exception::ServerDeviceFailure)?;
    if table.is_bits() {
        model.read_bits(table, start, qty, data)?;
    } else {
        model.read_registers(table, start, data)?;
    }
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
        *ex = exception as u8;
    }
    2
}
