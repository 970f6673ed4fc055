//! Exception responses, Application Protocol v1.1b3 §7 and the order of checks of §6
//! (figures 10–25): function code (01), then quantity, byte count, value and length (03),
//! then addresses (02), then execution (04).

mod common;

use avr_modbus::internal::{pdu, Access, Request};
use avr_modbus::{Exception, Reference, Table};
use common::{
    exception_reply, exchange, full_bank, read_pdu, slave, snapshot, spec_bank, to_slave, with_crc, write_multiple_pdu,
    Failing,
};

// ---- 01 Illegal Function -------------------------------------------------------------

/// Function codes this build does not implement (the optional ones depend on features).
fn unsupported_function_codes() -> Vec<u8> {
    let mut codes = vec![0x00, 0x2B, 0x41, 0x7F];
    if !cfg!(feature = "diagnostics") {
        codes.extend([0x07, 0x08, 0x0B, 0x11]);
    }
    if !cfg!(feature = "extra-fc") {
        codes.extend([0x16, 0x17]);
    }
    codes
}

#[test]
fn unknown_function_codes_are_illegal_function() {
    for function in unsupported_function_codes() {
        let mut bank = spec_bank();
        let reply = exchange(&mut bank, &[function, 0x00, 0x00, 0x00, 0x01]);
        assert_eq!(reply, exception_reply(function, 0x01), "function {function:#04X}");
    }
}

#[test]
fn unknown_function_is_illegal_function_whatever_the_pdu_length() {
    for function in [0x2B, 0x41, 0x64] {
        for data_len in [0usize, 1, 3, 4, 6, 100, 252] {
            let mut pdu = vec![function];
            pdu.extend((0..data_len).map(|i| i as u8));
            let reply = exchange(&mut spec_bank(), &pdu);
            assert_eq!(reply, exception_reply(function, 0x01), "function {function:#04X}, {data_len} data bytes");
        }
    }
}

#[test]
#[cfg(not(feature = "diagnostics"))]
fn fc7_with_only_the_function_code_is_illegal_function() {
    let request = with_crc(&[
        common::ID, // slave address
        0x07,       // function: read exception status (serial line only, not supported)
    ]);
    let reply = with_crc(&[
        common::ID, // slave address
        0x87,       // function | 0x80
        0x01,       // exception: illegal function
    ]);
    assert_eq!(common::ask(&mut slave(), &mut spec_bank(), &request), reply);
}

#[test]
fn function_code_with_bit_7_set_in_a_request_is_illegal_function() {
    let reply = exchange(&mut spec_bank(), &[0x83, 0x00, 0x6B, 0x00, 0x01]);
    assert_eq!(reply, exception_reply(0x83, 0x01));
}

// ---- 03 Illegal Data Value: quantities -----------------------------------------------

fn read_reply_len(function: u8, qty: u16) -> usize {
    let data = if function <= 2 { usize::from(qty.div_ceil(8)) } else { 2 * usize::from(qty) };
    1 + 1 + 1 + data + 2
}

fn read_is_answered(function: u8, qty: u16) {
    let reply = exchange(&mut full_bank(), &read_pdu(function, 0, qty));
    assert_eq!(reply.len(), read_reply_len(function, qty), "FC {function} qty {qty}");
    assert_eq!(reply[1], function);
    assert_eq!(usize::from(reply[2]), reply.len() - 5, "byte count");
    assert_eq!(with_crc(&reply[..reply.len() - 2]), reply, "CRC");
}

fn read_is_illegal_data_value(function: u8, qty: u16) {
    let reply = exchange(&mut full_bank(), &read_pdu(function, 0, qty));
    assert_eq!(reply, exception_reply(function, 0x03), "FC {function} qty {qty}");
}

#[test]
fn fc1_quantity_0_is_illegal_data_value() {
    read_is_illegal_data_value(0x01, 0);
}

#[test]
fn fc1_quantity_1_is_answered() {
    read_is_answered(0x01, 1);
}

