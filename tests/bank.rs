//! The sparse register bank: adding addresses in any order, merging runs, capacity and
//! errors, values in all four tables, the whole 0–65535 address space and the
//! master-writes counter.

mod common;

use avr_modbus::{bit_bytes, Bank, Error, Reference, Table};
use common::{ask, exception_reply, slave, to_slave, with_crc, ID};

type Small = Bank<4, 8, { bit_bytes(16) }>;

// ---- adding ----------------------------------------------------------------------------

#[test]
fn addresses_added_in_increasing_order_form_one_run() {
    let mut bank: Bank<2, 100, 1> = Bank::new();
    for n in 40001..=40100u32 {
        bank.add(n).unwrap();
    }
    assert_eq!(bank.runs(), 1);
    assert!((40001..=40100u32).all(|n| bank.contains(n)));
}

#[test]
fn addresses_added_in_reverse_order_form_one_run() {
    let mut bank: Bank<2, 100, 1> = Bank::new();
    for n in (40001..=40100u32).rev() {
        bank.add(n).unwrap();
    }
    assert_eq!(bank.runs(), 1);
    assert!((40001..=40100u32).all(|n| bank.contains(n)));
}

#[test]
fn addresses_added_out_of_order_form_one_run_and_keep_their_values() {
    let mut bank: Bank<8, 16, 2> = Bank::new();
    for n in [40005u32, 40001, 40003, 40002, 40004] {
        bank.add(n).unwrap();
        bank.set(n, (n - 40000) as u16 * 11).unwrap();
    }
    assert_eq!(bank.runs(), 1);
    for n in 40001..=40005u32 {
        assert_eq!(bank.get(n), Ok((n - 40000) as u16 * 11), "{n}");
    }
}

#[test]
fn skipping_addresses_makes_one_run_each() {
    let mut bank: Bank<4, 8, 1> = Bank::new();
    for n in [40001u32, 40003, 40005] {
        bank.add(n).unwrap();
    }
    assert_eq!(bank.runs(), 3);
    assert!(!bank.contains(40002));
    assert!(!bank.contains(40004));
}

#[test]
fn contiguous_ranges_merge_into_one_run() {
    let mut bank: Bank<4, 16, 1> = Bank::new();
    bank.add_range(40001, 5).unwrap();
    bank.add_range(40006, 5).unwrap();
    assert_eq!(bank.runs(), 1);
}

#[test]
fn a_range_added_just_before_a_run_merges_with_it() {
    let mut bank: Bank<4, 16, 1> = Bank::new();
    bank.add_range(40006, 5).unwrap();
    bank.set(40006, 66).unwrap();
    bank.add_range(40001, 5).unwrap();
    assert_eq!(bank.runs(), 1);
    assert_eq!(bank.get(40006), Ok(66));
    assert_eq!(bank.get(40005), Ok(0));
}

#[test]
fn bridging_add_joins_two_runs_and_keeps_their_values() {
    let mut bank: Bank<4, 16, 1> = Bank::new();
    bank.add_range(40001, 3).unwrap();
    bank.add_range(40007, 3).unwrap();
    for n in [40001u32, 40002, 40003, 40007, 40008, 40009] {
        bank.set(n, n as u16).unwrap();
    }
    assert_eq!(bank.runs(), 2);
    bank.add_range(40004, 3).unwrap();
    assert_eq!(bank.runs(), 1);
    for n in [40001u32, 40002, 40003, 40007, 40008, 40009] {
        assert_eq!(bank.get(n), Ok(n as u16), "{n}");
    }
    for n in [40004u32, 40005, 40006] {
        assert_eq!(bank.get(n), Ok(0), "{n}");
    }
}

#[test]
fn bridging_add_of_one_coil_joins_two_coil_runs() {
    let mut bank: Small = Bank::new();
    bank.add_range(1, 3).unwrap();
    bank.add_range(5, 3).unwrap();
    bank.set(3, 1).unwrap();
    bank.set(5, 1).unwrap();
    bank.add(4).unwrap();
    assert_eq!(bank.runs(), 1);
    let coils: Vec<u16> = (1..=7u32).map(|n| bank.get(n).unwrap()).collect();
    assert_eq!(coils, [0, 0, 1, 0, 1, 0, 0]);
}

