//! The server's RTU over TCP sockets against the imitation chip: socket 1 speaks RTU on
//! port 5020, the others MBAP on 502.

use super::super::tests::{bank, holding_reply, read_holding};
use super::super::Server;
use crate::link::crc::crc16;
use crate::slave::bank::Bank;
use crate::tcp::fake::Fake;
use crate::tcp::network::Network;
use crate::tcp::wiznet::state;
use crate::tcp::Serving;

const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(4).rtu_over_tcp(5020, 0b0010);

/// The socket that speaks RTU.
const RTU: usize = 1;

/// `body` (address and PDU) with its CRC, low byte first.
fn frame(body: &[u8]) -> Vec<u8> {
    let mut frame = body.to_vec();
    frame.extend_from_slice(&crc16(body).to_le_bytes());
    frame
}

/// FC 3: `qty` holding registers from `start` at `address`.
fn read(address: u8, start: u16, qty: u16) -> Vec<u8> {
    let [s0, s1] = start.to_be_bytes();
    let [q0, q1] = qty.to_be_bytes();
    frame(&[address, 0x03, s0, s1, q0, q1])
}

/// [`read`]'s reply from [`bank`].
fn read_reply(address: u8, start: u16, qty: u16) -> Vec<u8> {
    let mut body = vec![address, 0x03, (2 * qty) as u8];
    for i in 0..qty {
        body.extend_from_slice(&(0x0100 + start + i).to_be_bytes());
    }
    frame(&body)
}

/// A server on [`NET`] with a master connected on the RTU socket.
fn connected<const B: usize>(chip: &mut Fake, bank: &mut Bank<4, 16, 4, 0, 0>) -> Server<B> {
    let mut server = Server::new();
    server.poll(chip, &NET, &mut Serving(bank), false);
    let ports: Vec<u16> = chip.socks.iter().map(|s| s.port).collect();
    assert_eq!(ports, [502, 5020, 502, 502]);
    chip.connect(RTU, [10, 0, 0, 9]);
    server
}

fn poll<const B: usize>(server: &mut Server<B>, chip: &mut Fake, bank: &mut Bank<4, 16, 4, 0, 0>) {
    server.poll(chip, &NET, &mut Serving(bank), false);
}

#[test]
fn a_read_is_answered_with_its_address_and_a_crc() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    chip.deliver(RTU, &read(0x11, 2, 3));
    poll(&mut server, &mut chip, &mut bank);
    // 11 03 06 01 02 01 03 01 04 CRC
    assert_eq!(chip.socks[RTU].sent, read_reply(0x11, 2, 3));
    assert_eq!(chip.socks[RTU].rx_rd, chip.socks[RTU].rx_wr, "the frame taken whole");
    assert_eq!(server.counters().requests, 1);
}

#[test]
fn a_write_is_done_and_echoed() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    // FC 16: 40002-40003 = 0x000A, 0x0102.
    chip.deliver(RTU, &frame(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02]));
    // FC 6: 40005 = 0x1234.
    chip.deliver(RTU, &frame(&[0x11, 0x06, 0x00, 0x04, 0x12, 0x34]));
    poll(&mut server, &mut chip, &mut bank);
    let expected =
        [frame(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02]), frame(&[0x11, 0x06, 0x00, 0x04, 0x12, 0x34])].concat();
    assert_eq!(chip.socks[RTU].sent, expected);
    assert_eq!((bank.get(40002), bank.get(40003), bank.get(40005)), (Ok(0x000A), Ok(0x0102), Ok(0x1234)));
}

