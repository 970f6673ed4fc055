//! The Modbus master (client), Modbus over Serial Line v1.02 §2.4.1 and Application
//! Protocol v1.1b3 §6: requests checked and built, replies checked and read, the master's
//! states over the same link layer as the slave (framer, CRC, silences).
//!
//! On the AVR, `Master` (with `master!`) runs it from interrupts: the application starts a
//! [`Request`] and goes on; the outcome, a [`Reply`] or a [`Failure`], waits for it.

mod engine;
pub(crate) mod reply;
pub(crate) mod request;

pub use engine::{Failure, MasterCounters, Timeouts};
pub use reply::Reply;
pub use request::Request;

/// The master's parts for this crate's tests, simulator and fuzzing: not part of the API.
#[doc(hidden)]
pub mod internal {
    pub use super::engine::{Action, Engine};
    pub use super::request::Shape;
}
