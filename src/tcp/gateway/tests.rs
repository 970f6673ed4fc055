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
    /// Answers from its bank this many milliseconds after the request.
    Slow(u32, Regs),
}

/// What the line does to the next answer (one fault per answer, in order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    /// Lost.
    Dropped,
    /// Sent from the next address.
    WrongSlave,
    /// A byte damaged: the CRC fails.
    Damaged,
    /// The last data byte missing (with a right CRC).
    Short,
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
    /// Faults for the next answers, the first one next.
    faults: Vec<Option<Fault>>,
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
        Played {
            engine,
            slaves: slaves.into_iter().collect(),
            now: 1000,
            sent: Vec::new(),
            held: None,
            hold: false,
            faults: Vec::new(),
        }
    }

    /// Plays the line from `action` until the request is done: each try sent, answered
    /// or timed out.
    fn play(&mut self, mut action: Action) {
        while action == Action::Send {
            let frame = self.engine.request().to_vec();
            self.now += 1 + frame.len() as u32 / 2;
            self.sent.push((self.now, frame.clone()));
            self.engine.on_sent(self.now);
            let (delay, bank) = match self.slaves.get_mut(&frame[0]) {
                Some(Slave::Bank(bank)) => (0, Some(bank)),
                Some(Slave::Slow(delay, bank)) => (*delay, Some(bank)),
                _ => (0, None),
            };
            let mut answer = bank.and_then(|bank| {
                let mut adu = vec![0u8; 7];
                adu.extend_from_slice(&frame[1..frame.len() - 2]);
                adu.resize(7 + 256, 0);
                let pdu_len = frame.len() - 3;
                // A broadcast is carried out, unanswered.
                let (n, _) = crate::tcp::respond(&mut adu, pdu_len, bank)?;
                let mut reply = vec![frame[0]];
                reply.extend_from_slice(&adu[7..7 + n]);
                (frame[0] != 0).then_some(reply)
            });
            let fault = if answer.is_none() || self.faults.is_empty() { None } else { self.faults.remove(0) };
            match fault {
                Some(Fault::Dropped) => answer = None,
                Some(Fault::WrongSlave) => answer.as_mut().unwrap()[0] += 1,
                Some(Fault::Short) => {
                    answer.as_mut().unwrap().pop();
                }
                _ => {}
            }
            let answer = answer.map(|mut reply| {
                let crc = Crc16::new().update_slice(&reply).to_wire();
                reply.extend_from_slice(&crc);
                if fault == Some(Fault::Damaged) {
                    reply[1] ^= 0x40;
                }
                reply
            });
            // A slow answer comes once the timeout has had its chance.
            if delay > 0 {
                self.now += delay;
                action = self.engine.on_tick(self.now);
                if action == Action::Send || self.engine.outcome().is_some() {
                    // Too late: the master has given this try up.
                    continue;
                }
            }
            match answer {
                Some(reply) => {
                    self.now += 1 + reply.len() as u32 / 2;
                    let wrong = reply[0] != frame[0];
                    for b in reply {
                        self.engine.on_byte(b);
                    }
                    action = self.engine.on_end_deadline();
                    if wrong && action == Action::None && self.engine.outcome().is_none() {
                        // Ignored: the timeout runs on.
                        let wait = self.engine.timeouts().response_ms;
                        self.now += u32::from(wait) + 2;
                        action = self.engine.on_tick(self.now);
                    }
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
    fn forward(&mut self, len: usize, retries: u8, response_ms: u16, shape: Shape) -> bool {
        match self.engine.forward(len, retries, response_ms, shape) {
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

/// Routes 1-247 as they are, but unit 9, which is routed nowhere; unit 5's slave has a
/// response timeout of 500 ms (the line's is 100 ms).
struct NotNine;

impl Routes for NotNine {
    fn route(&self, unit: u8) -> Option<u8> {
        match unit {
            9 => None,
            // Nowhere a slave can be: taken as no route.
            250 => Some(0),
            251 => Some(248),
            _ => Direct.route(unit),
        }
    }

    fn response_ms(&self, unit: u8) -> Option<u16> {
        (unit == 5).then_some(500)
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
    net: Network,
}

impl Rig {
    fn new(slaves: impl IntoIterator<Item = (u8, Slave)>) -> Self {
        Rig::on(NET, slaves)
    }

    /// [`Rig::new`] with the settings `net`.
    fn on(net: Network, slaves: impl IntoIterator<Item = (u8, Slave)>) -> Self {
        let mut rig = Rig {
            chip: Fake::default(),
            server: Server::new(),
            gateway: Gateway::new(),
            line: Played::new(slaves),
            settings: GatewaySettings::new(),
            net,
        };
        rig.step();
        rig
    }

    /// One poll as the AVR layer makes it: the line's outcome passed back (and, the line
    /// free, the waiting connections resumed), then the chip served.
    fn step(&mut self) {
        if self.gateway.deliver(&mut self.server, &mut self.chip, &mut self.line, &self.settings, &self.net) {
            self.server.resume();
        }
        self.serve();
    }

    fn serve(&mut self) {
        self.serve_with(false);
    }

    /// One pass of the server, with `second` or not.
    fn serve_with(&mut self, second: bool) {
        let mut gate = Gate {
            gateway: &mut self.gateway,
            line: &mut self.line,
            routes: &NotNine,
            settings: &self.settings,
            waiting: self.server.waiting(),
            health: self.server.health,
            first: 0,
        };
        self.server.poll(&mut self.chip, &self.net, &mut gate, second);
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
    // Not routed (9), routed to 0 or 248 (250, 251), and the ids no slave has (248-254): 0A.
    for (t, unit) in [(2, 9), (3, 248), (4, 254), (5, 250), (6, 251)] {
        rig.chip.socks[1].sent.clear();
        rig.chip.deliver(1, &read(t, unit, 0, 1));
        rig.settle();
        assert_eq!(rig.chip.socks[1].sent, exception(t, unit, 3, 0x0A), "unit {unit}");
    }
    assert!(rig.line.sent.is_empty());
    assert_eq!(rig.gateway.counters().unavailable, 5);
    // Unit 0: a write goes out as a broadcast, unanswered; a read, which no slave may
    // answer, gets 0A at once.
    rig.chip.socks[1].sent.clear();
    let write = vec![0, 5, 0, 0, 0, 6, 0, 6, 0, 1, 0x12, 0x34];
    rig.chip.deliver(1, &write);
    rig.chip.deliver(1, &read(6, 0, 0, 1));
    rig.chip.deliver(1, &read(8, 1, 0, 1));
    rig.settle();
    let frames: Vec<Vec<u8>> = rig.line.sent.iter().map(|(_, f)| f[..f.len() - 2].to_vec()).collect();
    assert_eq!(frames, [vec![0, 6, 0, 1, 0x12, 0x34], vec![1, 3, 0, 0, 0, 1]]);
    assert_eq!(rig.chip.socks[1].sent, [exception(6, 0, 3, 0x0A), read_reply(8, 1, 0x100, 0, 1)].concat());
    assert_eq!(rig.gateway.counters().broadcasts, 1);
    assert_eq!(rig.gateway.counters().unavailable, 6);
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

#[cfg(feature = "write-protect")]
#[test]
fn a_reading_clients_write_is_answered_01_by_the_gateway_and_never_forwarded() {
    // 10.0.0.8 writes, 10.0.0.7 only reads.
    let net = NET.allow(&[[10, 0, 0, 8]]).allow_reading(&[[10, 0, 0, 7]]);
    let mut rig = Rig::on(net, [(1, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.connect(1, [10, 0, 0, 8]);
    let write = |transaction: u8| vec![0, transaction, 0, 0, 0, 6, 1, 0x06, 0, 0, 0x12, 0x34];
    // The reader's FC 6 and FC 16, then a read, which goes to the slave.
    rig.chip.deliver(0, &write(1));
    rig.chip.deliver(0, &[0, 2, 0, 0, 0, 9, 1, 0x10, 0, 0, 0, 1, 2, 0x12, 0x34]);
    rig.chip.deliver(0, &read(3, 1, 0, 1));
    rig.settle();
    let expected = [exception(1, 1, 0x06, 0x01), exception(2, 1, 0x10, 0x01), read_reply(3, 1, 0x100, 0, 1)];
    assert_eq!(rig.chip.socks[0].sent, expected.concat());
    let functions: Vec<u8> = rig.line.sent.iter().map(|(_, f)| f[1]).collect();
    assert_eq!(functions, [3], "only the read went to the line");
    // The writer's FC 6 goes to the line.
    rig.chip.deliver(1, &write(4));
    rig.settle();
    assert_eq!(rig.chip.socks[1].sent, write(4));
    assert_eq!(rig.line.sent.last().map(|(_, f)| f[1]), Some(0x06));
    assert_eq!(rig.server.counters().refused_writes, 2);
    assert_eq!(rig.gateway.counters().forwarded, 2);
}

/// Socket 0's answers since the last call, cleared.
fn answers(rig: &mut Rig) -> Vec<u8> {
    core::mem::take(&mut rig.chip.socks[0].sent)
}

#[test]
fn a_dead_slave_is_down_after_three_misses_then_gets_0b_at_once_until_rechecked() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead)]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    // Three misses, each after its try and retry: 0B, and down only after the third.
    for t in 1..=3 {
        rig.chip.deliver(0, &read(t, 3, 0, 1));
        rig.settle();
        assert_eq!(answers(&mut rig), exception(t, 3, 3, 0x0B));
        assert_eq!(rig.line.sent.len(), 2 * usize::from(t), "the request and its retry");
        assert_eq!(rig.gateway.is_down(3, &rig.settings), t == 3, "after {t} misses");
    }
    let health = rig.gateway.health(3, &rig.settings);
    assert_eq!(health, SlaveHealth { answers: 0, misses: 3, misses_in_a_row: 3, down: true });
    // Down: answered at once, the line untouched, the live slave served.
    rig.chip.deliver(0, &[read(4, 3, 0, 1), read(5, 1, 0, 1)].concat());
    rig.settle();
    assert_eq!(answers(&mut rig), [exception(4, 3, 3, 0x0B), read_reply(5, 1, 0x100, 0, 1)].concat());
    assert_eq!(rig.line.sent.len(), 7);
    // Once the recheck time has come: one try, no retry.
    rig.line.now += 1000;
    rig.chip.deliver(0, &read(6, 3, 0, 1));
    rig.settle();
    assert_eq!(answers(&mut rig), exception(6, 3, 3, 0x0B));
    assert_eq!(rig.line.sent.len(), 8);
    // It comes back: answered at the next recheck, up again, its run of misses ended.
    rig.line.slaves.insert(3, Slave::Bank(regs(0x300)));
    rig.line.now += 1000;
    rig.chip.deliver(0, &[read(7, 3, 0, 1), read(8, 3, 1, 1)].concat());
    rig.settle();
    assert_eq!(answers(&mut rig), [read_reply(7, 3, 0x300, 0, 1), read_reply(8, 3, 0x300, 1, 1)].concat());
    assert_eq!(
        rig.gateway.health(3, &rig.settings),
        SlaveHealth { answers: 2, misses: 4, misses_in_a_row: 0, down: false }
    );
    assert_eq!(rig.gateway.counters().no_response, 5);
}

#[test]
fn any_answer_an_exception_too_ends_a_run_of_misses() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    // Two misses (each try and retry lost), an exception (40011 missing), two misses:
    // never three in a row.
    rig.line.faults = [Some(Fault::Dropped); 4].to_vec();
    rig.chip.deliver(0, &[read(1, 1, 0, 1), read(2, 1, 0, 1), read(3, 1, 10, 1)].concat());
    rig.settle();
    rig.line.faults = [Some(Fault::Dropped); 4].to_vec();
    rig.chip.deliver(0, &[read(4, 1, 0, 1), read(5, 1, 0, 1), read(6, 1, 0, 1)].concat());
    rig.settle();
    let expected = [
        exception(1, 1, 3, 0x0B),
        exception(2, 1, 3, 0x0B),
        exception(3, 1, 3, 0x02),
        exception(4, 1, 3, 0x0B),
        exception(5, 1, 3, 0x0B),
        read_reply(6, 1, 0x100, 0, 1),
    ];
    assert_eq!(answers(&mut rig), expected.concat());
    assert_eq!(
        rig.gateway.health(1, &rig.settings),
        SlaveHealth { answers: 2, misses: 4, misses_in_a_row: 0, down: false }
    );
}

#[test]
fn down_after_0_never_takes_a_slave_down() {
    let mut rig = Rig::new([(3, Slave::Dead)]);
    rig.settings = rig.settings.down_after(0);
    rig.chip.connect(0, [10, 0, 0, 7]);
    for t in 1..=5 {
        rig.chip.deliver(0, &read(t, 3, 0, 1));
        rig.settle();
    }
    assert_eq!(rig.line.sent.len(), 10, "every request tried and retried");
    assert_eq!(
        rig.gateway.health(3, &rig.settings),
        SlaveHealth { answers: 0, misses: 5, misses_in_a_row: 5, down: false }
    );
    // And 1: down at the first miss.
    rig.settings = rig.settings.down_after(1);
    assert!(rig.gateway.is_down(3, &rig.settings));
}

#[test]
fn a_slave_that_drops_one_frame_in_twenty_is_never_down_and_every_request_is_answered() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    rig.settings = rig.settings.down_after(1);
    rig.chip.connect(0, [10, 0, 0, 7]);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for t in 0..400u16 {
        // Each answer lost, damaged, cut short or from the wrong address, one in twenty.
        let fault = match next(&mut seed) % 80 {
            0 => Some(Fault::Dropped),
            1 => Some(Fault::Damaged),
            2 => Some(Fault::Short),
            3 => Some(Fault::WrongSlave),
            _ => None,
        };
        rig.line.faults.push(fault);
        rig.line.faults.push(None);
        rig.chip.deliver(0, &read(t, 1, t % 10, 1));
        rig.settle();
        rig.line.faults.clear();
        assert_eq!(answers(&mut rig), read_reply(t, 1, 0x100, t % 10, 1), "request {t} ({fault:?})");
        assert!(!rig.gateway.is_down(1, &rig.settings), "down at request {t}");
    }
    let health = rig.gateway.health(1, &rig.settings);
    assert_eq!((health.answers, health.misses), (400, 0));
    assert!(rig.line.sent.len() > 410, "no fault was played: {} frames", rig.line.sent.len());
}

#[test]
fn a_wrong_slaves_damaged_or_short_answer_is_retried_within_the_transaction() {
    for fault in [Fault::WrongSlave, Fault::Damaged, Fault::Short] {
        let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
        rig.chip.connect(0, [10, 0, 0, 7]);
        rig.line.faults = vec![Some(fault)];
        rig.chip.deliver(0, &read(1, 1, 2, 3));
        rig.settle();
        assert_eq!(answers(&mut rig), read_reply(1, 1, 0x100, 2, 3), "{fault:?}");
        assert_eq!(rig.line.sent.len(), 2, "{fault:?}: the request and its retry");
        assert_eq!(rig.gateway.health(1, &rig.settings).misses, 0, "{fault:?}");
        // Without a retry left: 0B, a miss.
        rig.line.engine.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 20, retries: 0 });
        rig.line.faults = vec![Some(fault)];
        rig.chip.deliver(0, &read(2, 1, 2, 3));
        rig.settle();
        assert_eq!(answers(&mut rig), exception(2, 1, 3, 0x0B), "{fault:?}");
        assert_eq!(rig.gateway.health(1, &rig.settings).misses, 1, "{fault:?}");
    }
}

#[test]
fn a_route_with_its_own_response_timeout_waits_for_its_slow_slave() {
    // Slaves 4 and 5 answer after 300 ms; the line's timeout is 100 ms, unit 5's 500 ms.
    let mut rig = Rig::new([(4, Slave::Slow(300, regs(0x400))), (5, Slave::Slow(300, regs(0x500)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    rig.chip.deliver(0, &[read(1, 5, 0, 2), read(2, 4, 0, 2)].concat());
    rig.settle();
    assert_eq!(answers(&mut rig), [read_reply(1, 5, 0x500, 0, 2), exception(2, 4, 3, 0x0B)].concat());
    assert_eq!(rig.line.sent.len(), 3, "unit 5 once, unit 4 and its retry");
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
        // The gateway's own registers end at 12.
        0xFF => exception(transaction, unit, 3, 0x02),
        _ => exception(transaction, unit, 3, 0x0A),
    }
}

#[test]
fn every_request_of_every_connection_gets_exactly_its_one_answer() {
    // Random streams on four connections at once: reads of live slaves (1, 2), a dead one
    // (3), units routed nowhere (9, 248), the gateway's own (0xFF) and broadcast writes
    // (0), some padded, some with another protocol id, pipelined and cut anywhere,
    // delivered in random order while the line is held and released at random. Every
    // request gets exactly its answer, on its connection, in the order sent; the
    // broadcasts and other protocols none; the live slaves are never down.
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
                let start = (next(&mut seed) % 5) as u16 + if unit == 0xFF { 12 } else { 0 };
                let qty = 1 + (next(&mut seed) % 5) as u16;
                match next(&mut seed) % 8 {
                    // Padded: 03 from a slave's unit (0A and 0B come first), nothing on
                    // the line.
                    0 if unit != 0xFF => {
                        let mut padded = read(transaction, unit, start, qty);
                        padded[5] += 1;
                        padded.push(0xEE);
                        stream.extend(padded);
                        answer.extend(match expected(transaction, unit, start, qty) {
                            e if e[7] == 0x83 && e[8] != 0x0B => e,
                            _ => exception(transaction, unit, 3, 0x03),
                        });
                    }
                    // Another protocol id: dropped, nothing answered, the stream goes on.
                    1 => {
                        let mut other = read(transaction, unit, start, qty);
                        other[3] = 1;
                        stream.extend(other);
                    }
                    _ => {
                        stream.extend(read(transaction, unit, start, qty));
                        answer.extend(expected(transaction, unit, start, qty));
                    }
                }
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
        for unit in [1, 2] {
            assert_eq!(rig.gateway.health(unit, &rig.settings).misses, 0, "round {round}, slave {unit}");
        }
        assert!(rig.line.sent.iter().all(|(_, f)| f.len() == 8), "round {round}: a padded request on the line");
    }
}

#[test]
fn the_gateways_own_registers_count_what_it_did() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead), (17, Slave::Dead)]);
    rig.settings = rig.settings.down_after(1);
    rig.chip.connect(0, [10, 0, 0, 7]);
    let mut padded = read(6, 1, 0, 1);
    padded.extend([0xAA, 0xBB]);
    padded[5] += 2;
    let stream =
        [read(1, 1, 0, 1), read(2, 1, 10, 1), read(3, 9, 0, 1), read(4, 3, 0, 1), read(5, 17, 0, 1), padded].concat();
    rig.chip.deliver(0, &stream);
    rig.settle();
    rig.chip.socks[0].sent.clear();
    let mut status = read(7, 0xFF, 0, 9);
    status[7] = 4;
    rig.chip.deliver(0, &status);
    rig.settle();
    // forwarded 4, answers 2, exceptions 1, 0A 1, 0B 2, broadcasts 0, orphaned 0,
    // malformed 1, waiting 0.
    let values = [4u16, 2, 1, 1, 2, 0, 0, 1, 0];
    let mut expected = vec![0, 7, 0, 0, 0, 21, 0xFF, 4, 18];
    expected.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    assert_eq!(answers(&mut rig), expected);
    // Slave 1's and 3's health: answers, misses, misses in a row, down.
    rig.chip.deliver(0, &[read(8, 0xFF, 1000 + 4, 4), read(9, 0xFF, 1000 + 12, 4)].concat());
    rig.settle();
    let health = |t: u16, values: [u16; 4]| {
        let mut adu = vec![0, t as u8, 0, 0, 0, 11, 0xFF, 3, 8];
        adu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        adu
    };
    assert_eq!(answers(&mut rig), [health(8, [2, 0, 0, 0]), health(9, [0, 1, 1, 1])].concat());
    // Past the last register, or between the two ranges: 02; a quantity of 0: 03; a
    // write: 01.
    rig.chip.deliver(
        0,
        &[
            read(10, 0xFF, 8, 5),
            read(11, 0xFF, 200, 60),
            read(12, 0xFF, 2020, 5),
            read(13, 0xFF, 0, 0),
            vec![0, 14, 0, 0, 0, 6, 0xFF, 6, 0, 0, 0, 1],
        ]
        .concat(),
    );
    rig.settle();
    let expected =
        [exception(10, 0xFF, 3, 2), exception(11, 0xFF, 3, 2), exception(12, 0xFF, 3, 2), exception(13, 0xFF, 3, 3)];
    assert_eq!(answers(&mut rig), [expected.concat(), exception(14, 0xFF, 6, 1)].concat());
}

#[test]
fn the_gateways_own_registers_9_to_11_are_the_chips_resets_link_losses_and_link() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100)))]);
    let ask = |rig: &mut Rig, t: u16| {
        // The poll with `second`, which follows the check.
        rig.serve_with(true);
        if rig.chip.socks[0].status != crate::tcp::wiznet::state::ESTABLISHED {
            rig.chip.connect(0, [10, 0, 0, 7]);
        }
        let mut status = read(t, 0xFF, 9, 3);
        status[7] = 4;
        rig.chip.deliver(0, &status);
        rig.settle();
        let answer = answers(rig);
        answer[9..].chunks(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect::<Vec<_>>()
    };
    assert_eq!(ask(&mut rig, 1), [0, 0, 1], "no reset, no loss, the link up");
    rig.chip.link_down = true;
    assert!(rig.server.check(&mut rig.chip, &NET));
    assert_eq!(ask(&mut rig, 2), [0, 1, 0], "a loss, the link down");
    rig.chip.link_down = false;
    rig.chip.chip_reset();
    assert!(rig.server.check(&mut rig.chip, &NET));
    assert_eq!(ask(&mut rig, 3), [1, 1, 0], "a reset; the link is read at the next check");
    assert!(rig.server.check(&mut rig.chip, &NET));
    assert_eq!(ask(&mut rig, 4), [1, 1, 1], "the link up again");
}

