//! The PDU engine, Modbus Application Protocol v1.1b3 §6.1–6.6, §6.11–6.12 (function
//! codes 01–06, 0F, 10) and §7 (exception responses).
//!
//! [`Request::parse`] borrows the request PDU and applies the checks in the spec's order:
//! function code (01), then quantity, byte count, value and length (03), then the end of
//! the range inside 0–65535 (02). [`respond`] runs the request against a [`DataModel`]
//! (which answers 02 for missing addresses and 04 for failures) and writes the response
//! PDU over the request, in the same buffer.

use crate::model::DataModel;
use crate::reference::Table;

/// A function code, Application Protocol §5.1.
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
    /// 0x0F Write Multiple Coils, §6.11.
    WriteMultipleCoils,
    /// 0x10 Write Multiple Registers, §6.12.
    WriteMultipleRegisters,
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
            0x0F => FunctionCode::WriteMultipleCoils,
            0x10 => FunctionCode::WriteMultipleRegisters,
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
            FunctionCode::WriteMultipleCoils => 0x0F,
            FunctionCode::WriteMultipleRegisters => 0x10,
            FunctionCode::MaskWriteRegister => 0x16,
            FunctionCode::ReadWriteMultipleRegisters => 0x17,
            FunctionCode::Unknown(other) => other,
        }
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

/// FC 05's value for ON.
const COIL_ON: u16 = 0xFF00;
/// FC 05's value for OFF.
const COIL_OFF: u16 = 0x0000;

