//! The optional function codes end to end, Application Protocol v1.1b3 §6.7 (FC 7 Read
//! Exception Status), §6.8 (FC 8 Diagnostics, with the counters of Serial Line v1.02
//! §6.1.3), §6.9 (FC 11 = 0x0B Get Comm Event Counter), §6.13 (FC 17 = 0x11 Report Server
//! ID), §6.16 (FC 22 = 0x16 Mask Write Register) and §6.17 (FC 23 = 0x17 Read/Write
//! Multiple Registers): the release `configurable` firmware in simavr at 19200 8E1,
//! requests sent on the wire, replies compared byte for byte with frames whose CRC the
//! test computes itself.
//!
//! The firmware's map: coils 00001–00008, input registers 30001–30003, holding registers
//! 40001–40004 and the settings block 40101–40104 (left alone here); device info
//! "avr-modbus configurable"; no exception status bits. FC 8/04, which is never
//! answered, is in `sim_silent.rs`.

// The firmware is built with these features (see `make firmware`); the test needs them too
// (`required-features` in Cargo.toml).

mod sim;

use sim::{exception_reply, read_request, registers_reply, with_crc, write_register_request, Line, Rtu, ID};

fn configurable() -> Rtu {
    Rtu::boot("configurable", Line::B19200_8E1)
}

/// FC 8 to the slave with sub-function `sub` and data `data`.
fn diagnostic(sub: u8, data: u16) -> Vec<u8> {
    let [hi, lo] = data.to_be_bytes();
    with_crc(&[
        ID,   // slave address
        0x08, // function: diagnostics
        0x00, // sub-function hi
        sub,  // sub-function lo
        hi,   // data hi
        lo,   // data lo
    ])
}

/// The reply of a counter sub-function: the sub-function echoed, then the count.
fn count_reply(sub: u8, count: u16) -> Vec<u8> {
    let [hi, lo] = count.to_be_bytes();
    with_crc(&[
        ID,   // slave address
        0x08, // function
        0x00, // sub-function hi
        sub,  // sub-function lo
        hi,   // count hi
        lo,   // count lo
    ])
}

/// FC 3 of 40001 (zero after reset): a request answered normally.
fn read_40001() -> Vec<u8> {
    read_request(ID, 0x03, 0, 1)
}

/// FC 3 of 40001 with a bad CRC.
fn bad_crc() -> Vec<u8> {
    let mut frame = read_40001();
    frame[7] ^= 0xFF; // CRC hi
    frame
}

/// A broadcast FC 6 writing 40002.
fn broadcast_write() -> Vec<u8> {
    write_register_request(0, 1, 7)
}

/// Sends `frame` and checks that it gets no reply.
fn unanswered(rtu: &mut Rtu, frame: &[u8]) {
    let reply = rtu.ask(frame);
    assert!(reply.is_empty(), "{frame:02X?} answered {reply:02X?}");
}

// ---------------------------------------------------------------------------------------
// FC 7: Read Exception Status

#[test]
fn fc7_reads_the_exception_status_byte() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x07, // function: read exception status
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x07, // function
        0x00, // status bits: none set by the firmware
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn fc7_with_data_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x07, // function: read exception status
        0x00, // a data byte FC 7 does not have
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x07, 0x03));
}

// ---------------------------------------------------------------------------------------
// FC 8: Diagnostics, sub-functions 00, 01, 0A

#[test]
fn fc8_sub00_echoes_one_data_word() {
    let mut rtu = configurable();
    let request = diagnostic(0x00, 0xA537);
    assert_eq!(rtu.ask(&request), request);
}

#[test]
fn fc8_sub00_echoes_several_data_words() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x08, // function: diagnostics
        0x00, // sub-function hi
        0x00, // sub-function lo: return query data
        0x12, 0x34, // data word 1
        0x56, 0x78, // data word 2
        0x9A, 0xBC, // data word 3
    ]);
    assert_eq!(rtu.ask(&request), request);
}

