//! The client against an imitation of a chip's socket 0 and of the server at its other end:
//! a 2 KB ring each way with free-running pointers, as the W5100's and W5500's.

use super::*;
use crate::protocol::Exception;

const SIZE: u16 = 0x800;
const SERVER: [u8; 4] = [192, 168, 1, 10];

/// Socket 0 of the imitation chip, and the server's side of its connection.
struct Fake {
    status: u8,
    /// Sn_IR: CON, DISCON, RECV, SEND_OK as the chip sets them.
    ir: u8,
    /// Every CONNECT: local port, address, port.
    dials: Vec<(u16, [u8; 4], u16)>,
    rx: Vec<u8>,
    rx_wr: u16,
    rx_rd: u16,
    tx: Vec<u8>,
    tx_wr: u16,
    tx_rd: u16,
    /// What the server got, not yet looked at.
    sent: Vec<u8>,
    /// CLOSE commands given while connected (an RST to the server).
    resets: usize,
}

impl Default for Fake {
    fn default() -> Self {
        Fake {
            status: state::CLOSED,
            ir: 0,
            dials: Vec::new(),
            rx: vec![0; SIZE as usize],
            rx_wr: 0,
            rx_rd: 0,
            tx: vec![0; SIZE as usize],
            tx_wr: 0,
            tx_rd: 0,
            sent: Vec::new(),
            resets: 0,
        }
    }
}

impl Fake {
    /// The server accepts the SYN.
    fn accept(&mut self) {
        assert_eq!(self.status, state::SYNSENT, "no SYN to accept");
        self.status = state::ESTABLISHED;
        self.ir |= 0x01;
    }

    /// The server closes (`CLOSE_WAIT`: a FIN) or resets (`CLOSED`): DISCON.
    fn drop_to(&mut self, status: u8) {
        self.status = status;
        self.ir |= 0x02;
    }

    /// Bytes from the server land in the receive buffer.
    fn deliver(&mut self, bytes: &[u8]) {
        assert!(matches!(self.status, state::ESTABLISHED | state::CLOSE_WAIT), "deliver while {:#x}", self.status);
        for &b in bytes {
            self.rx[usize::from(self.rx_wr % SIZE)] = b;
            self.rx_wr = self.rx_wr.wrapping_add(1);
        }
        self.ir |= 0x04;
    }

    /// What the server received since the last look.
    fn take_sent(&mut self) -> Vec<u8> {
        core::mem::take(&mut self.sent)
    }
}

impl Sockets for Fake {
    fn events(&mut self) -> u8 {
        u8::from(self.ir != 0)
    }
    fn take_events(&mut self, _: u8) -> u8 {
        core::mem::take(&mut self.ir)
    }
    fn status(&mut self, s: u8) -> u8 {
        assert_eq!(s, 0);
        self.status
    }
    fn command(&mut self, s: u8, command: u8) {
        assert_eq!(s, 0);
        match command {
            command::CLOSE => {
                if self.status != state::CLOSED {
                    self.resets += 1;
                }
                self.status = state::CLOSED;
            }
            other => panic!("command {other:#x}"),
        }
    }
    fn listen(&mut self, _: u8, _: u16) {
        panic!("a client does not listen");
    }
    #[cfg(feature = "udp")]
    fn open(&mut self, _: u8, _: u16, _: bool) {
        panic!("a client has no UDP socket");
    }
    #[cfg(feature = "udp")]
    fn set_peer(&mut self, _: u8, _: &mut [u8]) {
        panic!("a client has no UDP socket");
    }
    fn peer(&mut self, _: u8) -> [u8; 4] {
        SERVER
    }
    fn received(&mut self, _: u8) -> u16 {
        self.rx_wr.wrapping_sub(self.rx_rd)
    }
    fn rx_pointer(&mut self, _: u8) -> u16 {
        self.rx_rd
    }
    fn read(&mut self, _: u8, pointer: u16, buf: &mut [u8]) {
        let end = pointer.wrapping_add(buf.len() as u16);
        assert!(end.wrapping_sub(self.rx_rd) <= self.rx_wr.wrapping_sub(self.rx_rd), "read past the received bytes");
        for (i, b) in buf.iter_mut().enumerate() {
            *b = self.rx[usize::from(pointer.wrapping_add(i as u16) % SIZE)];
        }
    }
    fn take(&mut self, _: u8, pointer: u16) {
        assert!(pointer.wrapping_sub(self.rx_rd) <= self.rx_wr.wrapping_sub(self.rx_rd), "took bytes not received");
        self.rx_rd = pointer;
    }
    fn tx_free(&mut self, _: u8) -> u16 {
        SIZE - self.tx_wr.wrapping_sub(self.tx_rd)
    }
    fn tx_pointer(&mut self, _: u8) -> u16 {
        self.tx_wr
    }
    fn write(&mut self, _: u8, pointer: u16, data: &mut [u8]) {
        assert!(pointer.wrapping_sub(self.tx_rd) as usize + data.len() <= SIZE as usize, "written over unsent bytes");
        for (i, &b) in data.iter().enumerate() {
            self.tx[usize::from(pointer.wrapping_add(i as u16) % SIZE)] = b;
        }
    }
    fn send(&mut self, _: u8, pointer: u16) {
        assert_eq!(self.status, state::ESTABLISHED, "SEND without a connection");
        self.tx_wr = pointer;
        while self.tx_rd != self.tx_wr {
            self.sent.push(self.tx[usize::from(self.tx_rd % SIZE)]);
            self.tx_rd = self.tx_rd.wrapping_add(1);
        }
        self.ir |= 0x10;
    }
}