/// An ADU for `unit` with the PDU `pdu`, its length field from it.
fn adu(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut adu = vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, pdu.len() as u8 + 1, unit];
    adu.extend_from_slice(pdu);
    adu
}

/// Requests whose form no slave accepts, each with what the spec answers.
const MALFORMED: [(&str, &[u8], u8); 13] = [
    ("FC 3 padded", &[3, 0, 0, 0, 4, 0xAA, 0xBB], 3),
    ("FC 6 a byte too long", &[6, 0, 1, 0, 2, 0], 3),
    ("FC 3 of 126", &[3, 0, 0, 0, 126], 3),
    ("FC 4 of 0", &[4, 0, 0, 0, 0], 3),
    ("FC 1 of 2001", &[1, 0, 0, 0x07, 0xD1], 3),
    ("FC 5 value 0x1234", &[5, 0, 1, 0x12, 0x34], 3),
    ("FC 15 of 10 with a byte count of 1", &[15, 0, 0, 0, 10, 1, 0xFF], 3),
    ("FC 16 of 2 with a byte count of 3", &[16, 0, 0, 0, 2, 3, 1, 2, 3], 3),
    ("FC 16 of 2 with 6 bytes", &[16, 0, 0, 0, 2, 4, 1, 2, 3, 4, 5, 6], 3),
    ("FC 16 of 124", &[16, 0, 0, 0, 124, 248], 3),
    ("FC 3 past 65535", &[3, 0xFF, 0xFF, 0, 2], 2),
    ("FC 22 a byte too long", &[0x16, 0, 1, 0xFF, 0, 0, 1, 0], 3),
    ("FC 23 writing 2 with a byte count of 2", &[0x17, 0, 0, 0, 1, 0, 0, 0, 2, 2, 0, 1], 3),
];

