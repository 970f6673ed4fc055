//! Normal replies of FC 01–06, 0F, 10 (Application Protocol v1.1b3 §6.1–6.6, §6.11,
//! §6.12), byte for byte through the whole ADU: the spec's own examples, sent to slave
//! 0x11 whose bank has holes around the addresses they use.

mod common;

use avr_modbus::Reference;
use common::{ask, slave, spec_bank, with_crc, ID};

#[test]
fn fc1_read_coils_spec_example_is_answered_byte_for_byte() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x01, // function: read coils
        0x00, // starting address hi
        0x13, // starting address lo: 19 (coil 00020)
        0x00, // quantity hi
        0x13, // quantity lo: 19
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x03, // byte count
        0xCD, // coils 00027..00020 (00020 is bit 0)
        0x6B, // coils 00035..00028
        0x05, // coils 00038..00036, the five unused high bits zero
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc1_reading_from_inside_a_run_shifts_the_first_coil_to_bit_0() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x01, // function: read coils
        0x00, // starting address hi
        0x15, // starting address lo: 21 (third coil of the run)
        0x00, // quantity hi
        0x08, // quantity lo: 8
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x01, // byte count
        0xF3, // (0xCD >> 2) | (0x6B << 6): coils 21..28
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc1_unused_high_bits_of_the_last_byte_are_zero_even_when_the_next_coils_are_on() {
    let mut bank = spec_bank(); // coils 40..47 are all on
    let request = with_crc(&[
        ID,   // slave address
        0x01, // function: read coils
        0x00, // starting address hi
        0x28, // starting address lo: 40
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x01, // byte count
        0x07, // three coils on, bits 3..7 zero
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc2_read_discrete_inputs_spec_example_is_answered_byte_for_byte() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x02, // function: read discrete inputs
        0x00, // starting address hi
        0xC4, // starting address lo: 196 (input 10197)
        0x00, // quantity hi
        0x16, // quantity lo: 22
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x02, // function
        0x03, // byte count
        0xAC, // inputs 10204..10197
        0xDB, // inputs 10212..10205
        0x35, // inputs 10218..10213, the two unused high bits zero
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc3_read_holding_registers_spec_example_is_big_endian() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x6B, // starting address lo: 107 (register 40108)
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x06, // byte count
        0x02, // register 40108 hi
        0x2B, // register 40108 lo: 555
        0x00, // register 40109 hi
        0x00, // register 40109 lo: 0
        0x00, // register 40110 hi
        0x64, // register 40110 lo: 100
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc3_request_bytes_match_the_spec_crc_check_value() {
    // Serial Line §6.2.2 check value: 11 03 00 6B 00 03 → CRC 76 87 (low byte first).
    let request = with_crc(&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03]);
    assert_eq!(&request[6..], &[0x76, 0x87]);
}

#[test]
fn fc4_read_input_registers_spec_example_is_answered_byte_for_byte() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x04, // function: read input registers
        0x00, // starting address hi
        0x08, // starting address lo: 8 (register 30009)
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x04, // function
        0x02, // byte count
        0x00, // register 30009 hi
        0x0A, // register 30009 lo: 10
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc4_register_high_byte_goes_first() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x04, // function: read input registers
        0x00, // starting address hi
        0x0A, // starting address lo: 10 (register 30011)
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x04, // function
        0x02, // byte count
        0x12, // 0x1234 hi
        0x34, // 0x1234 lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
}

#[test]
fn fc5_write_single_coil_on_is_echoed_and_sets_the_coil() {
    let mut bank = spec_bank();
    assert_eq!(bank.get(Reference::coil(172)), Ok(0));
    let request = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0x00, // output address hi
        0xAC, // output address lo: 172 (coil 00173)
        0xFF, // value hi: ON
        0x00, // value lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), request);
    assert_eq!(bank.get(173), Ok(1));
}

#[test]
fn fc5_write_single_coil_off_is_echoed_and_clears_the_coil() {
    let mut bank = spec_bank();
    bank.set(173, 1).unwrap();
    let request = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0x00, // output address hi
        0xAC, // output address lo: 172 (coil 00173)
        0x00, // value hi: OFF
        0x00, // value lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), request);
    assert_eq!(bank.get(173), Ok(0));
}

#[test]
fn fc6_write_single_register_spec_example_is_echoed_and_stored() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x01, // register address lo: 1 (register 40002)
        0x00, // value hi
        0x03, // value lo: 3
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), request);
    assert_eq!(bank.get(40002), Ok(0x0003));
    assert_eq!(bank.get(40001), Ok(0));
    assert_eq!(bank.get(40003), Ok(0));
}