#[test]
fn fc1_quantity_2000_is_answered_with_250_bytes() {
    read_is_answered(0x01, 2000);
}

#[test]
fn fc1_quantity_2001_is_illegal_data_value() {
    read_is_illegal_data_value(0x01, 2001);
}

#[test]
fn fc1_quantity_65535_is_illegal_data_value() {
    read_is_illegal_data_value(0x01, 0xFFFF);
}

#[test]
fn fc2_quantity_0_is_illegal_data_value() {
    read_is_illegal_data_value(0x02, 0);
}

#[test]
fn fc2_quantity_1_is_answered() {
    read_is_answered(0x02, 1);
}

#[test]
fn fc2_quantity_2000_is_answered_with_250_bytes() {
    read_is_answered(0x02, 2000);
}

#[test]
fn fc2_quantity_2001_is_illegal_data_value() {
    read_is_illegal_data_value(0x02, 2001);
}

#[test]
fn fc3_quantity_0_is_illegal_data_value() {
    read_is_illegal_data_value(0x03, 0);
}

#[test]
fn fc3_quantity_1_is_answered() {
    read_is_answered(0x03, 1);
}

#[test]
fn fc3_quantity_125_is_answered_with_250_bytes() {
    read_is_answered(0x03, 125);
}

#[test]
fn fc3_quantity_126_is_illegal_data_value() {
    read_is_illegal_data_value(0x03, 126);
}

#[test]
fn fc4_quantity_0_is_illegal_data_value() {
    read_is_illegal_data_value(0x04, 0);
}

#[test]
fn fc4_quantity_1_is_answered() {
    read_is_answered(0x04, 1);
}

#[test]
fn fc4_quantity_125_is_answered_with_250_bytes() {
    read_is_answered(0x04, 125);
}

#[test]
fn fc4_quantity_126_is_illegal_data_value() {
    read_is_illegal_data_value(0x04, 126);
}

#[test]
fn fc1_quantity_2000_reply_carries_every_coil() {
    let reply = exchange(&mut full_bank(), &read_pdu(0x01, 0, 2000));
    for k in 0..2000usize {
        let bit = reply[3 + k / 8] >> (k % 8) & 1;
        assert_eq!(bit, u8::from(k % 3 == 0), "coil {k}");
    }
}

#[test]
fn fc3_quantity_125_reply_carries_every_register() {
    let reply = exchange(&mut full_bank(), &read_pdu(0x03, 0, 125));
    for k in 0..125u16 {
        let i = 3 + 2 * usize::from(k);
        assert_eq!(u16::from_be_bytes([reply[i], reply[i + 1]]), 0x0100 * k + 1, "register {k}");
    }
}

fn coils(qty: u16) -> Vec<u8> {
    (0..qty.div_ceil(8)).map(|i| i as u8).collect()
}

fn registers(qty: u16) -> Vec<u8> {
    (0..2 * qty).map(|i| i as u8).collect()
}

#[test]
fn fc15_quantity_0_is_illegal_data_value() {
    let reply = exchange(&mut full_bank(), &write_multiple_pdu(0x0F, 0, 0, &[]));
    assert_eq!(reply, exception_reply(0x0F, 0x03));
}

#[test]
fn fc15_quantity_0_with_one_data_byte_is_illegal_data_value() {
    let reply = exchange(&mut full_bank(), &write_multiple_pdu(0x0F, 0, 0, &[0x00]));
    assert_eq!(reply, exception_reply(0x0F, 0x03));
}

#[test]
fn fc15_quantity_1_is_answered() {
    let reply = exchange(&mut full_bank(), &write_multiple_pdu(0x0F, 0, 1, &[0x01]));
    assert_eq!(reply, to_slave(&[0x0F, 0x00, 0x00, 0x00, 0x01]));
}

#[test]
fn fc15_quantity_1968_is_answered() {
    let mut bank = full_bank();
    let reply = exchange(&mut bank, &write_multiple_pdu(0x0F, 0, 1968, &[0x00; 246]));
    assert_eq!(reply, to_slave(&[0x0F, 0x00, 0x00, 0x07, 0xB0]));
    assert_eq!(bank.get(Reference::coil(1965)), Ok(0), "was on, written off");
    assert_eq!(bank.get(Reference::coil(1968)), Ok(1), "was on, not written");
}

