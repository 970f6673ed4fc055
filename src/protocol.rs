//! The Modbus vocabulary both roles speak: function codes, exception codes, slave
//! addresses, the data model's tables and references, 32-bit values in two registers, the
//! spec's limits. A leaf: it uses
//! nothing of the crate but [`crate::Error`].

/// A one-byte code type's named constants, spelled as the variants of an enum would be
/// (they stand where variants would: `Err(Exception::IllegalDataValue)`, `match` arms), with
/// `name()` and `Debug` (and with feature `ufmt`, `uDebug`) printing a named code's name
/// and any other as `Type(code)`: what [`Exception`] and [`FunctionCode`] share. `$make`
/// turns a code literal into the type in a constant; `code()` gives the byte back.
macro_rules! named_codes {
    ($ty:ident, $make:path; $($(#[$doc:meta])* $name:ident = $code:literal,)+) => {
        #[allow(non_upper_case_globals)]
        impl $ty {
            $($(#[$doc])* pub const $name: $ty = $make($code);)+

            /// The code's name (`"IllegalDataAddress"`, `"ReadCoils"`), `None` for a code
            /// without one.
            pub fn name(self) -> Option<&'static str> {
                const NAMES: &[($ty, &str)] = &[$(($ty::$name, stringify!($name)),)+];
                NAMES.iter().find(|(known, _)| *known == self).map(|(_, name)| *name)
            }

            /// For a code byte that has a name, the message that says which constant it is
            /// (`"FunctionCode 0x03 is named: FunctionCode::ReadHoldingRegisters"`), worked
            /// out in a constant; `None` for any other byte.
            #[allow(dead_code)] // asked by `FunctionCode::custom` only
            pub(crate) const fn named_message(code: u8) -> Option<&'static str> {
                match code {
                    $($code => Some(concat!(
                        stringify!($ty), " ", stringify!($code), " is named: ", stringify!($ty), "::", stringify!($name)
                    )),)+
                    _ => None,
                }
            }
        }

        /// The code's name (`IllegalDataAddress`), or `Type(0x07)` for a code without one.
        impl core::fmt::Debug for $ty {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                match self.name() {
                    Some(name) => f.write_str(name),
                    None => write!(f, "{}({:#04x})", stringify!($ty), self.code()),
                }
            }
        }

        /// The code's name, or `Type(7)` (the code in decimal), for arduino-hal's serial.
        #[cfg(feature = "ufmt")]
        impl ufmt::uDebug for $ty {
            fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
                match self.name() {
                    Some(name) => f.write_str(name),
                    None => ufmt::uwrite!(f, "{}({})", stringify!($ty), self.code()),
                }
            }
        }
    };
}

mod address;
mod exception;
mod function;
pub mod limits;
pub(crate) mod reference;
mod wide;

pub use address::SlaveId;
pub use exception::Exception;
pub use function::FunctionCode;
pub use wide::{Wide, WordOrder};
