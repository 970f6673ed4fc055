//! The server's Modbus UDP (feature `udp`) against the imitation chip's UDP socket
//! (`crate::tcp::fake`): TCP on sockets 0-2, UDP on socket 3.

use super::*;
use crate::slave::bank::Bank;
use crate::tcp::fake::{Fake, SIZE, UDP};
use crate::tcp::Serving;

const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(3).udp(3);
const U: usize = 3;

/// A sender: address and port, as the chip's header and Sn_DIPR/Sn_DPORT hold them.
fn sender(host: u8, port: u16) -> [u8; 6] {
    let [p0, p1] = port.to_be_bytes();
    [10, 0, 0, host, p0, p1]
}

/// A bank with holding registers 40001-40010 = 0x0100 + i.
fn bank() -> Bank<4, 16, 4, 0, 0> {
    let mut bank = Bank::new();
    bank.add_range(40001, 10).unwrap();
    for i in 0..10u16 {
        bank.set(40001 + i, 0x0100 + i).unwrap();
    }
    bank
}

type Regs = Bank<4, 16, 4, 0, 0>;

/// The server with `net` started: TCP sockets listening, the UDP socket open on 502.
fn started(chip: &mut Fake, bank: &mut Regs, net: &Network) -> Server {
    let mut server = Server::new();
    server.poll(chip, net, &mut Serving(bank), false);
    assert_eq!(chip.socks[U].status, UDP);
    assert_eq!(chip.socks[U].port, 502);
    assert!(chip.socks[..U].iter().all(|s| s.status == state::LISTEN));
    server
}

/// Polls until the server has nothing left to look at again (at most 50 polls).
fn settle(server: &mut Server, chip: &mut Fake, bank: &mut Regs, net: &Network) {
    for _ in 0..50 {
        server.poll(chip, net, &mut Serving(bank), false);
        if server.is_quiet() && chip.events() == 0 {
            return;
        }
    }
    panic!("the server never settled");
}

fn read_holding(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    let [t0, t1] = transaction.to_be_bytes();
    vec![t0, t1, 0, 0, 0, 6, unit, 0x03, 0, start as u8, 0, qty as u8]
}

fn holding_reply(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    let [t0, t1] = transaction.to_be_bytes();
    let len = 3 + 2 * qty;
    let mut adu = vec![t0, t1, 0, 0, 0, len as u8, unit, 0x03, (2 * qty) as u8];
    for i in 0..qty {
        adu.extend_from_slice(&(0x0100 + start + i).to_be_bytes());
    }
    adu
}

#[test]
fn a_datagram_is_answered_with_a_datagram_to_its_sender() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    assert!(chip.datagram(U, sender(9, 40000), &read_holding(0x1234, 0xFF, 2, 3)));
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 40000), holding_reply(0x1234, 0xFF, 2, 3))]);
    assert_eq!(chip.socks[U].rx_rd, chip.socks[U].rx_wr, "the datagram taken whole");
    assert_eq!(chip.socks[U].sends, 1);
    let counts = server.counters();
    assert_eq!((counts.requests, counts.connections, counts.bad_datagrams), (1, 0, 0));
}

#[test]
fn every_datagram_length_is_dropped_safely_and_the_next_one_answered() {
    // A datagram of each length from 0 to what the buffer holds: the request's bytes as far
    // as they go, then filler. Only 12 bytes make the request; every other length is
    // dropped and counted, and the request behind it is answered.
    let request = read_holding(7, 1, 0, 2);
    for len in 0..=usize::from(SIZE) - 8 {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank, &NET);
        let payload: Vec<u8> = (0..len).map(|i| request.get(i).copied().unwrap_or(0x5A)).collect();
        assert!(chip.datagram(U, sender(9, 1000), &payload));
        let behind = chip.datagram(U, sender(9, 1001), &request);
        settle(&mut server, &mut chip, &mut bank, &NET);
        if !behind {
            assert!(chip.datagram(U, sender(9, 1001), &request), "length {len}: room after the first");
            settle(&mut server, &mut chip, &mut bank, &NET);
        }
        let mut expected = Vec::new();
        if len == request.len() {
            expected.push((sender(9, 1000), holding_reply(7, 1, 0, 2)));
        }
        expected.push((sender(9, 1001), holding_reply(7, 1, 0, 2)));
        assert_eq!(chip.socks[U].datagrams, expected, "length {len}");
        assert_eq!(server.counters().bad_datagrams, u16::from(len != request.len()), "length {len}");
        assert_eq!(chip.socks[U].rx_rd, chip.socks[U].rx_wr, "length {len}: everything taken");
    }
}