#[test]
fn fc15_quantity_1969_is_illegal_data_value() {
    let mut bank = full_bank();
    let before = snapshot(&bank, Table::Coils, 0, 1999);
    let reply = exchange(&mut bank, &write_multiple_pdu(0x0F, 0, 1969, &coils(1969)));
    assert_eq!(reply, exception_reply(0x0F, 0x03));
    assert_eq!(snapshot(&bank, Table::Coils, 0, 1999), before);
}

#[test]
fn fc16_quantity_0_is_illegal_data_value() {
    let reply = exchange(&mut full_bank(), &write_multiple_pdu(0x10, 0, 0, &[]));
    assert_eq!(reply, exception_reply(0x10, 0x03));
}

#[test]
fn fc16_quantity_1_is_answered() {
    let reply = exchange(&mut full_bank(), &write_multiple_pdu(0x10, 0, 1, &registers(1)));
    assert_eq!(reply, to_slave(&[0x10, 0x00, 0x00, 0x00, 0x01]));
}

#[test]
fn fc16_quantity_123_is_answered() {
    let mut bank = full_bank();
    let reply = exchange(&mut bank, &write_multiple_pdu(0x10, 0, 123, &registers(123)));
    assert_eq!(reply, to_slave(&[0x10, 0x00, 0x00, 0x00, 0x7B]));
    assert_eq!(bank.get(Reference::holding_register(122)), Ok(0xF4F5));
    assert_eq!(bank.get(Reference::holding_register(123)), Ok(0x7B01), "not written");
}

#[test]
fn fc16_quantity_124_pdu_is_illegal_data_value() {
    // 124 registers need a 254-byte PDU, one more than an ADU can carry: parse it alone.
    let pdu = write_multiple_pdu(0x10, 0, 124, &registers(124));
    assert_eq!(pdu.len(), 254);
    assert_eq!(Request::parse(&pdu, pdu.len()), Err(Exception::IllegalDataValue));
}

#[test]
fn fc16_quantity_124_truncated_to_fit_the_adu_is_illegal_data_value() {
    let mut pdu = write_multiple_pdu(0x10, 0, 124, &registers(124));
    pdu.truncate(253);
    let reply = exchange(&mut full_bank(), &pdu);
    assert_eq!(reply, exception_reply(0x10, 0x03));
}

// ---- 03 Illegal Data Value: values, byte counts, lengths -----------------------------

#[test]
fn fc5_value_other_than_0000_or_ff00_is_illegal_data_value() {
    for value in [0x0001u16, 0x00FF, 0x0100, 0xFF01, 0xFFFF, 0x8000, 0x00FF, 0xF000] {
        let mut bank = spec_bank();
        let [hi, lo] = value.to_be_bytes();
        let request = to_slave(&[
            0x05, // function: write single coil
            0x00, // output address hi
            0xAC, // output address lo: 172 (exists)
            hi,   // value hi
            lo,   // value lo
        ]);
        assert_eq!(common::ask(&mut slave(), &mut bank, &request), exception_reply(0x05, 0x03), "{value:#06X}");
        assert_eq!(bank.get(Reference::coil(172)), Ok(0));
    }
}

#[test]
fn fc5_bad_value_at_a_missing_address_is_illegal_data_value() {
    let reply = exchange(&mut spec_bank(), &[0x05, 0x00, 0x26, 0x12, 0x34]);
    assert_eq!(reply, exception_reply(0x05, 0x03));
}

#[test]
fn fc1_to_fc6_with_a_pdu_one_byte_short_is_illegal_data_value() {
    for function in 1..=6u8 {
        let request = [function, 0x00, 0x6B, 0x00];
        assert_eq!(exchange(&mut spec_bank(), &request), exception_reply(function, 0x03), "FC {function}");
    }
}

