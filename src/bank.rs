//! A sparse register bank keyed by classic references, Application Protocol v1.1b3 §4.3:
//! the application adds the addresses it uses, in any order, and gets and sets them.
//!
//! # Layout and RAM
//! Values are stored in address order, registers big-endian (2 bytes each) and coils and
//! discrete inputs packed 8 to a byte. Addresses are described by *runs*: maximal ranges of
//! consecutive addresses of one table, 7 bytes each on AVR (table, first and last address,
//! offset of the first value). Adding an address next to a run extends it and joins it to
//! the following run when the gap closes, so 40001–40100 added one by one, in any order,
//! end as one run. Lookups are a binary search over the runs, O(log runs); a range the
//! master asks for is valid exactly when it lies inside one run.
//!
//! Capacity is fixed by three const parameters: `RUNS` runs, `REGS` registers (input and
//! holding together) and `BIT_BYTES` bytes of bits (coils and discrete inputs together;
//! [`bit_bytes`] converts a count of bits). Adding past capacity, a duplicate or a bad
//! reference is an error that changes nothing.

use crate::error::Error;
use crate::model::{Access, DataModel};
#[cfg(feature = "device-id")]
use crate::pdu::device_id::Identification;
use crate::pdu::Exception;
use crate::reference::{IntoReference, Reference, Table};
use crate::storage;

/// Bytes needed for `bits` coils and discrete inputs: use as `Bank<R, W, { bit_bytes(32) }>`.
pub const fn bit_bytes(bits: usize) -> usize {
    bits.div_ceil(8)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    table: Table,
    start: u16,
    last: u16,
    /// Index of the value of `start` in the register or bit storage.
    offset: u16,
}

impl Run {
    const EMPTY: Run = Run { table: Table::Coils, start: 0, last: 0, offset: 0 };

    fn len(&self) -> usize {
        usize::from(self.last - self.start) + 1
    }

    fn key(&self) -> (Table, u16) {
        (self.table, self.start)
    }
}

