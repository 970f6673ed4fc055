//! The server against an imitation of a chip's TCP sockets (`crate::tcp::fake`).

use super::*;
use crate::slave::bank::Bank;
use crate::tcp::fake::{Fake, SIZE};
use crate::tcp::Serving;

const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(4).evict_after(2);

/// A bank with holding registers 40001-40010 = 0x0100 + i.
pub(super) fn bank() -> Bank<4, 16, 4, 0, 0> {
    let mut bank = Bank::new();
    bank.add_range(40001, 10).unwrap();
    for i in 0..10u16 {
        bank.set(40001 + i, 0x0100 + i).unwrap();
    }
    bank
}

/// A server with all four sockets listening.
fn started(chip: &mut Fake, bank: &mut Bank<4, 16, 4, 0, 0>) -> Server {
    let mut server = Server::new();
    server.poll(chip, &NET, &mut Serving(bank), false);
    assert!(chip.socks.iter().all(|s| s.status == state::LISTEN && s.port == 502));
    server
}

pub(super) fn read_holding(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    let [t0, t1] = transaction.to_be_bytes();
    let [s0, s1] = start.to_be_bytes();
    let [q0, q1] = qty.to_be_bytes();
    vec![t0, t1, 0, 0, 0, 6, unit, 0x03, s0, s1, q0, q1]
}

/// The reply to `read_holding(transaction, unit, start, qty)` from [`bank`].
pub(super) fn holding_reply(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    let [t0, t1] = transaction.to_be_bytes();
    let len = 3 + 2 * qty;
    let mut adu = vec![t0, t1, 0, 0, (len >> 8) as u8, len as u8, unit, 0x03, (2 * qty) as u8];
    for i in 0..qty {
        adu.extend_from_slice(&(0x0100 + start + i).to_be_bytes());
    }
    adu
}

#[test]
fn a_request_is_answered_with_its_transaction_and_unit_id() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(1, [10, 0, 0, 9]);
    chip.deliver(1, &read_holding(0x1234, 0xFF, 2, 3));
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[1].sent, holding_reply(0x1234, 0xFF, 2, 3));
    assert_eq!(chip.socks[1].rx_rd, chip.socks[1].rx_wr, "the request taken whole");
    assert_eq!(server.counters().requests, 1);
    assert_eq!(server.counters().connections, 1);
}

#[test]
fn every_split_of_a_request_is_answered_once_whole() {
    let request = read_holding(7, 1, 0, 2);
    for cut in 1..request.len() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(0, [10, 0, 0, 9]);
        chip.deliver(0, &request[..cut]);
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert!(chip.socks[0].sent.is_empty(), "answered with {cut} bytes of 12");
        chip.deliver(0, &request[cut..]);
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert_eq!(chip.socks[0].sent, holding_reply(7, 1, 0, 2), "cut at {cut}");
    }
}

#[test]
fn requests_in_one_segment_are_answered_in_order_with_one_send() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(2, [10, 0, 0, 9]);
    let mut segment = read_holding(1, 1, 0, 1);
    segment.extend(read_holding(2, 1, 5, 2));
    segment.extend(read_holding(3, 1, 9, 1));
    chip.deliver(2, &segment);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    let mut expected = holding_reply(1, 1, 0, 1);
    expected.extend(holding_reply(2, 1, 5, 2));
    expected.extend(holding_reply(3, 1, 9, 1));
    assert_eq!(chip.socks[2].sent, expected);
    assert_eq!(chip.socks[2].sends, 1);
}

#[test]
fn a_bad_protocol_id_is_skipped_and_the_next_request_answered() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    let mut bad = read_holding(1, 1, 0, 1);
    bad[3] = 1;
    bad.extend(read_holding(2, 1, 0, 1));
    chip.deliver(0, &bad);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[0].sent, holding_reply(2, 1, 0, 1));
    assert_eq!(server.counters().bad_protocol, 1);
}

