//! The gateway against the imitation chip (`crate::tcp::fake`) and the RTU master's real
//! engine, whose line is played here: every frame it sends is logged, and each slave
//! answers from a bank, answers an exception, or is dead.

use std::collections::HashMap;

use super::*;
use crate::link::crc::Crc16;
use crate::master::internal::{Action, Engine};
use crate::master::Timeouts;
use crate::slave::bank::Bank;
use crate::tcp::fake::Fake;
use crate::tcp::network::Network;
use crate::tcp::server::Server;

type Regs = Bank<4, 16, 4, 0, 0>;

/// A slave on the played line.
enum Slave {
    /// Answers from its bank.
    Bank(Regs),
    /// Answers nothing.
    Dead,
}

/// The serial line: the master's engine, the slaves, the clock, every frame sent.
struct Played {
    engine: Engine<256>,
    slaves: HashMap<u8, Slave>,
    now: u32,
    /// Frames sent (address, PDU, CRC), with the time each went out.
    sent: Vec<(u32, Vec<u8>)>,
    /// The line is held: a request stays under way until `release`.
    held: Option<Action>,
    hold: bool,
}

/// A bank whose holding registers 40001-40010 hold `base + i`.
fn regs(base: u16) -> Regs {
    let mut bank = Bank::new();
    bank.add_range(40001, 10).unwrap();
    for i in 0..10u16 {
        bank.set(40001 + i, base + i).unwrap();
    }
    bank
}

impl Played {
    fn new(slaves: impl IntoIterator<Item = (u8, Slave)>) -> Self {
        let mut engine = Engine::new();
        engine.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 20, retries: 1 });
        // The power-up silence.
        assert_eq!(engine.on_end_deadline(), Action::None);
        Played { engine, slaves: slaves.into_iter().collect(), now: 1000, sent: Vec::new(), held: None, hold: false }
    }

    /// Plays the line from `action` until the request is done: each try sent, answered
    /// or timed out.
    fn play(&mut self, mut action: Action) {
        while action == Action::Send {
            let frame = self.engine.request().to_vec();
            self.now += 1 + frame.len() as u32 / 2;
            self.sent.push((self.now, frame.clone()));
            self.engine.on_sent(self.now);
            let answer = match self.slaves.get_mut(&frame[0]) {
                Some(Slave::Bank(bank)) if frame[0] != 0 => {
                    let mut adu = vec![0u8; 7];
                    adu.extend_from_slice(&frame[1..frame.len() - 2]);
                    adu.resize(7 + 256, 0);
                    let pdu_len = frame.len() - 3;
                    let (n, _) = crate::tcp::respond(&mut adu, pdu_len, bank).unwrap();
                    let mut reply = vec![frame[0]];
                    reply.extend_from_slice(&adu[7..7 + n]);
                    reply.extend_from_slice(&Crc16::new().update_slice(&reply).to_wire());
                    Some(reply)
                }
                Some(Slave::Bank(bank)) => {
                    // A broadcast: carried out, unanswered.
                    let mut adu = vec![0u8; 7];
                    adu.extend_from_slice(&frame[1..frame.len() - 2]);
                    adu.resize(7 + 256, 0);
                    let _ = crate::tcp::respond(&mut adu, frame.len() - 3, bank);
                    None
                }
                _ => None,
            };
            match answer {
                Some(reply) => {
                    self.now += 1 + reply.len() as u32 / 2;
                    for b in reply {
                        self.engine.on_byte(b);
                    }
                    action = self.engine.on_end_deadline();
                }
                None => {
                    assert_eq!(self.engine.on_end_deadline(), Action::None);
                    let wait = self.engine.timeouts().response_ms.max(self.engine.timeouts().turnaround_ms);
                    self.now += u32::from(wait) + 2;
                    action = self.engine.on_tick(self.now);
                }
            }
        }
    }
}

impl Played {
    /// The request held under way is played out.
    fn release(&mut self) {
        self.hold = false;
        if let Some(action) = self.held.take() {
            self.play(action);
        }
    }
}

