//! Serial-line diagnostics, Modbus Application Protocol v1.1b3 §6.7 (FC 7 Read Exception
//! Status), §6.8 (FC 8 Diagnostics), §6.9 (FC 11 = 0x0B Get Comm Event Counter) and §6.13
//! (FC 17 = 0x11 Report Server ID), with the counters of Modbus over Serial Line v1.02
//! §6.1.3.
//!
//! FC 8 sub-functions, each answering exception 01 when not listed and 03 when its data
//! field is not the one the spec prescribes:
//!
//! | sub | name | data | answer |
//! |-----|------|------|--------|
//! | 00 | Return Query Data | any | echo |
//! | 01 | Restart Communications Option | 0000 or FF00 | echo, then counters cleared and listen-only mode left; no answer while listen-only |
//! | 04 | Force Listen Only Mode | 0000 | none: the slave stays silent until sub-function 01 |
//! | 0A | Clear SlaveCounters and Diagnostic Register | 0000 | echo, counters cleared |
//! | 0B | Return Bus Message Count | 0000 | [`SlaveCounters::frames`] |
//! | 0C | Return Bus Communication Error Count | 0000 | [`SlaveCounters::crc_errors`] |
//! | 0D | Return Slave Exception Error Count | 0000 | [`SlaveCounters::exceptions`] |
//! | 0E | Return Slave Message Count | 0000 | [`SlaveCounters::messages`] |
//! | 0F | Return Slave No Response Count | 0000 | [`SlaveCounters::no_response`] |
//! | 10 | Return Slave NAK Count | 0000 | 0 (this slave never answers 07) |
//! | 11 | Return Slave Busy Count | 0000 | 0 (this slave never answers 06) |
//! | 12 | Return Bus Character Overrun Count | 0000 | [`SlaveCounters::overruns`] |

use crate::slave::counters::SlaveCounters;
use crate::slave::model::DataModel;
use crate::slave::pdu::{word, Answer, Exception, FunctionCode};

/// The feature is on: the engine sends FC 7, 8, 11 and 17 here.
pub(crate) const ENABLED: bool = true;

/// FC 8, for the slice patterns below.
const DIAGNOSTICS: u8 = FunctionCode::Diagnostics.code();

/// FC 8 sub-function 01: restart communications.
pub const RESTART_COMMUNICATIONS: u16 = 0x0001;
/// FC 8 sub-function 04: force listen-only mode.
pub const FORCE_LISTEN_ONLY: u16 = 0x0004;

/// True for FC 8 sub-function 04 with data 0000 (`pdu` without address and CRC): it puts
/// the slave in listen-only mode and gets no reply.
pub(crate) fn forces_listen_only(pdu: &[u8]) -> bool {
    matches!(pdu, [DIAGNOSTICS, 0x00, 0x04, 0x00, 0x00])
}

/// True for FC 8 sub-function 01 with data 0000 or FF00: restart communications.
pub(crate) fn restarts_communications(pdu: &[u8]) -> bool {
    matches!(pdu, [DIAGNOSTICS, 0x00, 0x01, 0x00 | 0xFF, 0x00])
}

fn put(pdu: &mut [u8], at: usize, value: u16) {
    if let Some(slot) = pdu.get_mut(at..at + 2) {
        slot.copy_from_slice(&value.to_be_bytes());
    }
}

/// Handles FC 7, 8, 11 (0x0B) and 17 (0x11) in place (the reply PDU over the request);
/// the engine sends only these codes here.
pub(crate) fn respond<M: DataModel + ?Sized>(
    pdu: &mut [u8],
    len: usize,
    model: &M,
    counters: &SlaveCounters,
    slave_id: u8,
) -> Result<Answer, Exception> {
    let code = pdu.first().copied().unwrap_or(0);
    match FunctionCode::from_code(code) {
        FunctionCode::Diagnostics => diagnostics(pdu, len, counters),
        // FC 7, 11 and 17 carry no data.
        _ if len != 1 => Err(Exception::IllegalDataValue),
        FunctionCode::ReadExceptionStatus => {
            put(pdu, 0, u16::from_be_bytes([code, model.exception_status()]));
            Ok(Answer::Reply(2))
        }
        FunctionCode::GetCommEventCounter => {
            // Status word 0000: no previous command still being processed.
            put(pdu, 1, 0);
            put(pdu, 3, counters.events);
            Ok(Answer::Reply(5))
        }
        FunctionCode::ReportServerId => {
            let info = model.device_info();
            let info = info.get(..info.len().min(249)).unwrap_or(&[]);
            put(pdu, 1, u16::from_be_bytes([2 + info.len() as u8, slave_id]));
            // Run indicator: ON.
            put(pdu, 3, u16::from_be_bytes([0xFF, 0]));
            if let Some(slot) = pdu.get_mut(4..4 + info.len()) {
                slot.copy_from_slice(info);
            }
            Ok(Answer::Reply(4 + info.len()))
        }
        _ => Err(Exception::IllegalFunction),
    }
}

fn diagnostics(pdu: &mut [u8], len: usize, counters: &SlaveCounters) -> Result<Answer, Exception> {
    // Only the request's own bytes count: past `len` the buffer holds its CRC.
    let request = pdu.get(..len).unwrap_or(&[]);
    if len < 3 {
        return Err(Exception::IllegalDataValue);
    }
    let sub = word(request, 1);
    let data = word(request, 3);
    // Return Query Data echoes any number of data words; the others carry exactly one.
    if sub == 0x0000 {
        return if len >= 3 && len % 2 == 1 { Ok(Answer::Reply(len)) } else { Err(Exception::IllegalDataValue) };
    }
    let counter = match sub {
        RESTART_COMMUNICATIONS | FORCE_LISTEN_ONLY | 0x000A => None,
        0x000B => Some(counters.frames),
        0x000C => Some(counters.crc_errors),
        0x000D => Some(counters.exceptions),
        0x000E => Some(counters.messages),
        0x000F => Some(counters.no_response),
        0x0010 | 0x0011 => Some(0),
        0x0012 => Some(counters.overruns),
        _ => return Err(Exception::IllegalFunction),
    };
    let data_ok = data == 0x0000 || (sub == RESTART_COMMUNICATIONS && data == 0xFF00);
    if len != 5 || !data_ok {
        return Err(Exception::IllegalDataValue);
    }
    match (sub, counter) {
        (_, Some(value)) => {
            put(pdu, 3, value);
            Ok(Answer::Reply(5))
        }
        (RESTART_COMMUNICATIONS, None) => Ok(Answer::Restart(5)),
        (FORCE_LISTEN_ONLY, None) => Ok(Answer::ListenOnly),
        // Clear SlaveCounters: the reply is the echo; the caller clears.
        _ => Ok(Answer::Restart(5)),
    }
}