#[test]
fn every_split_of_a_frame_is_answered_once_whole() {
    let requests = [read(1, 0, 2), frame(&[0x01, 0x10, 0x00, 0x00, 0x00, 0x01, 0x02, 0x01, 0x00])];
    let replies = [read_reply(1, 0, 2), frame(&[0x01, 0x10, 0x00, 0x00, 0x00, 0x01])];
    for (request, reply) in requests.iter().zip(&replies) {
        for cut in 1..request.len() {
            let (mut chip, mut bank) = (Fake::default(), bank());
            let mut server: Server = connected(&mut chip, &mut bank);
            chip.deliver(RTU, &request[..cut]);
            poll(&mut server, &mut chip, &mut bank);
            assert!(chip.socks[RTU].sent.is_empty(), "answered with {cut} bytes of {}", request.len());
            chip.deliver(RTU, &request[cut..]);
            poll(&mut server, &mut chip, &mut bank);
            assert_eq!(&chip.socks[RTU].sent, reply, "cut at {cut}");
            assert_eq!(server.counters().bad_frame, 0);
        }
    }
}

#[test]
fn frames_in_one_segment_are_answered_in_order_with_one_send() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    let segment = [read(1, 0, 1), frame(&[0x01, 0x06, 0x00, 0x09, 0xAB, 0xCD]), read(1, 5, 2), read(2, 9, 1)].concat();
    chip.deliver(RTU, &segment);
    poll(&mut server, &mut chip, &mut bank);
    // The last read sees the write before it.
    let expected = [
        read_reply(1, 0, 1),
        frame(&[0x01, 0x06, 0x00, 0x09, 0xAB, 0xCD]),
        read_reply(1, 5, 2),
        frame(&[0x02, 0x03, 0x02, 0xAB, 0xCD]),
    ]
    .concat();
    assert_eq!(chip.socks[RTU].sent, expected);
    assert_eq!(chip.socks[RTU].sends, 1);
}

#[test]
fn a_bad_crc_is_silence_and_the_next_segment_is_answered() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    let mut bad = read(1, 0, 1);
    bad[7] ^= 0x01;
    // A good frame behind the bad one in the same segment is lost with it: where it
    // starts cannot be known.
    chip.deliver(RTU, &[bad, read(1, 1, 1)].concat());
    poll(&mut server, &mut chip, &mut bank);
    assert!(chip.socks[RTU].sent.is_empty());
    assert_eq!(chip.socks[RTU].rx_rd, chip.socks[RTU].rx_wr, "everything received discarded");
    assert_eq!(server.counters().bad_frame, 1);
    chip.deliver(RTU, &read(1, 2, 1));
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(chip.socks[RTU].sent, read_reply(1, 2, 1));
    assert_eq!(chip.socks[RTU].status, state::ESTABLISHED, "the connection goes on");
}

#[test]
fn a_damaged_byte_anywhere_is_caught() {
    let request = frame(&[0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0x01, 0x02, 0x03, 0x04]);
    for at in 0..request.len() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server: Server = connected(&mut chip, &mut bank);
        let mut bad = request.clone();
        bad[at] ^= 0x10;
        chip.deliver(RTU, &bad);
        poll(&mut server, &mut chip, &mut bank);
        // A damaged byte count may also make the frame longer than what came: it waits.
        assert!(chip.socks[RTU].sent.is_empty(), "byte {at} damaged, answered");
        assert_eq!(bank.get(40001), Ok(0x0100), "byte {at} damaged, written");
    }
}

#[test]
fn garbage_is_dropped_and_counted_and_the_stream_starts_again() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    // An MBAP request on the RTU port: address 0, FC 1, then a bad CRC.
    chip.deliver(RTU, &[0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x01, 0x03, 0x00, 0x00, 0x00, 0x01]);
    poll(&mut server, &mut chip, &mut bank);
    // Bytes of no known code, no CRC.
    chip.deliver(RTU, &[0x55, 0xAA, 0x55, 0xAA, 0x55]);
    poll(&mut server, &mut chip, &mut bank);
    assert!(chip.socks[RTU].sent.is_empty());
    assert_eq!(server.counters().bad_frame, 2);
    chip.deliver(RTU, &read(1, 0, 1));
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(chip.socks[RTU].sent, read_reply(1, 0, 1));
}

#[test]
fn a_byte_count_past_256_bytes_is_no_frame() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    // FC 16 with a byte count of 255: 264 bytes.
    chip.deliver(RTU, &[0x01, 0x10, 0x00, 0x00, 0x00, 0x7B, 0xFF, 0x00]);
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(server.counters().bad_frame, 1);
    assert_eq!(chip.socks[RTU].rx_rd, chip.socks[RTU].rx_wr);
}