/// A range of coils or holding registers the master may read but not write.
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
/// feature `write-protect`).
///
/// ```
/// use avr_modbus_slave::{Bank, bit_bytes};
/// let mut bank: Bank<4, 8, { bit_bytes(16) }> = Bank::new();
/// bank.add(40001).unwrap();
/// bank.add_range(30001, 3).unwrap();
/// bank.set(40001, 1500).unwrap();
/// assert_eq!(bank.get(40001), Ok(1500));
/// assert_eq!(bank.get(30002), Ok(0));
/// ```
#[derive(Clone, Debug)]
pub struct Bank<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize = 0> {
    runs: [Run; RUNS],
    run_count: usize,
    registers: [storage::Word; REGS],
    register_count: usize,
    bits: [u8; BIT_BYTES],
    bit_count: usize,
    master_writes: u16,
    #[cfg(feature = "write-protect")]
    protected: [Protected; PROTECTED],
    #[cfg(feature = "write-protect")]
    protected_count: usize,
    #[cfg(feature = "diagnostics")]
    exception_status: u8,
    #[cfg(feature = "diagnostics")]
    device_info: &'static [u8],
    #[cfg(feature = "device-id")]
    identification: Option<&'static Identification>,
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize> Default
    for Bank<RUNS, REGS, BIT_BYTES, PROTECTED>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize>
    Bank<RUNS, REGS, BIT_BYTES, PROTECTED>
{
    /// An empty bank.
    pub const fn new() -> Self {
        Bank {
            runs: [Run::EMPTY; RUNS],
            run_count: 0,
            registers: [[0; 2]; REGS],
            register_count: 0,
            bits: [0; BIT_BYTES],
            bit_count: 0,
            master_writes: 0,
            #[cfg(feature = "write-protect")]
            protected: [Protected::EMPTY; PROTECTED],
            #[cfg(feature = "write-protect")]
            protected_count: 0,
            #[cfg(feature = "diagnostics")]
            exception_status: 0,
            #[cfg(feature = "diagnostics")]
            device_info: &[],
            #[cfg(feature = "device-id")]
            identification: None,
        }
    }

    /// Adds one address; its value reads 0 until set.
    pub fn add(&mut self, reference: impl IntoReference) -> Result<(), Error> {
        self.add_range(reference, 1)
    }

    /// Adds `count` consecutive addresses from `first`: all of them, or none on error.
    pub fn add_range(&mut self, first: impl IntoReference, count: u16) -> Result<(), Error> {
        let first = first.into_reference()?;
        let (table, start) = (first.table, first.address);
        let last = match count.checked_sub(1).and_then(|n| start.checked_add(n)) {
            Some(last) => last,
            None => return Err(Error::BadRange),
        };
        // The run the new range would follow, and the one it would precede.
        let runs = self.used();
        let at = runs.partition_point(|r| r.key() < (table, start));
        let before = at.checked_sub(1).and_then(|i| runs.get(i)).copied().filter(|r| r.table == table);
        let after = runs.get(at).copied().filter(|r| r.table == table);
        if before.is_some_and(|r| r.last >= start) || after.is_some_and(|r| r.start <= last) {
            return Err(Error::Duplicate);
        }
        let joins_before = before.filter(|r| r.last.checked_add(1) == Some(start));
        let joins_after = after.filter(|r| last.checked_add(1) == Some(r.start));
        let n = usize::from(count);
        if table.is_bits() {
            if self.bit_count + n > BIT_BYTES * 8 {
                return Err(Error::BitsFull);
            }
        } else if self.register_count + n > REGS {
            return Err(Error::RegistersFull);
        }
        if joins_before.is_none() && joins_after.is_none() && self.run_count == RUNS {
            return Err(Error::RunsFull);
        }

        // Storage position: right after the values of the same kind that sort before.
        let position = runs
            .get(..at)
            .unwrap_or(&[])
            .iter()
            .rev()
            .find(|r| r.table.is_bits() == table.is_bits())
            .map_or(0, |r| usize::from(r.offset) + r.len());
        self.open_storage(table.is_bits(), position, n);
        for run in self.runs.iter_mut().take(self.run_count).skip(at) {
            if run.table.is_bits() == table.is_bits() {
                run.offset += count;
            }
        }

        match (joins_before, joins_after) {
            (Some(b), Some(a)) => {
                self.replace_run(at - 1, Run { last: a.last, ..b });
                self.remove_run(at);
            }
            (Some(b), None) => self.replace_run(at - 1, Run { last, ..b }),
            (None, Some(a)) => self.replace_run(at, Run { start, offset: position as u16, ..a }),
            (None, None) => self.insert_run(at, Run { table, start, last, offset: position as u16 }),
        }
        Ok(())
    }

    /// The runs in use.
    fn used(&self) -> &[Run] {
        self.runs.get(..self.run_count).unwrap_or(&[])
    }

    fn replace_run(&mut self, at: usize, run: Run) {
        if let Some(slot) = self.runs.get_mut(at) {
            *slot = run;
        }
    }

    fn insert_run(&mut self, at: usize, run: Run) {
        for i in (at..self.run_count).rev() {
            if let Some(&moved) = self.runs.get(i) {
                self.replace_run(i + 1, moved);
            }
        }
        self.replace_run(at, run);
        self.run_count += 1;
    }

    fn remove_run(&mut self, at: usize) {
        for i in at + 1..self.run_count {
            if let Some(&moved) = self.runs.get(i) {
                self.replace_run(i - 1, moved);
            }
        }
        self.run_count -= 1;
    }

    /// Makes room for `n` zeroed values at `position` of the register or bit storage.
    fn open_storage(&mut self, bits: bool, position: usize, n: usize) {
        if bits {
            for i in (position..self.bit_count).rev() {
                let v = self.bit(i);
                self.set_bit(i + n, v);
            }
            for i in position..position + n {
                self.set_bit(i, false);
            }
            self.bit_count += n;
        } else {
            for i in (position..self.register_count).rev() {
                let v = self.registers.get(i).copied().unwrap_or_default();
                if let Some(slot) = self.registers.get_mut(i + n) {
                    *slot = v;
                }
            }
            for slot in self.registers.iter_mut().skip(position).take(n) {
                *slot = [0; 2];
            }
            self.register_count += n;
        }
    }

    fn bit(&self, i: usize) -> bool {
        storage::bit(&self.bits, i)
    }

    fn set_bit(&mut self, i: usize, on: bool) {
        storage::set_bit(&mut self.bits, i, on);
    }

    /// Storage index of `start` when `start..start + qty` all exist (in one run).
    fn locate(&self, table: Table, start: u16, qty: u16) -> Option<usize> {
        let last = start.checked_add(qty.checked_sub(1)?)?;
        let runs = self.used();
        let i = runs.partition_point(|r| r.key() <= (table, start)).checked_sub(1)?;
        let run = *runs.get(i)?;
        (run.table == table && last <= run.last).then(|| usize::from(run.offset) + usize::from(start - run.start))
    }

    /// True if the address was added.
    pub fn contains(&self, reference: impl IntoReference) -> bool {
        reference.into_reference().is_ok_and(|r| self.locate(r.table, r.address, 1).is_some())
    }

    /// The value: a register's word, or 0/1 for a coil or discrete input.
    pub fn get(&self, reference: impl IntoReference) -> Result<u16, Error> {
        let Reference { table, address } = reference.into_reference()?;
        let i = self.locate(table, address, 1).ok_or(Error::NotFound)?;
        Ok(if table.is_bits() { u16::from(self.bit(i)) } else { storage::word(&self.registers, i) })
    }

    /// Sets the value: a register's word, or for a coil or discrete input on when non-zero.
    pub fn set(&mut self, reference: impl IntoReference, value: u16) -> Result<(), Error> {
        let Reference { table, address } = reference.into_reference()?;
        let i = self.locate(table, address, 1).ok_or(Error::NotFound)?;
        if table.is_bits() {
            self.set_bit(i, value != 0);
        } else {
            storage::set_word(&mut self.registers, i, value);
        }
        Ok(())
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

    /// How many write requests from the master have succeeded (wrapping): compare with
    /// an earlier reading to learn cheaply whether coils or holding registers changed.
    pub fn master_writes(&self) -> u16 {
        self.master_writes
    }

    /// Sets the eight status bits FC 7 (Read Exception Status) reports.
    #[cfg(feature = "diagnostics")]
    pub fn set_exception_status(&mut self, bits: u8) {
        self.exception_status = bits;
    }

    /// Sets the device description FC 17 (0x11, Report Server ID) reports.
    #[cfg(feature = "diagnostics")]
    pub fn set_device_info(&mut self, info: &'static [u8]) {
        self.device_info = info;
    }

    /// Sets the objects FC 43 / MEI 14 (Read Device Identification) reports: see
    /// [`crate::identification!`].
    #[cfg(feature = "device-id")]
    pub fn set_identification(&mut self, identification: &'static Identification) {
        self.identification = Some(identification);
    }

    /// Contiguous runs in use (at most `RUNS`).
    pub fn runs(&self) -> usize {
        self.run_count
    }
}

impl<const RUNS: usize, const REGS: usize, const BIT_BYTES: usize, const PROTECTED: usize> DataModel
    for Bank<RUNS, REGS, BIT_BYTES, PROTECTED>
{
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
        self.master_writes
    }

    #[cfg(feature = "diagnostics")]
    fn exception_status(&self) -> u8 {
        self.exception_status
    }

    #[cfg(feature = "diagnostics")]
    fn device_info(&self) -> &[u8] {
        self.device_info
    }

    #[cfg(feature = "device-id")]
    fn identification(&self) -> Option<&Identification> {
        self.identification
    }

    fn transfer(
        &mut self,
        access: Access,
        table: Table,
        start: u16,
        qty: u16,
        data: &mut [u8],
    ) -> Result<(), Exception> {
        let first = self.locate(table, start, qty).ok_or(Exception::IllegalDataAddress)?;
        if access == Access::Write {
            if self.is_protected(table, start, qty) {
                return Err(Exception::IllegalDataAddress);
            }
            self.master_writes = self.master_writes.wrapping_add(1);
        }
        if table.is_bits() {
            storage::transfer_bits(&mut self.bits, first, qty, data, access);
        } else {
            storage::transfer_words(&mut self.registers, first, data, access);
        }
        Ok(())
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        let first = self.locate(table, start, qty).ok_or(Exception::IllegalDataAddress)?;
        storage::read_bits(&self.bits, first, qty, out);
        Ok(())
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        let qty = u16::try_from(out.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        let first = self.locate(table, start, qty).ok_or(Exception::IllegalDataAddress)?;
        storage::read_words(&self.registers, first, out);
        Ok(())
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        let first = self.locate(Table::Coils, start, qty).ok_or(Exception::IllegalDataAddress)?;
        if self.is_protected(Table::Coils, start, qty) {
            return Err(Exception::IllegalDataAddress);
        }
        storage::write_bits(&mut self.bits, first, qty, packed);
        self.master_writes = self.master_writes.wrapping_add(1);
        Ok(())
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        let qty = u16::try_from(values.len() / 2).map_err(|_| Exception::IllegalDataValue)?;
        let first = self.locate(Table::HoldingRegisters, start, qty).ok_or(Exception::IllegalDataAddress)?;
        if self.is_protected(Table::HoldingRegisters, start, qty) {
            return Err(Exception::IllegalDataAddress);
        }
        storage::write_words(&mut self.registers, first, values);
        self.master_writes = self.master_writes.wrapping_add(1);
        Ok(())
    }
}