impl Connect for Fake {
    fn connect(&mut self, s: u8, local_port: u16, ip: [u8; 4], port: u16) {
        assert_eq!(s, 0);
        // A new connection: pointers where the chip's OPEN leaves them, nothing received.
        let (dials, resets) = (core::mem::take(&mut self.dials), self.resets);
        *self = Fake { status: state::SYNSENT, dials, resets, ..Fake::default() };
        self.rx_wr = 0xFFF8;
        self.rx_rd = 0xFFF8;
        self.tx_wr = 0x7FFC;
        self.tx_rd = 0x7FFC;
        self.dials.push((local_port, ip, port));
    }
}

/// An ADU: the MBAP header (Implementation Guide §3.1.3) and `pdu`.
fn adu(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut out = transaction.to_be_bytes().to_vec();
    out.extend_from_slice(&[0, 0]); // protocol id
    out.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes()); // length: unit id and PDU
    out.push(unit);
    out.extend_from_slice(pdu);
    out
}

/// FC 3, 10 holding registers from address 0.
const READ: Request<'static> = Request::ReadHoldingRegisters { address: 0, quantity: 10 };
/// Its PDU.
const READ_PDU: [u8; 5] = [0x03, 0x00, 0x00, 0x00, 0x0A];

/// The reply PDU to [`READ`]: 40001-40010 = 0x0100 + i.
fn ten_registers() -> Vec<u8> {
    let mut pdu = vec![0x03, 20];
    for i in 0..10u16 {
        pdu.extend_from_slice(&(0x0100 + i).to_be_bytes());
    }
    pdu
}

/// A client and its chip at `now` 0, connected (one poll to dial, the SYN accepted, one poll
/// to see it).
fn connected() -> (Client<64>, Fake, u32) {
    let mut client = Client::<64>::new(SERVER, 502);
    let mut chip = Fake::default();
    client.poll(&mut chip, 0);
    assert_eq!(chip.dials, [(0xC001, SERVER, 502)]);
    chip.accept();
    client.poll(&mut chip, 1);
    assert!(client.is_connected());
    (client, chip, 2)
}

/// Polls every millisecond from `*now` for `ms` milliseconds.
fn run(client: &mut Client<64>, chip: &mut Fake, now: &mut u32, ms: u32) {
    for _ in 0..ms {
        client.poll(chip, *now);
        *now += 1;
    }
}

/// The registers of the outcome, or its failure; the outcome collected.
fn outcome(client: &mut Client<64>) -> Option<Result<Vec<u16>, Failure>> {
    let result = client.outcome().map(|r| r.map(|reply| reply.registers().collect()));
    client.collect();
    result
}