#[test]
fn fc1_to_fc6_with_a_pdu_one_byte_long_is_illegal_data_value() {
    for function in 1..=6u8 {
        let request = [function, 0x00, 0x00, 0x00, 0x01, 0x00];
        assert_eq!(exchange(&mut spec_bank(), &request), exception_reply(function, 0x03), "FC {function}");
    }
}

#[test]
fn fc1_to_fc6_with_only_the_function_code_is_illegal_data_value() {
    for function in 1..=6u8 {
        assert_eq!(exchange(&mut spec_bank(), &[function]), exception_reply(function, 0x03), "FC {function}");
    }
}

#[test]
fn fc6_with_an_extra_byte_changes_nothing() {
    let mut bank = spec_bank();
    let request = to_slave(&[
        0x06, // function: write single register
        0x00, // register address hi
        0x01, // register address lo
        0x12, // value hi
        0x34, // value lo
        0x56, // one byte too many
    ]);
    assert_eq!(common::ask(&mut slave(), &mut bank, &request), exception_reply(0x06, 0x03));
    assert_eq!(bank.get(40002), Ok(0));
}

#[test]
fn fc15_byte_count_smaller_than_quantity_needs_is_illegal_data_value() {
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19
        0x00, // quantity hi
        0x0A, // quantity lo: 10, needs 2 bytes
        0x01, // byte count: 1
        0xCD, // data
    ]);
    assert_eq!(common::ask(&mut slave(), &mut spec_bank(), &request), exception_reply(0x0F, 0x03));
}

#[test]
fn fc15_byte_count_larger_than_quantity_needs_is_illegal_data_value() {
    let mut bank = spec_bank();
    let before = snapshot(&bank, Table::Coils, 19, 37);
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19
        0x00, // quantity hi
        0x0A, // quantity lo: 10, needs 2 bytes
        0x03, // byte count: 3
        0x00, // data
        0x00, // data
        0x00, // data
    ]);
    assert_eq!(common::ask(&mut slave(), &mut bank, &request), exception_reply(0x0F, 0x03));
    assert_eq!(snapshot(&bank, Table::Coils, 19, 37), before);
}

#[test]
fn fc15_fewer_data_bytes_than_byte_count_is_illegal_data_value() {
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19
        0x00, // quantity hi
        0x0A, // quantity lo: 10
        0x02, // byte count: 2
        0xCD, // data, the second byte missing
    ]);
    assert_eq!(common::ask(&mut slave(), &mut spec_bank(), &request), exception_reply(0x0F, 0x03));
}

#[test]
fn fc15_more_data_bytes_than_byte_count_is_illegal_data_value() {
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19
        0x00, // quantity hi
        0x0A, // quantity lo: 10
        0x02, // byte count: 2
        0xCD, // data
        0x01, // data
        0x00, // one byte too many
    ]);
    assert_eq!(common::ask(&mut slave(), &mut spec_bank(), &request), exception_reply(0x0F, 0x03));
}

#[test]
fn fc15_without_a_byte_count_is_illegal_data_value() {
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    assert_eq!(common::ask(&mut slave(), &mut spec_bank(), &request), exception_reply(0x0F, 0x03));
}

#[test]
fn fc16_byte_count_not_twice_the_quantity_is_illegal_data_value() {
    for byte_count in [0u8, 2, 3, 5, 6] {
        let mut request = vec![
            0x10, // function: write multiple registers
            0x00, // starting address hi
            0x01, // starting address lo: 1
            0x00, // quantity hi
            0x02, // quantity lo: 2, needs 4 bytes
            byte_count,
        ];
        request.extend((0..byte_count).map(|i| 0xA0 + i));
        let mut bank = spec_bank();
        assert_eq!(exchange(&mut bank, &request), exception_reply(0x10, 0x03), "byte count {byte_count}");
        assert_eq!(bank.get(40002), Ok(0));
    }
}

