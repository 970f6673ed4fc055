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
/// it came ([`Exception::code`], [`Exception::is_known`]). One byte, as on the wire, never
/// 0 (no exception has code 0): a `Result<(), Exception>` is one byte too.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Exception(NonZeroU8);

/// `code` as an exception code, for the constants.
const fn named(code: u8) -> Exception {
    match NonZeroU8::new(code) {
        Some(code) => Exception(code),
        None => panic!("0 is no exception code"),
    }
}

// The spec's names, spelled as the variants of an enum would be: the constants stand where
// an enum's variants would (`Err(Exception::IllegalDataValue)`, `match` arms), and a struct
// of one byte keeps every `Result<_, Exception>` of the slave's engine as small as it was.
#[allow(non_upper_case_globals)]
impl Exception {
    /// 0x01 Illegal Function: the function code is not supported.
    pub const IllegalFunction: Exception = named(0x01);
    /// 0x02 Illegal Data Address: an address of the range does not exist.
    pub const IllegalDataAddress: Exception = named(0x02);
    /// 0x03 Illegal Data Value: quantity, byte count, value or length is wrong.
    pub const IllegalDataValue: Exception = named(0x03);
    /// 0x04 Server Device Failure: the request was valid but could not be carried out.
    pub const ServerDeviceFailure: Exception = named(0x04);
    /// 0x05 Acknowledge: accepted, and a long time to carry out (poll for the outcome).
    pub const Acknowledge: Exception = named(0x05);
    /// 0x06 Server Device Busy: busy with a long command; send again later.
    pub const ServerDeviceBusy: Exception = named(0x06);
    /// 0x08 Memory Parity Error: a record file's memory failed its check (FC 20, 21).
    pub const MemoryParityError: Exception = named(0x08);
    /// 0x0A Gateway Path Unavailable: a gateway could not route the request.
    pub const GatewayPathUnavailable: Exception = named(0x0A);
    /// 0x0B Gateway Target Device Failed to Respond: a gateway's target did not answer.
    pub const GatewayTargetDeviceFailedToRespond: Exception = named(0x0B);
}

/// The spec's names and codes, in order.
const NAMES: [(Exception, &str); 9] = [
    (Exception::IllegalFunction, "IllegalFunction"),
    (Exception::IllegalDataAddress, "IllegalDataAddress"),
    (Exception::IllegalDataValue, "IllegalDataValue"),
    (Exception::ServerDeviceFailure, "ServerDeviceFailure"),
    (Exception::Acknowledge, "Acknowledge"),
    (Exception::ServerDeviceBusy, "ServerDeviceBusy"),
    (Exception::MemoryParityError, "MemoryParityError"),
    (Exception::GatewayPathUnavailable, "GatewayPathUnavailable"),
    (Exception::GatewayTargetDeviceFailedToRespond, "GatewayTargetDeviceFailedToRespond"),
];

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

    /// The spec's name of the code (`"IllegalDataAddress"`), `None` for a code the spec
    /// does not name.
    pub fn name(self) -> Option<&'static str> {
        NAMES.iter().find(|(known, _)| *known == self).map(|(_, name)| *name)
    }

    /// True for the nine codes Application Protocol §7 names: 01–06, 08, 0A, 0B.
    pub fn is_known(self) -> bool {
        self.name().is_some()
    }
}

/// The spec's name (`IllegalDataAddress`), or `Exception(0x07)` for another code.
impl core::fmt::Debug for Exception {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.name() {
            Some(name) => f.write_str(name),
            None => write!(f, "Exception({:#04x})", self.code()),
        }
    }
}

/// The spec's name, or the code in decimal (`Exception(7)`), for arduino-hal's serial.
#[cfg(feature = "ufmt")]
impl ufmt::uDebug for Exception {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        match self.name() {
            Some(name) => f.write_str(name),
            None => ufmt::uwrite!(f, "Exception({})", self.code()),
        }
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