#[test]
fn a_bad_length_closes_the_connection_before_its_body_is_read() {
    for length in [0u16, 1, 255, 0x0800] {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(0, [10, 0, 0, 9]);
        let mut bad = read_holding(1, 1, 0, 1);
        bad[4..6].copy_from_slice(&length.to_be_bytes());
        chip.deliver(0, &bad[..7]);
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert!(chip.socks[0].reset && chip.socks[0].sent.is_empty(), "length {length}");
        assert_eq!(chip.socks[0].status, state::LISTEN, "listening again");
        assert_eq!(server.counters().bad_length, 1);
    }
}

#[test]
fn exceptions_are_the_rtu_slaves() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    // 126 registers: 03; address 10 missing: 02; FC 0x41: 01.
    chip.deliver(0, &read_holding(1, 1, 0, 126));
    chip.deliver(0, &read_holding(2, 1, 10, 1));
    chip.deliver(0, &[0, 3, 0, 0, 0, 2, 1, 0x41]);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(
        chip.socks[0].sent,
        [
            &[0, 1, 0, 0, 0, 3, 1, 0x83, 0x03][..],
            &[0, 2, 0, 0, 0, 3, 1, 0x83, 0x02],
            &[0, 3, 0, 0, 0, 3, 1, 0xC1, 0x01],
        ]
        .concat()
    );
    assert_eq!(server.counters().exceptions, 3);
}

#[test]
fn other_units_are_dropped_when_one_is_set() {
    let net = NET.only_unit(5);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    for unit in [4, 5, 0, 0xFF] {
        chip.deliver(0, &read_holding(u16::from(unit), unit, 0, 1));
    }
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    let expected: Vec<u8> = [5u8, 0, 0xFF].iter().flat_map(|&u| holding_reply(u16::from(u), u, 0, 1)).collect();
    assert_eq!(chip.socks[0].sent, expected);
    assert_eq!(server.counters().other_unit, 1);
}

#[test]
fn a_master_that_does_not_read_holds_only_its_socket() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    chip.connect(1, [10, 0, 0, 8]);
    chip.socks[0].reading = false;
    // Enough requests to fill socket 0's transmit buffer with replies of 29 bytes.
    for round in 0..100u16 {
        chip.deliver(0, &read_holding(round, 1, 0, 10));
        chip.deliver(1, &read_holding(round, 1, 0, 1));
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        if chip.socks[0].rx_wr.wrapping_sub(chip.socks[0].rx_rd) > 1500 {
            break;
        }
    }
    let others: Vec<u8> = (0..chip.socks[1].sent.len() as u16 / 11).flat_map(|r| holding_reply(r, 1, 0, 1)).collect();
    assert_eq!(chip.socks[1].sent, others);
    assert!(chip.socks[1].sent.len() >= 11 * 50);
    // Once the master reads again, its requests are answered in order.
    chip.socks[0].reading = true;
    chip.ack(0);
    chip.socks[0].ir |= SEND_OK;
    for _ in 0..200 {
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    }
    let n = chip.socks[0].sent.len() / 29;
    let expected: Vec<u8> = (0..n as u16).flat_map(|r| holding_reply(r, 1, 0, 10)).collect();
    assert_eq!(chip.socks[0].sent, expected);
    assert_eq!(chip.socks[0].rx_rd, chip.socks[0].rx_wr, "every request answered");
}

#[test]
fn a_refused_client_is_closed_and_counted() {
    let net = NET.allow(&[[10, 0, 0, 9]]);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 66]);
    chip.deliver(0, &read_holding(1, 1, 0, 1));
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    assert!(chip.socks[0].reset && chip.socks[0].sent.is_empty());
    assert_eq!(chip.socks[0].status, state::LISTEN);
    chip.connect(0, [10, 0, 0, 9]);
    chip.deliver(0, &read_holding(1, 1, 0, 1));
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[0].sent, holding_reply(1, 1, 0, 1));
    assert_eq!((server.counters().refused, server.counters().connections), (1, 1));
}

