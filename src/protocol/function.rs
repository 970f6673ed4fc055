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

named_codes! {
    FunctionCode, FunctionCode;
    /// 0x01 Read Coils, §6.1.
    ReadCoils = 0x01,
    /// 0x02 Read Discrete Inputs, §6.2.
    ReadDiscreteInputs = 0x02,
    /// 0x03 Read Holding Registers, §6.3.
    ReadHoldingRegisters = 0x03,
    /// 0x04 Read Input Registers, §6.4.
    ReadInputRegisters = 0x04,
    /// 0x05 Write Single Coil, §6.5.
    WriteSingleCoil = 0x05,
    /// 0x06 Write Single Register, §6.6.
    WriteSingleRegister = 0x06,
    /// 0x07 Read Exception Status, §6.7 (a slave answers it with feature `diagnostics`).
    ReadExceptionStatus = 0x07,
    /// 0x08 Diagnostics, §6.8 (a slave answers it with feature `diagnostics`).
    Diagnostics = 0x08,
    /// 0x0B Get Comm Event Counter, §6.9 (a slave answers it with feature `diagnostics`).
    GetCommEventCounter = 0x0B,
    /// 0x0F Write Multiple Coils, §6.11.
    WriteMultipleCoils = 0x0F,
    /// 0x10 Write Multiple Registers, §6.12.
    WriteMultipleRegisters = 0x10,
    /// 0x11 Report Server ID, §6.13 (a slave answers it with feature `diagnostics`).
    ReportServerId = 0x11,
    /// 0x16 Mask Write Register, §6.16 (a slave answers it with feature `extra-fc`).
    MaskWriteRegister = 0x16,
    /// 0x17 Read/Write Multiple Registers, §6.17 (a slave answers it with feature `extra-fc`).
    ReadWriteMultipleRegisters = 0x17,
    /// 0x2B Encapsulated Interface Transport, §6.19: MEI type 14 is Read Device Identification, §6.21 (a slave answers it with feature `device-id`).
    EncapsulatedInterface = 0x2B,
}

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