#[test]
fn runs_of_different_tables_never_merge() {
    let mut bank: Small = Bank::new();
    bank.add(Reference::coil(0)).unwrap();
    bank.add(Reference::discrete_input(1)).unwrap();
    bank.add(Reference::input_register(2)).unwrap();
    bank.add(Reference::holding_register(3)).unwrap();
    assert_eq!(bank.runs(), 4);
    assert!(!bank.contains(Reference::coil(1)));
    assert!(!bank.contains(Reference::holding_register(2)));
}

#[test]
fn bits_inserted_before_others_shift_them_without_losing_values() {
    let mut bank: Bank<8, 1, { bit_bytes(40) }> = Bank::new();
    // Discrete inputs first (they sort after coils), then coils in front of them.
    bank.add_range(10001, 9).unwrap();
    for (k, n) in (10001..=10009u32).enumerate() {
        bank.set(n, u16::from(k % 2 == 0)).unwrap();
    }
    bank.add_range(Reference::coil(100), 7).unwrap();
    bank.add_range(Reference::coil(10), 3).unwrap();
    bank.set(Reference::coil(11), 1).unwrap();
    for (k, n) in (10001..=10009u32).enumerate() {
        assert_eq!(bank.get(n), Ok(u16::from(k % 2 == 0)), "{n}");
    }
    assert_eq!(bank.get(Reference::coil(11)), Ok(1));
    assert!((100..107).all(|a| bank.get(Reference::coil(a)) == Ok(0)));
}

#[test]
fn registers_inserted_before_others_shift_them_without_losing_values() {
    let mut bank: Bank<8, 12, 1> = Bank::new();
    bank.add_range(40011, 4).unwrap();
    for n in 40011..=40014u32 {
        bank.set(n, n as u16).unwrap();
    }
    bank.add_range(30001, 4).unwrap();
    bank.add_range(40001, 4).unwrap();
    for n in 40011..=40014u32 {
        assert_eq!(bank.get(n), Ok(n as u16), "{n}");
    }
    assert!((30001..=30004u32).chain(40001..=40004).all(|n| bank.get(n) == Ok(0)));
}

// ---- errors that change nothing ----------------------------------------------------------

#[test]
fn adding_an_address_twice_is_duplicate() {
    let mut bank: Small = Bank::new();
    bank.add(40001).unwrap();
    bank.set(40001, 7).unwrap();
    assert_eq!(bank.add(40001), Err(Error::Duplicate));
    assert_eq!(bank.get(40001), Ok(7));
    assert_eq!(bank.runs(), 1);
}

#[test]
fn a_range_overlapping_the_end_of_a_run_is_duplicate_and_adds_none() {
    let mut bank: Small = Bank::new();
    bank.add_range(40001, 3).unwrap();
    assert_eq!(bank.add_range(40003, 3), Err(Error::Duplicate));
    assert!(!bank.contains(40004));
    assert!(!bank.contains(40005));
}

#[test]
fn a_range_overlapping_the_start_of_a_run_is_duplicate_and_adds_none() {
    let mut bank: Small = Bank::new();
    bank.add_range(40005, 2).unwrap();
    assert_eq!(bank.add_range(40003, 3), Err(Error::Duplicate));
    assert!(!bank.contains(40003));
    assert!(!bank.contains(40004));
}

#[test]
fn a_range_covering_a_whole_run_is_duplicate() {
    let mut bank: Small = Bank::new();
    bank.add(40005).unwrap();
    assert_eq!(bank.add_range(40001, 8), Err(Error::Duplicate));
    assert_eq!(bank.runs(), 1);
    assert!(!bank.contains(40001));
}

#[test]
fn the_same_address_in_another_table_is_not_a_duplicate() {
    let mut bank: Small = Bank::new();
    bank.add(40001).unwrap();
    assert_eq!(bank.add(30001), Ok(()));
    assert_eq!(bank.add(1), Ok(()));
    assert_eq!(bank.add(10001), Ok(()));
}

#[test]
fn a_fifth_run_in_a_four_run_bank_is_runs_full() {
    let mut bank: Small = Bank::new();
    for n in [40001u32, 40003, 40005, 40007] {
        bank.add(n).unwrap();
    }
    assert_eq!(bank.add(40009), Err(Error::RunsFull));
    assert!(!bank.contains(40009));
    assert_eq!(bank.runs(), 4);
}