impl RtuSide for Played {
    fn is_free(&mut self) -> bool {
        !self.engine.is_busy()
    }
    fn put(&mut self, at: usize, bytes: &[u8]) {
        self.engine.request_mut().expect("put while busy")[at..at + bytes.len()].copy_from_slice(bytes);
    }
    fn forward(&mut self, len: usize, retries: u8) -> bool {
        match self.engine.forward(len, retries) {
            Ok(action) if self.hold => {
                self.held = Some(action);
                true
            }
            Ok(action) => {
                self.play(action);
                true
            }
            Err(_) => false,
        }
    }
    fn outcome(&mut self) -> Option<Result<usize, Failure>> {
        self.engine.outcome().map(|o| o.map(|reply| reply.data().len()))
    }
    fn reply(&mut self, at: usize, out: &mut [u8]) {
        let pdu = self.engine.answer_pdu().expect("no answer to copy");
        out.copy_from_slice(&pdu[at..at + out.len()]);
    }
    fn collect(&mut self) {
        self.engine.collect();
    }
    fn retries(&mut self) -> u8 {
        self.engine.timeouts().retries
    }
    fn now(&mut self) -> u32 {
        self.now
    }
}

/// Routes 1-247 as they are, but unit 9, which is routed nowhere.
struct NotNine;

impl Routes for NotNine {
    fn route(&self, unit: u8) -> Option<u8> {
        (unit != 9).then(|| Direct.route(unit)).flatten()
    }
}

const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(4);

/// The gateway on the imitation chip: server, gateway state, its own registers, the line.
struct Rig {
    chip: Fake,
    server: Server<32>,
    gateway: Gateway,
    line: Played,
    settings: GatewaySettings,
}

impl Rig {
    fn new(slaves: impl IntoIterator<Item = (u8, Slave)>) -> Self {
        let mut rig = Rig {
            chip: Fake::default(),
            server: Server::new(),
            gateway: Gateway::new(),
            line: Played::new(slaves),
            settings: GatewaySettings::new(),
        };
        rig.step();
        rig
    }

    /// One poll as the AVR layer makes it: the line's outcome passed back (and, the line
    /// free, the waiting connections resumed), then the chip served.
    fn step(&mut self) {
        if self.gateway.deliver(&mut self.server, &mut self.chip, &mut self.line, &self.settings) {
            self.server.resume();
        }
        self.serve();
    }

    fn serve(&mut self) {
        let mut gate = Gate {
            gateway: &mut self.gateway,
            line: &mut self.line,
            routes: &NotNine,
            settings: &self.settings,
            waiting: self.server.waiting(),
        };
        self.server.poll(&mut self.chip, &NET, &mut gate, false);
    }

    /// Polls until nothing moves.
    fn settle(&mut self) {
        for _ in 0..200 {
            self.step();
        }
    }
}

fn read(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    let mut adu = vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, 6, unit, 3];
    adu.extend_from_slice(&start.to_be_bytes());
    adu.extend_from_slice(&qty.to_be_bytes());
    adu
}

fn read_reply(transaction: u16, unit: u8, base: u16, start: u16, qty: u16) -> Vec<u8> {
    let len = 3 + 2 * qty;
    let mut adu = vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, len as u8, unit, 3, 2 * qty as u8];
    for i in 0..qty {
        adu.extend_from_slice(&(base + start + i).to_be_bytes());
    }
    adu
}

fn exception(transaction: u16, unit: u8, function: u8, code: u8) -> Vec<u8> {
    vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, 3, unit, function | 0x80, code]
}

#[test]
fn each_answer_goes_back_to_its_connection_with_its_transaction_id() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (2, Slave::Bank(regs(0x200)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.connect(2, [10, 0, 0, 8]);
    rig.chip.deliver(0, &read(0x1111, 1, 0, 3));
    rig.chip.deliver(2, &read(0x2222, 2, 4, 2));
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, read_reply(0x1111, 1, 0x100, 0, 3));
    assert_eq!(rig.chip.socks[2].sent, read_reply(0x2222, 2, 0x200, 4, 2));
    let frames: Vec<u8> = rig.line.sent.iter().map(|(_, f)| f[0]).collect();
    assert_eq!(frames, [1, 2]);
    assert_eq!(rig.line.sent[0].1, [1, 3, 0, 0, 0, 3, 5, 0xCB], "the RTU request, CRC included");
    let counts = rig.gateway.counters();
    assert_eq!((counts.forwarded, counts.answers), (2, 2));
}

