//! Random sequences of adds and sets against a `BTreeMap` model of the bank: every add
//! succeeds exactly when the model says it fits, a refused add changes nothing, runs are
//! the maximal ranges of consecutive addresses, and values survive every insertion.

use std::collections::BTreeMap;

use avr_modbus::{Bank, Error, Reference, Table};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::select;
use proptest::test_runner::{RngAlgorithm, RngSeed};

const RUNS: usize = 6;
const REGS: usize = 24;
const BITS: usize = 32;
type SmallBank = Bank<RUNS, REGS, { BITS / 8 }>;

#[derive(Clone, Debug)]
enum Op {
    Add(Table, u16, u16),
    Set(Table, u16, u16),
}

fn table() -> impl Strategy<Value = Table> {
    select(vec![Table::Coils, Table::DiscreteInputs, Table::InputRegisters, Table::HoldingRegisters])
}

fn start() -> impl Strategy<Value = u16> {
    prop_oneof![6 => 0u16..40, 1 => 65530u16..=65535]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => (table(), start(), prop_oneof![4 => 1u16..=4, 1 => 0u16..=12]).prop_map(|(t, s, n)| Op::Add(t, s, n)),
        2 => (table(), start(), any::<u16>()).prop_map(|(t, s, v)| Op::Set(t, s, v)),
    ]
}

fn is_bits(table: Table) -> bool {
    matches!(table, Table::Coils | Table::DiscreteInputs)
}

/// Runs in the model: maximal ranges of consecutive addresses of one table.
fn runs(model: &BTreeMap<(Table, u16), u16>) -> usize {
    let mut count = 0;
    let mut previous: Option<(Table, u16)> = None;
    for &(table, address) in model.keys() {
        let continues = previous.is_some_and(|(t, a)| t == table && a.checked_add(1) == Some(address));
        if !continues {
            count += 1;
        }
        previous = Some((table, address));
    }
    count
}

/// The errors an add may give, or none when it must succeed.
fn add_errors(model: &BTreeMap<(Table, u16), u16>, table: Table, start: u16, count: u16) -> Vec<Error> {
    if count == 0 || u32::from(start) + u32::from(count) > 0x1_0000 {
        return vec![Error::BadRange];
    }
    let range = u32::from(start)..u32::from(start) + u32::from(count);
    if range.clone().any(|a| model.contains_key(&(table, a as u16))) {
        return vec![Error::Duplicate];
    }
    let mut errors = vec![];
    let same_kind = model.keys().filter(|(t, _)| is_bits(*t) == is_bits(table)).count();
    let limit = if is_bits(table) { BITS } else { REGS };
    if same_kind + usize::from(count) > limit {
        errors.push(if is_bits(table) { Error::BitsFull } else { Error::RegistersFull });
    }
    let mut after = model.clone();
    after.extend(range.map(|a| ((table, a as u16), 0)));
    if runs(&after) > RUNS {
        errors.push(Error::RunsFull);
    }
    errors
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 2000,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x0BA4_4C0D),
        ..ProptestConfig::default()
    })]

    #[test]
    fn bank_agrees_with_a_map_of_its_addresses(ops in vec(op(), 1..40)) {
        let mut bank = SmallBank::new();
        let mut model: BTreeMap<(Table, u16), u16> = BTreeMap::new();
        for op in ops {
            match op {
                Op::Add(table, start, count) => {
                    let expected = add_errors(&model, table, start, count);
                    let result = bank.add_range(Reference { table, address: start }, count);
                    match result {
                        Ok(()) => {
                            prop_assert!(expected.is_empty(), "{:?} {} {} should fail: {:?}", table, start, count, expected);
                            for a in start..=start + (count - 1) {
                                model.insert((table, a), 0);
                            }
                        }
                        Err(e) => prop_assert!(expected.contains(&e), "{:?} {} {}: {:?}, expected {:?}", table, start, count, e, expected),
                    }
                }
                Op::Set(table, address, value) => {
                    let reference = Reference { table, address };
                    let stored = if is_bits(table) { u16::from(value != 0) } else { value };
                    match model.get_mut(&(table, address)) {
                        Some(slot) => {
                            prop_assert_eq!(bank.set(reference, value), Ok(()));
                            *slot = stored;
                        }
                        None => prop_assert_eq!(bank.set(reference, value), Err(Error::NotFound)),
                    }
                }
            }
            prop_assert_eq!(bank.runs(), runs(&model));
            for (&(table, address), &value) in &model {
                prop_assert_eq!(bank.get(Reference { table, address }), Ok(value), "{:?} {}", table, address);
            }
            for table in [Table::Coils, Table::DiscreteInputs, Table::InputRegisters, Table::HoldingRegisters] {
                for address in (0..44).chain(65526..=65535) {
                    prop_assert_eq!(bank.contains(Reference { table, address }), model.contains_key(&(table, address)));
                }
            }
        }
    }
}
