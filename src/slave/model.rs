//! What the PDU engine needs from the application's data, Application Protocol v1.1b3
//! §4.3 (data model) and §6 (function code descriptions).
//!
//! The engine has checked the function code, quantity and byte count before it calls
//! these; an implementation answers [`Exception::IllegalDataAddress`] when any address of
//! the range is missing, [`Exception::ServerDeviceFailure`] when it can't do what was
//! asked, and in either case changes nothing.

use crate::error::Error;
#[cfg(feature = "eeprom-settings")]
use crate::link::config::Config;
use crate::protocol::limits::{MAX_READ_BITS, MAX_READ_REGISTERS, MAX_WRITE_COILS, MAX_WRITE_REGISTERS};
use crate::protocol::reference::{Reference, Table};
use crate::protocol::Exception;
use crate::slave::pdu::device_id::Identification;
use crate::slave::words::Place;

const fn min(a: u32, b: u32) -> u32 {
    if a < b {
        a
    } else {
        b
    }
}

const fn max(a: u32, b: u32) -> u32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The frame buffer ([`DataModel::FRAME`]) of a model whose longest runs of addresses (a
/// request reads or writes inside one) hold `coils`, `inputs` (discrete inputs),
/// `input_registers` and `holding` values: the longest request or reply of a request it
/// accepts, address and CRC included. FC 1 and 2 reply with the longest run of bits, FC 3
/// and 4 with the longest run of registers (up to 2000 bits and 125 registers); FC 15 and
/// 16 write the longest run of coils and holding registers (up to 1968 and 123); and
/// never less than [`ONE_VALUE_FRAME`]. 256 with features `diagnostics`,
/// `extra-fc` and `device-id`, whose requests echo, read and write more, or whose replies
/// run to 253 bytes. [`crate::register_map!`] passes its longest runs, [`crate::Bank`] its
/// capacity.
pub(crate) const fn frame_for(coils: u32, inputs: u32, input_registers: u32, holding: u32) -> usize {
    if cfg!(any(feature = "diagnostics", feature = "extra-fc", feature = "device-id")) {
        return crate::link::framer::MAX_FRAME;
    }
    // Address, function code, byte count, data, CRC.
    let bits_read = min(max(coils, inputs), MAX_READ_BITS as u32);
    let registers_read = min(max(input_registers, holding), MAX_READ_REGISTERS as u32);
    let read = max(5 + bits_read.div_ceil(8), 5 + 2 * registers_read);
    // Address, function code, start, quantity, byte count, data, CRC.
    let coils_written = min(coils, MAX_WRITE_COILS as u32);
    let registers_written = min(holding, MAX_WRITE_REGISTERS as u32);
    let written = max(9 + coils_written.div_ceil(8), 9 + 2 * registers_written);
    max(ONE_VALUE_FRAME as u32, max(read, written)) as usize
}

/// The smallest frame buffer [`frame_for`] gives: FC 16 writing one register, 11 bytes (FC
/// 1–6 take 8, FC 15 writing one coil 10). A request of one value, to any address, then
/// fits, and never takes the framer's path for bytes past the buffer, which costs the
/// receive interrupt about 30 cycles more a byte: a master polling one value at a time
/// keeps every byte of it on the fast path, whatever the map.
pub(crate) const ONE_VALUE_FRAME: usize = 11;
const _: () = assert!(ONE_VALUE_FRAME >= crate::link::framer::MIN_CAPACITY);

pub use crate::slave::words::Access;

/// The application's data as the master sees it.
pub trait DataModel {
    /// Bytes of the frame buffer the slave needs for this model: the longest request it
    /// accepts and the longest reply it sends, address and CRC included (8 to 256; the maps
    /// give 11 or more). Longer requests are still answered as the spec says (the engine
    /// keeps their first bytes; a longer request or reply can only belong to one the model
    /// refuses). 256, the longest RTU frame, unless the model knows better:
    /// [`crate::register_map!`] works it out from its ranges, [`crate::Bank`] from its
    /// capacity. Features `diagnostics`, `extra-fc` and `device-id` need 256.
    const FRAME: usize = crate::link::framer::MAX_FRAME;

    /// True when every request whose addresses all exist fits [`DataModel::FRAME`], as
    /// [`crate::register_map!`] and [`crate::Bank`] work it out: a request too long for
    /// the frame buffer then has a missing address, and gets exception 02 without a lookup.
    /// False, the default, asks [`DataModel::has_range`] (02 for a missing address, else 04).
    #[doc(hidden)]
    const FRAME_HOLDS_ALL: bool = false;

    /// Reads `qty` (≥ 1) bits of `table` (coils or discrete inputs) from `start` into
    /// `out`, packed LSB first, the unused high bits of the last byte zero.
    /// `out.len()` is `qty.div_ceil(8)`.
    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception>;

    /// Reads `out.len() / 2` (≥ 1) registers of `table` (input or holding) from `start`
    /// into `out`, big-endian.
    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception>;

    /// True when all `qty` (≥ 1) addresses of `table` from `start` exist: FC 23 (0x17) checks its
    /// read range with this before it writes anything.
    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool;

    /// Writes `qty` (≥ 1) coils from `start`, packed LSB first in `packed`; all of them or
    /// none.
    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception>;

    /// Writes `values.len() / 2` (≥ 1) holding registers from `start`, big-endian; all of
    /// them or none.
    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception>;

    /// What the engine calls for FC 1–6, 15 (0x0F) and 16 (0x10): moves `qty` (≥ 1) values of
    /// `table` from `start` between the model and `data`, the PDU's data field (packed bits
    /// or big-endian registers, as the methods above take them; for FC 5 the one byte 0xFF
    /// or 0x00). The default calls the method above that does the job; a model keeping its
    /// values in one place does it with one lookup and one copy ([`crate::register_map!`]
    /// and [`crate::Bank`] do), so that the firmware holds one path for the four instead of
    /// four.
    #[doc(hidden)]
    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        match (access, table.is_bits()) {
            (Access::Read, true) => self.read_bits(table, start, qty, data),
            (Access::Read, false) => self.read_registers(table, start, data),
            (Access::Write, true) => self.write_coils(start, qty, data),
            (Access::Write, false) => self.write_registers(start, data),
        }
    }

    /// The value at `reference`, for the application (see [`crate::Bank::get`]); a model
    /// that doesn't offer it answers [`Error::NotFound`].
    fn value(&self, reference: Reference) -> Result<u16, Error> {
        let _ = reference;
        Err(Error::NotFound)
    }

    /// Sets the value at `reference`, for the application (see [`crate::Bank::set`]).
    fn set_value(&mut self, reference: Reference, value: u16) -> Result<(), Error> {
        let _ = (reference, value);
        Err(Error::NotFound)
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]), read from [`DataModel::value`].
    fn get_wide<T: crate::Wide>(&self, first: Reference, order: crate::WordOrder) -> Result<T, Error>
    where
        Self: Sized,
    {
        get_wide(self, first, order)
    }

    /// Sets the two registers from `first` to `value` in `order` with
    /// [`DataModel::set_value`]: both, or neither when one is missing.
    fn set_wide<T: crate::Wide>(&mut self, first: Reference, value: T, order: crate::WordOrder) -> Result<(), Error>
    where
        Self: Sized,
    {
        set_wide(self, first, value, order)
    }

    /// Where the value at `reference` is kept, worked out with interrupts enabled by the
    /// slave's `get`, `set`, `get_wide` and `set_wide`, which then hold them off only for
    /// [`DataModel::load`] or [`DataModel::store`]. No `self`: only a layout fixed when the
    /// firmware is built answers ([`crate::register_map!`]), so nothing the slave's
    /// interrupts change is read meanwhile. [`Place::Ask`], the default: those calls run
    /// [`DataModel::value`] and [`DataModel::set_value`] with interrupts disabled.
    #[doc(hidden)]
    #[inline(always)]
    fn place(reference: Reference) -> Place
    where
        Self: Sized,
    {
        let _ = reference;
        Place::Ask
    }

    /// What is kept at `place`, a [`DataModel::place`] other than [`Place::Ask`] (see
    /// [`crate::internal::map::Values::load`]).
    #[doc(hidden)]
    fn load(&self, place: Place) -> u16 {
        let _ = place;
        0
    }

    /// Writes what [`Place::stored`] gave at `place`, a [`DataModel::place`] other than
    /// [`Place::Ask`] (see [`crate::internal::map::Values::store`]).
    #[doc(hidden)]
    fn store(&mut self, place: Place, stored: u16) {
        let _ = (place, stored);
    }

    /// True for a model that several ports serve at once (`shared_model!`): a port
    /// that runs its requests with interrupts enabled (the TCP server) runs each under
    /// [`DataModel::exclusive`], and every port says who asks with
    /// [`DataModel::serve_from`]. False, the default: a model one port owns, whose code
    /// has none of this.
    #[doc(hidden)]
    const SHARED: bool = false;

    /// Runs `f` on the model with no other port's request in between (interrupts held off,
    /// for a shared model); the default just runs it.
    #[doc(hidden)]
    #[inline(always)]
    fn exclusive<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R
    where
        Self: Sized,
    {
        f(self)
    }

    /// The port and unit id of the requests that follow, until the next call: the writes
    /// a shared model records ([`crate::Write`]). Nothing, the default.
    #[doc(hidden)]
    #[inline(always)]
    fn serve_from(&mut self, by: crate::slave::written::Port, unit: u8) {
        let _ = (by, unit);
    }

    /// How many master writes succeeded so far, wrapping (see
    /// [`crate::Bank::master_writes`]).
    fn master_writes(&self) -> u16 {
        0
    }

    /// The eight application-defined status bits of FC 7 (Read Exception Status).
    fn exception_status(&self) -> u8 {
        0
    }

    /// The device description FC 17 (0x11, Report Server ID) sends after the slave id and the
    /// run indicator (at most 249 bytes are sent).
    fn device_info(&self) -> &[u8] {
        &[]
    }

    /// The objects FC 43 / MEI 14 (Read Device Identification) reports (feature
    /// `device-id`); none: the slave answers exception 01.
    fn identification(&self) -> Option<&Identification> {
        None
    }

    /// Line settings the master wrote, ready to switch to (feature `eeprom-settings`, see
    /// [`crate::slave::settings::Configurable`]), handed over once: the slave asks whenever a reply
    /// has left the wire, and switches then.
    #[cfg(feature = "eeprom-settings")]
    fn take_new_settings(&mut self) -> Option<Config> {
        None
    }
}