#[test]
fn connections_take_turns_and_each_keeps_its_order() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    for s in 0..3 {
        rig.chip.connect(s, [10, 0, 0, 7 + s as u8]);
        // Five pipelined requests in one segment.
        let stream: Vec<u8> = (0..5).flat_map(|i| read(s as u16 * 100 + i, 1, i, 1)).collect();
        rig.chip.deliver(s, &stream);
    }
    rig.settle();
    for s in 0..3 {
        let expected: Vec<u8> = (0..5).flat_map(|i| read_reply(s as u16 * 100 + i, 1, 0x100, i, 1)).collect();
        assert_eq!(rig.chip.socks[s].sent, expected, "socket {s}");
    }
    // On the line: a request of each connection in turn.
    let order: Vec<u16> = rig.line.sent.iter().map(|(_, f)| u16::from_be_bytes([f[2], f[3]])).collect();
    assert_eq!(order, [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4]);
}

#[test]
fn connections_waiting_for_the_line_cost_no_reads_until_it_is_free() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.line.hold = true;
    for s in 0..3 {
        rig.chip.connect(s, [10, 0, 0, 7]);
        rig.chip.deliver(s, &read(s as u16, 1, 0, 1));
    }
    rig.step();
    assert!(rig.gateway.is_forwarding());
    let reads = rig.chip.reads;
    for _ in 0..50 {
        rig.step();
    }
    assert_eq!(rig.chip.reads, reads, "the waiting connections were read again");
    rig.line.release();
    rig.settle();
    for s in 0..3 {
        assert_eq!(rig.chip.socks[s].sent, read_reply(s as u16, 1, 0x100, 0, 1));
    }
}

#[test]
fn unit_ids_own_broadcast_routed_and_not() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (0, Slave::Dead)]);
    rig.chip.connect(1, [10, 0, 0, 7]);
    // The gateway's own unit, from its own registers; not on the line.
    rig.chip.deliver(1, &read(1, 0xFF, 0, 2));
    rig.settle();
    assert_eq!(rig.chip.socks[1].sent, [0, 1, 0, 0, 0, 7, 0xFF, 3, 4, 0, 0, 0, 0]);
    assert!(rig.line.sent.is_empty());
    // Not routed (9), and the ids no slave has (248-254): 0A.
    for (t, unit) in [(2, 9), (3, 248), (4, 254)] {
        rig.chip.socks[1].sent.clear();
        rig.chip.deliver(1, &read(t, unit, 0, 1));
        rig.settle();
        assert_eq!(rig.chip.socks[1].sent, exception(t, unit, 3, 0x0A), "unit {unit}");
    }
    assert!(rig.line.sent.is_empty());
    assert_eq!(rig.gateway.counters().unavailable, 3);
    // Unit 0: a write goes out as a broadcast, unanswered; a read goes nowhere.
    rig.chip.socks[1].sent.clear();
    let mut write = vec![0, 5, 0, 0, 0, 6, 0, 6, 0, 1, 0x12, 0x34];
    rig.chip.deliver(1, &write);
    rig.chip.deliver(1, &read(6, 0, 0, 1));
    write[1] = 7;
    rig.chip.deliver(1, &read(8, 1, 0, 1));
    rig.settle();
    let frames: Vec<Vec<u8>> = rig.line.sent.iter().map(|(_, f)| f[..f.len() - 2].to_vec()).collect();
    assert_eq!(frames, [vec![0, 6, 0, 1, 0x12, 0x34], vec![1, 3, 0, 0, 0, 1]]);
    assert_eq!(rig.chip.socks[1].sent, read_reply(8, 1, 0x100, 0, 1), "only the unit 1 read is answered");
    assert_eq!(rig.gateway.counters().broadcasts, 1);
}

#[test]
fn a_slaves_exception_is_passed_back_as_it_came() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    // 40011 does not exist on the slave: 02 from it.
    rig.chip.deliver(0, &read(0x77, 1, 10, 1));
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, exception(0x77, 1, 3, 0x02));
    let counts = rig.gateway.counters();
    assert_eq!((counts.answers, counts.exceptions, counts.no_response), (1, 1, 0));
}

