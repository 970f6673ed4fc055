//! Requests and responses longer than the frame buffer, Application Protocol v1.1b3
//! §6.1–6.4, §6.11–6.12 and §7: the exception they get.
//!
//! A data model may size the frame buffer for the longest request and response it can
//! accept ([`crate::DataModel::FRAME`]). A longer one always belongs to a request it
//! refuses, and the answer must be the one a 256-byte buffer gives:
//!
//! - A request longer than the buffer is received whole, but only its first bytes are
//!   kept (the framer counts the rest and checks the CRC over all of them). Function
//!   code, start, quantity and byte count are among them (the buffer holds at least 8
//!   bytes), so [`exception`] runs the checks in the order [`super::Request::parse`] runs
//!   them: 01, then 03 for quantity, byte count and length, then 02.
//! - A read whose response would not fit asks for more values than the model has in a
//!   row: [`range_exception`] answers 02 as the model would.

use super::{byte_count, max_write, quantity_check, word, Exception, FunctionCode};
use crate::model::DataModel;
use crate::reference::Table;

/// The exception for the request PDU of `len` bytes of which `kept` holds the first ones
/// (FC 1–6, 15, 16 and unknown codes; the optional codes need the full buffer, which
/// their features enforce). Comparisons of the code, no `match`: see [`super`].
#[inline(never)]
pub(crate) fn exception<M: DataModel + ?Sized>(kept: &[u8], len: usize, model: &M) -> Exception {
    let code = kept.first().copied().unwrap_or(0);
    let coils = code == FunctionCode::WriteMultipleCoils.value();
    if !coils && code != FunctionCode::WriteMultipleRegisters.value() {
        // FC 1–6 have a 5-byte PDU: a longer one has a wrong length.
        let fixed = FunctionCode::ReadCoils.value()..=FunctionCode::WriteSingleRegister.value();
        return if fixed.contains(&code) { Exception::IllegalDataValue } else { Exception::IllegalFunction };
    }
    let table = if coils { Table::Coils } else { Table::HoldingRegisters };
    let (start, qty) = (word(kept, 1), word(kept, 3));
    let bytes = usize::from(byte_count(table, qty));
    let count = kept.get(5).copied().map(usize::from);
    if quantity_check(qty, max_write(table)).is_err() || count != Some(bytes) || len != 6 + bytes {
        return Exception::IllegalDataValue;
    }
    // A range past 65535 (02 in the parser) has addresses no model has, so the model's
    // answer is the same.
    range_exception(model, table, start, qty)
}

/// The exception for a request of `qty` values of `table` from `start` that does not fit
/// the buffer, its request or its response: the model sized the buffer for its longest
/// run of addresses, so one of them is missing (02); were none, it sized it wrong and
/// cannot carry the request out (04).
#[inline(never)]
pub(crate) fn range_exception<M: DataModel + ?Sized>(model: &M, table: Table, start: u16, qty: u16) -> Exception {
    if model.has_range(table, start, qty) {
        Exception::ServerDeviceFailure
    } else {
        Exception::IllegalDataAddress
    }
}