#[test]
fn fc16_data_length_not_equal_to_byte_count_is_illegal_data_value() {
    for data_len in [0u8, 3, 5, 8] {
        let mut request = vec![
            0x10, // function: write multiple registers
            0x00, // starting address hi
            0x01, // starting address lo: 1
            0x00, // quantity hi
            0x02, // quantity lo: 2
            0x04, // byte count: 4
        ];
        request.extend((0..data_len).map(|i| 0xA0 + i));
        let mut bank = spec_bank();
        assert_eq!(exchange(&mut bank, &request), exception_reply(0x10, 0x03), "{data_len} data bytes");
        assert_eq!(bank.get(40002), Ok(0));
    }
}

#[test]
fn fc16_without_a_byte_count_is_illegal_data_value() {
    let reply = exchange(&mut spec_bank(), &[0x10, 0x00, 0x01, 0x00, 0x01]);
    assert_eq!(reply, exception_reply(0x10, 0x03));
}

// ---- 02 Illegal Data Address ---------------------------------------------------------

/// A bank where the last address of every table exists, so only the 65536 limit can fail.
fn bank_with_address_65535() -> common::TestBank {
    let mut bank = common::TestBank::new();
    bank.add_range(Reference::coil(65534), 2).unwrap();
    bank.add_range(Reference::discrete_input(65534), 2).unwrap();
    bank.add_range(Reference::input_register(65534), 2).unwrap();
    bank.add_range(Reference::holding_register(65534), 2).unwrap();
    bank
}

#[test]
fn reads_at_start_65535_quantity_2_are_illegal_data_address() {
    for function in 1..=4u8 {
        let reply = exchange(&mut bank_with_address_65535(), &read_pdu(function, 0xFFFF, 2));
        assert_eq!(reply, exception_reply(function, 0x02), "FC {function}");
    }
}

#[test]
fn reads_at_start_65535_quantity_1_are_answered() {
    for function in 1..=4u8 {
        let reply = exchange(&mut bank_with_address_65535(), &read_pdu(function, 0xFFFF, 1));
        assert_eq!(reply[1], function, "FC {function}");
    }
}

#[test]
fn fc15_at_start_65535_quantity_2_is_illegal_data_address() {
    let reply = exchange(&mut bank_with_address_65535(), &write_multiple_pdu(0x0F, 0xFFFF, 2, &[0x03]));
    assert_eq!(reply, exception_reply(0x0F, 0x02));
}

#[test]
fn fc16_at_start_65535_quantity_2_is_illegal_data_address() {
    let reply = exchange(&mut bank_with_address_65535(), &write_multiple_pdu(0x10, 0xFFFF, 2, &[1, 2, 3, 4]));
    assert_eq!(reply, exception_reply(0x10, 0x02));
}

#[test]
fn fc1_start_1_quantity_2000_past_an_empty_table_is_illegal_data_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x01, 1, 2000));
    assert_eq!(reply, exception_reply(0x01, 0x02));
}

#[test]
fn illegal_quantity_past_65535_is_illegal_data_value_not_address() {
    for (function, qty) in [(0x01u8, 2001u16), (0x02, 0), (0x03, 126), (0x04, 0xFFFF)] {
        let reply = exchange(&mut bank_with_address_65535(), &read_pdu(function, 0xFFFF, qty));
        assert_eq!(reply, exception_reply(function, 0x03), "FC {function} qty {qty}");
    }
}

#[test]
fn fc15_bad_byte_count_past_65535_is_illegal_data_value_not_address() {
    let reply = exchange(&mut bank_with_address_65535(), &write_multiple_pdu(0x0F, 0xFFFF, 9, &[0xFF]));
    assert_eq!(reply, exception_reply(0x0F, 0x03));
}

#[test]
fn fc16_bad_byte_count_past_65535_is_illegal_data_value_not_address() {
    let reply = exchange(&mut bank_with_address_65535(), &write_multiple_pdu(0x10, 0xFFFF, 2, &[1, 2, 3]));
    assert_eq!(reply, exception_reply(0x10, 0x03));
}

