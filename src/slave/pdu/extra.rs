//! FC 22 (0x16, Mask Write Register) and FC 23 (0x17, Read/Write Multiple Registers),
//! Modbus Application Protocol v1.1b3 §6.16 and §6.17 (feature `extra-fc`).

use super::{read_response, read_write_check, value_check, word, Exception, FunctionCode};
use crate::protocol::reference::Table;
use crate::slave::model::{Access, DataModel};

/// The feature is on: the engine sends FC 22 and 23 here.
pub(crate) const ENABLED: bool = true;

/// Handles FC 22 or 23 in `pdu[..len]` and writes the response PDU over it, like
/// [`super::respond`]; for a broadcast (`reply` false) FC 23 writes and skips its read.
///
/// FC 22: the register becomes `(current & and_mask) | (or_mask & !and_mask)`; the
/// response is the request. FC 23: read quantity 1–125, write quantity 1–121, byte count
/// twice the write quantity and equal to the data that follows (03); both ranges inside
/// 0–65535 (02); the read range must exist before anything is written (02); the write
/// happens first, then the read.
pub fn respond<M: DataModel + ?Sized>(
    pdu: &mut [u8],
    len: usize,
    model: &mut M,
    reply: bool,
) -> Result<usize, Exception> {
    let request = pdu.get(..len).ok_or(Exception::ServerDeviceFailure)?;
    let (start, b) = (word(request, 1), word(request, 3));
    if request.first().copied() == Some(FunctionCode::MaskWriteRegister.code()) {
        value_check(len == 7)?;
        model.mask_write_register(start, b, word(request, 5))?;
        return Ok(7);
    }
    let (write_start, write_qty) = (word(request, 5), word(request, 7));
    read_write_check(request, len)?;
    if !model.has_range(Table::HoldingRegisters, start, b) {
        return Err(Exception::IllegalDataAddress);
    }
    let values = pdu.get_mut(10..len).unwrap_or(&mut []);
    model.transfer(Access::Write, Table::HoldingRegisters, write_start, write_qty, values)?;
    if reply {
        read_response(pdu, model, Table::HoldingRegisters, start, b)
    } else {
        Ok(0)
    }
}
