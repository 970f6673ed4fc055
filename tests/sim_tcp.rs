//! The Modbus TCP server on the simulated Uno with its simulated Ethernet shield
//! (`examples/tcp_server.rs` as `make chips` builds it for the W5100 and the W5500): requests
//! through the chip's sockets as a network would bring them (whole, split over segments,
//! several in one), every socket serving at once while the main loop blocks, the fifth
//! master, a master that does not read, one that resets, one that vanishes. Implementation
//! Guide v1.0b §3.1.3 (MBAP), §4.2 (connection management).

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, cycles_to_us, us_to_cycles};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Uno, Wiznet};

/// The firmware's port.
const PORT: u16 = 502;

/// The TCP server for `shield` (`w5100`, `w5500`, `w5100-int`), running until every socket
/// listens.
fn boot(shield: &str) -> Uno {
    let chip = if shield.starts_with("w5500") { Wiznet::W5500 } else { Wiznet::W5100 };
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, &format!("-{shield}"), "tcp_server");
    let mut options = Options::new().wiznet(chip);
    if shield.ends_with("-int") {
        // The W5100 shield's solder jumper: INT to pin 2 (PD2).
        options = options.wiznet_int('D', 2);
    }
    let mut uno = Uno::load_with(elf, options).unwrap();
    let sockets = if chip == Wiznet::W5500 { 8 } else { 4 };
    while !(0..sockets).all(|n| uno.wiznet().unwrap().status(n) == state::LISTEN) {
        assert!(uno.now() < us_to_cycles(50_000), "{shield}: the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno
}

fn peer(i: u8) -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + i), 40000 + u16::from(i))
}

/// An ADU: the MBAP header (Implementation Guide §3.1.3) and `pdu`.
fn adu(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let len = pdu.len() as u16 + 1;
    let mut out = vec![
        (transaction >> 8) as u8,
        transaction as u8, // transaction id
        0x00,
        0x00, // protocol id: Modbus
        (len >> 8) as u8,
        len as u8, // length: unit id and PDU
        unit,      // unit id
    ];
    out.extend_from_slice(pdu);
    out
}

/// FC 3 or 4, `qty` registers from `start`.
fn read(transaction: u16, function: u8, start: u16, qty: u16) -> Vec<u8> {
    adu(transaction, 1, &[function, (start >> 8) as u8, start as u8, (qty >> 8) as u8, qty as u8])
}