#[test]
fn a_full_run_table_still_extends_and_bridges_runs() {
    let mut bank: Small = Bank::new();
    for n in [40001u32, 40003, 40005, 40007] {
        bank.add(n).unwrap();
    }
    assert_eq!(bank.add(40008), Ok(()));
    assert_eq!(bank.add(40002), Ok(()));
    assert_eq!(bank.runs(), 3);
}

#[test]
fn registers_past_regs_are_registers_full() {
    let mut bank: Small = Bank::new();
    bank.add_range(40001, 6).unwrap();
    bank.set(40006, 6).unwrap();
    assert_eq!(bank.add_range(30001, 3), Err(Error::RegistersFull));
    assert!(!bank.contains(30001));
    assert_eq!(bank.add_range(30001, 2), Ok(()), "exactly REGS fit");
    assert_eq!(bank.add(40007), Err(Error::RegistersFull));
    assert_eq!(bank.get(40006), Ok(6));
}

#[test]
fn bits_past_bit_bytes_times_8_are_bits_full() {
    let mut bank: Small = Bank::new();
    bank.add_range(1, 10).unwrap();
    assert_eq!(bank.add_range(10001, 7), Err(Error::BitsFull));
    assert!(!bank.contains(10001));
    assert_eq!(bank.add_range(10001, 6), Ok(()), "exactly 16 bits fit");
    assert_eq!(bank.add(11), Err(Error::BitsFull));
}

#[test]
fn bad_classic_references_are_refused() {
    let mut bank: Small = Bank::new();
    for bad in [0u32, 10000, 20001, 29999, 30000, 40000, 50000, 99999] {
        assert_eq!(bank.add(bad), Err(Error::BadReference), "{bad}");
        assert_eq!(bank.get(bad), Err(Error::BadReference), "{bad}");
        assert_eq!(bank.set(bad, 1), Err(Error::BadReference), "{bad}");
    }
    assert_eq!(bank.add(-40001), Err(Error::BadReference));
    assert_eq!(bank.runs(), 0);
}

#[test]
fn a_range_past_65535_is_bad_range() {
    let mut bank: Small = Bank::new();
    assert_eq!(bank.add_range(Reference::holding_register(65535), 2), Err(Error::BadRange));
    assert_eq!(bank.add_range(Reference::coil(65530), 7), Err(Error::BadRange));
    assert!(!bank.contains(Reference::holding_register(65535)));
    assert_eq!(bank.runs(), 0);
}

#[test]
fn an_empty_range_is_bad_range() {
    let mut bank: Small = Bank::new();
    assert_eq!(bank.add_range(40001, 0), Err(Error::BadRange));
    assert_eq!(bank.runs(), 0);
}

#[test]
fn a_failed_add_does_not_use_up_capacity() {
    let mut bank: Small = Bank::new();
    for _ in 0..10 {
        let _ = bank.add_range(40001, 9);
        let _ = bank.add_range(Reference::holding_register(65535), 2);
    }
    assert_eq!(bank.add_range(40001, 8), Ok(()));
}

// ---- get and set ----------------------------------------------------------------------

#[test]
fn unset_values_read_zero_in_all_four_tables() {
    let mut bank: Small = Bank::new();
    for n in [1u32, 10001, 30001, 40001] {
        bank.add(n).unwrap();
        assert_eq!(bank.get(n), Ok(0), "{n}");
    }
}

#[test]
fn missing_addresses_are_not_found() {
    let mut bank: Small = Bank::new();
    bank.add(40002).unwrap();
    assert_eq!(bank.get(40001), Err(Error::NotFound));
    assert_eq!(bank.set(40003, 1), Err(Error::NotFound));
    assert_eq!(bank.get(30002), Err(Error::NotFound));
}

#[test]
fn classic_references_name_protocol_address_0_of_each_table() {
    let cases = [
        (1u32, Reference::coil(0)),
        (10001, Reference::discrete_input(0)),
        (30001, Reference::input_register(0)),
        (40001, Reference::holding_register(0)),
    ];
    for (classic, typed) in cases {
        let mut bank: Small = Bank::new();
        bank.add(classic).unwrap();
        assert!(bank.contains(typed), "{classic}");
        bank.set(typed, 1).unwrap();
        assert_eq!(bank.get(classic), Ok(1), "{classic}");
    }
}

#[test]
fn registers_hold_any_16_bit_value() {
    let mut bank: Small = Bank::new();
    bank.add(30001).unwrap();
    bank.add(40001).unwrap();
    for value in [0u16, 1, 0x00FF, 0x8000, 0xFFFF] {
        bank.set(30001, value).unwrap();
        bank.set(40001, !value).unwrap();
        assert_eq!(bank.get(30001), Ok(value));
        assert_eq!(bank.get(40001), Ok(!value));
    }
}