#[test]
fn fc8_sub00_with_an_odd_number_of_data_bytes_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x08, // function: diagnostics
        0x00, // sub-function hi
        0x00, // sub-function lo: return query data
        0x12, // data: one byte, not a word
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x08, 0x03));
}

#[test]
fn fc8_sub01_is_echoed_and_clears_the_counters() {
    for data in [0x0000, 0xFF00] {
        let mut rtu = configurable();
        rtu.ask(&read_40001());
        unanswered(&mut rtu, &bad_crc());
        let restart = diagnostic(0x01, data);
        assert_eq!(rtu.ask(&restart), restart, "FC 8/01 data {data:04X} echoes");
        assert_eq!(rtu.ask(&diagnostic(0x0B, 0)), count_reply(0x0B, 1), "bus messages: only the 0B request");
        assert_eq!(rtu.ask(&diagnostic(0x0C, 0)), count_reply(0x0C, 0), "CRC errors cleared");
    }
}

#[test]
fn fc8_sub01_with_data_other_than_0000_or_ff00_is_exception_03() {
    let mut rtu = configurable();
    assert_eq!(rtu.ask(&diagnostic(0x01, 0x1234)), exception_reply(ID, 0x08, 0x03));
}

#[test]
fn fc8_sub04_with_data_other_than_0000_is_exception_03_and_keeps_the_slave_online() {
    let mut rtu = configurable();
    assert_eq!(rtu.ask(&diagnostic(0x04, 0xFF00)), exception_reply(ID, 0x08, 0x03));
    assert_eq!(rtu.ask(&read_40001()), registers_reply(ID, 0x03, &[0]), "still answering");
}

#[test]
fn fc8_sub0a_is_echoed_and_clears_the_counters() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    unanswered(&mut rtu, &bad_crc());
    let clear = diagnostic(0x0A, 0x0000);
    assert_eq!(rtu.ask(&clear), clear);
    assert_eq!(rtu.ask(&diagnostic(0x0E, 0)), count_reply(0x0E, 1), "slave messages: only the 0E request");
    assert_eq!(rtu.ask(&diagnostic(0x0C, 0)), count_reply(0x0C, 0), "CRC errors cleared");
}

// ---------------------------------------------------------------------------------------
// FC 8: the counters, sub-functions 0B–12 (each counts from power-up)

#[test]
fn fc8_sub0b_returns_the_bus_message_count() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    unanswered(&mut rtu, &bad_crc());
    unanswered(&mut rtu, &read_request(2, 0x03, 0, 1));
    unanswered(&mut rtu, &broadcast_write());
    // Every frame on the bus: the four above and the 0B request itself.
    assert_eq!(rtu.ask(&diagnostic(0x0B, 0)), count_reply(0x0B, 5));
}

#[test]
fn fc8_sub0c_returns_the_crc_error_count() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    unanswered(&mut rtu, &bad_crc());
    unanswered(&mut rtu, &bad_crc());
    assert_eq!(rtu.ask(&diagnostic(0x0C, 0)), count_reply(0x0C, 2));
}

#[test]
fn fc8_sub0d_returns_the_exception_count() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 4, 1)), exception_reply(ID, 0x03, 0x02), "40005 is missing");
    assert_eq!(rtu.ask(&diagnostic(0x02, 0)), exception_reply(ID, 0x08, 0x01), "sub-function 02 is not supported");
    assert_eq!(rtu.ask(&diagnostic(0x0D, 0)), count_reply(0x0D, 2));
}

#[test]
fn fc8_sub0e_returns_the_slave_message_count() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    unanswered(&mut rtu, &bad_crc());
    unanswered(&mut rtu, &read_request(2, 0x03, 0, 1));
    unanswered(&mut rtu, &broadcast_write());
    // Good frames for this slave or broadcast: FC 3, the broadcast, the 0E request itself.
    assert_eq!(rtu.ask(&diagnostic(0x0E, 0)), count_reply(0x0E, 3));
}

