//! The contract from a run-time `Bank` (`examples/sixteen_each_bank.rs`) end to end in
//! simavr at 19200 8E1, against the same contract fixed at build time
//! (`examples/sixteen_each.rs`): every function code (Application Protocol v1.1b3
//! §6.1–6.6, §6.11, §6.12), exceptions 01–03 (§7), requests longer than the bank's frame
//! buffer (sized from its capacity: 57 bytes) and a bad CRC (Serial Line v1.02 §2.5.1.2)
//! get the same replies, or the same silence, from both.

mod sim;

use sim::{exception_reply, read_request, registers_reply, with_crc, Line, Rtu, ID};

fn bank() -> Rtu {
    Rtu::boot("sixteen_each_bank", Line::B19200_8E1)
}

fn map() -> Rtu {
    Rtu::boot("sixteen_each", Line::B19200_8E1)
}

/// FC 16 to `start` of `qty` registers, byte count `count`, `data` data bytes 0, 1, 2 …
fn fc16(start: u16, qty: u16, count: u8, data: usize) -> Vec<u8> {
    let mut frame = vec![ID, 0x10];
    frame.extend(start.to_be_bytes());
    frame.extend(qty.to_be_bytes());
    frame.push(count);
    frame.extend((0..data).map(|i| i as u8));
    with_crc(&frame)
}

#[test]
fn fc16_then_fc3_round_trip_through_the_bank() {
    let mut rtu = bank();
    let write = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x0E, // starting address lo: 40015
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0x12, // 40015 hi
        0x34, // 40015 lo
        0xAB, // 40016 hi
        0xCD, // 40016 lo
    ]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x0E, 0x00, 0x02]));
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 14, 2)), registers_reply(ID, 0x03, &[0x1234, 0xABCD]));
}

#[test]
fn fc15_then_fc1_round_trip_through_the_bank() {
    let mut rtu = bank();
    let write = with_crc(&[
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x03, // starting address lo: coil 00004
        0x00, // quantity hi
        0x0A, // quantity lo: 10
        0x02, // byte count
        0xCD, // coils 00011..00004
        0x01, // coils 00013..00012
    ]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x0F, 0x00, 0x03, 0x00, 0x0A]));
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x02, // byte count
        0x68, // coils 00008..00001: 0110 1000
        0x0E, // coils 00016..00009: 0000 1110
    ]);
    assert_eq!(rtu.ask(&read_request(ID, 0x01, 0, 16)), reply);
}

#[test]
fn the_bank_reads_each_table_to_its_end_and_not_past_it() {
    let mut rtu = bank();
    assert_eq!(rtu.ask(&read_request(ID, 0x02, 0, 16)), with_crc(&[ID, 0x02, 0x02, 0x00, 0x00]));
    assert_eq!(rtu.ask(&read_request(ID, 0x04, 0, 8)), registers_reply(ID, 0x04, &[0; 8]));
    assert_eq!(rtu.ask(&read_request(ID, 0x04, 0, 9)), exception_reply(ID, 0x04, 0x02));
    assert_eq!(rtu.ask(&read_request(ID, 0x02, 15, 2)), exception_reply(ID, 0x02, 0x02));
}

#[test]
fn fc16_of_100_registers_longer_than_the_banks_buffer_is_illegal_data_address() {
    // 209 bytes against a 57-byte buffer: received whole, CRC checked over all of it.
    let mut rtu = bank();
    assert_eq!(rtu.ask(&fc16(0, 100, 200, 200)), exception_reply(ID, 0x10, 0x02));
    assert_eq!(rtu.ask(&fc16(0x0100, 100, 199, 199)), exception_reply(ID, 0x10, 0x03));
}

#[test]
fn a_long_frame_with_a_bad_crc_gets_silence_from_the_bank() {
    let mut rtu = bank();
    let mut frame = fc16(0, 100, 200, 200);
    frame[150] ^= 0x04;
    let end = rtu.send(&frame);
    assert!(rtu.receive(end).reply.is_empty());
    rtu.assert_silent("a frame with a bad CRC");
    // And answers the next one.
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 1)), registers_reply(ID, 0x03, &[0]));
}

#[test]
fn the_bank_answers_every_request_as_the_compiled_map_does() {
    let requests = [
        read_request(ID, 0x01, 0, 16),
        read_request(ID, 0x01, 0, 17),
        read_request(ID, 0x01, 0, 0),
        read_request(ID, 0x01, 0, 2000),
        read_request(ID, 0x01, 0, 2001),
        read_request(ID, 0x02, 5, 11),
        read_request(ID, 0x02, 16, 1),
        read_request(ID, 0x03, 0, 16),
        read_request(ID, 0x03, 10, 7),
        read_request(ID, 0x03, 0, 125),
        read_request(ID, 0x03, 0, 126),
        read_request(ID, 0x04, 7, 1),
        read_request(ID, 0x04, 0xFFFF, 2),
        with_crc(&[ID, 0x05, 0x00, 0x0F, 0xFF, 0x00]),
        with_crc(&[ID, 0x05, 0x00, 0x10, 0xFF, 0x00]),
        with_crc(&[ID, 0x05, 0x00, 0x00, 0x12, 0x34]),
        with_crc(&[ID, 0x06, 0x00, 0x0F, 0xBE, 0xEF]),
        with_crc(&[ID, 0x06, 0x00, 0x10, 0xBE, 0xEF]),
        with_crc(&[ID, 0x0F, 0x00, 0x08, 0x00, 0x09, 0x02, 0xFF, 0x01]),
        with_crc(&[ID, 0x0F, 0x00, 0x08, 0x00, 0x09, 0x01, 0xFF]),
        fc16(0, 16, 32, 32),
        fc16(1, 16, 32, 32),
        fc16(0, 24, 48, 48),
        fc16(0, 123, 246, 246),
        with_crc(&[ID, 0x07]),
        with_crc(&[ID, 0x41, 0x00, 0x00, 0x00, 0x01]),
        read_request(ID, 0x01, 0, 16),
        read_request(ID, 0x03, 0, 16),
    ];
    let (mut bank, mut map) = (bank(), map());
    for request in &requests {
        assert_eq!(bank.ask(request), map.ask(request), "request {request:02X?}");
    }
}