/// A parsed request, borrowing its data from the request PDU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request<'a> {
    /// FC 1.
    ReadCoils {
        /// First address.
        start: u16,
        /// Number of coils, 1–2000.
        qty: u16,
    },
    /// FC 2.
    ReadDiscreteInputs {
        /// First address.
        start: u16,
        /// Number of inputs, 1–2000.
        qty: u16,
    },
    /// FC 3.
    ReadHoldingRegisters {
        /// First address.
        start: u16,
        /// Number of registers, 1–125.
        qty: u16,
    },
    /// FC 4.
    ReadInputRegisters {
        /// First address.
        start: u16,
        /// Number of registers, 1–125.
        qty: u16,
    },
    /// FC 5.
    WriteSingleCoil {
        /// Address.
        address: u16,
        /// New state (0xFF00 on, 0x0000 off on the wire).
        on: bool,
    },
    /// FC 6.
    WriteSingleRegister {
        /// Address.
        address: u16,
        /// New value.
        value: u16,
    },
    /// FC 15 (0x0F).
    WriteMultipleCoils {
        /// First address.
        start: u16,
        /// Number of coils, 1–1968.
        qty: u16,
        /// The states, packed LSB first, `qty.div_ceil(8)` bytes.
        packed: &'a [u8],
    },
    /// FC 16 (0x10).
    WriteMultipleRegisters {
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

/// 02 unless `start..start + qty` stays inside 0–65535.
fn check_range(start: u16, qty: u16) -> Result<(), Exception> {
    if u32::from(start) + u32::from(qty) > 0x1_0000 {
        Err(Exception::IllegalDataAddress)
    } else {
        Ok(())
    }
}

impl<'a> Request<'a> {
    /// Parses a request PDU (function code and data, no address or CRC).
    pub fn parse(pdu: &'a [u8]) -> Result<Self, Exception> {
        let code = FunctionCode::from_u8(pdu.first().copied().unwrap_or(0));
        let (a, b) = (word(pdu, 1), word(pdu, 3));
        match code {
            FunctionCode::Unknown(_) => Err(Exception::IllegalFunction),
            #[cfg(not(feature = "extra-fc"))]
            FunctionCode::MaskWriteRegister | FunctionCode::ReadWriteMultipleRegisters => {
                Err(Exception::IllegalFunction)
            }
            #[cfg(feature = "extra-fc")]
            FunctionCode::MaskWriteRegister => match pdu.len() {
                7 => Ok(Request::MaskWriteRegister { address: a, and_mask: b, or_mask: word(pdu, 5) }),
                _ => Err(Exception::IllegalDataValue),
            },
            #[cfg(feature = "extra-fc")]
            FunctionCode::ReadWriteMultipleRegisters => Self::parse_read_write(pdu, a, b),
            FunctionCode::WriteMultipleCoils => Self::parse_write_multiple(pdu, a, b, MAX_WRITE_COILS, b.div_ceil(8))
                .map(|packed| Request::WriteMultipleCoils { start: a, qty: b, packed }),
            FunctionCode::WriteMultipleRegisters => {
                Self::parse_write_multiple(pdu, a, b, MAX_WRITE_REGISTERS, b.saturating_mul(2))
                    .map(|values| Request::WriteMultipleRegisters { start: a, values })
            }
            _ if pdu.len() != 5 => Err(Exception::IllegalDataValue),
            FunctionCode::WriteSingleCoil => match b {
                COIL_ON | COIL_OFF => Ok(Request::WriteSingleCoil { address: a, on: b == COIL_ON }),
                _ => Err(Exception::IllegalDataValue),
            },
            FunctionCode::WriteSingleRegister => Ok(Request::WriteSingleRegister { address: a, value: b }),
            FunctionCode::ReadCoils | FunctionCode::ReadDiscreteInputs => {
                Self::check_read(a, b, MAX_READ_BITS)?;
                Ok(if code == FunctionCode::ReadCoils {
                    Request::ReadCoils { start: a, qty: b }
                } else {
                    Request::ReadDiscreteInputs { start: a, qty: b }
                })
            }
            FunctionCode::ReadHoldingRegisters | FunctionCode::ReadInputRegisters => {
                Self::check_read(a, b, MAX_READ_REGISTERS)?;
                Ok(if code == FunctionCode::ReadHoldingRegisters {
                    Request::ReadHoldingRegisters { start: a, qty: b }
                } else {
                    Request::ReadInputRegisters { start: a, qty: b }
                })
            }
        }
    }

    fn check_read(start: u16, qty: u16, max: u16) -> Result<(), Exception> {
        if qty == 0 || qty > max {
            return Err(Exception::IllegalDataValue);
        }
        check_range(start, qty)
    }

    /// FC 15 / 16: quantity in range, byte count as the quantity requires and equal to
    /// the data that follows; returns the data.
    fn parse_write_multiple(pdu: &'a [u8], start: u16, qty: u16, max: u16, bytes: u16) -> Result<&'a [u8], Exception> {
        let byte_count = pdu.get(5).copied();
        if qty == 0 || qty > max || byte_count.map(u16::from) != Some(bytes) || pdu.len() != 6 + usize::from(bytes) {
            return Err(Exception::IllegalDataValue);
        }
        check_range(start, qty)?;
        Ok(pdu.get(6..).unwrap_or(&[]))
    }

    /// FC 23: read quantity 1–125, write quantity 1–121, byte count twice the write
    /// quantity and equal to the data that follows (03); both ranges inside 0–65535 (02).
    #[cfg(feature = "extra-fc")]
    fn parse_read_write(pdu: &'a [u8], read_start: u16, read_qty: u16) -> Result<Self, Exception> {
        let (write_start, write_qty) = (word(pdu, 5), word(pdu, 7));
        let bytes = write_qty.saturating_mul(2);
        let byte_count = pdu.get(9).copied().map(u16::from);
        if read_qty == 0
            || read_qty > MAX_READ_REGISTERS
            || write_qty == 0
            || write_qty > MAX_READ_WRITE_REGISTERS
            || byte_count != Some(bytes)
            || pdu.len() != 10 + usize::from(bytes)
        {
            return Err(Exception::IllegalDataValue);
        }
        check_range(read_start, read_qty)?;
        check_range(write_start, write_qty)?;
        Ok(Request::ReadWriteMultipleRegisters {
            read_start,
            read_qty,
            write_start,
            values: pdu.get(10..).unwrap_or(&[]),
        })
    }

    /// The function code of this request.
    pub fn function_code(&self) -> FunctionCode {
        match self {
            Request::ReadCoils { .. } => FunctionCode::ReadCoils,
            Request::ReadDiscreteInputs { .. } => FunctionCode::ReadDiscreteInputs,
            Request::ReadHoldingRegisters { .. } => FunctionCode::ReadHoldingRegisters,
            Request::ReadInputRegisters { .. } => FunctionCode::ReadInputRegisters,
            Request::WriteSingleCoil { .. } => FunctionCode::WriteSingleCoil,
            Request::WriteSingleRegister { .. } => FunctionCode::WriteSingleRegister,
            Request::WriteMultipleCoils { .. } => FunctionCode::WriteMultipleCoils,
            Request::WriteMultipleRegisters { .. } => FunctionCode::WriteMultipleRegisters,
            #[cfg(feature = "extra-fc")]
            Request::MaskWriteRegister { .. } => FunctionCode::MaskWriteRegister,
            #[cfg(feature = "extra-fc")]
            Request::ReadWriteMultipleRegisters { .. } => FunctionCode::ReadWriteMultipleRegisters,
        }
    }

    /// True for the function codes that change data (the ones a broadcast executes).
    pub fn is_write(&self) -> bool {
        !matches!(
            self,
            Request::ReadCoils { .. }
                | Request::ReadDiscreteInputs { .. }
                | Request::ReadHoldingRegisters { .. }
                | Request::ReadInputRegisters { .. }
        )
    }

    /// Carries out a write request; a read does nothing here.
    pub fn write<M: DataModel + ?Sized>(&self, model: &mut M) -> Result<(), Exception> {
        match *self {
            Request::WriteSingleCoil { address, on } => model.write_coils(address, 1, &[on as u8]),
            Request::WriteSingleRegister { address, value } => model.write_registers(address, &value.to_be_bytes()),
            Request::WriteMultipleCoils { start, qty, packed } => model.write_coils(start, qty, packed),
            Request::WriteMultipleRegisters { start, values } => model.write_registers(start, values),
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
            _ => Ok(()),
        }
    }
}

/// Handles the request PDU `pdu[..len]` and writes the response PDU over it, from
/// `pdu[0]`. Returns the response length, or the exception; on an exception `pdu` holds
/// the request unchanged (see [`encode_exception`]). `pdu` must have room for the
/// longest response, 252 bytes (FC 03 × 125); with less, a read answers 04.
pub fn respond<M: DataModel + ?Sized>(pdu: &mut [u8], len: usize, model: &mut M) -> Result<usize, Exception> {
    let request = Request::parse(pdu.get(..len).ok_or(Exception::ServerDeviceFailure)?)?;
    let (table, start, qty) = match request {
        Request::ReadCoils { start, qty } => (Table::Coils, start, qty),
        Request::ReadDiscreteInputs { start, qty } => (Table::DiscreteInputs, start, qty),
        Request::ReadHoldingRegisters { start, qty } => (Table::HoldingRegisters, start, qty),
        Request::ReadInputRegisters { start, qty } => (Table::InputRegisters, start, qty),
        #[cfg(feature = "extra-fc")]
        Request::ReadWriteMultipleRegisters { read_start, read_qty, .. } => {
            request.write(model)?;
            (Table::HoldingRegisters, read_start, read_qty)
        }
        // FC 22's response is its request (7 bytes).
        #[cfg(feature = "extra-fc")]
        Request::MaskWriteRegister { .. } => return request.write(model).map(|()| 7),
        // Every other write's response is the first five bytes of its request: an echo
        // for FC 5 / 6, function code, start and quantity for FC 15 / 16.
        write => return write.write(model).map(|()| 5),
    };
    let bytes = if table.is_bits() { usize::from(qty.div_ceil(8)) } else { 2 * usize::from(qty) };
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
