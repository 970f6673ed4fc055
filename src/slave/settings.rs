//! Line settings a master can change and the device keeps across resets, Modbus over
//! Serial Line v1.02 §2.5.1 (baud rate, parity, stop bits) and §2.2 (slave address).
//!
//! Two representations of one [`Config`](crate::Config):
//!
//! * **The settings block**: four holding registers at an address the application
//!   chooses, read and written with FC 03, 06 and 16 (and 22/23 with `extra-fc`):
//!
//!   | offset | register  | values                                         |
//!   |-------:|-----------|------------------------------------------------|
//!   | 0      | slave id  | 1–247                                          |
//!   | 1      | baud/100  | 12–10000 (115200 bps = 1152)                   |
//!   | 2      | parity    | 0 none, 1 odd, 2 even                          |
//!   | 3      | stop bits | 1 or 2                                         |
//!   | 4      | mode      | 0 RTU, 1 ASCII (7 data bits), 2 ASCII with 8 (feature `ascii`) |
//!
//!   A write builds a candidate from the settings with the written registers replaced (so
//!   FC 06 on one register changes just that setting) and checks it as
//!   [`Config::try_new`](crate::Config::try_new) would ([`LineSettings::is_runnable`]): anything the slave can't
//!   run (an unknown code, a rate the USART can't make at the CPU clock) is answered with exception
//!   03 (Illegal Data Value) and changes nothing. A baud register written with the value it already reads keeps the exact rate,
//!   so rates that are not a multiple of 100 survive a write of the whole block.
//!   [`Configurable`] wraps any [`DataModel`](crate::DataModel) with such a block; the slave applies a valid
//!   write only after the reply to it has left the wire (see
//!   [`DataModel::take_new_settings`](crate::DataModel::take_new_settings)).
//!
//! * **The EEPROM record**: [`RECORD_LEN`] bytes with a sequence number and a CRC
//!   ([`encode`], [`decode`]; a format-1 record of earlier firmware is still read,
//!   [`decode_legacy`]), kept in two [`Slots`] so that a reset during a store leaves the
//!   old settings or the new ones, never neither. The AVR layer reads and writes the
//!   slots' bytes. When neither slot holds a valid record, the application starts with its
//!   compiled-in default.
//!
//! One file per job: `block` (the register block and its checks), `configurable` (the data
//! model wrapper that shows the block), `record` (the EEPROM record codec) and `slots`
//! (the two slots the record alternates between).

mod block;
mod configurable;
mod record;
mod slots;

#[cfg(feature = "ascii")]
pub use block::{mode_from_code, MODE};
pub use block::{
    parity_code, parity_from_code, stop_bits_count, stop_bits_from_count, LineSettings, BAUD_100, BLOCK_LEN, PARITY,
    SLAVE_ID, STOP_BITS,
};
pub use configurable::Configurable;
pub use record::{decode, decode_legacy, encode, Record, LEGACY_LEN, LEGACY_MAGIC, MAGIC, RECORD_LEN};
pub use slots::{is_newer, Newest, Slot, Slots, Write, Writes, MAX_WRITES, SLOTS_LEN};
