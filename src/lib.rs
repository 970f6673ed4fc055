#![doc = include_str!("../README.md")]
#![cfg_attr(not(test), no_std)]
#![cfg_attr(target_arch = "avr", feature(asm_experimental_arch, const_type_name))]
#![cfg_attr(all(target_arch = "avr", feature = "millis"), feature(abi_avr_interrupt))]
#![deny(missing_docs)]

#[cfg(target_arch = "avr")]
mod avr;
mod bank;
mod config;
mod crc;
#[cfg(feature = "diagnostics")]
mod diagnostics;
mod engine;
mod error;
mod framer;
mod map;
#[cfg(feature = "master")]
pub mod master;
mod model;
mod pdu;
#[cfg(any(target_arch = "avr", test))]
mod peripheral;
mod reference;
#[cfg(feature = "eeprom-settings")]
mod settings;
mod storage;
mod timing;
mod wide;

#[cfg(target_arch = "avr")]
#[doc(hidden)]
pub use avr::__private;
#[cfg(target_arch = "avr")]
#[cfg(all(target_arch = "avr", feature = "millis"))]
pub use avr::millis;
#[cfg(all(target_arch = "avr", feature = "master"))]
pub use avr::Master;
#[cfg(target_arch = "avr")]
pub use avr::{board, NoPin, Slave};
pub use bank::{bit_bytes, Bank};
#[cfg(feature = "ascii")]
pub use config::Mode;
pub use config::{Config, Parity, SlaveId, StopBits};
pub use engine::Counters;
pub use error::Error;
pub use model::DataModel;
pub use pdu::device_id::Identification;
pub use pdu::Exception;
pub use reference::{IntoReference, Reference, Table};
#[cfg(feature = "eeprom-settings")]
pub use settings::Configurable;
pub use wide::{Wide, WordOrder};

/// The protocol engine's parts, for this crate's tests, simulator and benchmarks: not
/// part of the API, and they change without notice.
#[doc(hidden)]
pub mod internal {
    pub use crate::crc::{crc16, Crc16};
    pub use crate::engine::{EndOfFrame, Engine};
    pub use crate::framer::{FrameError, Framer, UartError, MAX_FRAME, MIN_FRAME};
    pub use crate::model::Access;
    pub use crate::pdu::{encode_exception, respond, FunctionCode, Request};
    pub use crate::timing::{BaudDivisor, CharTimes, Deadline, TimerPlan, Uptime};

    /// The compile-time register map's parts, for [`crate::register_map!`].
    pub mod map {
        pub use crate::map::{Layout, Span};
        pub use crate::storage::Values;
    }
    /// FC 43 / MEI 14: what [`crate::identification!`] expands to.
    pub mod device_id {
        pub use crate::pdu::device_id::*;
    }
    /// The PDU engine.
    pub mod pdu {
        pub use crate::pdu::*;
    }
    /// Character times and the USART and Timer0 arithmetic.
    pub mod timing {
        pub use crate::timing::*;
    }
    /// ASCII framing: LRC, hex, the reply's characters.
    #[cfg(feature = "ascii")]
    pub mod ascii {
        pub use crate::framer::ascii::*;
    }
    /// FC 7, 8, 11 and 17.
    #[cfg(feature = "diagnostics")]
    pub mod diagnostics {
        pub use crate::diagnostics::*;
    }
    /// The settings record and block.
    #[cfg(feature = "eeprom-settings")]
    pub mod settings {
        pub use crate::settings::*;
    }
}