#[test]
fn a_dead_slave_gets_0b_after_its_retries_then_at_once_until_rechecked() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead)]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.deliver(0, &read(1, 3, 0, 1));
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, exception(1, 3, 3, 0x0B));
    assert_eq!(rig.line.sent.len(), 2, "the request and its retry");
    assert!(rig.gateway.is_down(3));
    // Down: answered at once, the line untouched, the live slave served.
    rig.chip.socks[0].sent.clear();
    rig.chip.deliver(0, &[read(2, 3, 0, 1), read(3, 1, 0, 1)].concat());
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, [exception(2, 3, 3, 0x0B), read_reply(3, 1, 0x100, 0, 1)].concat());
    assert_eq!(rig.line.sent.len(), 3);
    // Once the recheck time has come: one try, no retry.
    rig.line.now += 1000;
    rig.chip.socks[0].sent.clear();
    rig.chip.deliver(0, &read(4, 3, 0, 1));
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, exception(4, 3, 3, 0x0B));
    assert_eq!(rig.line.sent.len(), 4);
    // It comes back: answered, up again.
    rig.line.slaves.insert(3, Slave::Bank(regs(0x300)));
    rig.line.now += 1000;
    rig.chip.socks[0].sent.clear();
    rig.chip.deliver(0, &[read(5, 3, 0, 1), read(6, 3, 1, 1)].concat());
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, [read_reply(5, 3, 0x300, 0, 1), read_reply(6, 3, 0x300, 1, 1)].concat());
    assert!(!rig.gateway.is_down(3));
    assert_eq!(rig.gateway.counters().no_response, 3);
}

#[test]
fn an_answer_for_a_connection_that_closed_is_dropped() {
    let mut rig = Rig::new([(3, Slave::Dead)]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.deliver(0, &read(1, 3, 0, 1));
    // The request goes out; its master leaves and another takes the socket.
    rig.line.hold = true;
    rig.step();
    assert!(rig.gateway.is_forwarding());
    rig.chip.socks[0].status = crate::tcp::wiznet::state::CLOSED;
    rig.chip.socks[0].ir |= 0x02;
    rig.step();
    rig.chip.connect(0, [10, 0, 0, 8]);
    rig.step();
    rig.line.release();
    rig.settle();
    assert!(rig.chip.socks[0].sent.is_empty(), "the new connection got nothing");
    assert_eq!(rig.gateway.counters().orphaned, 1);
    assert!(!rig.gateway.is_forwarding());
}

#[test]
fn a_master_that_closes_its_side_after_its_request_gets_the_answer_then_a_fin() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.deliver(0, &read(5, 1, 0, 2));
    // Its FIN comes with the request: the socket is in CLOSE_WAIT.
    rig.chip.socks[0].status = crate::tcp::wiznet::state::CLOSE_WAIT;
    rig.chip.socks[0].ir |= 0x02;
    rig.line.hold = true;
    rig.step();
    assert!(rig.gateway.is_forwarding());
    rig.step();
    assert!(!rig.chip.socks[0].fin, "closed while its answer was on the line");
    rig.line.release();
    rig.settle();
    assert_eq!(rig.chip.socks[0].sent, read_reply(5, 1, 0x100, 0, 2));
    assert!(rig.chip.socks[0].fin, "no FIN after the answer");
    assert_eq!(rig.gateway.counters().orphaned, 0);
}

/// xorshift64: the random streams' source, the same every run.
fn next(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

/// What the gateway must answer to a read of `qty` registers from `start` at `unit`: the
/// reply, an exception, or nothing (a broadcast).
fn expected(transaction: u16, unit: u8, start: u16, qty: u16) -> Vec<u8> {
    match unit {
        0 => Vec::new(),
        1 => read_reply(transaction, unit, 0x100, start, qty),
        2 => read_reply(transaction, unit, 0x200, start, qty),
        3 => exception(transaction, unit, 3, 0x0B),
        // The gateway's own registers end at 24.
        0xFF => exception(transaction, unit, 3, 0x02),
        _ => exception(transaction, unit, 3, 0x0A),
    }
}

#[test]
fn every_request_of_every_connection_gets_exactly_its_one_answer() {
    // Random streams on four connections at once: reads of live slaves (1, 2), a dead one
    // (3), units routed nowhere (9, 248), the gateway's own (0xFF) and broadcast writes
    // (0), pipelined and cut anywhere, delivered in random order while the line is held
    // and released at random. Every request gets exactly its answer, on its connection,
    // in the order sent; the broadcasts none.
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    for round in 0..200 {
        let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (2, Slave::Bank(regs(0x200))), (3, Slave::Dead)]);
        let mut streams: Vec<Vec<u8>> = Vec::new();
        let mut answers: Vec<Vec<u8>> = Vec::new();
        for s in 0..4 {
            rig.chip.connect(s, [10, 0, 0, 7 + s as u8]);
            let (mut stream, mut answer) = (Vec::new(), Vec::new());
            for i in 0..(next(&mut seed) % 8) as u16 {
                let transaction = (s as u16) << 12 | i;
                let unit = [0, 1, 1, 2, 2, 3, 9, 248, 0xFF][(next(&mut seed) % 9) as usize];
                if unit == 0 {
                    stream.extend([(transaction >> 8) as u8, transaction as u8, 0, 0, 0, 6, 0, 6, 0, 0, 0, 1]);
                    continue;
                }
                let start = (next(&mut seed) % 5) as u16 + if unit == 0xFF { 24 } else { 0 };
                let qty = 1 + (next(&mut seed) % 5) as u16;
                stream.extend(read(transaction, unit, start, qty));
                answer.extend(expected(transaction, unit, start, qty));
            }
            streams.push(stream);
            answers.push(answer);
        }
        let mut at = [0usize; 4];
        while at.iter().zip(&streams).any(|(a, s)| *a < s.len()) {
            let s = (next(&mut seed) % 4) as usize;
            let n = ((next(&mut seed) % 20) as usize).min(streams[s].len() - at[s]);
            rig.chip.deliver(s, &streams[s][at[s]..at[s] + n]);
            at[s] += n;
            match next(&mut seed) % 4 {
                0 => rig.line.hold = true,
                1 => rig.line.release(),
                _ => {}
            }
            rig.step();
        }
        rig.line.release();
        rig.settle();
        for (s, answer) in answers.iter().enumerate() {
            assert_eq!(&rig.chip.socks[s].sent, answer, "round {round}, socket {s}");
        }
    }
}