/// The reply to a read of registers with these values.
fn registers(transaction: u16, function: u8, values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![function, 2 * values.len() as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    adu(transaction, 1, &pdu)
}

/// A connection from `who` to socket `n`, established and seen by the firmware.
fn connect(uno: &mut Uno, who: u8) -> usize {
    let n = uno.wiznet_mut().unwrap().connect(PORT, peer(who)).expect("a socket listens");
    uno.run_for(us_to_cycles(3000)).unwrap();
    n
}

/// Sends `request` on socket `n` and runs until `expected_len` bytes came back (at most 20 ms).
fn ask(uno: &mut Uno, n: usize, request: &[u8], expected_len: usize) -> Vec<u8> {
    assert_eq!(uno.wiznet_mut().unwrap().deliver(n, request), request.len());
    let mut got = Vec::new();
    let until = uno.now() + us_to_cycles(20_000);
    while got.len() < expected_len && uno.now() < until {
        uno.run_for(us_to_cycles(100)).unwrap();
        got.extend(uno.wiznet_mut().unwrap().take_sent(n));
    }
    got
}

#[test]
fn both_chips_answer_reads_writes_and_exceptions_with_the_transaction_id() {
    for shield in ["w5100", "w5500", "w5100-int"] {
        let mut uno = boot(shield);
        let n = connect(&mut uno, 0);
        // FC 16: 40001-40003 = 1, 2, 3.
        let write = adu(0x1234, 0xFF, &[0x10, 0x00, 0x00, 0x00, 0x03, 0x06, 0, 1, 0, 2, 0, 3]);
        assert_eq!(ask(&mut uno, n, &write, 12), adu(0x1234, 0xFF, &[0x10, 0x00, 0x00, 0x00, 0x03]), "{shield}");
        assert_eq!(ask(&mut uno, n, &read(0xBEEF, 3, 0, 3), 15), registers(0xBEEF, 3, &[1, 2, 3]), "{shield}");
        // 40017 is past the map: 02; 126 registers: 03; FC 0x41: 01.
        assert_eq!(ask(&mut uno, n, &read(7, 3, 16, 1), 9), adu(7, 1, &[0x83, 0x02]), "{shield}");
        assert_eq!(ask(&mut uno, n, &read(8, 3, 0, 126), 9), adu(8, 1, &[0x83, 0x03]), "{shield}");
        assert_eq!(ask(&mut uno, n, &adu(9, 1, &[0x41]), 9), adu(9, 1, &[0xC1, 0x01]), "{shield}");
    }
}

#[test]
fn a_request_split_over_segments_is_answered_once_whole() {
    let mut uno = boot("w5100");
    let n = connect(&mut uno, 0);
    let request = read(5, 4, 0, 2);
    let t = uno.now();
    let w = uno.wiznet_mut().unwrap();
    // Header cut in two, then the PDU's last byte 3 ms later.
    w.deliver_at(n, &request[..4], t + us_to_cycles(200));
    w.deliver_at(n, &request[4..11], t + us_to_cycles(1500));
    w.deliver_at(n, &request[11..], t + us_to_cycles(4500));
    uno.run_for(us_to_cycles(4400)).unwrap();
    assert!(uno.wiznet_mut().unwrap().take_sent(n).is_empty(), "answered before the request was whole");
    uno.run_for(us_to_cycles(3000)).unwrap();
    let reply = uno.wiznet_mut().unwrap().take_sent(n);
    assert_eq!(reply.len(), 13);
    assert_eq!(reply[..9], registers(5, 4, &[0, 0])[..9]);
}

#[test]
fn three_requests_in_one_segment_are_answered_in_order() {
    let mut uno = boot("w5500");
    let n = connect(&mut uno, 0);
    let mut segment = read(1, 3, 0, 1);
    segment.extend(read(2, 3, 1, 2));
    segment.extend(adu(3, 1, &[0x06, 0x00, 0x05, 0xAB, 0xCD]));
    let mut expected = registers(1, 3, &[0]);
    expected.extend(registers(2, 3, &[0, 0]));
    expected.extend(adu(3, 1, &[0x06, 0x00, 0x05, 0xAB, 0xCD]));
    assert_eq!(ask(&mut uno, n, &segment, expected.len()), expected);
}

/// Each of `masters` (one socket each) reads 40001 every 5 ms for `seconds` of simulated
/// time; returns the replies each got, checking every one.
fn poll_together(uno: &mut Uno, sockets: &[usize], seconds: u64) -> Vec<u32> {
    let mut answered = vec![0u32; sockets.len()];
    let rounds = seconds * 200;
    for round in 0..rounds {
        for (i, &n) in sockets.iter().enumerate() {
            let transaction = (round as u16) ^ (i as u16) << 12;
            uno.wiznet_mut().unwrap().deliver(n, &read(transaction, 3, 0, 1));
        }
        uno.run_for(us_to_cycles(5000)).unwrap();
        for (i, &n) in sockets.iter().enumerate() {
            let transaction = (round as u16) ^ (i as u16) << 12;
            let reply = uno.wiznet_mut().unwrap().take_sent(n);
            assert_eq!(reply, registers(transaction, 3, &[0]), "master {i}, round {round}");
            answered[i] += 1;
        }
    }
    answered
}

/// 30001: the seconds the main loop counted.
fn seconds_counted(uno: &mut Uno, n: usize) -> u16 {
    let reply = ask(uno, n, &read(0x7777, 4, 0, 1), 11);
    u16::from_be_bytes([reply[9], reply[10]])
}

#[test]
fn every_socket_serves_a_master_at_once_while_the_main_loop_blocks() {
    for (shield, count) in [("w5100", 4u8), ("w5500", 8)] {
        let mut uno = boot(shield);
        let sockets: Vec<usize> = (0..count).map(|i| connect(&mut uno, i)).collect();
        let mut distinct = sockets.clone();
        distinct.dedup();
        assert_eq!(distinct.len(), usize::from(count), "{shield}: one socket each");
        let answered = poll_together(&mut uno, &sockets, 3);
        assert!(answered.iter().all(|&a| a == 600), "{shield}: {answered:?}");
        let seconds = seconds_counted(&mut uno, sockets[0]);
        assert!(seconds >= 1, "{shield}: the main loop counted {seconds} s in 3 s");
    }
}

#[test]
fn a_fifth_master_gets_the_socket_of_the_one_idle_longest() {
    let mut uno = boot("w5100");
    let sockets: Vec<usize> = (0..4).map(|i| connect(&mut uno, i)).collect();
    // All four busy: no socket listens, the fifth's SYN finds none.
    poll_together(&mut uno, &sockets, 1);
    assert_eq!(uno.wiznet().unwrap().listening(PORT), None);
    // Master 2 goes quiet; the others keep polling: after 2 s idle its connection is
    // closed (an RST) and the socket listens for the newcomer.
    let busy = [sockets[0], sockets[1], sockets[3]];
    poll_together(&mut uno, &busy, 3);
    let w = uno.wiznet().unwrap();
    assert!(w.connection(sockets[2]).unwrap().reset_by_chip(), "the idle one closed with an RST");
    assert_eq!(w.listening(PORT), Some(sockets[2]));
    let fifth = connect(&mut uno, 4);
    assert_eq!(ask(&mut uno, fifth, &read(0x5555, 3, 0, 1), 11), registers(0x5555, 3, &[0]));
}

#[test]
fn a_master_that_does_not_read_holds_only_its_own_socket() {
    let mut uno = boot("w5100");
    let stuck = connect(&mut uno, 0);
    let other = connect(&mut uno, 1);
    uno.wiznet_mut().unwrap().set_peer_window(stuck, Some(0));
    // 150 reads of 16 registers (12 bytes each, 1800 of the 2 KB receive buffer; a reply of
    // 41 bytes each, which the server sends one SEND at a time as the peer takes them).
    for t in 0..150u16 {
        uno.wiznet_mut().unwrap().deliver(stuck, &read(t, 3, 0, 16));
        assert_eq!(ask(&mut uno, other, &read(t, 3, 0, 1), 11), registers(t, 3, &[0]), "request {t}");
    }
    let w = uno.wiznet().unwrap();
    assert!(w.tx_pending(stuck) > 0, "a reply waits for the peer");
    assert!(w.socket_register16(stuck, 0x26) > 1000, "its requests wait in the chip");
    // It reads again: the replies come, in order.
    uno.wiznet_mut().unwrap().set_peer_window(stuck, None);
    uno.run_for(us_to_cycles(200_000)).unwrap();
    let replies = uno.wiznet_mut().unwrap().take_sent(stuck);
    assert_eq!(replies.len() % 41, 0);
    for (t, reply) in replies.chunks(41).enumerate() {
        assert_eq!(reply, registers(t as u16, 3, &[0; 16]), "reply {t}");
    }
    assert_eq!(replies.len() / 41, 150, "every request answered");
}

#[test]
fn a_reset_frees_the_socket_at_once() {
    let mut uno = boot("w5100");
    let n = connect(&mut uno, 0);
    uno.wiznet_mut().unwrap().peer_reset(n);
    uno.run_for(us_to_cycles(3000)).unwrap();
    assert_eq!(uno.wiznet().unwrap().status(n), state::LISTEN);
}

#[test]
fn a_closing_master_gets_its_answer_then_a_fin_and_the_socket_listens_again() {
    let mut uno = boot("w5500");
    let n = connect(&mut uno, 0);
    uno.wiznet_mut().unwrap().deliver(n, &read(42, 3, 0, 1));
    uno.wiznet_mut().unwrap().peer_fin(n);
    uno.run_for(us_to_cycles(5000)).unwrap();
    let w = uno.wiznet_mut().unwrap();
    assert_eq!(w.take_sent(n), registers(42, 3, &[0]));
    let conn = w.connection(n).unwrap();
    assert!(conn.fin_from_chip() && !conn.reset_by_chip(), "{conn:?}");
    assert_eq!(w.status(n), state::LISTEN);
}

#[test]
fn a_vanished_master_is_closed_when_its_socket_is_needed() {
    let mut uno = boot("w5100");
    let sockets: Vec<usize> = (0..4).map(|i| connect(&mut uno, i)).collect();
    uno.wiznet_mut().unwrap().peer_vanish(sockets[1]);
    let alive = [sockets[0], sockets[2], sockets[3]];
    poll_together(&mut uno, &alive, 3);
    assert_eq!(uno.wiznet().unwrap().listening(PORT), Some(sockets[1]), "its socket listens again");
}

#[test]
fn one_thousand_requests_on_one_connection_and_the_reply_latency() {
    // The figure make bench prints; here only that each is answered, and the latency's
    // spread for the record.
    for shield in ["w5100", "w5100-int", "w5500", "w5500-int"] {
        let mut uno = boot(shield);
        let n = connect(&mut uno, 0);
        let mut latencies = Vec::new();
        for t in 0..1000u16 {
            assert_eq!(ask(&mut uno, n, &read(t, 3, 0, 1), 11), registers(t, 3, &[0]), "request {t}");
            let w = uno.wiznet().unwrap();
            let send = w.sends(n).last().unwrap().cycle;
            latencies.push(send - w.last_delivery(n).unwrap());
            uno.run_for(us_to_cycles(u64::from(t % 7) * 137)).unwrap();
        }
        latencies.sort_unstable();
        eprintln!(
            "tcp_server ({shield}): request in the chip -> SEND, p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs",
            cycles_to_us(latencies[500]),
            cycles_to_us(latencies[990]),
            cycles_to_us(latencies[999])
        );
    }
}
