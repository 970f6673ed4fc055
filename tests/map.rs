//! The register map fixed at build time (`register_map!`): its layout, its lookups, and
//! every request answered exactly as the run-time `Bank` with the same addresses answers
//! it (random requests of every function code, replies and contents compared).

mod common;

use avr_modbus::internal::map::Device;
use avr_modbus::{Bank, DataModel, Error, Reference, Table};
use common::{bit_of, exchange, spec_bank, with_crc, TestBank, ID};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::{RngAlgorithm, RngSeed};

avr_modbus::register_map! {
    /// `common::spec_bank`'s addresses in classic references, declared out of order.
    struct SpecMap {
        40113,
        10197..=10218,
        20..=38,
        41..=48,
        173,
        30009,
        30011,
        40001..=40003,
        40108..=40110,
    }
}

avr_modbus::register_map! {
    /// Ranges that touch, declared apart and backwards.
    struct Touching {
        40005..=40008,
        40001..=40004,
        5..=8,
        1..=4,
        30002,
        30001,
    }
}

avr_modbus::register_map! {
    /// The ends of the classic references, and one coil and one discrete input at the same
    /// address.
    struct Edges {
        1,
        10001,
        49999,
        39999,
        9998..=9999,
    }
}

/// `spec_bank`'s values, set through the map.
fn spec_map() -> SpecMap {
    let mut map = SpecMap::new();
    for k in 0..19 {
        map.set(Reference::coil(19 + k), bit_of(&[0xCD, 0x6B, 0x05], k)).unwrap();
    }
    for a in 40..48 {
        map.set(Reference::coil(a), 1).unwrap();
    }
    for k in 0..22 {
        map.set(Reference::discrete_input(196 + k), bit_of(&[0xAC, 0xDB, 0x35], k)).unwrap();
    }
    map.set(Reference::input_register(8), 0x000A).unwrap();
    map.set(Reference::input_register(10), 0x1234).unwrap();
    map.set(Reference::holding_register(107), 0x022B).unwrap();
    map.set(Reference::holding_register(109), 0x0064).unwrap();
    map
}

/// `values` bytes of values plus what every map holds beside them: the write count and what
/// FC 7, 17 and 43 report (`Device`: with `diagnostics` the exception status and the
/// device-information bytes, with `device-id` the identification, nothing without them);
/// padded to the alignment of `M`.
fn footprint<M>(values: usize) -> usize {
    (values + 2 + core::mem::size_of::<Device>()).next_multiple_of(core::mem::align_of::<M>())
}

/// What `Device` holds: its fields, padded to its alignment (none on the AVR).
fn device_footprint() -> usize {
    let fields = if cfg!(feature = "diagnostics") { 1 + core::mem::size_of::<&[u8]>() } else { 0 }
        + if cfg!(feature = "device-id") { core::mem::size_of::<&avr_modbus::Identification>() } else { 0 };
    fields.next_multiple_of(core::mem::align_of::<Device>())
}

#[test]
fn storage_is_the_values_and_nothing_else() {
    assert_eq!(core::mem::size_of::<Device>(), device_footprint());
    // 19 + 8 + 1 coils and 22 inputs: 50 bits in 7 bytes; 9 registers.
    assert_eq!(core::mem::size_of::<SpecMap>(), footprint::<SpecMap>(7 + 2 * 9));
    // 8 coils in 1 byte, 10 registers.
    assert_eq!(core::mem::size_of::<Touching>(), footprint::<Touching>(1 + 2 * 10));
}

#[test]
fn every_declared_address_is_found_and_no_other() {
    let map = spec_map();
    let bank = spec_bank();
    for table in [Table::Coils, Table::DiscreteInputs, Table::InputRegisters, Table::HoldingRegisters] {
        for address in 0..=300 {
            let reference = Reference { table, address };
            assert_eq!(map.get(reference), bank.get(reference), "{reference:?}");
            assert_eq!(map.contains(reference), bank.contains(reference), "{reference:?}");
        }
    }
}

#[test]
fn a_missing_address_is_not_found_and_a_bad_reference_refused() {
    let mut map = SpecMap::new();
    assert_eq!(map.get(40004), Err(Error::NotFound));
    assert_eq!(map.set(40004, 1), Err(Error::NotFound));
    assert_eq!(map.get(20000), Err(Error::BadReference));
    assert_eq!(map.set(0, 1), Err(Error::BadReference));
}

#[test]
fn coils_and_inputs_at_one_address_are_two_values() {
    let mut map = Edges::new();
    map.set(1, 1).unwrap();
    assert_eq!((map.get(1), map.get(10001)), (Ok(1), Ok(0)));
    map.set(10001, 1).unwrap();
    map.set(1, 0).unwrap();
    assert_eq!((map.get(1), map.get(10001)), (Ok(0), Ok(1)));
    map.set(49999, 0xBEEF).unwrap();
    map.set(39999, 0x1234).unwrap();
    assert_eq!((map.get(49999), map.get(39999)), (Ok(0xBEEF), Ok(0x1234)));
    assert!(
        map.contains(Reference::coil(9998))
            && map.contains(Reference::coil(9997))
            && !map.contains(Reference::coil(9996))
    );
}

