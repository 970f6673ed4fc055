//! Exception codes, Modbus Application Protocol v1.1b3 §7: what a slave answers instead of
//! a normal response (the function code with bit 7 set, then the code), and what a master
//! hands back when it gets one.

use core::num::NonZeroU8;

/// An exception code, Application Protocol §7. The slave answers 01–04 itself; a
/// [`crate::DataModel`] may return any of them; a master reports the one it got, known
/// or not.
///
/// A code byte: the spec's names are its constants, so a `match` reads as on an enum
/// (`Exception::IllegalDataAddress => …`), and any other code the master gets is kept as
/// it came ([`Exception::is_known`]). One byte, as on the wire, never 0 (no exception has
/// code 0): a `Result<(), Exception>` is one byte too. Its number, named or not, is
/// [`Exception::code`], a `u8`, or `u8::from(e)`, `u16::from(e)` (`e.into()`: a register's
/// value, say):
///
/// ```
/// use avr_modbus::Exception;
/// let busy = Exception::ServerDeviceBusy;
/// assert_eq!((busy.code(), u8::from(busy), u16::from(busy)), (6, 6, 6));
/// let register: u16 = Exception::IllegalDataAddress.into();
/// assert_eq!(register, 2);
/// ```
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Exception(NonZeroU8);

/// `code` as an exception code, for the constants.
const fn named(code: u8) -> Exception {
    match NonZeroU8::new(code) {
        Some(code) => Exception(code),
        None => panic!("0 is no exception code"),
    }
}

named_codes! {
    Exception, named;
    /// 0x01 Illegal Function: the function code is not supported.
    IllegalFunction = 0x01,
    /// 0x02 Illegal Data Address: an address of the range does not exist.
    IllegalDataAddress = 0x02,
    /// 0x03 Illegal Data Value: quantity, byte count, value or length is wrong.
    IllegalDataValue = 0x03,
    /// 0x04 Server Device Failure: the request was valid but could not be carried out.
    ServerDeviceFailure = 0x04,
    /// 0x05 Acknowledge: accepted, and a long time to carry out (poll for the outcome).
    Acknowledge = 0x05,
    /// 0x06 Server Device Busy: busy with a long command; send again later.
    ServerDeviceBusy = 0x06,
    /// 0x08 Memory Parity Error: a record file's memory failed its check (FC 20, 21).
    MemoryParityError = 0x08,
    /// 0x0A Gateway Path Unavailable: a gateway could not route the request.
    GatewayPathUnavailable = 0x0A,
    /// 0x0B Gateway Target Device Failed to Respond: a gateway's target did not answer.
    GatewayTargetDeviceFailedToRespond = 0x0B,
}

impl Exception {
    /// The exception of a code byte, named or not; `None` for 0, which no exception is.
    pub const fn from_code(code: u8) -> Option<Self> {
        match NonZeroU8::new(code) {
            Some(code) => Some(Exception(code)),
            None => None,
        }
    }

    /// The code byte (1–255).
    pub const fn code(self) -> u8 {
        self.0.get()
    }

    /// True for the nine codes Application Protocol §7 names: 01–06, 08, 0A, 0B.
    pub fn is_known(self) -> bool {
        self.name().is_some()
    }
}

/// The code byte ([`Exception::code`]).
impl From<Exception> for u8 {
    fn from(exception: Exception) -> u8 {
        exception.code()
    }
}

/// The code byte as a register's value.
impl From<Exception> for u16 {
    fn from(exception: Exception) -> u16 {
        u16::from(exception.code())
    }
}

#[cfg(test)]
mod tests {
    use super::Exception;

    #[test]
    fn every_code_byte_comes_back_as_it_went() {
        for code in 1..=255u8 {
            assert_eq!(Exception::from_code(code).map(Exception::code), Some(code));
        }
        assert_eq!(Exception::from_code(0), None);
        assert_eq!(core::mem::size_of::<Result<(), Exception>>(), 1);
    }

    #[test]
    fn an_exception_converts_to_its_code_as_u8_and_u16() {
        for code in 1..=255u8 {
            let exception = Exception::from_code(code).unwrap();
            assert_eq!(u8::from(exception), code);
            let wide: u16 = exception.into();
            assert_eq!(wide, u16::from(code));
        }
        assert_eq!(u8::from(Exception::GatewayTargetDeviceFailedToRespond), 0x0B);
    }

    #[test]
    fn the_specs_codes_have_their_names() {
        let named = [
            (0x01, Exception::IllegalFunction),
            (0x02, Exception::IllegalDataAddress),
            (0x03, Exception::IllegalDataValue),
            (0x04, Exception::ServerDeviceFailure),
            (0x05, Exception::Acknowledge),
            (0x06, Exception::ServerDeviceBusy),
            (0x08, Exception::MemoryParityError),
            (0x0A, Exception::GatewayPathUnavailable),
            (0x0B, Exception::GatewayTargetDeviceFailedToRespond),
        ];
        for (code, exception) in named {
            assert_eq!(Exception::from_code(code), Some(exception));
            assert!(exception.is_known());
        }
        assert_eq!(format!("{:?}", Exception::GatewayPathUnavailable), "GatewayPathUnavailable");
        assert_eq!(format!("{:?}", Exception::from_code(7).unwrap()), "Exception(0x07)");
        for unnamed in [0x07, 0x09, 0x0C, 0xFF] {
            assert!(!Exception::from_code(unnamed).is_some_and(Exception::is_known), "{unnamed:#x}");
        }
    }
}