#[test]
fn a_malformed_request_is_answered_as_the_server_answers_it_and_never_reaches_the_line() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (0, Slave::Bank(regs(0x100)))]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    for (t, (what, pdu, code)) in MALFORMED.iter().enumerate() {
        rig.chip.deliver(0, &adu(t as u16, 1, pdu));
        rig.settle();
        let answer = answers(&mut rig);
        assert_eq!(answer, exception(t as u16, 1, pdu[0], *code), "{what}");
        // The TCP server's answer to the same ADU (FC 22 and 23 with feature extra-fc,
        // 01 without).
        if crate::slave::pdu::extra::ENABLED || pdu[0] < 0x16 {
            let mut server = adu(t as u16, 1, pdu);
            server.resize(260, 0);
            let (n, _) = crate::tcp::respond(&mut server, pdu.len(), &mut regs(0)).unwrap();
            crate::tcp::mbap::seal(&mut server, n);
            assert_eq!(answer, server[..7 + n], "{what}: not the server's answer");
        }
        // As a broadcast: nothing sent, nothing answered (a read: 0A, as any read to 0).
        rig.chip.deliver(0, &adu(t as u16, 0, pdu));
        rig.settle();
        let expected = if broadcastable(pdu[0]) { vec![] } else { exception(t as u16, 0, pdu[0], 0x0A) };
        assert_eq!(answers(&mut rig), expected, "{what} as a broadcast");
    }
    assert!(rig.line.sent.is_empty(), "on the line: {:?}", rig.line.sent);
    let writes = MALFORMED.iter().filter(|(_, pdu, _)| broadcastable(pdu[0])).count();
    assert_eq!(rig.gateway.counters().malformed, (MALFORMED.len() + writes) as u16);
    assert_eq!(rig.gateway.health(1, &rig.settings), SlaveHealth::default(), "counted against the slave");
    // The same requests well formed go out.
    rig.chip.deliver(0, &[adu(20, 1, &[3, 0, 0, 0, 4]), adu(21, 1, &[16, 0, 0, 0, 2, 4, 1, 2, 3, 4])].concat());
    rig.settle();
    assert_eq!(rig.line.sent.len(), 2);
}

