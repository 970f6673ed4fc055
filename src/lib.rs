#![doc = include_str!("../README.md")]
#![cfg_attr(not(test), no_std)]
#![cfg_attr(target_arch = "avr", feature(asm_experimental_arch, const_type_name))]
#![cfg_attr(all(target_arch = "avr", any(feature = "millis", feature = "tcp")), feature(abi_avr_interrupt))]
#![deny(missing_docs)]
// The docs as docs.rs builds them (`[package.metadata.docs.rs]`): each item shows the
// features and the target it needs.
#![cfg_attr(docsrs, feature(doc_cfg))]
#![cfg_attr(docsrs, doc(auto_cfg(hide(docsrs))))]

// The AVR layer (`Slave`, `slave!`, `Master`, `master!`, `Eeprom`, `millis`, `NoPin`) is the
// firmware's: only an AVR build compiles it. docs.rs documents a crate for a host target (it
// takes its targets from rustup, which has none for the AVR), so given `--cfg docsrs`
// rustdoc documents the layer on the host too: the module itself, its real signatures and
// docs. rustdoc neither type-checks nor compiles function bodies, so their `asm!` stays as
// it is; only the interrupt handler the crate binds itself (`avr::clock`) is left out, and
// the Uno's chip table is the one named. `doc` keeps all this out of every rustc build, even
// one given `--cfg docsrs`. The `doc(cfg)`s below give each item its badge (the automatic
// one would read "(AVR)" and repeat "AVR" on every method).
#[cfg(any(target_arch = "avr", all(doc, docsrs)))]
#[cfg_attr(docsrs, doc(cfg(target_arch = "avr")))]
mod avr;
mod error;
mod link;
#[cfg(feature = "master")]
pub mod master;
#[cfg(any(target_arch = "avr", all(doc, docsrs), test))]
mod peripheral;
pub(crate) mod protocol;
mod slave;
#[cfg(feature = "tcp")]
pub mod tcp;

#[cfg(target_arch = "avr")]
#[doc(hidden)]
pub use avr::__private;
#[cfg(all(target_arch = "avr", feature = "examples"))]
#[doc(hidden)]
pub use avr::board;
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "millis"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "millis"))))]
pub use avr::millis;
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "eeprom-settings"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "eeprom-settings"))))]
pub use avr::Eeprom;
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "master"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "master"))))]
pub use avr::Master;
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "tcp", feature = "master"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp", feature = "master"))))]
pub use avr::TcpClient;
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "tcp", feature = "master"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp", feature = "master"))))]
pub use avr::TcpGateway;
#[cfg(any(target_arch = "avr", all(doc, docsrs)))]
#[cfg_attr(docsrs, doc(cfg(target_arch = "avr")))]
pub use avr::{NoPin, SharedModel, Slave};
#[cfg(all(any(target_arch = "avr", all(doc, docsrs)), feature = "tcp"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp"))))]
pub use avr::{Pin10, TcpServer};
pub use error::Error;
#[cfg(feature = "ascii")]
pub use link::config::Mode;
pub use link::config::{Config, Line, Parity, StopBits};
pub use protocol::limits;
pub use protocol::reference::{IntoReference, Reference, Table};
pub use protocol::SlaveId;
pub use protocol::{Exception, FunctionCode};
pub use protocol::{Wide, WordOrder};
pub use slave::bank::{bit_bytes, Bank};
pub use slave::counters::SlaveCounters;
pub use slave::model::DataModel;
pub use slave::pdu::device_id::Identification;
#[cfg(feature = "eeprom-settings")]
pub use slave::settings::Configurable;
pub use slave::written::{Port, Write};

/// The guides in `docs/`, the depth behind the README (documentation only: each guide's
/// Rust blocks are doctests, so that they keep up with the API).
#[cfg(any(doc, doctest))]
pub mod guide {
    #[doc = include_str!("../docs/slave.md")]
    pub mod slave {}
    #[doc = include_str!("../docs/master.md")]
    pub mod master {}
    #[doc = include_str!("../docs/real-board.md")]
    pub mod real_board {}
    #[doc = include_str!("../docs/masters.md")]
    pub mod masters {}
    #[doc = include_str!("../docs/virtual-boards.md")]
    pub mod virtual_boards {}
    #[doc = include_str!("../docs/serial-line.md")]
    pub mod serial_line {}
    #[doc = include_str!("../docs/ascii.md")]
    pub mod ascii {}
    #[doc = include_str!("../docs/recovering.md")]
    pub mod recovering {}
    #[doc = include_str!("../docs/tcp.md")]
    pub mod tcp {}
}

/// The protocol engine's parts, for this crate's tests, simulator and benchmarks: not
/// part of the API, and they change without notice.
#[doc(hidden)]
pub mod internal {
    pub use crate::link::crc::{crc16, Crc16};
    pub use crate::link::framer::{FrameError, Framer, UartError, MAX_FRAME, MIN_FRAME};
    pub use crate::link::timing::{BaudDivisor, CharTimes, Deadline, TimerPlan, Uptime};
    pub use crate::slave::engine::{EndOfFrame, Engine};
    pub use crate::slave::model::Access;
    pub use crate::slave::pdu::{encode_exception, respond, FunctionCode, Request};

    /// The compile-time register map's parts, for [`crate::register_map!`].
    pub mod map {
        pub use crate::slave::device::Device;
        pub use crate::slave::map::{Layout, Span};
        pub use crate::slave::storage::Values;
        pub use crate::slave::words::Place;
    }
    /// FC 43 / MEI 14: what [`crate::identification!`] expands to.
    pub mod device_id {
        pub use crate::slave::pdu::device_id::*;
    }
    /// The PDU engine.
    pub mod pdu {
        pub use crate::slave::pdu::*;
    }
    /// Character times and the USART and Timer0 arithmetic.
    pub mod timing {
        pub use crate::link::timing::*;
    }
    /// ASCII framing: LRC, hex, the reply's characters.
    #[cfg(feature = "ascii")]
    pub mod ascii {
        pub use crate::link::framer::ascii::*;
    }
    /// FC 7, 8, 11 and 17.
    #[cfg(feature = "diagnostics")]
    pub mod diagnostics {
        pub use crate::slave::diagnostics::*;
    }
    /// Modbus TCP's parts: the MBAP header, the server over any chip's sockets, the
    /// WIZnet chips' frames and registers, a request handled against a model.
    #[cfg(feature = "tcp")]
    pub mod tcp {
        /// The MBAP header.
        pub mod mbap {
            pub use crate::tcp::mbap::*;
        }
        /// The client over any chip's sockets (with feature `master`).
        #[cfg(feature = "master")]
        pub use crate::tcp::client::{Client, Connect};
        #[cfg(feature = "master")]
        pub use crate::tcp::gateway::{Gate, Gateway, RtuSide};
        pub use crate::tcp::server::{Answered, Handler, Server, Sockets};
        pub use crate::tcp::wiznet::{command, sn, state, Block, Bus, Chip, Wiznet, RECV, SEND_OK};
        pub use crate::tcp::{respond, Serving};
        /// The addresses' EEPROM record (with feature `eeprom-settings`).
        #[cfg(feature = "eeprom-settings")]
        pub mod record {
            pub use crate::tcp::record::*;
        }
    }
    /// The settings record and block.
    #[cfg(feature = "eeprom-settings")]
    pub mod settings {
        pub use crate::slave::settings::*;
    }
}
