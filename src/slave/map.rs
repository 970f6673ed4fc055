//! A register map fixed when the firmware is built, Application Protocol v1.1b3 §4.3: the
//! ranges of classic references a firmware serves, declared with [`crate::register_map!`].
//!
//! The ranges are checked while the firmware compiles (a bad reference, an empty range or
//! two ranges that overlap fail the build) and cost no RAM: only the values do, registers
//! as two bytes each and coils and discrete inputs packed 8 to a byte. A lookup is a chain of
//! compares against constants, one per declared range; by a constant reference
//! (`SLAVE.set(30001, x)`) it folds to an index. Ranges of one table that touch
//! (40001–40004 and 40005–40008) are stored side by side, so the master reads across them
//! as across one range.

use crate::protocol::reference::{Reference, Table};

/// One declared range, as the lookup needs it.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    table: Table,
    start: u16,
    last: u16,
    /// The last address of the ranges of the same table that follow this one without a
    /// gap: a request from inside this range may run up to here.
    reach: u16,
    /// Index of the value of `start` in the register or bit storage.
    offset: u16,
}

/// A classic reference range `first..=last` as (table, first address, last address);
/// panics (a build error, since it only runs in `const` items) when it is not one.
const fn decode(range: (u32, u32)) -> (Table, u16, u16) {
    let (first, last) = match (Reference::classic(range.0), Reference::classic(range.1)) {
        (Ok(first), Ok(last)) => (first, last),
        _ => panic!("register_map!: not a classic reference (00001, 10001, 30001, 40001 ...)"),
    };
    if first.table as u8 != last.table as u8 || first.address > last.address {
        panic!("register_map!: a range runs from its first reference up to its last, in one table");
    }
    (first.table, first.address, last.address)
}

/// True when `a` is stored before `b`: registers and bits are two storages, each in table
/// and then address order.
const fn sorts_before(a: (Table, u16), b: (Table, u16)) -> bool {
    (a.0 as u8) < (b.0 as u8) || ((a.0 as u8) == (b.0 as u8) && a.1 < b.1)
}

/// The register map's layout, worked out while the firmware compiles.
#[doc(hidden)]
pub struct Layout;

impl Layout {
    /// Checks `ranges` (each `(first, last)` in classic references): every reference valid,
    /// no two ranges overlapping. Panics otherwise, which in a `const` is a build error.
    pub const fn check(ranges: &[(u32, u32)]) {
        let mut i = 0;
        while i < ranges.len() {
            let (table, start, last) = decode(ranges[i]);
            let mut j = i + 1;
            while j < ranges.len() {
                let (other, other_start, other_last) = decode(ranges[j]);
                if table as u8 == other as u8 && start <= other_last && other_start <= last {
                    panic!("register_map!: two ranges overlap");
                }
                j += 1;
            }
            i += 1;
        }
    }

    /// Registers (input and holding together) the ranges hold.
    pub const fn words(ranges: &[(u32, u32)]) -> usize {
        Self::count(ranges, false)
    }

    /// Bytes of coils and discrete inputs (together) the ranges hold.
    pub const fn bit_bytes(ranges: &[(u32, u32)]) -> usize {
        Self::count(ranges, true).div_ceil(8)
    }

    const fn count(ranges: &[(u32, u32)], bits: bool) -> usize {
        Self::check(ranges);
        let mut n = 0;
        let mut i = 0;
        while i < ranges.len() {
            let (table, start, last) = decode(ranges[i]);
            if table.is_bits() == bits {
                n += (last - start) as usize + 1;
            }
            i += 1;
        }
        n
    }

    /// The longest run of addresses of `table` a request can cover: ranges that touch
    /// count as one.
    const fn longest_run(ranges: &[(u32, u32)], table: Table) -> u32 {
        let mut longest = 0;
        let mut i = 0;
        while i < ranges.len() {
            let span = Self::span(ranges, ranges[i].0);
            if span.table as u8 == table as u8 {
                let run = (span.reach - span.start) as u32 + 1;
                if run > longest {
                    longest = run;
                }
            }
            i += 1;
        }
        longest
    }