#[test]
fn fc8_sub0f_returns_the_no_response_count() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    unanswered(&mut rtu, &broadcast_write());
    unanswered(&mut rtu, &broadcast_write());
    unanswered(&mut rtu, &read_request(2, 0x03, 0, 1));
    // Messages for this slave left unanswered: the two broadcasts (not the other slave's).
    assert_eq!(rtu.ask(&diagnostic(0x0F, 0)), count_reply(0x0F, 2));
}

#[test]
fn fc8_sub10_slave_nak_count_is_zero() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    assert_eq!(rtu.ask(&diagnostic(0x10, 0)), count_reply(0x10, 0));
}

#[test]
fn fc8_sub11_slave_busy_count_is_zero() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    assert_eq!(rtu.ask(&diagnostic(0x11, 0)), count_reply(0x11, 0));
}

#[test]
fn fc8_sub12_returns_the_character_overrun_count() {
    let mut rtu = configurable();
    // 300 bytes in one frame: past 256 the rest is lost, and counted as an overrun.
    let flood: Vec<u8> = read_40001().into_iter().cycle().take(300).collect();
    unanswered(&mut rtu, &flood);
    assert_eq!(rtu.uno.uart_counters().rx_overruns, 0, "the USART itself lost nothing");
    assert_eq!(rtu.ask(&diagnostic(0x12, 0)), count_reply(0x12, 1));
}

// ---------------------------------------------------------------------------------------
// FC 8: exceptions

#[test]
fn fc8_unknown_sub_functions_are_exception_01() {
    let mut rtu = configurable();
    // 02 diagnostic register, 03 ASCII delimiter, 13 and 15 reserved, 14 clear overrun
    // counter: none of them implemented.
    for sub in [0x02, 0x03, 0x13, 0x14, 0x15, 0xFF] {
        assert_eq!(rtu.ask(&diagnostic(sub, 0)), exception_reply(ID, 0x08, 0x01), "sub-function {sub:02X}");
    }
}

#[test]
fn fc8_counter_sub_function_with_data_other_than_0000_is_exception_03() {
    let mut rtu = configurable();
    for sub in 0x0B..=0x12 {
        assert_eq!(rtu.ask(&diagnostic(sub, 0x0001)), exception_reply(ID, 0x08, 0x03), "sub-function {sub:02X}");
    }
}

#[test]
fn fc8_pdu_shorter_than_sub_function_and_data_is_exception_03() {
    let mut rtu = configurable();
    for pdu in [
        &[0x08][..],               // function alone
        &[0x08, 0x00],             // half a sub-function
        &[0x08, 0x00, 0x0B],       // sub-function 0B without data
        &[0x08, 0x00, 0x0B, 0x00], // half a data word
    ] {
        let mut frame = vec![ID];
        frame.extend_from_slice(pdu);
        assert_eq!(rtu.ask(&with_crc(&frame)), exception_reply(ID, 0x08, 0x03), "PDU {pdu:02X?}");
    }
}

// ---------------------------------------------------------------------------------------
// FC 11: Get Comm Event Counter

#[test]
fn fc11_returns_status_0000_and_the_successful_requests_before_it() {
    let mut rtu = configurable();
    rtu.ask(&read_40001());
    rtu.ask(&read_40001());
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 4, 1)), exception_reply(ID, 0x03, 0x02), "not counted");
    let request = with_crc(&[
        ID,   // slave address
        0x0B, // function: get comm event counter
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x0B, // function
        0x00, // status hi
        0x00, // status lo: no program command in progress
        0x00, // event count hi
        0x02, // event count lo: the two FC 3
    ]);
    assert_eq!(rtu.ask(&request), reply);
    assert_eq!(rtu.ask(&request), reply, "FC 11 does not count itself");
}

#[test]
fn fc11_with_data_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x0B, // function: get comm event counter
        0x00, // a data byte FC 11 does not have
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x0B, 0x03));
}

// ---------------------------------------------------------------------------------------
// FC 17: Report Server ID