#[test]
fn a_frame_longer_than_the_buffer_gets_the_mbap_paths_exception() {
    // FC 16 of 100 registers (209 bytes) to a server whose buffer holds 32: read through it
    // for the CRC, then answered as over MBAP (02: 40001-40100 are not all there).
    let mut body = vec![0x01, 0x10, 0x00, 0x00, 0x00, 100, 200];
    body.extend((0..200).map(|i| i as u8));
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server<32> = connected(&mut chip, &mut bank);
    chip.deliver(RTU, &frame(&body));
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(chip.socks[RTU].sent, frame(&[0x01, 0x90, 0x02]));
    // Its CRC damaged, silence.
    let mut bad = frame(&body);
    bad[150] ^= 1;
    chip.deliver(RTU, &bad);
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(chip.socks[RTU].sent, frame(&[0x01, 0x90, 0x02]));
    assert_eq!(server.counters().bad_frame, 1);
}

#[test]
fn an_unknown_code_with_a_good_crc_gets_01_and_with_a_bad_one_silence() {
    for code in [0x09, 0x0A, 0x0D, 0x13, 0x19, 0x41, 0x64] {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server: Server = connected(&mut chip, &mut bank);
        chip.deliver(RTU, &frame(&[0x01, code, 0x00, 0x01]));
        poll(&mut server, &mut chip, &mut bank);
        assert_eq!(chip.socks[RTU].sent, frame(&[0x01, code | 0x80, 0x01]), "FC {code:#04x}");
        chip.deliver(RTU, &[0x01, code, 0x00, 0x01, 0x00, 0x00]);
        poll(&mut server, &mut chip, &mut bank);
        assert_eq!(server.counters().bad_frame, 1, "FC {code:#04x}");
        assert_eq!(chip.socks[RTU].sent.len(), 5, "FC {code:#04x}");
    }
}

#[test]
fn exceptions_are_the_mbap_paths() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    // 126 registers: 03; address 10 missing: 02; FC 0x41, last in the segment: 01.
    chip.deliver(RTU, &[read(1, 0, 126), read(1, 10, 1), frame(&[0x01, 0x41])].concat());
    poll(&mut server, &mut chip, &mut bank);
    let expected = [frame(&[0x01, 0x83, 0x03]), frame(&[0x01, 0x83, 0x02]), frame(&[0x01, 0xC1, 0x01])].concat();
    assert_eq!(chip.socks[RTU].sent, expected);
    assert_eq!(server.counters().exceptions, 3);
}

#[test]
fn only_unit_drops_other_addresses_and_address_0_is_a_broadcast() {
    let net = NET.only_unit(5);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    for address in [4, 5, 0xFF] {
        chip.deliver(RTU, &read(address, 0, 1));
    }
    // A broadcast write: done, not answered; then a broadcast read: not answered.
    chip.deliver(RTU, &frame(&[0x00, 0x06, 0x00, 0x01, 0xBE, 0xEF]));
    chip.deliver(RTU, &read(0, 0, 1));
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[RTU].sent, [read_reply(5, 0, 1), read_reply(0xFF, 0, 1)].concat());
    assert_eq!(bank.get(40002), Ok(0xBEEF));
    assert_eq!(server.counters().other_unit, 1);
    assert_eq!(server.counters().requests, 2);
}

#[test]
fn mbap_goes_on_on_the_other_sockets() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server: Server = connected(&mut chip, &mut bank);
    chip.connect(2, [10, 0, 0, 8]);
    chip.deliver(2, &read_holding(7, 1, 0, 2));
    chip.deliver(RTU, &read(1, 0, 2));
    poll(&mut server, &mut chip, &mut bank);
    assert_eq!(chip.socks[2].sent, holding_reply(7, 1, 0, 2));
    assert_eq!(chip.socks[RTU].sent, read_reply(1, 0, 2));
}