#[test]
fn fc3_quantity_0_at_a_missing_address_is_illegal_data_value_not_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x03, 50, 0));
    assert_eq!(reply, exception_reply(0x03, 0x03));
}

#[test]
fn fc1_range_running_into_a_hole_is_illegal_data_address() {
    // Coils 19..37 exist, 38 does not.
    let reply = exchange(&mut spec_bank(), &read_pdu(0x01, 37, 2));
    assert_eq!(reply, exception_reply(0x01, 0x02));
}

#[test]
fn fc1_range_spanning_a_hole_between_two_runs_is_illegal_data_address() {
    // Coils 19..37 and 40..47 exist, 38 and 39 do not.
    let reply = exchange(&mut spec_bank(), &read_pdu(0x01, 30, 15));
    assert_eq!(reply, exception_reply(0x01, 0x02));
}

#[test]
fn fc1_range_starting_before_a_run_is_illegal_data_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x01, 18, 2));
    assert_eq!(reply, exception_reply(0x01, 0x02));
}

#[test]
fn fc2_range_running_into_a_hole_is_illegal_data_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x02, 217, 2));
    assert_eq!(reply, exception_reply(0x02, 0x02));
}

#[test]
fn fc2_address_that_exists_only_as_a_coil_is_illegal_data_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x02, 40, 1));
    assert_eq!(reply, exception_reply(0x02, 0x02));
}

#[test]
fn fc3_range_running_into_a_hole_is_illegal_data_address() {
    // Holding registers 0..2 exist, 3 does not.
    let reply = exchange(&mut spec_bank(), &read_pdu(0x03, 2, 2));
    assert_eq!(reply, exception_reply(0x03, 0x02));
}

#[test]
fn fc3_address_that_exists_only_as_an_input_register_is_illegal_data_address() {
    let reply = exchange(&mut spec_bank(), &read_pdu(0x03, 8, 1));
    assert_eq!(reply, exception_reply(0x03, 0x02));
}

#[test]
fn fc4_range_over_a_one_register_hole_is_illegal_data_address() {
    // Input registers 8 and 10 exist, 9 does not.
    let reply = exchange(&mut spec_bank(), &read_pdu(0x04, 8, 3));
    assert_eq!(reply, exception_reply(0x04, 0x02));
}

#[test]
fn fc5_missing_coil_is_illegal_data_address() {
    let mut bank = spec_bank();
    let reply = exchange(&mut bank, &[0x05, 0x00, 0x26, 0xFF, 0x00]);
    assert_eq!(reply, exception_reply(0x05, 0x02));
    assert!(!bank.contains(Reference::coil(38)));
}

#[test]
fn fc6_missing_register_is_illegal_data_address() {
    let mut bank = spec_bank();
    let reply = exchange(&mut bank, &[0x06, 0x00, 0x03, 0x12, 0x34]);
    assert_eq!(reply, exception_reply(0x06, 0x02));
    assert!(!bank.contains(40004));
}

#[test]
fn fc15_touching_a_hole_is_illegal_data_address_and_writes_no_coil() {
    let mut bank = spec_bank();
    let before = snapshot(&bank, Table::Coils, 19, 47);
    let request = to_slave(&[
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x22, // starting address lo: 34 (34..37 exist, 38 does not)
        0x00, // quantity hi
        0x05, // quantity lo: 5
        0x01, // byte count
        0x00, // all off
    ]);
    assert_eq!(common::ask(&mut slave(), &mut bank, &request), exception_reply(0x0F, 0x02));
    assert_eq!(snapshot(&bank, Table::Coils, 19, 47), before);
    assert_eq!(bank.master_writes(), 0);
}