#[test]
fn bad_headers_are_dropped_and_counted_each_in_its_counter() {
    let net = NET.only_unit(1);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &net);
    let mut protocol = read_holding(1, 1, 0, 1);
    protocol[3] = 1;
    let mut length_1 = read_holding(2, 1, 0, 1);
    length_1[5] = 1;
    let mut length_255 = read_holding(3, 1, 0, 1);
    length_255[5] = 255;
    let mut longer = read_holding(4, 1, 0, 1);
    longer.push(0);
    let mut shorter = read_holding(5, 1, 0, 1);
    shorter[5] = 7;
    let header_only = read_holding(6, 1, 0, 1)[..7].to_vec();
    let other_unit = read_holding(7, 2, 0, 1);
    for bad in [&protocol, &length_1, &length_255, &longer, &shorter, &header_only, &other_unit] {
        assert!(chip.datagram(U, sender(9, 1000), bad));
    }
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(8, 1, 0, 1)));
    settle(&mut server, &mut chip, &mut bank, &net);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1000), holding_reply(8, 1, 0, 1))]);
    let counts = server.counters();
    assert_eq!(
        (counts.bad_protocol, counts.bad_datagrams, counts.other_unit, counts.bad_length, counts.requests),
        (1, 5, 1, 0, 1)
    );
}

#[test]
fn a_datagram_shorter_than_a_header_counts_for_its_length_whatever_follows_it() {
    // 5 bytes: a transaction id, protocol id 1, a length field's high byte. Read as a
    // header, the next datagram's chip header (its sender's first address byte, 10) would
    // make a length of 10 and a protocol id to refuse: the datagram is counted for its length.
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    assert!(chip.datagram(U, sender(9, 1000), &[0, 1, 0, 1, 0]));
    assert!(chip.datagram(U, sender(9, 1001), &read_holding(2, 1, 0, 1)));
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1001), holding_reply(2, 1, 0, 1))]);
    let counts = server.counters();
    assert_eq!((counts.bad_datagrams, counts.bad_protocol), (1, 0));
}

#[test]
fn a_flood_from_an_address_not_allowed_costs_one_header_read_each_and_no_answer() {
    let net = NET.allow(&[[10, 0, 0, 9]]);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &net);
    let mut flood = 0;
    while chip.datagram(U, sender(66, 502), &read_holding(flood, 1, 0, 1)) {
        flood += 1;
    }
    assert_eq!(flood, 102, "2048 bytes of 20-byte datagrams");
    chip.reads = 0;
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    assert!(chip.socks[U].datagrams.is_empty(), "never answered");
    assert_eq!(chip.reads, 1 + 102, "the count, then each datagram's 8-byte chip header alone");
    assert_eq!(chip.socks[U].rx_rd, chip.socks[U].rx_wr, "all dropped in one poll");
    assert_eq!(server.counters().refused, 102);
    assert!(server.is_quiet());
    // The allowed master is served as before.
    assert!(chip.datagram(U, sender(9, 502), &read_holding(1, 1, 0, 1)));
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 502), holding_reply(1, 1, 0, 1))]);
}

#[test]
fn pipelined_datagrams_from_several_senders_are_answered_in_order_each_to_its_own() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    let senders = [sender(9, 1000), sender(10, 2000), sender(9, 1001)];
    let mut expected = Vec::new();
    for i in 0..9u16 {
        let from = senders[usize::from(i) % 3];
        assert!(chip.datagram(U, from, &read_holding(100 + i, 1, i, 1)));
        expected.push((from, holding_reply(100 + i, 1, i, 1)));
    }
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, expected);
    assert_eq!(chip.socks[U].sends, 9, "one SEND a datagram");
    assert_eq!(server.counters().requests, 9);
}

#[test]
fn a_reply_that_finds_no_room_waits_in_the_chip() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    // The chip holds its SENDs (an ARP under way): the first answer fills the buffer.
    chip.socks[U].reading = false;
    let sock = &mut chip.socks[U];
    sock.tx_rd = sock.tx_wr.wrapping_sub(SIZE - 100);
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(1, 1, 0, 1)));
    let rx_rd = chip.socks[U].rx_rd;
    for _ in 0..3 {
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    }
    assert_eq!(chip.socks[U].rx_rd, rx_rd, "left in the chip");
    assert_eq!(server.counters().requests, 0);
    assert!(!server.is_quiet(), "looked at again");
    // Room again: answered.
    chip.socks[U].reading = true;
    chip.socks[U].tx_rd = chip.socks[U].tx_wr;
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1000), holding_reply(1, 1, 0, 1))]);
}