#[test]
fn a_master_that_closes_gets_its_answers_then_the_socket_listens_again() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(3, [10, 0, 0, 9]);
    chip.deliver(3, &read_holding(9, 1, 0, 1));
    chip.socks[3].status = state::CLOSE_WAIT;
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[3].sent, holding_reply(9, 1, 0, 1));
    assert!(chip.socks[3].fin);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), true);
    assert_eq!(chip.socks[3].status, state::LISTEN);
}

#[test]
fn a_reset_connection_listens_again_at_once() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    chip.socks[0].status = state::CLOSED;
    chip.socks[0].ir |= 0x02;
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    assert_eq!(chip.socks[0].status, state::LISTEN);
}

#[test]
fn a_vanished_master_is_closed_after_the_idle_timeout() {
    let net = NET.idle_timeout(5);
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    chip.connect(0, [10, 0, 0, 9]);
    server.poll(&mut chip, &net, &mut Serving(&mut bank), false);
    for second in 1..=5 {
        assert_eq!(chip.socks[0].status, state::ESTABLISHED, "closed after {} s", second - 1);
        server.poll(&mut chip, &net, &mut Serving(&mut bank), true);
    }
    assert!(chip.socks[0].reset);
    assert_eq!(chip.socks[0].status, state::LISTEN);
    assert_eq!(server.counters().idle_closed, 1);
}

#[test]
fn with_every_socket_taken_the_one_idle_longest_makes_room() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    for s in 0..4 {
        chip.connect(s, [10, 0, 0, 10 + s as u8]);
    }
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
    // Sockets 0, 2, 3 keep polling; 1 goes quiet.
    for _ in 0..3 {
        for s in [0, 2, 3] {
            chip.deliver(s, &read_holding(1, 1, 0, 1));
        }
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), true);
    }
    assert_eq!(server.counters().evicted, 1);
    assert!(chip.socks[1].reset && chip.socks[1].status == state::LISTEN);
    assert!([0, 2, 3].iter().all(|&s| chip.socks[s].status == state::ESTABLISHED));
}

#[test]
fn busy_sockets_are_never_evicted() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = started(&mut chip, &mut bank);
    for s in 0..4 {
        chip.connect(s, [10, 0, 0, 10 + s as u8]);
    }
    for _ in 0..10 {
        for s in 0..4 {
            chip.deliver(s, &read_holding(1, 1, 0, 1));
        }
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), true);
    }
    assert_eq!(server.counters().evicted, 0);
    assert!(chip.socks.iter().all(|s| s.status == state::ESTABLISHED));
}