fn values() -> Vec<u16> {
    (0..10).map(|i| 0x0100 + i).collect()
}

#[test]
fn a_request_goes_out_with_transaction_id_1_protocol_0_and_its_unit_id() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(chip.take_sent(), adu(1, 0xFF, &READ_PDU));
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
    assert!(!client.is_busy());
}

#[test]
fn each_request_takes_the_next_transaction_id_and_wraps() {
    let (mut client, mut chip, mut now) = connected();
    client.transaction = 0xFFFE;
    for expected in [0xFFFF, 0x0000, 0x0001] {
        client.start(1, &READ, now).unwrap();
        run(&mut client, &mut chip, &mut now, 1);
        assert_eq!(chip.take_sent(), adu(expected, 1, &READ_PDU));
        chip.deliver(&adu(expected, 1, &ten_registers()));
        run(&mut client, &mut chip, &mut now, 1);
        assert_eq!(outcome(&mut client), Some(Ok(values())), "transaction {expected:#x}");
    }
}

#[test]
fn a_reply_with_another_transaction_id_is_never_taken_and_the_wait_goes_on() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    chip.take_sent();
    // Another id with a reply that would fit the request: skipped, counted.
    let mut other = ten_registers();
    other[2] = 0xEE;
    chip.deliver(&adu(2, 0xFF, &other));
    run(&mut client, &mut chip, &mut now, 100);
    assert_eq!(outcome(&mut client), None, "taken or ended");
    assert_eq!(client.counters().unexpected, 1);
    assert_eq!(chip.received(0), 0, "skipped from the chip");
    // The right one, later, inside the timeout.
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
    assert_eq!(client.counters().retries, 0);
}

#[test]
fn a_reply_with_another_id_only_times_out() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 200, turnaround_ms: 0, retries: 0 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    chip.deliver(&adu(0x1234, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 250);
    assert_eq!(outcome(&mut client), Some(Err(Failure::Timeout)));
}

#[test]
fn a_reply_split_over_segments_is_taken_once_whole() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    let reply = adu(1, 0xFF, &ten_registers());
    // A byte every 5 ms, as libmodbus's test server sends register 0x173's.
    for (i, &byte) in reply.iter().enumerate() {
        assert_eq!(outcome(&mut client), None, "done after {i} bytes");
        chip.deliver(&[byte]);
        run(&mut client, &mut chip, &mut now, 5);
    }
    assert_eq!(outcome(&mut client), Some(Ok(values())));
}

#[test]
fn a_silent_server_times_out_after_each_try_with_the_same_transaction_id() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 2 });
    let start = now;
    client.start(0xFF, &READ, now).unwrap();
    while client.outcome().is_none() {
        run(&mut client, &mut chip, &mut now, 1);
        assert!(now - start < 1000);
    }
    assert_eq!(outcome(&mut client), Some(Err(Failure::Timeout)));
    // Three tries, each 100 ms (never less, one poll more at most).
    assert!((302..=306).contains(&(now - start)), "{} ms", now - start);
    let request = adu(1, 0xFF, &READ_PDU);
    assert_eq!(chip.take_sent(), [request.clone(), request.clone(), request].concat());
    let counters = client.counters();
    assert_eq!((counters.requests, counters.timeouts, counters.retries), (3, 3, 2));
}

#[test]
fn a_late_reply_to_the_first_try_answers_the_retry() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 1 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 150);
    assert_eq!(client.counters().retries, 1);
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
}

#[test]
fn a_late_reply_to_an_earlier_request_is_skipped() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 0 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 150);
    assert_eq!(outcome(&mut client), Some(Err(Failure::Timeout)));
    client.start(0xFF, &Request::ReadHoldingRegisters { address: 0, quantity: 1 }, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    // Request 1's reply comes now, then request 2's.
    chip.deliver(&[adu(1, 0xFF, &ten_registers()), adu(2, 0xFF, &[0x03, 2, 0xAB, 0xCD])].concat());
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(vec![0xABCD])));
    assert_eq!(client.counters().unexpected, 1);
}