#[test]
fn setting_a_bit_to_any_non_zero_value_reads_back_as_1() {
    let mut bank: Small = Bank::new();
    bank.add(1).unwrap();
    bank.add(10001).unwrap();
    for value in [1u16, 2, 0x0100, 0xFF00, 0xFFFF] {
        bank.set(1, value).unwrap();
        bank.set(10001, value).unwrap();
        assert_eq!(bank.get(1), Ok(1), "{value:#X}");
        assert_eq!(bank.get(10001), Ok(1), "{value:#X}");
        bank.set(1, 0).unwrap();
        assert_eq!(bank.get(1), Ok(0));
    }
}

#[test]
fn neighbouring_bits_are_independent() {
    let mut bank: Small = Bank::new();
    bank.add_range(1, 16).unwrap();
    bank.set(8, 1).unwrap();
    bank.set(9, 1).unwrap();
    bank.set(8, 0).unwrap();
    let coils: Vec<u16> = (1..=16u32).map(|n| bank.get(n).unwrap()).collect();
    assert_eq!(coils, [0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]);
}

// ---- the whole address space ---------------------------------------------------------------

#[test]
fn address_65535_can_be_added_set_and_read_in_every_table() {
    for table in [Table::Coils, Table::DiscreteInputs, Table::InputRegisters, Table::HoldingRegisters] {
        let mut bank: Small = Bank::new();
        let top = Reference { table, address: 65535 };
        bank.add(top).unwrap();
        bank.set(top, 1).unwrap();
        assert_eq!(bank.get(top), Ok(1), "{table:?}");
        assert!(!bank.contains(Reference { table, address: 65534 }));
    }
}

#[test]
fn address_0_to_65535_can_be_one_run() {
    let mut bank: Bank<1, 0, { bit_bytes(65536) }> = Bank::new();
    bank.add_range(Reference::coil(0), 65535).unwrap();
    bank.add(Reference::coil(65535)).unwrap();
    assert_eq!(bank.runs(), 1);
    bank.set(Reference::coil(65535), 1).unwrap();
    assert_eq!(bank.get(Reference::coil(65535)), Ok(1));
    assert_eq!(bank.get(Reference::coil(0)), Ok(0));
}

#[test]
fn holding_register_65535_is_read_by_fc3() {
    let mut bank: Small = Bank::new();
    bank.add(Reference::holding_register(65535)).unwrap();
    bank.set(Reference::holding_register(65535), 0xCAFE).unwrap();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0xFF, // starting address hi
        0xFF, // starting address lo: 65535
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x02, // byte count
        0xCA, // value hi
        0xFE, // value lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn coil_65535_is_written_by_fc5() {
    let mut bank: Small = Bank::new();
    bank.add(Reference::coil(65535)).unwrap();
    let request = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0xFF, // output address hi
        0xFF, // output address lo: 65535
        0xFF, // value hi: ON
        0x00, // value lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), request);
    assert_eq!(bank.get(Reference::coil(65535)), Ok(1));
}

// ---- master writes ----------------------------------------------------------------------

fn writable_bank() -> Small {
    let mut bank: Small = Bank::new();
    bank.add_range(1, 8).unwrap();
    bank.add_range(40001, 4).unwrap();
    bank.add(30001).unwrap();
    bank.add(10001).unwrap();
    bank
}

#[test]
fn each_successful_master_write_counts_once() {
    let mut bank = writable_bank();
    let mut slave = slave();
    let writes: [&[u8]; 4] = [
        &[0x05, 0x00, 0x00, 0xFF, 0x00],
        &[0x06, 0x00, 0x01, 0x12, 0x34],
        &[0x0F, 0x00, 0x00, 0x00, 0x08, 0x01, 0xA5],
        &[0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0x00, 0x01, 0x00, 0x02],
    ];
    for (n, write) in writes.iter().enumerate() {
        ask(&mut slave, &mut bank, &to_slave(write));
        assert_eq!(bank.master_writes(), n as u16 + 1, "after FC {}", write[0]);
    }
}