#[test]
fn a_udp_socket_closed_under_the_server_is_opened_again() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    // A chip reset: the socket closed; the once-a-second sweep sees it.
    chip.socks[U].status = state::CLOSED;
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), true);
    assert_eq!(chip.socks[U].status, UDP);
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(2, 1, 0, 1)));
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1000), holding_reply(2, 1, 0, 1))]);
}

#[test]
fn a_reply_whose_arp_timed_out_does_not_hold_the_next() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    // The chip holds the SEND (its ARP under way), then gives it up: TIMEOUT, no SEND_OK,
    // nothing sent.
    chip.socks[U].reading = false;
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(1, 1, 0, 1)));
    assert!(chip.datagram(U, sender(10, 1000), &read_holding(2, 1, 0, 1)));
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[U].sends, 1, "the second waits for the first's end");
    let sock = &mut chip.socks[U];
    sock.ir |= 0x08;
    sock.tx_rd = sock.tx_wr;
    sock.reading = true;
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, [(sender(10, 1000), holding_reply(2, 1, 0, 1))]);
}

#[test]
fn tcp_and_udp_are_served_side_by_side() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    chip.connect(0, [10, 0, 0, 9]);
    chip.deliver(0, &read_holding(1, 1, 0, 1));
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(2, 1, 1, 1)));
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[0].sent, holding_reply(1, 1, 0, 1));
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1000), holding_reply(2, 1, 1, 1))]);
    assert_eq!(server.counters().connections, 1);
}

#[test]
fn without_udp_the_socket_stays_the_applications() {
    let net = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(3);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = Server::<260>::new();
    server.poll(&mut chip, &net, &mut Serving(&mut bank), true);
    assert_eq!(chip.socks[U].status, state::CLOSED);
}

#[test]
fn a_datagram_not_all_there_waits_for_the_rest() {
    // Sn_RX_RSR read as the chip wrote a datagram: its header says more than the count
    // holds. Nothing is taken until the rest is there.
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &NET);
    assert!(chip.datagram(U, sender(9, 1000), &read_holding(1, 1, 0, 1)));
    for missing in [1u16, 5, 12, 13, 19] {
        chip.socks[U].rx_wr = chip.socks[U].rx_wr.wrapping_sub(missing);
        let rx_rd = chip.socks[U].rx_rd;
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert_eq!(chip.socks[U].rx_rd, rx_rd, "{missing} bytes missing: nothing taken");
        assert!(chip.socks[U].datagrams.is_empty());
        chip.socks[U].rx_wr = chip.socks[U].rx_wr.wrapping_add(missing);
    }
    chip.socks[U].ir |= 0x04;
    settle(&mut server, &mut chip, &mut bank, &NET);
    assert_eq!(chip.socks[U].datagrams, [(sender(9, 1000), holding_reply(1, 1, 0, 1))]);
    assert_eq!(server.counters().bad_datagrams, 0);
}

#[cfg(feature = "write-protect")]
#[test]
fn each_datagram_has_its_senders_right_to_write() {
    // 10.0.0.9 writes, 10.0.0.7 only reads: a reader's write between two of the writer's.
    let net = NET.allow(&[[10, 0, 0, 9]]).allow_reading(&[[10, 0, 0, 7]]);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank, &net);
    let write = |transaction: u8, value: u8| vec![0, transaction, 0, 0, 0, 6, 1, 0x06, 0, 0, 0, value];
    assert!(chip.datagram(U, sender(9, 1000), &write(1, 0x11)));
    assert!(chip.datagram(U, sender(7, 1000), &write(2, 0x22)));
    assert!(chip.datagram(U, sender(9, 1000), &write(3, 0x33)));
    assert!(chip.datagram(U, sender(7, 1000), &read_holding(4, 1, 0, 1)));
    settle(&mut server, &mut chip, &mut bank, &net);
    let refused = vec![0, 2, 0, 0, 0, 3, 1, 0x86, 0x01];
    let mut read = holding_reply(4, 1, 0, 1);
    read[9..11].copy_from_slice(&[0, 0x33]);
    assert_eq!(
        chip.socks[U].datagrams,
        [
            (sender(9, 1000), write(1, 0x11)),
            (sender(7, 1000), refused),
            (sender(9, 1000), write(3, 0x33)),
            (sender(7, 1000), read)
        ]
    );
    assert_eq!((bank.master_writes(), server.counters().refused_writes), (2, 1));
}
