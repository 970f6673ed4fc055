//! Responses longer than the frame buffer, Application Protocol v1.1b3 §6.1–6.4 and §7:
//! the exception they get.
//!
//! A data model may size the frame buffer for the longest request and response it can
//! accept ([`crate::DataModel::FRAME`]). A request longer than the buffer is received
//! whole but only its first bytes are kept (the framer checks the CRC over all of them),
//! and [`super::Request::parse`] checks it from those and its real length, as it would a
//! whole one. Once it passes, its data (or a read's response) does not fit the buffer: it
//! asks for more values than the model has in a row, and [`range_exception`] answers 02 as
//! the model would.

use super::Exception;
use crate::protocol::reference::Table;
use crate::slave::model::DataModel;

/// The exception for a request of `qty` values of `table` from `start` that does not fit
/// the buffer, its request or its response: the model sized the buffer for its longest
/// run of addresses, so one of them is missing (02); were none, it sized it wrong and
/// cannot carry the request out (04).
#[inline(never)]
pub(crate) fn range_exception<M: DataModel + ?Sized>(model: &M, table: Table, start: u16, qty: u16) -> Exception {
    if !M::FRAME_HOLDS_ALL && model.has_range(table, start, qty) {
        Exception::ServerDeviceFailure
    } else {
        Exception::IllegalDataAddress
    }
}
