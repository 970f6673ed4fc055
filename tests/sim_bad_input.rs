//! Damaged and foreign frames are dropped in silence, Modbus over Serial Line v1.02
//! §2.4.1 (broadcast), §2.5.1.1 (frame errors) and §2.5.1.2 (CRC): the release `uno_slave`
//! firmware at 19200 8E1 sends nothing back, and answers the next good request normally.

mod sim;

use sim::{read_request, registers_reply, with_crc, Line, Rtu, ID};
use uno_sim::LineError;

fn uno_slave() -> Rtu {
    Rtu::boot("uno_slave", Line::B19200_8E1)
}

/// FC 03 for 40003 and 40004, zero after reset.
fn good_request() -> Vec<u8> {
    with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x02, // starting address lo: 40003
        0x00, // quantity hi
        0x02, // quantity lo: 2
    ])
}

fn good_reply() -> Vec<u8> {
    with_crc(&[
        ID,   // slave address
        0x03, // function
        0x04, // byte count
        0x00, 0x00, // 40003
        0x00, 0x00, // 40004
    ])
}

/// `frame` (sent after T3.5 of silence, back to back) gets no reply, and the good request
/// after it gets the right one.
fn dropped_then_recovers(mut rtu: Rtu, frame: &[u8], what: &str) {
    let end = rtu.send(frame);
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "{what}: the slave answered {:02X?}", exchange.bytes());
    assert_eq!(rtu.ask(&good_request()), good_reply(), "{what}: the next good request");
}

#[test]
fn frame_with_bad_crc_is_not_answered() {
    let mut frame = good_request();
    frame[6] ^= 0x01; // CRC low byte off by one bit
    dropped_then_recovers(uno_slave(), &frame, "bad CRC");
}

#[test]
fn frame_with_data_bit_flipped_is_not_answered() {
    let mut frame = good_request();
    frame[3] ^= 0x80; // starting address lo changed after the CRC was computed
    dropped_then_recovers(uno_slave(), &frame, "flipped data bit");
}

#[test]
fn frame_for_slave_2_is_not_answered() {
    dropped_then_recovers(uno_slave(), &read_request(2, 0x03, 2, 2), "slave 2");
}

#[test]
fn frame_for_reserved_address_248_is_not_answered() {
    dropped_then_recovers(uno_slave(), &read_request(248, 0x03, 2, 2), "address 248");
}

#[test]
fn request_cut_after_6_bytes_is_not_answered() {
    let frame = good_request();
    dropped_then_recovers(uno_slave(), &frame[..6], "request without its CRC");
}

#[test]
fn three_byte_fragment_is_not_answered() {
    let frame = good_request();
    dropped_then_recovers(uno_slave(), &frame[..3], "3 bytes");
}

#[test]
fn flood_of_300_bytes_is_not_answered_and_nothing_overruns() {
    let mut rtu = uno_slave();
    // A good request repeated: whatever the slave kept of it, no 256-byte window ends well.
    let flood: Vec<u8> = good_request().into_iter().cycle().take(300).collect();
    let end = rtu.send(&flood);
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "300-byte flood answered: {:02X?}", exchange.bytes());
    assert_eq!(rtu.uno.uart_counters().rx_overruns, 0, "the RX handler kept up with the flood");
    assert_eq!(rtu.ask(&good_request()), good_reply(), "the next good request");
}

/// Sends `frame` with byte `index` damaged by `error`; returns the end of the last byte.
fn send_damaged(rtu: &mut Rtu, frame: &[u8], index: usize, error: LineError) -> u64 {
    let first_end = rtu.first_end_after_silence(2 * rtu.tick);
    let head_end = rtu.send_at(&frame[..index], first_end, 0);
    let damaged_end = head_end + rtu.char_cycles;
    rtu.uno.send_byte_with_error(frame[index], damaged_end, error).unwrap();
    rtu.send_at(&frame[index + 1..], damaged_end + rtu.char_cycles, 0)
}

fn damaged_byte_drops_the_frame(error: LineError) {
    let mut rtu = uno_slave();
    // The byte arrives intact, only flagged: the frame's CRC is good.
    let end = send_damaged(&mut rtu, &good_request(), 3, error);
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "{error:?} error in byte 3: answered {:02X?}", exchange.bytes());
    assert_eq!(rtu.ask(&good_request()), good_reply(), "the next good request");
}

#[test]
fn framing_error_inside_a_frame_drops_it() {
    damaged_byte_drops_the_frame(LineError::Framing);
}

#[test]
fn parity_error_inside_a_frame_drops_it() {
    damaged_byte_drops_the_frame(LineError::Parity);
}

#[test]
fn broadcast_fc6_is_executed_without_a_reply() {
    let mut rtu = uno_slave();
    let write = with_crc(&[
        0x00, // slave address: broadcast
        0x06, // function: write single register
        0x00, // register address hi
        0x04, // register address lo: 40005
        0x0B, // value hi
        0xB8, // value lo: 3000
    ]);
    let end = rtu.send(&write);
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "broadcast answered: {:02X?}", exchange.bytes());
    let read = read_request(ID, 0x03, 4, 1);
    assert_eq!(rtu.ask(&read), registers_reply(ID, 0x03, &[3000]), "40005 after the broadcast");
}

#[test]
fn broadcast_fc16_is_executed_without_a_reply() {
    let mut rtu = uno_slave();
    let write = with_crc(&[
        0x00, // slave address: broadcast
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x05, // starting address lo: 40006
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0x00, 0x07, // 40006
        0x70, 0x00, // 40007
    ]);
    let end = rtu.send(&write);
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "broadcast answered: {:02X?}", exchange.bytes());
    let read = read_request(ID, 0x03, 5, 2);
    assert_eq!(rtu.ask(&read), registers_reply(ID, 0x03, &[0x0007, 0x7000]), "40006, 40007 after the broadcast");
}

#[test]
fn broadcast_read_is_ignored() {
    dropped_then_recovers(uno_slave(), &read_request(0, 0x03, 0, 2), "broadcast FC 03");
}

#[test]
fn broadcast_with_an_exception_is_not_answered() {
    // 40011 does not exist: exception 02 for a unicast, silence for a broadcast.
    dropped_then_recovers(uno_slave(), &with_crc(&[0x00, 0x06, 0x00, 0x0A, 0x00, 0x01]), "broadcast FC 06 to 40011");
}

/// A character received while a long reply goes out (RS-232 is full duplex: a master's echo,
/// noise), then T3.5 of silence while the reply is still on the wire: the reply ends where it
/// ends (the silence's end finds no frame and sends nothing), and the next request is
/// answered.
#[test]
fn a_character_received_during_a_long_reply_leaves_the_reply_whole() {
    let mut rtu = uno_slave();
    // FC 3 of 10 registers: 25 characters, 14 ms at 19200.
    let request = read_request(ID, 0x03, 0, 10);
    let whole = rtu.ask(&request);
    assert_eq!(whole.len(), 25);
    let end = rtu.send(&request);
    // One character 5 ms into the reply: T3.5 (2 ms) passes while the reply goes on.
    rtu.send_at(&[0x55], end + rtu.line.t35() + 5 * 16_000, 0);
    let exchange = rtu.receive(end);
    assert_eq!(exchange.bytes(), whole, "the reply");
    assert_eq!(rtu.ask(&good_request()), good_reply(), "the next good request");
}