#[test]
fn an_exception_reply_is_the_outcome() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    chip.deliver(&adu(1, 0xFF, &[0x83, 0x02]));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Err(Failure::Exception(Exception::IllegalDataAddress))));
    assert_eq!(client.counters().exceptions, 1);
}

#[test]
fn a_reply_from_another_unit_id_is_skipped_and_the_wait_goes_on() {
    let (mut client, mut chip, mut now) = connected();
    client.start(17, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(chip.take_sent(), adu(1, 17, &READ_PDU));
    chip.deliver(&adu(1, 18, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 10);
    assert_eq!(outcome(&mut client), None);
    assert_eq!(client.counters().unexpected, 1);
    chip.deliver(&adu(1, 17, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
}

#[test]
fn a_protocol_id_other_than_0_is_skipped_and_the_wait_goes_on() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    let mut other = adu(1, 0xFF, &ten_registers());
    other[3] = 0x01;
    chip.deliver(&other);
    run(&mut client, &mut chip, &mut now, 10);
    assert_eq!(outcome(&mut client), None);
    assert_eq!(client.counters().malformed, 1);
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
}

#[test]
fn a_reply_shorter_than_its_length_field_is_awaited_whole() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 0 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    // The length says 2 bytes more than come: the reply is not taken short.
    let mut short = adu(1, 0xFF, &ten_registers());
    short[5] += 2;
    chip.deliver(&short);
    run(&mut client, &mut chip, &mut now, 150);
    assert_eq!(outcome(&mut client), Some(Err(Failure::Timeout)));
    assert_eq!(client.counters().replies, 0);
}

#[test]
fn a_reply_longer_than_its_length_field_is_no_answer() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 0 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    // The length field counts 2 register bytes fewer than the byte count says: the PDU it
    // delimits does not answer the read; what follows is no header.
    let mut long = adu(1, 0xFF, &ten_registers());
    long[5] -= 2;
    chip.deliver(&long);
    run(&mut client, &mut chip, &mut now, 150);
    assert_eq!(outcome(&mut client), Some(Err(Failure::BadReply)));
    assert_eq!(client.counters().replies, 0);
}

#[test]
fn a_reply_longer_than_the_buffer_is_no_answer() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 0 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    let mut long = vec![0x03, 80];
    long.extend_from_slice(&[0; 80]);
    chip.deliver(&adu(1, 0xFF, &long));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Err(Failure::BadReply)));
    assert_eq!(client.counters().overruns, 1);
}

#[test]
fn a_length_field_outside_2_to_254_closes_the_connection_and_a_new_one_carries_the_retry() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    chip.take_sent();
    let mut bad = adu(1, 0xFF, &ten_registers());
    bad[4] = 0x01;
    chip.deliver(&bad);
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(chip.resets, 1, "closed with an RST");
    assert_eq!(client.counters().malformed, 1);
    // A new connection at once, from the next local port; the retry goes out on it.
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(chip.dials.last(), Some(&(0xC002, SERVER, 502)));
    chip.accept();
    run(&mut client, &mut chip, &mut now, 2);
    assert_eq!(chip.take_sent(), adu(1, 0xFF, &READ_PDU));
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
    assert_eq!(client.connections(), 2);
}

#[test]
fn nothing_is_sent_before_the_connection_and_a_request_meanwhile_is_refused() {
    let mut client = Client::<64>::new(SERVER, 502);
    let mut chip = Fake::default();
    assert_eq!(client.start(0xFF, &READ, 0), Err(Error::NotConnected));
    client.poll(&mut chip, 0);
    assert_eq!(client.start(0xFF, &READ, 0), Err(Error::NotConnected), "SYN sent only");
    assert!(!client.is_busy());
}

#[test]
fn a_refused_connection_is_tried_again_every_second() {
    let mut client = Client::<64>::new(SERVER, 1502);
    let mut chip = Fake::default();
    // The server answers each SYN with an RST: the socket closes at once.
    for now in 0..3500 {
        client.poll(&mut chip, now);
        if chip.status == state::SYNSENT {
            chip.status = state::CLOSED;
        }
    }
    assert_eq!(chip.dials.len(), 4, "at 0, 1001, 2002 and 3003 ms: {:?}", chip.dials);
    assert!(chip.dials.iter().all(|&(_, ip, port)| ip == SERVER && port == 1502));
}