/// A small deterministic generator for the property below.
fn next(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

#[test]
fn no_byte_stream_makes_the_server_read_or_write_outside_its_buffers() {
    // The imitation chip asserts every read and take lies within the received bytes and
    // every write within the free room; the server's buffer is a slice (a write past it
    // panics). Random streams: valid requests, cut anywhere, mixed with garbage headers.
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for round in 0..300 {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server: Server<24> = Server::new();
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        chip.connect(0, [10, 0, 0, 9]);
        let mut stream = Vec::new();
        let mut whole = 0;
        for _ in 0..20 {
            match next(&mut seed) % 4 {
                0 => {
                    let n = (next(&mut seed) % 40) as usize;
                    stream.extend((0..n).map(|_| next(&mut seed) as u8));
                }
                1 => {
                    let len = (next(&mut seed) % 300) as u16;
                    stream.extend([0, 1, 0, 0, (len >> 8) as u8, len as u8, 1]);
                }
                _ => {
                    stream.extend(read_holding(whole, 1, 0, 1 + (next(&mut seed) % 12) as u16));
                    whole += 1;
                }
            }
        }
        let mut at = 0;
        while at < stream.len() {
            let room = SIZE as usize - usize::from(server_received(&mut chip));
            let n = ((next(&mut seed) % 64) as usize).min(stream.len() - at).min(room);
            chip.deliver(0, &stream[at..at + n]);
            at += n;
            server.poll(&mut chip, &NET, &mut Serving(&mut bank), next(&mut seed) % 8 == 0);
            if chip.socks[0].status != state::ESTABLISHED {
                break;
            }
        }
        // Whatever was answered are whole replies whose transaction ids were sent, in order.
        let sent = &chip.socks[0].sent;
        let mut i = 0;
        while i < sent.len() {
            let len = usize::from(u16::from_be_bytes([sent[i + 4], sent[i + 5]]));
            assert!(i + 6 + len <= sent.len(), "round {round}: a reply cut");
            i += 6 + len;
        }
        assert_eq!(i, sent.len(), "round {round}");
    }
}

fn server_received(chip: &mut Fake) -> u16 {
    chip.received(0)
}

/// Clients that may only read (feature `write-protect`): [`Network::allow_reading`] and
/// [`Server::set_read_only`].
#[cfg(feature = "write-protect")]
mod read_only {
    use super::*;

    /// 10.0.0.9 writes, 10.0.0.7 only reads.
    const SPLIT: Network = NET.allow(&[[10, 0, 0, 9]]).allow_reading(&[[10, 0, 0, 7]]);

    /// FC 6 writing `value` to 40001.
    fn write_single(transaction: u16, value: u16) -> Vec<u8> {
        let [v0, v1] = value.to_be_bytes();
        vec![0, transaction as u8, 0, 0, 0, 6, 1, 0x06, 0, 0, v0, v1]
    }

    /// The exception reply to a request of `function`.
    fn exception(transaction: u16, function: u8, code: u8) -> Vec<u8> {
        vec![0, transaction as u8, 0, 0, 0, 3, 1, function | 0x80, code]
    }

    #[test]
    fn a_reading_clients_writes_get_01_and_change_nothing_while_a_writing_client_writes() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(0, [10, 0, 0, 7]);
        chip.connect(1, [10, 0, 0, 9]);
        // The reader: FC 6; FC 16 of quantity 0 (03 from a writer); FC 23 (its read refused
        // too); then a read, answered.
        chip.deliver(0, &write_single(1, 0x1234));
        chip.deliver(0, &[0, 2, 0, 0, 0, 6, 1, 0x10, 0, 0, 0, 0]);
        chip.deliver(0, &[0, 3, 0, 0, 0, 13, 1, 0x17, 0, 0, 0, 1, 0, 1, 0, 1, 2, 0xAB, 0xCD]);
        chip.deliver(0, &read_holding(4, 1, 0, 1));
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        let expected =
            [exception(1, 0x06, 0x01), exception(2, 0x10, 0x01), exception(3, 0x17, 0x01), holding_reply(4, 1, 0, 1)];
        assert_eq!(chip.socks[0].sent, expected.concat());
        assert_eq!((bank.get(40001), bank.get(40002), bank.master_writes()), (Ok(0x0100), Ok(0x0101), 0));
        // The writer's FC 6 is done.
        chip.deliver(1, &write_single(5, 0x1234));
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        assert_eq!(chip.socks[1].sent, write_single(5, 0x1234));
        assert_eq!((bank.get(40001), bank.master_writes()), (Ok(0x1234), 1));
        let counters = server.counters();
        assert_eq!((counters.refused_writes, counters.exceptions, counters.requests), (3, 3, 5));
        assert_eq!((counters.connections, counters.refused), (2, 0));
    }

    #[test]
    fn the_next_connection_on_a_socket_has_its_own_clients_right() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(0, [10, 0, 0, 7]);
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        // The reader resets; the writer comes on the same socket.
        chip.socks[0].status = state::CLOSED;
        chip.socks[0].ir |= 0x02;
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        chip.connect(0, [10, 0, 0, 9]);
        chip.deliver(0, &write_single(1, 0x4321));
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        assert_eq!(chip.socks[0].sent, write_single(1, 0x4321));
        assert_eq!(bank.get(40001), Ok(0x4321));
    }

    #[test]
    fn a_client_on_neither_list_is_refused() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(0, [10, 0, 0, 8]);
        server.poll(&mut chip, &SPLIT, &mut Serving(&mut bank), false);
        assert!(chip.socks[0].reset);
        assert_eq!(server.counters().refused, 1);
    }

    #[test]
    fn the_whole_server_read_only_refuses_every_write_until_switched_back() {
        let (mut chip, mut bank) = (Fake::default(), bank());
        let mut server = started(&mut chip, &mut bank);
        chip.connect(1, [10, 0, 0, 9]);
        server.set_read_only(true);
        assert!(server.is_read_only());
        chip.deliver(1, &write_single(1, 0x1234));
        chip.deliver(1, &read_holding(2, 1, 0, 1));
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert_eq!(chip.socks[1].sent, [exception(1, 0x06, 0x01), holding_reply(2, 1, 0, 1)].concat());
        assert_eq!(bank.get(40001), Ok(0x0100));
        server.set_read_only(false);
        chip.deliver(1, &write_single(3, 0x1234));
        server.poll(&mut chip, &NET, &mut Serving(&mut bank), false);
        assert_eq!(bank.get(40001), Ok(0x1234));
        assert_eq!(server.counters().refused_writes, 1);
    }
}