    /// The frame buffer the map needs ([`crate::DataModel::FRAME`]): the longest request
    /// or reply of a request it accepts, address and CRC included, from its longest runs of
    /// addresses of each table (see [`crate::slave::model::frame_for`]).
    pub const fn frame(ranges: &[(u32, u32)]) -> usize {
        crate::slave::model::frame_for(
            Self::longest_run(ranges, Table::Coils),
            Self::longest_run(ranges, Table::DiscreteInputs),
            Self::longest_run(ranges, Table::InputRegisters),
            Self::longest_run(ranges, Table::HoldingRegisters),
        )
    }

    /// The span of the range of `ranges` that starts at classic reference `first`.
    pub const fn span(ranges: &[(u32, u32)], first: u32) -> Span {
        Self::check(ranges);
        let mut at = 0;
        while at < ranges.len() && ranges[at].0 != first {
            at += 1;
        }
        let (table, start, last) = decode(ranges[at]);
        let (mut offset, mut reach) = (0u16, last);
        let mut i = 0;
        while i < ranges.len() {
            let (other, other_start, other_last) = decode(ranges[i]);
            if other.is_bits() == table.is_bits() && sorts_before((other, other_start), (table, start)) {
                offset += other_last - other_start + 1;
            }
            i += 1;
        }
        // Follow the ranges of the same table that continue without a gap.
        let mut extended = true;
        while extended && reach < u16::MAX {
            extended = false;
            let mut k = 0;
            while k < ranges.len() {
                let (other, other_start, other_last) = decode(ranges[k]);
                if other as u8 == table as u8 && other_start == reach + 1 {
                    reach = other_last;
                    extended = true;
                }
                k += 1;
            }
        }
        Span { table, start, last, reach, offset }
    }
}

impl Layout {
    /// The ranges declared as pairs, decoded: (table, first address, last address).
    /// Panics (a build error) unless each is registers, an even number of them.
    pub const fn pairs<const N: usize>(declared: &[Option<(u32, u32)>]) -> [Option<(Table, u16, u16)>; N] {
        let mut out = [None; N];
        let mut i = 0;
        while i < N {
            if let Some(range) = declared[i] {
                let (table, start, last) = decode(range);
                if table.is_bits() {
                    panic!("register_map!: pairs (as u32, i32, f32) are registers, 30001 or 40001 ...");
                }
                if (last - start) % 2 == 0 {
                    panic!("register_map!: a range of pairs (as u32, i32, f32) holds an even number of registers");
                }
                out[i] = Some((table, start, last));
            }
            i += 1;
        }
        out
    }

    /// True when a range is declared as pairs.
    pub const fn any_pair(declared: &[Option<(u32, u32)>]) -> bool {
        let mut i = 0;
        while i < declared.len() {
            if declared[i].is_some() {
                return true;
            }
            i += 1;
        }
        false
    }

    /// True when writing `qty` registers of `table` from `start` would write one register of
    /// a pair and not the other: it starts on a pair's second register or ends on a first.
    #[inline(always)]
    pub fn cuts_pair(pairs: &[Option<(Table, u16, u16)>], table: Table, start: u16, qty: u16) -> bool {
        let (start, end) = (u32::from(start), u32::from(start) + u32::from(qty) - 1);
        pairs.iter().flatten().any(|&(pair_table, first, last)| {
            let (first, last) = (u32::from(first), u32::from(last));
            let starts_on_a_second = start > first && start <= last && (start - first) % 2 == 1;
            let ends_on_a_first = end >= first && end < last && (end - first) % 2 == 0;
            pair_table as u8 == table as u8 && (starts_on_a_second || ends_on_a_first)
        })
    }
}

impl Span {
    /// The storage index of `start` when `start..start + qty` (`qty` ≥ 1) all exist and
    /// `start` lies in this range.
    #[inline(always)]
    pub fn index(self, table: Table, start: u16, qty: u16) -> Option<usize> {
        if table != self.table || start < self.start || start > self.last || qty.wrapping_sub(1) > self.reach - start {
            return None;
        }
        Some(usize::from(self.offset) + usize::from(start - self.start))
    }
}