#[test]
fn fc16_touching_a_hole_is_illegal_data_address_and_writes_no_register() {
    let mut bank = spec_bank();
    let before = snapshot(&bank, Table::HoldingRegisters, 100, 115);
    let request = to_slave(&[
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x6C, // starting address lo: 108 (108, 109 exist, 110 does not)
        0x00, // quantity hi
        0x03, // quantity lo: 3
        0x06, // byte count
        0xDE, // register 108 hi
        0xAD, // register 108 lo
        0xBE, // register 109 hi
        0xEF, // register 109 lo
        0x12, // register 110 hi
        0x34, // register 110 lo
    ]);
    assert_eq!(common::ask(&mut slave(), &mut bank, &request), exception_reply(0x10, 0x02));
    assert_eq!(snapshot(&bank, Table::HoldingRegisters, 100, 115), before);
    assert_eq!(bank.master_writes(), 0);
}

#[test]
fn fc16_starting_in_a_hole_is_illegal_data_address_and_writes_no_register() {
    let mut bank = spec_bank();
    let before = snapshot(&bank, Table::HoldingRegisters, 100, 115);
    let reply = exchange(&mut bank, &write_multiple_pdu(0x10, 106, 4, &[0x55; 8]));
    assert_eq!(reply, exception_reply(0x10, 0x02));
    assert_eq!(snapshot(&bank, Table::HoldingRegisters, 100, 115), before);
}

// ---- 04 Server Device Failure --------------------------------------------------------

#[test]
fn failing_model_answers_every_valid_request_with_server_device_failure() {
    let requests: [&[u8]; 8] = [
        &[0x01, 0x00, 0x13, 0x00, 0x13],
        &[0x02, 0x00, 0xC4, 0x00, 0x16],
        &[0x03, 0x00, 0x6B, 0x00, 0x03],
        &[0x04, 0x00, 0x08, 0x00, 0x01],
        &[0x05, 0x00, 0xAC, 0xFF, 0x00],
        &[0x06, 0x00, 0x01, 0x00, 0x03],
        &[0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01],
        &[0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02],
    ];
    for request in requests {
        let mut model = Failing(spec_bank());
        assert_eq!(exchange(&mut model, request), exception_reply(request[0], 0x04), "FC {}", request[0]);
    }
}

#[test]
fn failing_writes_change_nothing() {
    let mut model = Failing(spec_bank());
    exchange(&mut model, &[0x05, 0x00, 0xAC, 0xFF, 0x00]);
    exchange(&mut model, &[0x06, 0x00, 0x01, 0x00, 0x03]);
    exchange(&mut model, &[0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0x00, 0x00]);
    exchange(&mut model, &[0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02]);
    let fresh = spec_bank();
    for table in [Table::Coils, Table::HoldingRegisters] {
        assert_eq!(snapshot(&model.0, table, 0, 200), snapshot(&fresh, table, 0, 200), "{table:?}");
    }
    assert_eq!(model.0.master_writes(), 0);
}

#[test]
fn missing_address_is_illegal_data_address_before_server_device_failure() {
    let mut model = Failing(spec_bank());
    assert_eq!(exchange(&mut model, &read_pdu(0x03, 2, 2)), exception_reply(0x03, 0x02));
    assert_eq!(exchange(&mut model, &[0x06, 0x00, 0x03, 0x00, 0x01]), exception_reply(0x06, 0x02));
}

#[test]
fn illegal_quantity_is_illegal_data_value_before_server_device_failure() {
    let mut model = Failing(spec_bank());
    assert_eq!(exchange(&mut model, &read_pdu(0x03, 107, 0)), exception_reply(0x03, 0x03));
}

#[test]
fn unknown_function_is_illegal_function_before_server_device_failure() {
    let mut model = Failing(spec_bank());
    assert_eq!(exchange(&mut model, &[0x2B, 0x0E, 0x01, 0x00]), exception_reply(0x2B, 0x01));
}

// ---- the PDU layer on its own ----------------------------------------------------------

#[test]
fn respond_leaves_the_request_in_place_on_an_exception() {
    let mut bank = spec_bank();
    let mut buf = [0u8; 253];
    let request = [0x03, 0x00, 0x02, 0x00, 0x02];
    buf[..5].copy_from_slice(&request);
    assert_eq!(pdu::respond(&mut buf, 5, &mut bank), Err(Exception::IllegalDataAddress));
    assert_eq!(buf[..5], request);
    assert_eq!(pdu::encode_exception(&mut buf, Exception::IllegalDataAddress), 2);
    assert_eq!(buf[..2], [0x83, 0x02]);
}