/// A model several ports serve ([`DataModel::SHARED`]): the bank, and the port each
/// request was said to come from, with the bank's value of 40002 at that moment.
struct SharedBank {
    bank: Bank<4, 16, 4, 0, 0>,
    from: Vec<(crate::Port, u8, u16)>,
}

impl crate::DataModel for SharedBank {
    const SHARED: bool = true;

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), crate::Exception> {
        self.bank.read_bits(table, start, qty, out)
    }
    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), crate::Exception> {
        self.bank.read_registers(table, start, out)
    }
    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        self.bank.has_range(table, start, qty)
    }
    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), crate::Exception> {
        self.bank.write_coils(start, qty, packed)
    }
    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), crate::Exception> {
        self.bank.write_registers(start, values)
    }
    fn serve_from(&mut self, by: crate::Port, unit: u8) {
        self.from.push((by, unit, self.bank.get(40002).unwrap()));
    }
}

use crate::protocol::reference::Table;

#[test]
fn a_shared_model_is_told_the_socket_before_each_request_and_a_writers_address() {
    let mut chip = Fake::default();
    let mut shared = SharedBank { bank: bank(), from: Vec::new() };
    let mut server: Server = Server::new();
    server.poll(&mut chip, &NET, &mut Serving(&mut shared), false);
    chip.connect(2, [10, 0, 0, 9]);
    // A read, then FC 6 writing 40002 = 0xBEEF.
    chip.deliver(2, &read_holding(1, 0x11, 0, 2));
    chip.deliver(2, &[0, 2, 0, 0, 0, 6, 0x11, 0x06, 0x00, 0x01, 0xBE, 0xEF]);
    server.poll(&mut chip, &NET, &mut Serving(&mut shared), false);
    let mut expected = holding_reply(1, 0x11, 0, 2);
    expected.extend_from_slice(&[0, 2, 0, 0, 0, 6, 0x11, 0x06, 0x00, 0x01, 0xBE, 0xEF]);
    assert_eq!(chip.socks[2].sent, expected);
    assert_eq!(shared.bank.get(40002), Ok(0xBEEF));
    // The address is read from the chip for a write only; each call before its request ran.
    let read_from = crate::Port::Tcp { socket: 2, client: [0; 4] };
    let write_from = crate::Port::Tcp { socket: 2, client: [10, 0, 0, 9] };
    assert_eq!(shared.from, [(read_from, 0x11, 0x0101), (write_from, 0x11, 0x0101)]);
}
