//! A sparse register bank keyed by classic references, Application Protocol v1.1b3 §4.3:
//! the application adds the addresses it uses, in any order, and gets and sets them.
//!
//! # Layout and RAM
//! Values are stored as [`crate::register_map!`] stores them ([`Values`]), in address
//! order: registers big-endian (2 bytes each), coils and discrete inputs packed 8 to a byte.
//! Addresses are described by *runs*: maximal ranges of consecutive addresses of one table,
//! 5 bytes each on AVR (table, first and last address), in no particular order. Adding an
//! address next to a run extends it and joins it to the following run when the gap closes,
//! so 40001–40100 added one by one, in any order, end as one run. A lookup walks the runs,
//! counts the values of those below the address and finds the one that holds it; a range
//! the master asks for is valid exactly when it lies inside one run. Beside the runs,
//! 12 bytes: their count and, for each kind of value (bits; registers), how many are in use
//! and the highest address.
//!
//! # Adding
//! A range above every address of its kind, as a firmware adds its map in address order,
//! is a new run at the end and its values go after all others of its kind: a few compares
//! and stores, made where [`Bank::add_range`] is called. Constant references added to a new
//! bank one call after another (`examples/sixteen_each_bank.rs`) are worked out while the
//! firmware compiles, as `register_map!`'s are: what is left is the stores of the runs.
//! Any other range goes to [`Bank::insert`]: one walk over the runs that checks it, then
//! one move of the values above it ([`Values::open`]), nothing per address.
//!
//! Capacity is fixed by three const parameters: `RUNS` runs, `REGS` registers (input and
//! holding together) and `BIT_BYTES` bytes of bits (coils and discrete inputs together;
//! [`bit_bytes`] converts a count of bits). Adding past capacity, a duplicate or a bad
//! reference is an error that changes nothing. No run can be longer than the capacity, so
//! the slave's frame buffer is sized from it ([`DataModel::FRAME`]), as `register_map!`
//! sizes its own from its ranges.

use crate::error::Error;
use crate::protocol::reference::{IntoReference, Reference, Table};
use crate::slave::model::{frame_for, Access, DataModel};
#[cfg(feature = "device-id")]
use crate::slave::pdu::device_id::Identification;
use crate::slave::pdu::Exception;
use crate::slave::storage::Values;

/// Bytes needed for `bits` coils and discrete inputs: use as `Bank<R, W, { bit_bytes(32) }>`.
pub const fn bit_bytes(bits: usize) -> usize {
    bits.div_ceil(8)
}

/// A maximal range of consecutive addresses of one table, `start..=last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    table: Table,
    start: u16,
    last: u16,
}

impl Run {
    const EMPTY: Run = Run { table: Table::Coils, start: 0, last: 0 };

    /// How many values the run holds.
    fn len(self) -> usize {
        usize::from(self.last - self.start) + 1
    }

    /// True when the run overlaps `start..=last` of `table` or touches it.
    fn meets(self, table: Table, start: u16, last: u16) -> bool {
        // Saturated, 65535 + 1 compares as 65536 would with any address.
        self.table == table && self.start <= last.saturating_add(1) && start <= self.last.saturating_add(1)
    }
}

/// One kind of value, bits (coils and discrete inputs) or registers (input and holding),
/// as [`Bank::add_range`] needs it: how many are in use and, when some are, the highest
/// address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Kind {
    used: usize,
    /// The table and address of the highest.
    table: Table,
    last: u16,
}

impl Kind {
    const EMPTY: Kind = Kind { used: 0, table: Table::Coils, last: 0 };

    /// True when `start` of `table` (of this kind) lies above every address in use.
    #[inline(always)]
    fn is_below(self, table: Table, start: u16) -> bool {
        self.used == 0 || (self.table as u8) < (table as u8) || (self.table == table && self.last < start)
    }

