//! The Modbus vocabulary both roles speak: function codes, exception codes, slave
//! addresses, the data model's tables and references, the spec's limits. A leaf: it uses
//! nothing of the crate but [`crate::Error`].

mod address;
mod exception;
mod function;
pub(crate) mod limits;
pub(crate) mod reference;

pub use address::SlaveId;
pub use exception::Exception;
pub use function::FunctionCode;
