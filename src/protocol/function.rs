//! Function codes, Modbus Application Protocol v1.1b3 §5.1 and §6: the byte after the
//! address that says what a request asks.

/// A function code, Application Protocol §5.1: a code byte whose constants are the codes
/// this crate sends or answers by name (`FunctionCode::ReadCoils` … `FunctionCode::EncapsulatedInterface`,
/// below). Any other code of 1–127 is one too ([`FunctionCode::custom`] in a constant,
/// [`FunctionCode::from_code`] for a byte): a slave answers it with exception 01, a master
/// sends it as a `master::Request::Raw`. As [`crate::Exception`], one byte, matched as an
/// enum's variants are (`FunctionCode::ReadCoils => …`); [`FunctionCode::code`] and
/// `u8::from(function)` give the byte.
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

    /// A code this crate does not name, for a `master::Request::Raw`, in a constant: the
    /// spec's public codes without a constant here (0x0C Get Comm Event Log, 0x14 and 0x15
    /// the file records, 0x18 Read FIFO Queue), the user-defined 65–72 (0x41–0x48) and
    /// 100–110 (0x64–0x6E), any other of 1–127. As [`crate::SlaveId::new`], a code that
    /// cannot be stops the build: 0 (no function has it), 128–255 (an exception reply's
    /// function byte) and a code with a name (`custom(0x03)`: use
    /// [`FunctionCode::ReadHoldingRegisters`], which the master checks the reply of).
    ///
    /// ```
    /// use avr_modbus::FunctionCode;
    /// const VENDOR: FunctionCode = FunctionCode::custom(0x41);
    /// assert_eq!(VENDOR.code(), 0x41);
    /// ```
    ///
    /// ```compile_fail,E0080
    /// # use avr_modbus::FunctionCode;
    /// const NONE: FunctionCode = FunctionCode::custom(0);
    /// ```
    ///
    /// ```compile_fail,E0080
    /// # use avr_modbus::FunctionCode;
    /// const EXCEPTION_REPLY: FunctionCode = FunctionCode::custom(0x83);
    /// ```
    ///
    /// ```compile_fail,E0080
    /// # use avr_modbus::FunctionCode;
    /// const READ: FunctionCode = FunctionCode::custom(0x03); // FunctionCode::ReadHoldingRegisters
    /// ```
    ///
    /// Outside a constant such a code panics: a code byte known only at run time is
    /// [`FunctionCode::from_code`]'s, and `send` refuses a `Raw` request whose code is not
    /// 1–127 with [`Error::Function`](crate::Error::Function).
    pub const fn custom(code: u8) -> Self {
        match code {
            0 => panic!("function code 0 does not exist: a custom code is 1-127"),
            0x80..=0xFF => panic!("function codes 128-255 are exception replies: a custom code is 1-127"),
            _ => match Self::named_message(code) {
                Some(message) => panic!("{}", message),
                None => FunctionCode(code),
            },
        }
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

impl FunctionCode {
    /// True for the codes that write a model's coils or holding registers: FC 5, 6, 15
    /// (0x0F), 16 (0x10), 22 (0x16) and 23 (0x17).
    pub const fn is_write(self) -> bool {
        matches!(
            self,
            FunctionCode::WriteSingleCoil
                | FunctionCode::WriteSingleRegister
                | FunctionCode::WriteMultipleCoils
                | FunctionCode::WriteMultipleRegisters
                | FunctionCode::MaskWriteRegister
                | FunctionCode::ReadWriteMultipleRegisters
        )
    }
}

/// The code byte ([`FunctionCode::code`]).
impl From<FunctionCode> for u8 {
    fn from(function: FunctionCode) -> u8 {
        function.code()
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
        assert_eq!(u8::from(FunctionCode::WriteMultipleCoils), 0x0F);
        assert_eq!(FunctionCode::EncapsulatedInterface.code(), 0x2B);
        assert_eq!(format!("{:?}", FunctionCode::from_code(0x10)), "WriteMultipleRegisters");
        assert_eq!(format!("{:?}", FunctionCode::custom(0x41)), "FunctionCode(0x41)");
        let named = (0..=255u8).filter(|&c| FunctionCode::from_code(c).name().is_some()).count();
        assert_eq!(named, 15);
        let writes: Vec<u8> = (0..=255u8).filter(|&c| FunctionCode::from_code(c).is_write()).collect();
        assert_eq!(writes, [0x05, 0x06, 0x0F, 0x10, 0x16, 0x17]);
    }

    #[test]
    fn custom_takes_every_code_of_1_to_127_without_a_name() {
        for code in 1..=0x7Fu8 {
            let named = FunctionCode::from_code(code).name();
            assert_eq!(FunctionCode::named_message(code).is_some(), named.is_some(), "{code:#04x}");
            if named.is_none() {
                assert_eq!(FunctionCode::custom(code).code(), code);
            }
        }
        assert_eq!(
            FunctionCode::named_message(0x03),
            Some("FunctionCode 0x03 is named: FunctionCode::ReadHoldingRegisters")
        );
    }

    #[test]
    #[should_panic(expected = "function code 0 does not exist")]
    fn custom_0_panics_outside_a_constant() {
        FunctionCode::custom(std::hint::black_box(0));
    }

    #[test]
    #[should_panic(expected = "exception replies")]
    fn custom_0x80_panics_outside_a_constant() {
        FunctionCode::custom(std::hint::black_box(0x80));
    }

    #[test]
    #[should_panic(expected = "is named: FunctionCode::ReadHoldingRegisters")]
    fn custom_of_a_named_code_panics_outside_a_constant() {
        FunctionCode::custom(std::hint::black_box(0x03));
    }
}