    /// True when `start` of `table` (of this kind) lies above every address in use, and
    /// not just above the highest: a range from there is a run of its own.
    #[inline(always)]
    fn is_apart_below(self, table: Table, start: u16) -> bool {
        self.used == 0
            || (self.table as u8) < (table as u8)
            || (self.table == table && u32::from(self.last) + 1 < u32::from(start))
    }
}

/// The runs in use and both kinds: what [`Bank::add_range`] reads as one copy and writes
/// field by field. The compiler follows a copy of a new bank's zeros through a row of calls
/// where it may not follow the loads of single fields, and then folds them; written back
/// whole, each call's copy left stores in the firmware that the next call's overwrite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Tally {
    runs: usize,
    /// Bits, then registers.
    kinds: [Kind; 2],
}

/// [`Tally::kinds`]'s index for a table: 0 bits, 1 registers.
#[inline(always)]
fn kind(table: Table) -> usize {
    usize::from(!table.is_bits())
}

/// True when `run` is `table` or the table before it of its kind (coils before discrete
/// inputs, input registers before holding registers): the tables whose runs a lookup in
/// `table` counts. The tables are numbered coils 0, discrete inputs 1, input registers 2,
/// holding registers 3, so `table - run` (wrapping) is then 0, or 1 for the second table of a
/// kind (odd): one subtraction and one compare.
#[inline(always)]
fn is_at_or_below(run: Table, table: Table) -> bool {
    (table as u8).wrapping_sub(run as u8) <= (table as u8 & 1)
}

const _: () = assert!(Table::Coils as u8 == 0 && Table::DiscreteInputs as u8 == 1);
const _: () = assert!(Table::InputRegisters as u8 == 2 && Table::HoldingRegisters as u8 == 3);

/// A range of coils or holding registers the master may read but not write.
/// Holding registers `start..=last` that hold 32-bit values in pairs from `start`
/// ([`Bank::add_pairs`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pairs {
    start: u16,
    last: u16,
}

impl Pairs {
    /// No range: a slot not taken.
    const EMPTY: Pairs = Pairs { start: 1, last: 0 };

    /// True when a write of holding registers `start..=end` would write one register of a
    /// pair and not the other: it starts on a pair's second register or ends on a first.
    fn cut_by(self, start: u32, end: u32) -> bool {
        let (first, last) = (u32::from(self.start), u32::from(self.last));
        let starts_on_a_second = start > first && start <= last && (start - first) % 2 == 1;
        let ends_on_a_first = end >= first && end < last && (end - first) % 2 == 0;
        starts_on_a_second || ends_on_a_first
    }
}

#[cfg(feature = "write-protect")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Protected {
    table: Table,
    start: u16,
    last: u16,
}

#[cfg(feature = "write-protect")]
impl Protected {
    const EMPTY: Protected = Protected { table: Table::Coils, start: 1, last: 0 };

    fn overlaps(&self, table: Table, start: u16, last: u16) -> bool {
        self.table == table && self.start <= last && start <= self.last
    }
}

/// The sparse bank: see the module documentation for capacity and RAM. The optional
/// fourth parameter is how many read-only ranges `Bank::protect` can hold (5 bytes each;
/// feature `write-protect`), the fifth how many ranges of holding-register pairs
/// [`Bank::add_pairs`] can hold (4 bytes each).
///
/// ```
/// use avr_modbus::{Bank, bit_bytes};
/// let mut bank: Bank<4, 8, { bit_bytes(16) }> = Bank::new();
/// bank.add(40001).unwrap();
/// bank.add_range(30001, 3).unwrap();
/// bank.set(40001, 1500).unwrap();
/// assert_eq!(bank.get(40001), Ok(1500));
/// assert_eq!(bank.get(30002), Ok(0));
/// ```
#[derive(Clone, Debug)]
pub struct Bank<
    const RUNS: usize,
    const REGS: usize,
    const BIT_BYTES: usize,
    const PROTECTED: usize = 0,
    const PAIRS: usize = 0,