#[test]
fn an_unanswered_syn_is_given_up_after_3_s() {
    let mut client = Client::<64>::new(SERVER, 502);
    let mut chip = Fake::default();
    let mut now = 0;
    run(&mut client, &mut chip, &mut now, 3500);
    assert_eq!(chip.dials.len(), 1);
    run(&mut client, &mut chip, &mut now, 1000);
    assert_eq!(chip.dials.len(), 2, "closed at 3 s, tried again a second later");
}

#[test]
fn a_connection_the_server_closes_is_opened_again_and_the_retry_goes_out_on_it() {
    for how in [state::CLOSED, state::CLOSE_WAIT] {
        let (mut client, mut chip, mut now) = connected();
        client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 1 });
        client.start(0xFF, &READ, now).unwrap();
        run(&mut client, &mut chip, &mut now, 1);
        chip.take_sent();
        // An RST, or a FIN, with the request unanswered.
        chip.drop_to(how);
        run(&mut client, &mut chip, &mut now, 1);
        assert!(!client.is_connected());
        assert_eq!(client.start(0xFF, &READ, now), Err(Error::Busy), "the request is still under way");
        run(&mut client, &mut chip, &mut now, 1);
        assert_eq!(chip.dials.len(), 2, "{how:#x}: a new connection at once");
        chip.accept();
        // The try times out on its own clock; the retry goes out on the new connection.
        run(&mut client, &mut chip, &mut now, 101);
        assert_eq!(chip.take_sent(), adu(1, 0xFF, &READ_PDU), "{how:#x}");
        chip.deliver(&adu(1, 0xFF, &ten_registers()));
        run(&mut client, &mut chip, &mut now, 1);
        assert_eq!(outcome(&mut client), Some(Ok(values())), "{how:#x}");
        assert_eq!(client.connections(), 2);
    }
}

#[test]
fn a_reply_the_server_sent_before_its_fin_is_taken() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    chip.deliver(&adu(1, 0xFF, &ten_registers()));
    chip.drop_to(state::CLOSE_WAIT);
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(values())));
    assert!(!client.is_connected());
}

#[test]
fn a_retry_waits_for_the_connection_within_its_timeout() {
    let (mut client, mut chip, mut now) = connected();
    client.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 0, retries: 1 });
    client.start(0xFF, &READ, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    // The connection drops and the server never answers a SYN again: the retry never goes
    // out, and times out too.
    chip.drop_to(state::CLOSED);
    run(&mut client, &mut chip, &mut now, 250);
    assert_eq!(outcome(&mut client), Some(Err(Failure::Timeout)));
    assert_eq!(client.counters().requests, 1);
}

#[test]
fn a_write_is_answered_by_its_echo() {
    let (mut client, mut chip, mut now) = connected();
    client.start(0xFF, &Request::WriteSingleRegister { address: 5, value: 0x1234 }, now).unwrap();
    run(&mut client, &mut chip, &mut now, 1);
    let pdu = [0x06, 0x00, 0x05, 0x12, 0x34];
    assert_eq!(chip.take_sent(), adu(1, 0xFF, &pdu));
    chip.deliver(&adu(1, 0xFF, &pdu));
    run(&mut client, &mut chip, &mut now, 1);
    assert_eq!(outcome(&mut client), Some(Ok(vec![])));
}

#[test]
fn a_quiet_socket_costs_one_register_read_and_a_close_without_an_event_is_seen_within_a_second() {
    let (mut client, mut chip, mut now) = connected();
    run(&mut client, &mut chip, &mut now, 1100);
    // The socket closed and the chip said nothing: seen at the next sweep, at most 1 s later.
    chip.status = state::CLOSED;
    run(&mut client, &mut chip, &mut now, 900);
    assert_eq!(chip.dials.len(), 1, "looked at the state without an event or a sweep");
    run(&mut client, &mut chip, &mut now, 200);
    assert_eq!(chip.dials.len(), 2, "the close not seen by the sweep");
}