#[test]
fn fc6_value_is_taken_high_byte_first() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x70, // register address lo: 112 (register 40113)
        0xBE, // value hi
        0xEF, // value lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), request);
    assert_eq!(bank.get(40113), Ok(0xBEEF));
}

#[test]
fn fc15_write_multiple_coils_spec_example_answers_start_and_quantity() {
    let mut bank = spec_bank();
    for address in 19..=37 {
        bank.set(Reference::coil(address), 0).unwrap();
    }
    let request = with_crc(&[
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x13, // starting address lo: 19 (coil 00020)
        0x00, // quantity hi
        0x0A, // quantity lo: 10
        0x02, // byte count
        0xCD, // coils 00027..00020
        0x01, // coils 00029..00028
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x0F, // function
        0x00, // starting address hi
        0x13, // starting address lo
        0x00, // quantity hi
        0x0A, // quantity lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
    let written: Vec<u16> = (19..=28).map(|a| bank.get(Reference::coil(a)).unwrap()).collect();
    assert_eq!(written, [1, 0, 1, 1, 0, 0, 1, 1, 1, 0]);
}

#[test]
fn fc15_bits_past_the_quantity_in_the_last_byte_are_not_written() {
    let mut bank = spec_bank();
    for address in 19..=37 {
        bank.set(Reference::coil(address), 0).unwrap();
    }
    let request = with_crc(&[
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x14, // starting address lo: 20
        0x00, // quantity hi
        0x03, // quantity lo: 3
        0x01, // byte count
        0xFF, // three coils on; bits 3..7 are padding
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x0F, // function
        0x00, // starting address hi
        0x14, // starting address lo
        0x00, // quantity hi
        0x03, // quantity lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
    let coils: Vec<u16> = (19..=24).map(|a| bank.get(Reference::coil(a)).unwrap()).collect();
    assert_eq!(coils, [0, 1, 1, 1, 0, 0]);
}

#[test]
fn fc16_write_multiple_registers_spec_example_answers_start_and_quantity() {
    let mut bank = spec_bank();
    let request = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x01, // starting address lo: 1 (register 40002)
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0x00, // register 40002 hi
        0x0A, // register 40002 lo
        0x01, // register 40003 hi
        0x02, // register 40003 lo
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x10, // function
        0x00, // starting address hi
        0x01, // starting address lo
        0x00, // quantity hi
        0x02, // quantity lo
    ]);
    assert_eq!(ask(&mut slave(), &mut bank, &request), reply);
    assert_eq!(bank.get(40001), Ok(0));
    assert_eq!(bank.get(40002), Ok(0x000A));
    assert_eq!(bank.get(40003), Ok(0x0102));
}

#[test]
fn fc16_then_fc3_reads_back_what_was_written() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let write = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x6B, // starting address lo: 107
        0x00, // quantity hi
        0x03, // quantity lo: 3
        0x06, // byte count
        0xA1, // register 40108 hi
        0xB2, // register 40108 lo
        0xC3, // register 40109 hi
        0xD4, // register 40109 lo
        0xE5, // register 40110 hi
        0xF6, // register 40110 lo
    ]);
    ask(&mut slave, &mut bank, &write);
    let read = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x6B, // starting address lo: 107
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x06, // byte count
        0xA1, // register 40108 hi
        0xB2, // register 40108 lo
        0xC3, // register 40109 hi
        0xD4, // register 40109 lo
        0xE5, // register 40110 hi
        0xF6, // register 40110 lo
    ]);
    assert_eq!(ask(&mut slave, &mut bank, &read), reply);
}