#[test]
fn a_read_of_125_own_registers_comes_whole_through_the_small_buffer() {
    let mut rig = Rig::new([(1, Slave::Bank(regs(0x100))), (2, Slave::Dead)]);
    rig.chip.connect(0, [10, 0, 0, 7]);
    for t in 0..7 {
        rig.chip.deliver(0, &read(t, 1 + (t % 2) as u8, 0, 1));
        rig.settle();
    }
    answers(&mut rig);
    // Registers 256-380: the health of slaves 0 to 31 (1: 4 answers, 2: 3 misses, down).
    rig.chip.deliver(0, &read(9, 0xFF, 1000, 125));
    rig.settle();
    let mut values = [0u16; 125];
    values[4..8].copy_from_slice(&[4, 0, 0, 0]);
    values[8..12].copy_from_slice(&[0, 3, 3, 1]);
    let mut expected = vec![0, 9, 0, 0, 0, 253, 0xFF, 3, 250];
    expected.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    assert_eq!(answers(&mut rig), expected);
}

#[test]
fn a_ninth_slave_takes_the_record_given_longest_ago() {
    // Unit 9 is routed nowhere: slaves 1-8 and 10.
    let addresses: Vec<u8> = (1..=TRACKED as u8).chain([10]).collect();
    let mut rig = Rig::new(addresses.iter().map(|&a| (a, Slave::Bank(regs(0x100)))));
    rig.chip.connect(0, [10, 0, 0, 7]);
    // Slaves 1 to 8, 2 again (its record stays), then 10, in slave 1's place, then 2.
    let units = (1..=TRACKED as u8).chain([2, 10, 2]);
    for (t, unit) in units.enumerate() {
        rig.chip.deliver(0, &read(t as u16, unit, 0, 1));
        rig.settle();
    }
    assert_eq!(rig.line.sent.len(), TRACKED + 3);
    assert_eq!(rig.gateway.health(1, &rig.settings), SlaveHealth::default(), "its record was the oldest");
    assert_eq!(rig.gateway.health(2, &rig.settings).answers, 3);
    for a in (3..=TRACKED as u8).chain([10]) {
        assert_eq!(rig.gateway.health(a, &rig.settings).answers, 1, "slave {a}");
    }
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

/// The gateway on RTU over TCP: socket 1 speaks RTU on port 5020.
#[cfg(feature = "rtu-over-tcp")]
mod rtu_over_tcp {
    use super::*;
    use crate::link::crc::crc16;

    /// `body` (address and PDU) with its CRC.
    fn frame(body: &[u8]) -> Vec<u8> {
        let mut frame = body.to_vec();
        frame.extend_from_slice(&crc16(body).to_le_bytes());
        frame
    }

    /// A gateway whose socket 1 speaks RTU over TCP, a master connected to it.
    fn rig(slaves: impl IntoIterator<Item = (u8, Slave)>) -> Rig {
        let mut rig = Rig::on(NET.rtu_over_tcp(5020, 0b0010), slaves);
        assert_eq!(rig.chip.socks[1].port, 5020);
        rig.chip.connect(1, [10, 0, 0, 7]);
        rig
    }

    /// The frames the line carried, without their CRCs.
    fn on_the_line(rig: &Rig) -> Vec<Vec<u8>> {
        rig.line.sent.iter().map(|(_, f)| f[..f.len() - 2].to_vec()).collect()
    }

    #[test]
    fn a_frame_goes_to_the_line_as_it_is_and_the_answer_comes_back_framed() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100))), (2, Slave::Bank(regs(0x200)))]);
        // Two frames in one segment, each to its slave; then a write.
        rig.chip.deliver(1, &[frame(&[1, 3, 0, 2, 0, 3]), frame(&[2, 3, 0, 0, 0, 1])].concat());
        rig.chip.deliver(1, &frame(&[1, 6, 0, 4, 0xAB, 0xCD]));
        rig.settle();
        assert_eq!(on_the_line(&rig), [vec![1, 3, 0, 2, 0, 3], vec![2, 3, 0, 0, 0, 1], vec![1, 6, 0, 4, 0xAB, 0xCD]]);
        let expected = [
            frame(&[1, 3, 6, 0x01, 0x02, 0x01, 0x03, 0x01, 0x04]),
            frame(&[2, 3, 2, 0x02, 0x00]),
            frame(&[1, 6, 0, 4, 0xAB, 0xCD]),
        ]
        .concat();
        assert_eq!(rig.chip.socks[1].sent, expected);
    }

    #[test]
    fn the_gateways_own_exceptions_and_registers_are_framed() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead)]);
        // A slave's exception (40011 missing), a dead slave (0B), a unit not routed (0A),
        // a malformed request (03, never on the line), the gateway's own registers.
        for request in [
            frame(&[1, 3, 0, 10, 0, 1]),
            frame(&[3, 3, 0, 0, 0, 1]),
            frame(&[9, 3, 0, 0, 0, 1]),
            frame(&[1, 3, 0, 0, 0, 0]),
            frame(&[0xFF, 4, 0, 0, 0, 1]),
        ] {
            rig.chip.deliver(1, &request);
            rig.settle();
        }
        let expected = [
            frame(&[1, 0x83, 0x02]),
            frame(&[3, 0x83, 0x0B]),
            frame(&[9, 0x83, 0x0A]),
            frame(&[1, 0x83, 0x03]),
            // forwarded: 2 (slave 1 and slave 3 once, its retry not counted)
            frame(&[0xFF, 4, 2, 0, 2]),
        ]
        .concat();
        assert_eq!(rig.chip.socks[1].sent, expected);
        assert_eq!(on_the_line(&rig).len(), 3, "slave 1 once, slave 3 twice (a retry)");
    }

    #[test]
    fn a_frame_longer_than_the_gateways_buffer_reaches_the_line_whole() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100)))]);
        // FC 16 of 10 registers: a PDU of 26 bytes, past the 32-byte buffer's room.
        let mut body = vec![1, 0x10, 0, 0, 0, 10, 20];
        body.extend((0..20).map(|i| 0xA0 + i as u8));
        rig.chip.deliver(1, &frame(&body));
        rig.settle();
        assert_eq!(on_the_line(&rig), [body]);
        assert_eq!(rig.chip.socks[1].sent, frame(&[1, 0x10, 0, 0, 0, 10]));
    }

    #[test]
    fn a_broadcast_goes_to_the_line_and_nothing_comes_back() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100)))]);
        rig.chip.deliver(1, &frame(&[0, 6, 0, 1, 0x12, 0x34]));
        rig.chip.deliver(1, &frame(&[0, 3, 0, 0, 0, 1]));
        rig.chip.deliver(1, &frame(&[1, 3, 0, 1, 0, 1]));
        rig.settle();
        assert_eq!(on_the_line(&rig), [vec![0, 6, 0, 1, 0x12, 0x34], vec![1, 3, 0, 1, 0, 1]]);
        assert_eq!(rig.chip.socks[1].sent, frame(&[1, 3, 2, 0x01, 0x01]));
    }

    #[test]
    fn a_bad_crc_never_reaches_the_line() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100)))]);
        let mut bad = frame(&[1, 6, 0, 1, 0x12, 0x34]);
        bad[5] ^= 1;
        rig.chip.deliver(1, &bad);
        rig.settle();
        assert!(rig.line.sent.is_empty() && rig.chip.socks[1].sent.is_empty());
        assert_eq!(rig.server.counters().bad_frame, 1);
    }

    #[test]
    fn mbap_and_rtu_connections_share_the_line() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100)))]);
        rig.chip.connect(0, [10, 0, 0, 8]);
        rig.chip.deliver(0, &read(0x4242, 1, 0, 2));
        rig.chip.deliver(1, &frame(&[1, 3, 0, 2, 0, 1]));
        rig.settle();
        assert_eq!(rig.chip.socks[0].sent, read_reply(0x4242, 1, 0x100, 0, 2));
        assert_eq!(rig.chip.socks[1].sent, frame(&[1, 3, 2, 0x01, 0x02]));
    }
}