#[test]
fn exception_codes_have_their_spec_values() {
    assert_eq!(Exception::IllegalFunction.code(), 0x01);
    assert_eq!(Exception::IllegalDataAddress.code(), 0x02);
    assert_eq!(Exception::IllegalDataValue.code(), 0x03);
    assert_eq!(Exception::ServerDeviceFailure.code(), 0x04);
}

#[test]
fn exceptions_are_counted() {
    let mut bank = spec_bank();
    let mut slave = slave();
    common::ask(&mut slave, &mut bank, &to_slave(&[0x41]));
    common::ask(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 0, 0)));
    common::ask(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 0, 1)));
    common::ask(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 3, 1)));
    let counters = slave.counters();
    assert_eq!((counters.exceptions, counters.replies, counters.messages), (3, 4, 4));
}

// ---- the 65536 limit is the engine's, whatever the data model ------------------------------

/// A data model where every address of every table exists (and reads 0).
struct Everything;

impl avr_modbus::DataModel for Everything {
    fn has_range(&self, _: Table, _: u16, _: u16) -> bool {
        true
    }

    fn read_bits(&self, _: Table, _: u16, _: u16, out: &mut [u8]) -> Result<(), Exception> {
        out.fill(0);
        Ok(())
    }

    fn read_registers(&self, _: Table, _: u16, out: &mut [u8]) -> Result<(), Exception> {
        out.fill(0);
        Ok(())
    }

    fn write_coils(&mut self, _: u16, _: u16, _: &[u8]) -> Result<(), Exception> {
        Ok(())
    }

    fn write_registers(&mut self, _: u16, _: &[u8]) -> Result<(), Exception> {
        Ok(())
    }
}

#[test]
fn start_plus_quantity_past_65536_is_illegal_data_address_even_if_the_model_would_accept_it() {
    let requests = [
        read_pdu(0x01, 0xFFFF, 2),
        read_pdu(0x02, 0xF831, 2000),
        read_pdu(0x03, 0xFF84, 125),
        read_pdu(0x04, 0xFFFF, 2),
        write_multiple_pdu(0x0F, 0xFFFF, 2, &[0x03]),
        write_multiple_pdu(0x10, 0xFFFF, 2, &[0, 1, 0, 2]),
    ];
    for pdu in requests {
        assert_eq!(exchange(&mut Everything, &pdu), exception_reply(pdu[0], 0x02), "{pdu:02X?}");
    }
}

#[test]
fn start_plus_quantity_of_exactly_65536_is_answered() {
    let requests = [
        read_pdu(0x01, 0xFFFF, 1),
        read_pdu(0x02, 0xF830, 2000),
        read_pdu(0x03, 0xFF83, 125),
        read_pdu(0x04, 0xFFFE, 2),
        write_multiple_pdu(0x0F, 0xFFFE, 2, &[0x03]),
        write_multiple_pdu(0x10, 0xFFFE, 2, &[0, 1, 0, 2]),
    ];
    for pdu in requests {
        assert_eq!(exchange(&mut Everything, &pdu)[1], pdu[0], "{pdu:02X?}");
    }
}

#[test]
fn request_parse_applies_the_65536_limit() {
    assert_eq!(Request::parse(&read_pdu(0x03, 0xFFFF, 2), 5), Err(Exception::IllegalDataAddress));
    assert_eq!(
        Request::parse(&read_pdu(0x03, 0xFFFF, 1), 5),
        Ok(Request {
            table: Table::HoldingRegisters,
            start: 0xFFFF,
            qty: 1,
            access: Access::Read,
            data_at: 2,
            data_len: 2
        })
    );
    let pdu = write_multiple_pdu(0x0F, 0xFFF9, 8, &[0xFF]);
    assert_eq!(Request::parse(&pdu, pdu.len()), Err(Exception::IllegalDataAddress));
}