/// The pair of registers from `first`: two of one register table, the second at the next
/// address. A coil or discrete input, or a first register at 65535, is
/// [`Error::BadReference`].
pub(crate) fn pair(first: Reference) -> Result<(Reference, Reference), Error> {
    match first.address.checked_add(1) {
        Some(address) if !first.table.is_bits() => Ok((first, Reference { table: first.table, address })),
        _ => Err(Error::BadReference),
    }
}

/// 32-bit values ([`crate::Wide`]) in a model: the value the pair of registers from `first` holds in `model`, read together.
pub(crate) fn get_wide<M: DataModel + ?Sized, T: crate::Wide>(
    model: &M,
    first: Reference,
    order: crate::WordOrder,
) -> Result<T, Error> {
    let (first, second) = pair(first)?;
    Ok(order.join([model.value(first)?, model.value(second)?]))
}

/// Sets the pair of registers from `first` in `model` to `value`: both, or neither when
/// one is missing.
pub(crate) fn set_wide<M: DataModel + ?Sized, T: crate::Wide>(
    model: &mut M,
    first: Reference,
    value: T,
    order: crate::WordOrder,
) -> Result<(), Error> {
    let (first, second) = pair(first)?;
    model.value(second)?;
    let [a, b] = order.split(value);
    model.set_value(first, a)?;
    model.set_value(second, b)
}