#[cfg(feature = "udp")]
mod udp {
    //! Modbus UDP through the gateway: TCP on sockets 0-2, UDP on socket 3.

    use super::*;
    use crate::tcp::fake::UDP;

    const U: usize = 3;

    fn sender(host: u8, port: u16) -> [u8; 6] {
        let [p0, p1] = port.to_be_bytes();
        [10, 0, 0, host, p0, p1]
    }

    /// The rig with TCP on three sockets and UDP on the fourth.
    fn rig(slaves: impl IntoIterator<Item = (u8, Slave)>) -> Rig {
        let mut rig = Rig::new(slaves);
        rig.net = NET.sockets(3).udp(3);
        rig.chip = Fake::default();
        rig.server = Server::new();
        rig.step();
        assert_eq!(rig.chip.socks[U].status, UDP);
        rig
    }

    #[test]
    fn each_datagrams_answer_from_the_line_goes_back_to_its_sender() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100))), (2, Slave::Bank(regs(0x200)))]);
        rig.line.hold = true;
        assert!(rig.chip.datagram(U, sender(7, 1000), &read(0x1111, 1, 0, 3)));
        assert!(rig.chip.datagram(U, sender(8, 2000), &read(0x2222, 2, 4, 2)));
        assert!(rig.chip.datagram(U, sender(7, 1001), &read(0x3333, 2, 0, 1)));
        rig.settle();
        assert!(rig.line.held.is_some(), "one on the line");
        assert!(rig.chip.socks[U].datagrams.is_empty());
        assert_ne!(rig.chip.socks[U].rx_rd, rig.chip.socks[U].rx_wr, "the others wait in the chip");
        rig.line.release();
        rig.line.hold = false;
        rig.settle();
        assert_eq!(
            rig.chip.socks[U].datagrams,
            [
                (sender(7, 1000), read_reply(0x1111, 1, 0x100, 0, 3)),
                (sender(8, 2000), read_reply(0x2222, 2, 0x200, 4, 2)),
                (sender(7, 1001), read_reply(0x3333, 2, 0x200, 0, 1)),
            ]
        );
        let counts = rig.gateway.counters();
        assert_eq!((counts.forwarded, counts.answers, counts.orphaned), (3, 3, 0));
    }

    #[test]
    fn own_registers_unavailable_units_malformed_requests_and_dead_slaves_as_over_tcp() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100))), (3, Slave::Dead)]);
        let mut zero_quantity = read(4, 1, 0, 0);
        zero_quantity[11] = 0;
        for (i, adu) in [read(1, 0xFF, 0, 2), read(2, 9, 0, 1), read(3, 3, 0, 1), zero_quantity].iter().enumerate() {
            assert!(rig.chip.datagram(U, sender(7, 1000 + i as u16), adu));
        }
        rig.settle();
        assert_eq!(
            rig.chip.socks[U].datagrams,
            [
                (sender(7, 1000), vec![0, 1, 0, 0, 0, 7, 0xFF, 3, 4, 0, 0, 0, 0]),
                (sender(7, 1001), exception(2, 9, 3, 0x0A)),
                (sender(7, 1002), exception(3, 3, 3, 0x0B)),
                (sender(7, 1003), exception(4, 1, 3, 0x03)),
            ]
        );
        let counts = rig.gateway.counters();
        assert_eq!((counts.unavailable, counts.no_response, counts.malformed), (1, 1, 1));
        assert!(rig.line.sent.iter().all(|(_, f)| f[0] == 3), "only the dead slave's tries on the line");
    }

    #[test]
    fn tcp_and_udp_share_the_line_each_answered_its_own_way() {
        let mut rig = rig([(1, Slave::Bank(regs(0x100)))]);
        rig.chip.connect(0, [10, 0, 0, 7]);
        rig.chip.deliver(0, &[read(1, 1, 0, 1), read(2, 1, 1, 1)].concat());
        assert!(rig.chip.datagram(U, sender(8, 5000), &read(3, 1, 2, 1)));
        assert!(rig.chip.datagram(U, sender(8, 5000), &read(4, 1, 3, 1)));
        rig.settle();
        assert_eq!(rig.chip.socks[0].sent, [read_reply(1, 1, 0x100, 0, 1), read_reply(2, 1, 0x100, 1, 1)].concat());
        assert_eq!(
            rig.chip.socks[U].datagrams,
            [(sender(8, 5000), read_reply(3, 1, 0x100, 2, 1)), (sender(8, 5000), read_reply(4, 1, 0x100, 3, 1))]
        );
        // They took turns on the line.
        let order: Vec<u8> = rig.line.sent.iter().map(|(_, f)| f[3]).collect();
        assert_eq!(order, [0, 2, 1, 3]);
    }
}