#[test]
fn the_gateways_own_registers_count_what_it_did() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead), (17, Slave::Dead)]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    let stream = [read(1, 1, 0, 1), read(2, 1, 10, 1), read(3, 9, 0, 1), read(4, 3, 0, 1), read(5, 17, 0, 1)].concat();
    rig.chip.deliver(0, &stream);
    rig.settle();
    rig.chip.socks[0].sent.clear();
    let mut status = read(6, 0xFF, 0, 10);
    status[7] = 4;
    rig.chip.deliver(0, &status);
    rig.settle();
    // forwarded 4, answers 2, exceptions 1, 0A 1, 0B 2, broadcasts 0, orphaned 0, waiting
    // 0, slaves 3 and 17 down.
    let values = [4u16, 2, 1, 1, 2, 0, 0, 0, 1 << 3, 1 << 1];
    let mut expected = vec![0, 6, 0, 0, 0, 23, 0xFF, 4, 20];
    expected.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    assert_eq!(rig.chip.socks[0].sent, expected);
    // Past the last register: 02; a quantity of 0: 03; a write: 01.
    rig.chip.socks[0].sent.clear();
    rig.chip
        .deliver(0, &[read(7, 0xFF, 20, 5), read(8, 0xFF, 0, 0), vec![0, 9, 0, 0, 0, 6, 0xFF, 6, 0, 0, 0, 1]].concat());
    rig.settle();
    assert_eq!(
        rig.chip.socks[0].sent,
        [exception(7, 0xFF, 3, 2), exception(8, 0xFF, 3, 3), exception(9, 0xFF, 6, 1)].concat()
    );
}

#[test]
fn a_master_that_does_not_read_its_answers_holds_up_only_itself() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.connect(1, [10, 0, 0, 8]);
    // Socket 0's master stops reading: its SEND never completes (no SEND_OK), and its
    // transmit buffer fills up.
    rig.chip.socks[0].reading = false;
    rig.chip.deliver(0, &[read(1, 1, 0, 10), read(2, 1, 0, 10)].concat());
    rig.settle();
    assert_eq!(rig.line.sent.len(), 1, "its second request waits for the first answer's SEND");
    for i in 0..20u16 {
        rig.chip.deliver(1, &read(100 + i, 1, 0, 1));
        rig.settle();
    }
    let expected: Vec<u8> = (0..20u16).flat_map(|i| read_reply(100 + i, 1, 0x100, 0, 1)).collect();
    assert_eq!(rig.chip.socks[1].sent, expected, "the other connection was held up");
    assert_eq!(rig.line.sent.len(), 21);
    // It reads again: its second request goes out and is answered.
    rig.chip.socks[0].reading = true;
    rig.chip.ack(0);
    rig.chip.socks[0].ir |= crate::tcp::wiznet::SEND_OK;
    rig.settle();
    rig.chip.ack(0);
    assert_eq!(rig.chip.socks[0].sent, [read_reply(1, 1, 0x100, 0, 10), read_reply(2, 1, 0x100, 0, 10)].concat());
}