#[test]
fn reads_do_not_count_as_master_writes() {
    let mut bank = writable_bank();
    let mut slave = slave();
    for read in [[0x01, 0x00, 0x00, 0x00, 0x08], [0x02, 0, 0, 0, 1], [0x03, 0, 0, 0, 4], [0x04, 0, 0, 0, 1]] {
        assert_eq!(ask(&mut slave, &mut bank, &to_slave(&read))[1], read[0]);
    }
    assert_eq!(bank.master_writes(), 0);
}

#[test]
fn failed_master_writes_do_not_count() {
    let mut bank = writable_bank();
    let mut slave = slave();
    let failures: [(&[u8], u8); 4] = [
        (&[0x05, 0x00, 0x08, 0xFF, 0x00], 0x02),
        (&[0x05, 0x00, 0x00, 0x12, 0x34], 0x03),
        (&[0x06, 0x00, 0x04, 0x00, 0x01], 0x02),
        (&[0x10, 0x00, 0x03, 0x00, 0x02, 0x04, 0x00, 0x01, 0x00, 0x02], 0x02),
    ];
    for (request, code) in failures {
        assert_eq!(ask(&mut slave, &mut bank, &to_slave(request)), exception_reply(request[0], code));
    }
    assert_eq!(bank.master_writes(), 0);
}

#[test]
fn application_sets_do_not_count_as_master_writes() {
    let mut bank = writable_bank();
    bank.set(40001, 5).unwrap();
    bank.set(1, 1).unwrap();
    assert_eq!(bank.master_writes(), 0);
}

// ---- write protection ------------------------------------------------------------------

#[cfg(feature = "write-protect")]
mod protection {
    use super::common::{ask, exception_reply, slave, to_slave};
    use avr_modbus::{Bank, Error};

    type Guarded = Bank<4, 8, 1, 2>;

    /// Coils 00001–00008 and holding registers 40001–40008; coils 00003–00004 and
    /// registers 40005–40008 read-only to the master.
    fn guarded() -> Guarded {
        let mut bank = Guarded::new();
        bank.add_range(1, 8).unwrap();
        bank.add_range(40001, 8).unwrap();
        bank.protect(3, 2).unwrap();
        bank.protect(40005, 4).unwrap();
        bank
    }

    #[test]
    fn a_write_touching_a_read_only_register_is_illegal_data_address_and_changes_nothing() {
        let mut bank = guarded();
        let fc16 = [0x10, 0x00, 0x03, 0x00, 0x02, 0x04, 0x11, 0x11, 0x22, 0x22]; // 40004–40005
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc16)), exception_reply(0x10, 0x02));
        assert_eq!((bank.get(40004), bank.get(40005)), (Ok(0), Ok(0)));
        let fc6 = [0x06, 0x00, 0x07, 0x12, 0x34]; // 40008
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc6)), exception_reply(0x06, 0x02));
        assert_eq!(bank.master_writes(), 0);
    }

    #[test]
    fn a_write_touching_a_read_only_coil_is_illegal_data_address_and_changes_nothing() {
        let mut bank = guarded();
        let fc15 = [0x0F, 0x00, 0x00, 0x00, 0x08, 0x01, 0xFF]; // 00001–00008
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc15)), exception_reply(0x0F, 0x02));
        assert_eq!(bank.get(1), Ok(0));
        let fc5 = [0x05, 0x00, 0x03, 0xFF, 0x00]; // 00004
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc5)), exception_reply(0x05, 0x02));
    }

    #[test]
    fn read_only_addresses_are_readable_and_set_by_the_application() {
        let mut bank = guarded();
        bank.set(40006, 0xABCD).unwrap();
        let fc3 = [0x03, 0x00, 0x05, 0x00, 0x01];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc3)), to_slave(&[0x03, 0x02, 0xAB, 0xCD]));
        let fc6 = [0x06, 0x00, 0x03, 0x12, 0x34]; // 40004 is writable
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&fc6)), to_slave(&fc6));
    }

    #[test]
    fn protect_refuses_input_tables_bad_ranges_and_a_full_list() {
        let mut bank = Guarded::new();
        assert_eq!(bank.protect(30001, 1), Err(Error::BadReference));
        assert_eq!(bank.protect(10001, 1), Err(Error::BadReference));
        assert_eq!(bank.protect(40001, 0), Err(Error::BadRange));
        bank.protect(40001, 1).unwrap();
        bank.protect(40002, 1).unwrap();
        assert_eq!(bank.protect(40003, 1), Err(Error::ProtectionsFull));
    }
}