/// Declares a register map fixed when the firmware is built: a struct holding the values
/// of exactly the classic references listed, each a single reference or a range
/// `first..=last`, in any order. It implements [`crate::DataModel`], so
/// `slave!` takes it, and has `new()` (every value 0), `get`, `set`,
/// `contains`, `master_writes`, and with their features `set_exception_status`,
/// `set_device_info` (`diagnostics`) and `set_identification` (`device-id`), as
/// [`crate::Bank`] does.
///
/// ```
/// avr_modbus::register_map! {
///     /// The contract map: 16 coils, 16 inputs, 8 input and 16 holding registers.
///     pub struct Registers {
///         00001..=00016,
///         10001..=10016,
///         30001..=30008,
///         40001..=40016,
///     }
/// }
/// let mut map = Registers::new();
/// map.set(40001, 1500).unwrap();
/// assert_eq!(map.get(40001), Ok(1500));
/// assert_eq!(map.get(40017), Err(avr_modbus::Error::NotFound));
/// # #[cfg(not(any(feature = "diagnostics", feature = "device-id")))] // they keep FC 7, 17, 43 data too
/// assert_eq!(core::mem::size_of::<Registers>(), 2 * 24 + 4 + 2);
/// ```
///
/// A range of registers may be declared as pairs holding 32-bit values, `as u32`, `as i32`
/// or `as f32` (`40011..=40014 as f32`: two floats): the application reads and writes each
/// with `get_wide` and `set_wide` (in either [`crate::WordOrder`]), and a master's write that
/// would change one register of a pair and not the other gets exception 02, so that a pair
/// is never half old, half new. Reads of one register of a pair are answered.
///
/// ```
/// use avr_modbus::WordOrder;
/// avr_modbus::register_map! {
///     struct Meter { 40001..=40010, 40011..=40014 as f32, 30001..=30002 as u32 }
/// }
/// let mut map = Meter::new();
/// map.set_wide(40011, 1.0f32, WordOrder::HighFirst).unwrap();
/// assert_eq!((map.get(40011), map.get(40012)), (Ok(0x3F80), Ok(0x0000)));
/// map.set_wide(30001, 0x1234_5678u32, WordOrder::LowFirst).unwrap();
/// assert_eq!((map.get(30001), map.get(30002)), (Ok(0x5678), Ok(0x1234)));
/// assert_eq!(map.get_wide::<u32>(30001, WordOrder::LowFirst), Ok(0x1234_5678));
/// ```
///
/// A reference that is not a classic one, an empty range or two ranges that overlap fail
/// the build:
///
/// ```compile_fail
/// avr_modbus::register_map! {
///     struct Overlapping { 40001..=40010, 40005 }
/// }
/// let _ = Overlapping::new();
/// ```
#[cfg_attr(
    not(feature = "diagnostics"),
    doc = r#"
Without feature `diagnostics` there is no FC 7, and no setter of its status bits that would
keep nothing:

