//! Function codes, Modbus Application Protocol v1.1b3 §5.1 and §6: the byte after the
//! address that says what a request asks.

/// A function code, Application Protocol §5.1: a code byte whose constants are the codes
/// this crate sends or answers by name. Any other code is one too
/// ([`FunctionCode::custom`]: the user-defined 65–72 and 100–110, and the rest): a slave
/// answers it with exception 01, a master sends it as a
/// `master::Request::Raw`. As [`crate::Exception`], one byte, matched as an
/// enum's variants are (`FunctionCode::ReadCoils => …`).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct FunctionCode(u8);

// The spec's names, spelled as an enum's variants would be (see `Exception`).
#[allow(non_upper_case_globals)]
impl FunctionCode {
    /// 0x01 Read Coils, §6.1.
    pub const ReadCoils: FunctionCode = FunctionCode(0x01);
    /// 0x02 Read Discrete Inputs, §6.2.
    pub const ReadDiscreteInputs: FunctionCode = FunctionCode(0x02);
    /// 0x03 Read Holding Registers, §6.3.
    pub const ReadHoldingRegisters: FunctionCode = FunctionCode(0x03);
    /// 0x04 Read Input Registers, §6.4.
    pub const ReadInputRegisters: FunctionCode = FunctionCode(0x04);
    /// 0x05 Write Single Coil, §6.5.
    pub const WriteSingleCoil: FunctionCode = FunctionCode(0x05);
    /// 0x06 Write Single Register, §6.6.
    pub const WriteSingleRegister: FunctionCode = FunctionCode(0x06);
    /// 0x07 Read Exception Status, §6.7 (a slave answers it with feature `diagnostics`).
    pub const ReadExceptionStatus: FunctionCode = FunctionCode(0x07);
    /// 0x08 Diagnostics, §6.8 (a slave answers it with feature `diagnostics`).
    pub const Diagnostics: FunctionCode = FunctionCode(0x08);
    /// 0x0B Get Comm Event Counter, §6.9 (a slave answers it with feature `diagnostics`).
    pub const GetCommEventCounter: FunctionCode = FunctionCode(0x0B);
    /// 0x0F Write Multiple Coils, §6.11.
    pub const WriteMultipleCoils: FunctionCode = FunctionCode(0x0F);
    /// 0x10 Write Multiple Registers, §6.12.
    pub const WriteMultipleRegisters: FunctionCode = FunctionCode(0x10);
    /// 0x11 Report Server ID, §6.13 (a slave answers it with feature `diagnostics`).
    pub const ReportServerId: FunctionCode = FunctionCode(0x11);
    /// 0x16 Mask Write Register, §6.16 (a slave answers it with feature `extra-fc`).
    pub const MaskWriteRegister: FunctionCode = FunctionCode(0x16);
    /// 0x17 Read/Write Multiple Registers, §6.17 (a slave answers it with feature `extra-fc`).
    pub const ReadWriteMultipleRegisters: FunctionCode = FunctionCode(0x17);
    /// 0x2B Encapsulated Interface Transport, §6.19: MEI type 14 is Read Device Identification, §6.21 (a slave answers it with feature `device-id`).
    pub const EncapsulatedInterface: FunctionCode = FunctionCode(0x2B);
}

/// The named codes and their names, in order.
const NAMES: [(FunctionCode, &str); 15] = [
    (FunctionCode::ReadCoils, "ReadCoils"),
    (FunctionCode::ReadDiscreteInputs, "ReadDiscreteInputs"),
    (FunctionCode::ReadHoldingRegisters, "ReadHoldingRegisters"),
    (FunctionCode::ReadInputRegisters, "ReadInputRegisters"),
    (FunctionCode::WriteSingleCoil, "WriteSingleCoil"),
    (FunctionCode::WriteSingleRegister, "WriteSingleRegister"),
    (FunctionCode::ReadExceptionStatus, "ReadExceptionStatus"),
    (FunctionCode::Diagnostics, "Diagnostics"),
    (FunctionCode::GetCommEventCounter, "GetCommEventCounter"),
    (FunctionCode::WriteMultipleCoils, "WriteMultipleCoils"),
    (FunctionCode::WriteMultipleRegisters, "WriteMultipleRegisters"),
    (FunctionCode::ReportServerId, "ReportServerId"),
    (FunctionCode::MaskWriteRegister, "MaskWriteRegister"),
    (FunctionCode::ReadWriteMultipleRegisters, "ReadWriteMultipleRegisters"),
    (FunctionCode::EncapsulatedInterface, "EncapsulatedInterface"),
];

impl FunctionCode {
    /// The function code of a byte, named or not.
    pub const fn from_code(code: u8) -> Self {
        FunctionCode(code)
    }

    /// A code this crate does not name (the user-defined 65–72 and 100–110, say), for a
    /// `master::Request::Raw`: the same as [`FunctionCode::from_code`].
    pub const fn custom(code: u8) -> Self {
        FunctionCode(code)
    }

    /// The code byte.
    pub const fn code(self) -> u8 {
        self.0
    }

    /// The name of a code this crate names (`"ReadCoils"`), `None` for the rest.
    pub fn name(self) -> Option<&'static str> {
        NAMES.iter().find(|(known, _)| *known == self).map(|(_, name)| *name)
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

/// The name (`ReadCoils`), or `FunctionCode(0x41)` for a code this crate does not name.
impl core::fmt::Debug for FunctionCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.name() {
            Some(name) => f.write_str(name),
            None => write!(f, "FunctionCode({:#04x})", self.0),
        }
    }
}

/// The name, or the code in decimal (`FunctionCode(65)`), for arduino-hal's serial.
#[cfg(feature = "ufmt")]
impl ufmt::uDebug for FunctionCode {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        match self.name() {
            Some(name) => f.write_str(name),
            None => ufmt::uwrite!(f, "FunctionCode({})", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::FunctionCode;

    #[test]
    fn every_code_byte_comes_back_as_it_went_and_the_named_ones_have_their_names() {
        for code in 0..=255u8 {
            assert_eq!(FunctionCode::from_code(code).code(), code);
        }
        assert_eq!(FunctionCode::ReadHoldingRegisters.code(), 0x03);
        assert_eq!(FunctionCode::EncapsulatedInterface.code(), 0x2B);
        assert_eq!(format!("{:?}", FunctionCode::from_code(0x10)), "WriteMultipleRegisters");
        assert_eq!(format!("{:?}", FunctionCode::custom(0x41)), "FunctionCode(0x41)");
        let named = (0..=255u8).filter(|&c| FunctionCode::from_code(c).name().is_some()).count();
        assert_eq!(named, 15);
    }
}