> {
    runs: [Run; RUNS],
    tally: Tally,
    values: Values<REGS, BIT_BYTES>,
    #[cfg(feature = "write-protect")]
    protected: [Protected; PROTECTED],
    #[cfg(feature = "write-protect")]
    protected_count: usize,
    /// Holding registers declared as pairs ([`Bank::add_pairs`]); none with `PAIRS` 0.
    pairs: [Pairs; PAIRS],
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize, const PAIRS: usize> Default
    for Bank<RUNS, REGS, BIT_BYTES, PROTECTED, PAIRS>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize, const PAIRS: usize>
    Bank<RUNS, REGS, BIT_BYTES, PROTECTED, PAIRS>
{
    /// An empty bank.
    pub const fn new() -> Self {
        Bank {
            runs: [Run::EMPTY; RUNS],
            tally: Tally { runs: 0, kinds: [Kind::EMPTY, Kind::EMPTY] },
            values: Values::new(),
            #[cfg(feature = "write-protect")]
            protected: [Protected::EMPTY; PROTECTED],
            #[cfg(feature = "write-protect")]
            protected_count: 0,
            pairs: [Pairs::EMPTY; PAIRS],
        }
    }

    /// Adds one address; its value reads 0 until set.
    pub fn add(&mut self, reference: impl IntoReference) -> Result<(), Error> {
        self.add_range(reference, 1)
    }

    /// Adds `count` consecutive addresses from `first`: all of them, or none on error.
    ///
    /// Inlined: a range above every address of its kind in use and not next to the highest
    /// (a map added in address order) is a new run made here with a few compares and
    /// stores, which constant references on a new bank fold away; any other range is one
    /// call, which moves the values above it at once.
    #[inline(always)]
    pub fn add_range(&mut self, first: impl IntoReference, count: u16) -> Result<(), Error> {
        let Reference { table, address: start } = first.into_reference()?;
        let last = count.checked_sub(1).and_then(|n| start.checked_add(n)).ok_or(Error::BadRange)?;
        let k = kind(table);
        let tally = self.tally;
        let top = tally.kinds[k];
        if !top.is_apart_below(table, start) {
            return self.insert(table, start, last);
        }
        let used = top.used + usize::from(count);
        if used > self.capacity(table) {
            return Err(full(table));
        }
        let slot = self.runs.get_mut(tally.runs).ok_or(Error::RunsFull)?;
        *slot = Run { table, start, last };
        self.tally.runs = tally.runs + 1;
        self.tally.kinds[k] = Kind { used, table, last };
        Ok(())
    }

    /// How many values of `table`'s kind the bank holds.
    #[inline(always)]
    fn capacity(&self, table: Table) -> usize {
        if table.is_bits() {
            BIT_BYTES * 8
        } else {
            REGS
        }
    }

    /// [`Bank::add_range`] of `start..=last` of `table` below or next to the highest
    /// address of its kind in use: one walk over the runs checks it before anything
    /// changes; then the values of its kind above it move up at once, and it joins the runs
    /// it touches or takes a new one.
    #[inline(never)]
    fn insert(&mut self, table: Table, start: u16, last: u16) -> Result<(), Error> {
        let k = kind(table);
        // The values of its kind below it (where its own go), the runs of its table it
        // meets (touches or overlaps) and the run they make with it.
        let (mut rank, mut meets, mut joined) = (0, 0, Run { table, start, last });
        for run in self.runs.iter().take(self.tally.runs) {
            if kind(run.table) != k {
                continue;
            }
            if (run.table as u8) < (table as u8) || (run.table == table && run.last < start) {
                rank += run.len();
            }
            if run.meets(table, start, last) {
                if run.start <= last && start <= run.last {
                    return Err(Error::Duplicate);
                }
                meets += 1;
                joined.start = joined.start.min(run.start);
                joined.last = joined.last.max(run.last);
            }
        }
        let used = self.tally.kinds[k].used;
        let count = usize::from(last - start) + 1;
        if used + count > self.capacity(table) {
            return Err(full(table));
        }
        if self.tally.runs + 1 - meets > RUNS {
            return Err(Error::RunsFull);
        }

        self.values.open(table.is_bits(), rank, used, count);
        let top = &mut self.tally.kinds[k];
        if top.is_below(table, start) {
            (top.table, top.last) = (table, last);
        }
        top.used = used + count;
        // The runs it meets leave, the others close up, and the run they make goes last.
        let mut kept = 0;
        for i in 0..self.tally.runs {
            let run = self.runs.get(i).copied().unwrap_or(Run::EMPTY);
            if !run.meets(table, start, last) {
                if let Some(slot) = self.runs.get_mut(kept) {
                    *slot = run;
                }
                kept += 1;
            }
        }
        if let Some(slot) = self.runs.get_mut(kept) {
            *slot = joined;
        }
        self.tally.runs = kept + 1;
        Ok(())
    }

    /// Storage index of `start` when `start..start + qty` (`qty` ≥ 1) all exist (in one
    /// run): the values of its kind below `start`.
    ///
    /// Not inlined: every request and every `get` and `set` calls this one copy, and its
    /// loop keeps its values in registers, which it did not inside the engine's `process`.
    /// The runs in use are walked as a slice of at most `RUNS`, so that one count ends the
    /// loop. At most one run of `table` holds `start`: runs of one table never overlap.
    #[inline(never)]
    fn locate(&self, table: Table, start: u16, qty: u16) -> Option<usize> {
        let (mut rank, mut at) = (0, None);
        let mut rest = self.runs.get(..self.tally.runs.min(RUNS)).unwrap_or(&[]);
        while let [run, tail @ ..] = rest {
            rest = tail;
            if !is_at_or_below(run.table, table) {
                continue;
            }
            if run.table != table || run.last < start {
                // Below `start`: a run of the table before it, or of its table ending
                // before `start`.
                rank += run.len();
            } else if run.start <= start {
                // The run holds `start`: the range exists when it ends in the run too.
                at = (qty.wrapping_sub(1) <= run.last - start).then_some(start - run.start);
            }
        }
        at.map(|i| rank + usize::from(i))
    }

    /// True if the address was added.
    pub fn contains(&self, reference: impl IntoReference) -> bool {
        reference.into_reference().is_ok_and(|r| self.locate(r.table, r.address, 1).is_some())
    }

    /// The value: a register's word, or 0/1 for a coil or discrete input.
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let Reference { table, address } = reference.into_reference()?;
        self.values.get(table, self.locate(table, address, 1))
    }

    /// Sets the value: a register's word, or for a coil or discrete input on when non-zero.
    pub fn set(&mut self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let Reference { table, address } = reference.into_reference()?;
        let at = self.locate(table, address, 1);
        self.values.set(table, at, value)
    }

    /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order` (see
    /// [`crate::WordOrder`]): `bank.get_wide::<f32>(40010, WordOrder::HighFirst)`.
    pub fn get_wide<T: crate::Wide>(&self, first: impl IntoReference, order: crate::WordOrder) -> Result<T, Error> {
        crate::slave::model::get_wide(self, first.into_reference()?, order)
    }

    /// Sets the two registers from `first` to `value` in `order`: both, or neither when one
    /// is missing.
    pub fn set_wide<T: crate::Wide>(
        &mut self,
        first: impl IntoReference,
        value: T,
        order: crate::WordOrder,
    ) -> Result<(), Error> {
        crate::slave::model::set_wide(self, first.into_reference()?, value, order)
    }

    #[cfg(feature = "write-protect")]
    /// Makes `count` coils or holding registers from `first` read-only to the master: a
    /// write touching any of them is answered with exception 02 (Illegal Data Address: the
    /// spec's answer for an address the server does not allow for this request) and changes
    /// nothing. The application still sets them with [`Bank::set`]. The addresses need not
    /// exist yet.
    pub fn protect(&mut self, first: impl IntoReference, count: u16) -> Result<(), Error> {
        let first = first.into_reference()?;
        if !matches!(first.table, Table::Coils | Table::HoldingRegisters) {
            return Err(Error::BadReference);
        }
        let last = count.checked_sub(1).and_then(|n| first.address.checked_add(n)).ok_or(Error::BadRange)?;
        let slot = self.protected.get_mut(self.protected_count).ok_or(Error::ProtectionsFull)?;
        *slot = Protected { table: first.table, start: first.address, last };
        self.protected_count += 1;
        Ok(())
    }

    /// True when a master write of `qty` addresses of `table` from `start` touches a
    /// read-only range.
    #[cfg(feature = "write-protect")]
    fn is_protected(&self, table: Table, start: u16, qty: u16) -> bool {
        let last = start.saturating_add(qty.saturating_sub(1));
        self.protected.iter().take(self.protected_count).any(|p| p.overlaps(table, start, last))
    }

    #[cfg(not(feature = "write-protect"))]
    fn is_protected(&self, _: Table, _: u16, _: u16) -> bool {
        false
    }

    /// Storage index of a master write's first value, or exception 02 when an address is
    /// missing or read-only.
    fn writable(&self, table: Table, start: u16, qty: u16) -> Option<usize> {
        self.locate(table, start, qty)
            .filter(|_| !self.is_protected(table, start, qty) && !self.cuts_pair(table, start, qty))
    }

    /// True when a master write of `qty` registers of `table` from `start` would write one
    /// register of a pair ([`Bank::add_pairs`]) and not the other. Never with `PAIRS` 0.
    fn cuts_pair(&self, table: Table, start: u16, qty: u16) -> bool {
        let end = u32::from(start) + u32::from(qty) - 1;
        PAIRS != 0 && table == Table::HoldingRegisters && self.pairs.iter().any(|p| p.cut_by(u32::from(start), end))
    }

    /// Adds `count` pairs of registers from `first` (2 × `count` input or holding
    /// registers, as [`Bank::add_range`] does) for 32-bit values, read and written with
    /// [`Bank::get_wide`] and [`Bank::set_wide`]. A master's write of holding registers that
    /// would change one register of a pair and not the other gets exception 02 and changes
    /// nothing (see the README's "32-bit values"); the bank keeps the range in one of its
    /// `PAIRS` slots ([`Error::PairsFull`] when none is left; input registers, which no
    /// master writes, take none).
    pub fn add_pairs(&mut self, first: impl IntoReference, count: u16) -> Result<(), Error> {
        let first = first.into_reference()?;
        if first.table.is_bits() {
            return Err(Error::BadReference);
        }
        let registers = count.checked_mul(2).ok_or(Error::BadRange)?;
        let holding = first.table == Table::HoldingRegisters;
        let slot = self.pairs.iter().position(|p| *p == Pairs::EMPTY);
        if holding && slot.is_none() {
            return Err(Error::PairsFull);
        }
        self.add_range(first, registers)?;
        if let (true, Some(slot)) = (holding, slot.and_then(|i| self.pairs.get_mut(i))) {
            *slot = Pairs { start: first.address, last: first.address + (registers - 1) };
        }
        Ok(())
    }

    /// How many write requests from the master have succeeded (wrapping): compare with
    /// an earlier reading to learn cheaply whether coils or holding registers changed.
    pub fn master_writes(&self) -> u16 {
        self.values.master_writes()
    }

    /// Sets the eight status bits FC 7 (Read Exception Status) reports.
    #[cfg(feature = "diagnostics")]
    pub fn set_exception_status(&mut self, bits: u8) {
        self.values.device_mut().set_exception_status(bits);
    }

    /// Sets the device description FC 17 (0x11, Report Server ID) reports.
    #[cfg(feature = "diagnostics")]
    pub fn set_device_info(&mut self, info: &'static [u8]) {
        self.values.device_mut().set_device_info(info);
    }

    /// Sets the objects FC 43 / MEI 14 (Read Device Identification) reports: see
    /// [`crate::identification!`].
    #[cfg(feature = "device-id")]
    pub fn set_identification(&mut self, identification: &'static Identification) {
        self.values.device_mut().set_identification(identification);
    }

    /// Contiguous runs in use (at most `RUNS`).
    pub fn runs(&self) -> usize {
        self.tally.runs
    }
}

/// The error for no room for more values of `table`'s kind.
fn full(table: Table) -> Error {
    if table.is_bits() {
        Error::BitsFull
    } else {
        Error::RegistersFull
    }
}

/// The longest runs of bits and of registers a bank of `bit_bytes` bytes of bits and `regs`
/// registers holds, for [`frame_for`]: past 2000 bits and 125 registers, every request's
/// limit, the count matters no more (and is kept from overflowing).
const fn longest_runs(bit_bytes: usize, regs: usize) -> (u32, u32) {
    let bits = if bit_bytes < 0x1000 { bit_bytes as u32 * 8 } else { 0x8000 };
    let registers = if regs < 0x1000 { regs as u32 } else { 0x1000 };
    (bits, registers)
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize, const PAIRS: usize> DataModel
    for Bank<RUNS, REGS, BIT_BYTES, PROTECTED, PAIRS>
{
    /// Sized from the capacity: no run holds more than `BIT_BYTES × 8` bits or `REGS`
    /// registers.
    const FRAME: usize = {
        let (bits, registers) = longest_runs(BIT_BYTES, REGS);
        frame_for(bits, bits, registers, registers)
    };
    const FRAME_HOLDS_ALL: bool = true;

    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        self.locate(table, start, qty).is_some()
    }

    fn value(&self, reference: Reference) -> Result<u16, Error> {
        self.get(reference)
    }

    fn set_value(&mut self, reference: Reference, value: u16) -> Result<(), Error> {
        self.set(reference, value)
    }

    fn master_writes(&self) -> u16 {
        self.values.master_writes()
    }

    fn exception_status(&self) -> u8 {
        self.values.device().exception_status()
    }

    fn device_info(&self) -> &[u8] {
        self.values.device().device_info()
    }

    #[cfg(feature = "device-id")]
    fn identification(&self) -> Option<&Identification> {
        self.values.device().identification()
    }

    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        let at = match access {
            Access::Read => self.locate(table, start, qty),
            Access::Write => self.writable(table, start, qty),
        };
        self.values.transfer(access, table, at, qty, data)
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.values.read_bits(self.locate(table, start, qty), qty, out)
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        let qty = u16::try_from(out.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        self.values.read_words(self.locate(table, start, qty), out)
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        let at = self.writable(Table::Coils, start, qty);
        self.values.write_bits(at, qty, packed)
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        let qty = u16::try_from(values.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        let at = self.writable(Table::HoldingRegisters, start, qty);
        self.values.write_words(at, values)
    }
}

#[cfg(test)]
mod tests {
    use super::{is_at_or_below, longest_runs};
    use crate::protocol::reference::Table::*;

    #[test]
    fn a_lookup_counts_the_runs_of_its_table_and_of_the_table_before_it_of_its_kind() {
        let tables = [Coils, DiscreteInputs, InputRegisters, HoldingRegisters];
        let below = [(Coils, DiscreteInputs), (InputRegisters, HoldingRegisters)];
        for run in tables {
            for table in tables {
                let counted = run == table || below.contains(&(run, table));
                assert_eq!(is_at_or_below(run, table), counted, "a run of {run:?} for {table:?}");
            }
        }
    }

    #[test]
    fn a_bank_s_longest_runs_are_its_capacity_up_to_past_every_request_s_limit() {
        assert_eq!(longest_runs(2, 3), (16, 3));
        assert_eq!(longest_runs(0x0FFF, 0x0FFF), (0x7FF8, 0x0FFF));
        assert_eq!(longest_runs(0x1000, 0x1000), (0x8000, 0x1000));
        assert_eq!(longest_runs(usize::MAX, usize::MAX), (0x8000, 0x1000));
    }
}