```compile_fail,E0599
avr_modbus::register_map! { struct Registers { 40001 } }
Registers::new().set_exception_status(0b1010);
```
"#
)]
#[macro_export]
macro_rules! register_map {
    ($(#[$attr:meta])* $vis:vis struct $name:ident { $($first:literal $(..= $last:literal)? $(as $wide:ident)?),+ $(,)? }) => {
        $(#[$attr])*
        $vis struct $name(
            $crate::internal::map::Values<
                { $crate::internal::map::Layout::words(&[$($crate::__range!($first $(..= $last)?)),+]) },
                { $crate::internal::map::Layout::bit_bytes(&[$($crate::__range!($first $(..= $last)?)),+]) },
            >,
        );

        impl $name {
            /// The map with every value 0.
            #[allow(dead_code)]
            $vis const fn new() -> Self {
                $name($crate::internal::map::Values::new())
            }

            /// Storage index of `start..start + qty` (`qty` ≥ 1) of `table`, when all exist.
            #[inline(always)]
            fn locate(table: $crate::Table, start: u16, qty: u16) -> ::core::option::Option<usize> {
                const RANGES: &[(u32, u32)] = &[$($crate::__range!($first $(..= $last)?)),+];
                $(
                    {
                        const SPAN: $crate::internal::map::Span = $crate::internal::map::Layout::span(RANGES, $first);
                        if let ::core::option::Option::Some(at) = SPAN.index(table, start, qty) {
                            return ::core::option::Option::Some(at);
                        }
                    }
                )+
                ::core::option::Option::None
            }

            /// True when writing `qty` registers of `table` from `start` would write one
            /// register of a pair declared `as u32`, `as i32` or `as f32` without the other;
            /// never in a map without pairs (folded away).
            #[inline(always)]
            fn cuts_pair(table: $crate::Table, start: u16, qty: u16) -> bool {
                const DECLARED: &[::core::option::Option<(u32, u32)>] = &[$($crate::__pair!($first $(..= $last)? $(as $wide)?)),+];
                const PAIRS: &[::core::option::Option<($crate::Table, u16, u16)>] =
                    &$crate::internal::map::Layout::pairs::<{ DECLARED.len() }>(DECLARED);
                const ANY: bool = $crate::internal::map::Layout::any_pair(DECLARED);
                ANY && $crate::internal::map::Layout::cuts_pair(PAIRS, table, start, qty)
            }

            #[inline(always)]
            fn locate_one(reference: $crate::Reference) -> ::core::option::Option<usize> {
                Self::locate(reference.table, reference.address, 1)
            }

            /// The value: a register's word, or 0/1 for a coil or discrete input.
            #[allow(dead_code)]
            #[inline(always)]
            $vis fn get(&self, reference: impl $crate::IntoReference) -> ::core::result::Result<u16, $crate::Error> {
                let reference = reference.into_reference()?;
                self.0.get(reference.table, Self::locate_one(reference))
            }

            /// Sets the value: a register's word, or for a coil or discrete input on when non-zero.
            #[allow(dead_code)]
            #[inline(always)]
            $vis fn set(&mut self, reference: impl $crate::IntoReference, value: u16) -> ::core::result::Result<(), $crate::Error> {
                let reference = reference.into_reference()?;
                self.0.set(reference.table, Self::locate_one(reference), value)
            }

            /// The `u32`, `i32` or `f32` the two registers from `first` hold, in `order`.
            #[allow(dead_code)]
            $vis fn get_wide<T: $crate::Wide>(&self, first: impl $crate::IntoReference, order: $crate::WordOrder) -> ::core::result::Result<T, $crate::Error> {
                <Self as $crate::DataModel>::get_wide(self, first.into_reference()?, order)
            }

            /// Sets the two registers from `first` to `value` in `order`: both, or neither.
            #[allow(dead_code)]
            $vis fn set_wide<T: $crate::Wide>(&mut self, first: impl $crate::IntoReference, value: T, order: $crate::WordOrder) -> ::core::result::Result<(), $crate::Error> {
                <Self as $crate::DataModel>::set_wide(self, first.into_reference()?, value, order)
            }

            /// True if the map has the reference.
            #[allow(dead_code)]
            $vis fn contains(&self, reference: impl $crate::IntoReference) -> bool {
                reference.into_reference().is_ok_and(|r| Self::locate_one(r).is_some())
            }

            /// How many write requests from the master have succeeded (wrapping).
            #[allow(dead_code)]
            $vis fn master_writes(&self) -> u16 {
                self.0.master_writes()
            }

            $crate::__map_diagnostics!($vis);
            $crate::__map_device_id!($vis);
        }

        impl $crate::DataModel for $name {
            const FRAME: usize = $crate::internal::map::Layout::frame(&[$($crate::__range!($first $(..= $last)?)),+]);
            const FRAME_HOLDS_ALL: bool = true;

            fn read_bits(&self, table: $crate::Table, start: u16, qty: u16, out: &mut [u8]) -> ::core::result::Result<(), $crate::Exception> {
                self.0.read_bits(Self::locate(table, start, qty), qty, out)
            }

            fn read_registers(&self, table: $crate::Table, start: u16, out: &mut [u8]) -> ::core::result::Result<(), $crate::Exception> {
                self.0.read_words(Self::locate(table, start, (out.len() / 2) as u16), out)
            }

            fn transfer(
                &mut self,
                access: $crate::internal::Access,
                table: $crate::Table,
                start: u16,
                qty: u16,
                data: &mut [u8],
            ) -> ::core::result::Result<(), $crate::Exception> {
                let at = Self::locate(table, start, qty);
                let cuts = access == $crate::internal::Access::Write && Self::cuts_pair(table, start, qty);
                self.0.transfer(access, table, if cuts { ::core::option::Option::None } else { at }, qty, data)
            }

            fn has_range(&self, table: $crate::Table, start: u16, qty: u16) -> bool {
                Self::locate(table, start, qty).is_some()
            }

            fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> ::core::result::Result<(), $crate::Exception> {
                self.0.write_bits(Self::locate($crate::Table::Coils, start, qty), qty, packed)
            }

            fn write_registers(&mut self, start: u16, values: &[u8]) -> ::core::result::Result<(), $crate::Exception> {
                let qty = (values.len() / 2) as u16;
                let at = Self::locate($crate::Table::HoldingRegisters, start, qty);
                let cuts = Self::cuts_pair($crate::Table::HoldingRegisters, start, qty);
                self.0.write_words(if cuts { ::core::option::Option::None } else { at }, values)
            }

            #[inline(always)]
            fn value(&self, reference: $crate::Reference) -> ::core::result::Result<u16, $crate::Error> {
                self.0.get(reference.table, Self::locate_one(reference))
            }

            #[inline(always)]
            fn set_value(&mut self, reference: $crate::Reference, value: u16) -> ::core::result::Result<(), $crate::Error> {
                self.0.set(reference.table, Self::locate_one(reference), value)
            }

            #[inline(always)]
            fn place(reference: $crate::Reference) -> $crate::internal::map::Place {
                $crate::internal::map::Place::of(reference.table, Self::locate_one(reference))
            }

            #[inline(always)]
            fn load(&self, place: $crate::internal::map::Place) -> u16 {
                self.0.load(place)
            }

            #[inline(always)]
            fn store(&mut self, place: $crate::internal::map::Place, stored: u16) {
                self.0.store(place, stored)
            }

            #[inline(always)]
            fn master_writes(&self) -> u16 {
                self.0.master_writes()
            }

            fn exception_status(&self) -> u8 {
                self.0.device().exception_status()
            }

            fn device_info(&self) -> &[u8] {
                self.0.device().device_info()
            }

            fn identification(&self) -> ::core::option::Option<&$crate::Identification> {
                self.0.device().identification()
            }
        }
    };
}

/// One range of [`register_map!`] as a pair range: `Some((first, last))` when declared
/// `as u32`, `as i32` or `as f32` (the type checked to be one of them), else `None`.
#[doc(hidden)]
#[macro_export]
macro_rules! __pair {
    ($first:literal ..= $last:literal as $wide:ident) => {{
        const fn wide<T: $crate::Wide>() {}
        wide::<$wide>();
        ::core::option::Option::Some(($first, $last))
    }};
    ($first:literal as $wide:ident) => {
        ::core::compile_error!("register_map!: a pair takes a range of two registers, first..=last")
    };
    ($first:literal $(..= $last:literal)?) => {
        ::core::option::Option::None
    };
}

/// One range of [`register_map!`] as `(first, last)`.
#[doc(hidden)]
#[macro_export]
macro_rules! __range {
    ($first:literal ..= $last:literal) => {
        ($first, $last)
    };
    ($first:literal) => {
        ($first, $first)
    };
}

/// The map's FC 7 and FC 17 setters, [`register_map!`]'s part that only feature
/// `diagnostics` has: a macro of this crate, so that the feature it follows is this
/// crate's, not the firmware's (without it a map has no such setter, rather than one that
/// does nothing).
#[cfg(feature = "diagnostics")]
#[doc(hidden)]
#[macro_export]
macro_rules! __map_diagnostics {
    ($vis:vis) => {
        /// Sets the eight status bits FC 7 (Read Exception Status) reports (feature
        /// `diagnostics`).
        #[allow(dead_code)]
        $vis fn set_exception_status(&mut self, bits: u8) {
            self.0.device_mut().set_exception_status(bits);
        }

        /// Sets the device description FC 17 (0x11, Report Server ID) reports (feature
        /// `diagnostics`).
        #[allow(dead_code)]
        $vis fn set_device_info(&mut self, info: &'static [u8]) {
            self.0.device_mut().set_device_info(info);
        }
    };
}

/// Without feature `diagnostics`: no FC 7 and FC 17 setters.
#[cfg(not(feature = "diagnostics"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __map_diagnostics {
    ($vis:vis) => {};
}

/// The map's FC 43 setter, [`register_map!`]'s part that only feature `device-id` has (see
/// `__map_diagnostics`).
#[cfg(feature = "device-id")]
#[doc(hidden)]
#[macro_export]
macro_rules! __map_device_id {
    ($vis:vis) => {
        /// Sets the objects FC 43 / MEI 14 (Read Device Identification) reports, declared
        /// with `identification!` (feature `device-id`).
        #[allow(dead_code)]
        $vis fn set_identification(&mut self, identification: &'static $crate::Identification) {
            self.0.device_mut().set_identification(identification);
        }
    };
}

/// Without feature `device-id`: no FC 43 setter.
#[cfg(not(feature = "device-id"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __map_device_id {
    ($vis:vis) => {};
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_longest_run_counts_touching_ranges_as_one_in_their_table() {
        let ranges = [(40_101, 40_105), (40_106, 40_110), (40_201, 40_203), (1, 16), (30_001, 30_002)];
        assert_eq!(Layout::longest_run(&ranges, Table::HoldingRegisters), 10);
        assert_eq!(Layout::longest_run(&ranges, Table::Coils), 16);
        assert_eq!(Layout::longest_run(&ranges, Table::InputRegisters), 2);
        assert_eq!(Layout::longest_run(&ranges, Table::DiscreteInputs), 0);
    }

    #[test]
    fn a_write_cuts_a_pair_when_it_starts_on_its_second_register_or_ends_on_its_first() {
        // Holding registers 10..=13: the pairs 10–11 and 12–13.
        let pairs = [None, Some((Table::HoldingRegisters, 10, 13))];
        let cuts = |start, qty| Layout::cuts_pair(&pairs, Table::HoldingRegisters, start, qty);
        for (start, qty) in [(10, 1), (11, 1), (12, 1), (13, 1), (9, 2), (11, 2), (10, 3), (13, 2)] {
            assert!(cuts(start, qty), "{start} × {qty}");
        }
        for (start, qty) in [(10, 2), (12, 2), (10, 4), (8, 2), (9, 5), (14, 1), (0, 10)] {
            assert!(!cuts(start, qty), "{start} × {qty}");
        }
        assert!(!Layout::cuts_pair(&pairs, Table::InputRegisters, 11, 1));
    }

    #[test]
    #[should_panic(expected = "two ranges overlap")]
    fn overlapping_ranges_are_refused() {
        Layout::check(&[(40_001, 40_010), (40_010, 40_020)]);
    }

    #[test]
    fn ranges_of_one_address_each_side_by_side_or_in_two_tables_are_taken() {
        Layout::check(&[(40_001, 40_001), (40_002, 40_002), (30_001, 30_002), (1, 2)]);
    }

    #[test]
    #[should_panic(expected = "in one table")]
    fn a_range_that_runs_backwards_is_refused() {
        Layout::check(&[(40_010, 40_001)]);
    }

    #[test]
    #[should_panic(expected = "in one table")]
    fn a_range_across_two_tables_is_refused() {
        Layout::check(&[(30_001, 40_002)]);
    }
}
