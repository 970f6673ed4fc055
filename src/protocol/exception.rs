//! Exception codes, Modbus Application Protocol v1.1b3 §7: what a slave answers instead of
//! a normal response (the function code with bit 7 set, then the code), and what a master
//! hands back when it gets one.

/// An exception code, Application Protocol §7. The slave answers 01–04 itself; a
/// [`crate::DataModel`] may return any of them; a master reports the one it got, known
/// or not.
///
/// A code byte: the spec's names are its constants, so a `match` reads as on an enum
/// (`Exception::IllegalDataAddress => …`), and any other code the master gets is kept as
/// it came ([`Exception::code`], [`Exception::is_known`]). One byte, as on the wire.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Exception(u8);

// The spec's names, spelled as the variants of an enum would be: the constants stand where
// an enum's variants would (`Err(Exception::IllegalDataValue)`, `match` arms), and a struct
// of one byte keeps every `Result<_, Exception>` of the slave's engine as small as it was.
#[allow(non_upper_case_globals)]
impl Exception {
    /// 0x01 Illegal Function: the function code is not supported.
    pub const IllegalFunction: Exception = Exception(0x01);
    /// 0x02 Illegal Data Address: an address of the range does not exist.
    pub const IllegalDataAddress: Exception = Exception(0x02);
    /// 0x03 Illegal Data Value: quantity, byte count, value or length is wrong.
    pub const IllegalDataValue: Exception = Exception(0x03);
    /// 0x04 Server Device Failure: the request was valid but could not be carried out.
    pub const ServerDeviceFailure: Exception = Exception(0x04);
    /// 0x05 Acknowledge: accepted, and a long time to carry out (poll for the outcome).
    pub const Acknowledge: Exception = Exception(0x05);
    /// 0x06 Server Device Busy: busy with a long command; send again later.
    pub const ServerDeviceBusy: Exception = Exception(0x06);
    /// 0x08 Memory Parity Error: a record file's memory failed its check (FC 20, 21).
    pub const MemoryParityError: Exception = Exception(0x08);
    /// 0x0A Gateway Path Unavailable: a gateway could not route the request.
    pub const GatewayPathUnavailable: Exception = Exception(0x0A);
    /// 0x0B Gateway Target Device Failed to Respond: a gateway's target did not answer.
    pub const GatewayTargetDeviceFailedToRespond: Exception = Exception(0x0B);
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
    /// The exception of a code byte, named or not.
    pub const fn from_code(code: u8) -> Self {
        Exception(code)
    }

    /// The code byte.
    pub const fn code(self) -> u8 {
        self.0
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
            None => write!(f, "Exception({:#04x})", self.0),
        }
    }
}

/// The spec's name, or the code in decimal (`Exception(7)`), for arduino-hal's serial.
#[cfg(feature = "ufmt")]
impl ufmt::uDebug for Exception {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        match self.name() {
            Some(name) => f.write_str(name),
            None => ufmt::uwrite!(f, "Exception({})", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Exception;

    #[test]
    fn every_code_byte_comes_back_as_it_went() {
        for code in 0..=255u8 {
            assert_eq!(Exception::from_code(code).code(), code);
        }
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
            assert_eq!(Exception::from_code(code), exception);
            assert!(exception.is_known());
        }
        assert_eq!(format!("{:?}", Exception::GatewayPathUnavailable), "GatewayPathUnavailable");
        assert_eq!(format!("{:?}", Exception::from_code(7)), "Exception(0x07)");
        for unnamed in [0x00, 0x07, 0x09, 0x0C, 0xFF] {
            assert!(!Exception::from_code(unnamed).is_known(), "{unnamed:#x}");
        }
    }
}
