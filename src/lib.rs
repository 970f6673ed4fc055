#![doc = include_str!("../README.md")]
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

#[cfg(target_arch = "avr")]
pub mod avr;
pub mod bank;
pub mod config;
pub mod crc;
#[cfg(feature = "diagnostics")]
pub mod diagnostics;
pub mod framer;
pub mod model;
pub mod pdu;
pub mod reference;
#[cfg(feature = "eeprom-settings")]
pub mod settings;
pub mod slave;
pub mod timing;

pub use bank::{bit_bytes, Bank, Variables};
pub use config::{Config, ConfigError, Parity, SlaveId, StopBits};
pub use crc::{crc16, Crc16};
pub use framer::{FrameError, Framer, UartError};
pub use model::DataModel;
pub use pdu::{Exception, FunctionCode, Request};
pub use reference::{BankError, IntoReference, Reference, Table};
#[cfg(feature = "eeprom-settings")]
pub use settings::Configurable;
pub use slave::{Counters, EndOfFrame, Slave};
pub use timing::{BaudDivisor, CharTimes, Deadline, Prescaler, TimerPlan};