#[test]
fn ranges_that_touch_read_and_write_as_one() {
    let mut map = Touching::new();
    // FC 16 across the two holding ranges: 40003–40006.
    let reply = exchange(&mut map, &[0x10, 0x00, 0x02, 0x00, 0x04, 0x08, 0, 1, 0, 2, 0, 3, 0, 4]);
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x02, 0x00, 0x04]));
    assert_eq!((map.get(40003), map.get(40006)), (Ok(1), Ok(4)));
    // FC 3 over all eight.
    let reply = exchange(&mut map, &[0x03, 0x00, 0x00, 0x00, 0x08]);
    assert_eq!(reply, with_crc(&[ID, 0x03, 16, 0, 0, 0, 0, 0, 1, 0, 2, 0, 3, 0, 4, 0, 0, 0, 0]));
    // FC 15 across the two coil ranges, FC 1 back, FC 4 across the two input registers.
    exchange(&mut map, &[0x0F, 0x00, 0x02, 0x00, 0x04, 0x01, 0b1011]);
    assert_eq!(exchange(&mut map, &[0x01, 0x00, 0x00, 0x00, 0x08]), with_crc(&[ID, 0x01, 1, 0b0010_1100]));
    assert_eq!(exchange(&mut map, &[0x04, 0x00, 0x00, 0x00, 0x02]), with_crc(&[ID, 0x04, 4, 0, 0, 0, 0]));
    // One past the end is 02.
    assert_eq!(exchange(&mut map, &[0x03, 0x00, 0x00, 0x00, 0x09]), with_crc(&[ID, 0x83, 0x02]));
    assert_eq!(map.master_writes(), 2);
}

#[test]
fn the_map_answers_the_specs_examples_as_the_bank_does() {
    // Application Protocol §6.1–6.4's requests.
    for pdu in [
        &[0x01, 0x00, 0x13, 0x00, 0x13][..],
        &[0x02, 0x00, 0xC4, 0x00, 0x16],
        &[0x03, 0x00, 0x6B, 0x00, 0x03],
        &[0x04, 0x00, 0x08, 0x00, 0x01],
    ] {
        assert_eq!(exchange(&mut spec_map(), pdu), exchange(&mut spec_bank(), pdu), "{pdu:02X?}");
    }
}

/// Every value of the spec layout's neighbourhood, through the data model.
fn contents<M: DataModel>(model: &M) -> Vec<Result<u16, Error>> {
    let mut all = Vec::new();
    for table in [Table::Coils, Table::DiscreteInputs, Table::InputRegisters, Table::HoldingRegisters] {
        for address in (0..=250).chain(65530..=65535) {
            all.push(model.value(Reference { table, address }));
        }
    }
    all
}

fn address() -> impl Strategy<Value = u16> {
    prop_oneof![4 => 0u16..=60, 3 => 100u16..=120, 3 => 165u16..=225, 1 => 65520u16..=65535, 1 => any::<u16>()]
}

fn quantity() -> impl Strategy<Value = u16> {
    prop_oneof![6 => 1u16..=30, 1 => Just(0u16), 1 => any::<u16>(), 1 => 120u16..=2001]
}

/// A request PDU of one of the eight function codes (or another code), mostly well formed.
fn request() -> impl Strategy<Value = Vec<u8>> {
    let code = prop_oneof![8 => proptest::sample::select(vec![1u8, 2, 3, 4, 5, 6, 15, 16]), 1 => any::<u8>()];
    (code, address(), quantity(), vec(any::<u8>(), 0..70), any::<bool>()).prop_map(
        |(code, start, qty, data, consistent)| {
            let mut pdu = vec![code];
            pdu.extend_from_slice(&start.to_be_bytes());
            match code {
                5 if consistent => pdu.extend_from_slice(&[if qty % 2 == 0 { 0xFF } else { 0 }, 0]),
                5 | 6 => pdu.extend_from_slice(&qty.to_be_bytes()),
                15 | 16 if consistent => {
                    let bytes = if code == 15 { qty.div_ceil(8) } else { qty.saturating_mul(2) };
                    pdu.extend_from_slice(&qty.to_be_bytes());
                    pdu.push(bytes as u8);
                    pdu.extend(
                        (0..usize::from(bytes).min(246))
                            .map(|k| data.get(k % data.len().max(1)).copied().unwrap_or(k as u8)),
                    );
                }
                15 | 16 => {
                    pdu.extend_from_slice(&qty.to_be_bytes());
                    pdu.extend_from_slice(&data);
                }
                _ => pdu.extend_from_slice(&qty.to_be_bytes()),
            }
            pdu.truncate(253);
            pdu
        },
    )
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("FUZZ_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(1000),
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(std::env::var("FUZZ_SEED").ok().and_then(|n| n.parse().ok()).unwrap_or(11)),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// A sequence of requests gets the same replies from the map as from the bank, and
    /// leaves the same contents and write count.
    #[test]
    fn the_map_answers_every_request_as_the_bank_does(requests in vec(request(), 1..12)) {
        let (mut map, mut bank): (SpecMap, TestBank) = (spec_map(), spec_bank());
        for pdu in &requests {
            prop_assert_eq!(exchange(&mut map, pdu), exchange(&mut bank, pdu), "{:02X?}", pdu);
        }
        prop_assert_eq!(contents(&map), contents(&bank));
        prop_assert_eq!(map.master_writes(), Bank::master_writes(&bank));
    }
}