#[test]
fn fc17_reports_the_slave_id_run_indicator_and_device_info() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x11, // function: report server id
    ]);
    let info = b"avr-modbus configurable";
    let mut reply = vec![
        ID,                   // slave address
        0x11,                 // function
        2 + info.len() as u8, // byte count: id, run indicator, device info
        ID,                   // server id
        0xFF,                 // run indicator: ON
    ];
    reply.extend_from_slice(info); // device info
    assert_eq!(rtu.ask(&request), with_crc(&reply));
}

#[test]
fn fc17_with_data_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x11, // function: report server id
        0x00, // a data byte FC 17 does not have
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x11, 0x03));
}

// ---------------------------------------------------------------------------------------
// FC 22: Mask Write Register

#[test]
fn fc22_ands_then_ors_as_the_spec_example() {
    let mut rtu = configurable();
    let preset = write_register_request(ID, 0, 0x0012);
    assert_eq!(rtu.ask(&preset), preset, "40001 = 0x0012");
    let request = with_crc(&[
        ID,   // slave address
        0x16, // function: mask write register
        0x00, // address hi
        0x00, // address lo: 40001
        0x00, // AND mask hi
        0xF2, // AND mask lo
        0x00, // OR mask hi
        0x25, // OR mask lo
    ]);
    assert_eq!(rtu.ask(&request), request, "the reply echoes the request");
    // (0x0012 AND 0x00F2) OR (0x0025 AND NOT 0x00F2) = 0x0017.
    assert_eq!(rtu.ask(&read_40001()), registers_reply(ID, 0x03, &[0x0017]));
}

#[test]
fn fc22_on_a_missing_register_is_exception_02() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x16, // function: mask write register
        0x00, // address hi
        0x04, // address lo: 40005, not in the map
        0x00, // AND mask hi
        0xF2, // AND mask lo
        0x00, // OR mask hi
        0x25, // OR mask lo
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x16, 0x02));
}

#[test]
fn fc22_without_its_or_mask_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x16, // function: mask write register
        0x00, // address hi
        0x00, // address lo: 40001
        0x00, // AND mask hi
        0xF2, // AND mask lo
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x16, 0x03));
}

// ---------------------------------------------------------------------------------------
// FC 23: Read/Write Multiple Registers

#[test]
fn fc23_writes_first_then_reads() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x17, // function: read/write multiple registers
        0x00, // read starting address hi
        0x00, // read starting address lo: 40001
        0x00, // quantity to read hi
        0x04, // quantity to read lo: 4
        0x00, // write starting address hi
        0x01, // write starting address lo: 40002
        0x00, // quantity to write hi
        0x02, // quantity to write lo: 2
        0x04, // write byte count
        0x00, 0xFF, // 40002
        0x12, 0x34, // 40003
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x17, // function
        0x08, // byte count
        0x00, 0x00, // 40001
        0x00, 0xFF, // 40002, just written
        0x12, 0x34, // 40003, just written
        0x00, 0x00, // 40004
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn fc23_with_a_missing_read_register_is_exception_02_and_writes_nothing() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x17, // function: read/write multiple registers
        0x00, // read starting address hi
        0x02, // read starting address lo: 40003
        0x00, // quantity to read hi
        0x03, // quantity to read lo: 3, up to 40005, not in the map
        0x00, // write starting address hi
        0x00, // write starting address lo: 40001
        0x00, // quantity to write hi
        0x01, // quantity to write lo: 1
        0x02, // write byte count
        0x43, 0x21, // 40001
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x17, 0x02));
    assert_eq!(rtu.ask(&read_40001()), registers_reply(ID, 0x03, &[0]), "40001 not written");
}

#[test]
fn fc23_write_quantity_0_is_exception_03() {
    let mut rtu = configurable();
    let request = with_crc(&[
        ID,   // slave address
        0x17, // function: read/write multiple registers
        0x00, // read starting address hi
        0x00, // read starting address lo: 40001
        0x00, // quantity to read hi
        0x01, // quantity to read lo: 1
        0x00, // write starting address hi
        0x00, // write starting address lo: 40001
        0x00, // quantity to write hi
        0x00, // quantity to write lo: 0
        0x00, // write byte count
    ]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x17, 0x03));
}
