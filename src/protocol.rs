//! The Modbus vocabulary both roles speak: function codes, exception codes, slave
//! addresses, the data model's tables and references, 32-bit values in two registers, the
//! spec's limits. A leaf: it uses
//! nothing of the crate but [`crate::Error`].

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
