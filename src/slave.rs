//! The slave (server), Modbus Application Protocol v1.1b3 §6: its protocol state above the
//! link (`engine`), the PDU engine and the optional function codes (`pdu`, `diagnostics`),
//! and the data it serves: the classic references, the register map fixed at build time,
//! the run-time bank, the data-model trait, the record of who wrote a shared model, their shared value storage and the line
//! settings kept as registers.

pub(crate) mod bank;
pub(crate) mod counters;
pub(crate) mod device;
#[cfg(feature = "diagnostics")]
pub(crate) mod diagnostics;
pub(crate) mod engine;
pub(crate) mod map;
pub(crate) mod model;
pub(crate) mod pdu;
#[cfg(feature = "eeprom-settings")]
pub(crate) mod settings;
pub(crate) mod storage;
pub(crate) mod words;
pub(crate) mod written;
