//! `examples/tcp_gateway.rs` (the Modbus TCP to RTU gateway: an Uno, a W5100 shield, RS-485
//! on USART0 at 19200 8E1, the transceiver's DE on pin 3 = PD3, a response timeout of 200 ms
//! and one retry) on the simulated Uno and shield, as `make tcp-firmware` builds it: the chip
//! polled every Timer0 overflow, and served from its INT line on pin 2; every test runs both.
//!
//! The test plays both sides on simulated time: three RS-485 slaves on the line (ids 1, 2
//! and 3, 125 holding registers each, answering T3.5 + 0.5 ms after a request's end, as
//! real slaves do) and TCP masters on the shield's sockets (requests landing in the chip at
//! any phase of the firmware's poll, whole, split, or several in one segment). Every frame
//! on the line is logged with the cycle of its first start bit and of its last stop bit,
//! and every test ends by checking the log (Serial Line v1.02 §2.5.1.1): each request of
//! the gateway starts T3.5 or more after the previous frame's end, is one frame (no gap
//! over T1.5 inside) and carries the right CRC. `GATEWAY_DUMP=1` prints the log.
//!
//! The gateway's rules (Implementation Guide v1.0b §4.4.1.2, §4.4.2.5; `src/tcp/gateway.rs`):
//! requests wait in the chip until the line is free, connections take turns, each answer
//! goes back on its own connection with its own transaction id; 0A for units 248–254, 0B
//! for a slave that does not answer after its retries (after three such requests in a row,
//! 0B at once but for one try a second), unit 0 a broadcast of writes with no TCP answer
//! and a read there 0A, malformed requests answered without the line, the gateway's own
//! registers and the slaves' health at unit 0xFF.
//!
//! Build: `make tcp-firmware` (or `.ci/chip-build atmega328p "" atmega328p-tcp-gateway
//! examples,tcp,master tcp_gateway`, and `AVR_MODBUS_EXAMPLE_SHIELD=w5100-int` into
//! `atmega328p-tcp-gateway-int`). One character at 19200 8E1 is 11 bits = 573 µs;
//! T1.5 = 859 µs, T3.5 = 2005 µs.

mod sim;

use std::collections::VecDeque;
use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, crc16, cycles_to_us, us_to_cycles, with_crc, Line, Rng};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Parity, TxByte, Uno, Wiznet};

/// `make tcp-firmware`'s gateways: the build's suffix, and whether the chip's INT line is
/// wired (pin 2) and serves it, or it polls the chip every Timer0 overflow.
type Build = (&'static str, bool);
const BUILDS: [Build; 2] = [("-tcp-gateway", false), ("-tcp-gateway-int", true)];

/// The gateway's port.
const PORT: u16 = 502;
/// The example's response timeout and retries on the line.
const RESPONSE_TIMEOUT_MS: u64 = 200;
const RETRIES: usize = 1;
/// How often a slave taken to be down is tried again, and after how many requests in a row
/// without an answer it is (`GatewaySettings::new`).
const RECHECK_MS: u64 = 1000;
const DOWN_AFTER: usize = 3;
/// The tries of a slave that is off before it is taken to be down.
const TRIES_BEFORE_DOWN: usize = DOWN_AFTER * (RETRIES + 1);
/// A slave answers this long after T3.5 following a request's end.
const SLAVE_DELAY_US: u64 = 500;
/// Holding registers each slave has (0–124: a read of all of them is the longest answer).
const REGISTERS: usize = 125;
/// The RS-485 driver enable: pin 3.
const DE: (char, u8) = ('D', 3);
/// Exceptions (Application Protocol §7): illegal function, illegal data address, gateway
/// path unavailable, gateway target device failed to respond.
const ILLEGAL_FUNCTION: u8 = 0x01;
const ILLEGAL_ADDRESS: u8 = 0x02;
const PATH_UNAVAILABLE: u8 = 0x0A;
const NO_RESPONSE: u8 = 0x0B;

fn ms(n: u64) -> u64 {
    us_to_cycles(1000 * n)
}

fn fmt_ms(cycles: u64) -> String {
    format!("{:.3} ms", cycles_to_us(cycles) / 1000.0)
}

// ---------------------------------------------------------------------------------------
// Frames on either side

/// An ADU: the MBAP header (Implementation Guide §3.1.3) and `pdu`.
fn adu(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let [t0, t1] = transaction.to_be_bytes();
    let [l0, l1] = (pdu.len() as u16 + 1).to_be_bytes();
    let mut out = vec![
        t0, t1, // transaction id
        0x00, 0x00, // protocol id: Modbus
        l0, l1,   // length: unit id and PDU
        unit, // unit id
    ];
    out.extend_from_slice(pdu);
    out
}

/// FC 3 or 4: `qty` registers from `start`.
fn read_pdu(function: u8, start: u16, qty: u16) -> Vec<u8> {
    let [s0, s1] = start.to_be_bytes();
    let [q0, q1] = qty.to_be_bytes();
    vec![function, s0, s1, q0, q1]
}

/// FC 6: register `address` = `value` (its answer is the same PDU).
fn write_pdu(address: u16, value: u16) -> Vec<u8> {
    let [a0, a1] = address.to_be_bytes();
    let [v0, v1] = value.to_be_bytes();
    vec![0x06, a0, a1, v0, v1]
}

/// FC 16: registers from `start` = `values`.
fn write_multiple_pdu(start: u16, values: &[u16]) -> Vec<u8> {
    let [s0, s1] = start.to_be_bytes();
    let [q0, q1] = (values.len() as u16).to_be_bytes();
    let mut pdu = vec![0x10, s0, s1, q0, q1, 2 * values.len() as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    pdu
}

/// The answer PDU to a read of registers with these values.
fn registers_pdu(function: u8, values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![function, 2 * values.len() as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    pdu
}

fn word(bytes: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([bytes[at], bytes[at + 1]])
}

/// Who put a frame on the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Who {
    /// The gateway's master.
    Gateway,
    /// The test's slave with this id.
    Slave(u8),
}

/// A frame on the line with its times.
#[derive(Clone, Debug)]
struct Frame {
    who: Who,
    bytes: Vec<u8>,
    /// Start of its first start bit.
    start: u64,
    /// End of its last stop bit.
    end: u64,
    /// Longest idle time between two of its characters.
    max_gap: u64,
}

impl Frame {
    fn from_chars(chars: &[TxByte]) -> Frame {
        Frame {
            who: Who::Gateway,
            bytes: chars.iter().map(|c| c.byte).collect(),
            start: chars[0].start_cycle,
            end: chars[chars.len() - 1].end_cycle,
            max_gap: chars.windows(2).map(|w| w[1].start_cycle - w[0].end_cycle).max().unwrap_or(0),
        }
    }

    /// The slave address it carries (a gateway's request).
    fn address(&self) -> u8 {
        self.bytes[0]
    }
}

// ---------------------------------------------------------------------------------------
// The slaves

/// One RS-485 slave: its registers, whether it is powered, and how late it answers the
/// next request if not T3.5 + 0.5 ms after its end.
struct Slave {
    id: u8,
    registers: [u16; REGISTERS],
    on: bool,
    late_once: Option<u64>,
    /// Requests it does not hear (as a noisy line loses them): one in `n`, drawn from the
    /// generator.
    loses: Option<(Rng, u64)>,
}

impl Slave {
    fn new(id: u8) -> Slave {
        Slave { id, registers: initial_registers(id), on: true, late_once: None, loses: None }
    }

    /// Executes `frame` (address, PDU, CRC already checked), addressed to it or broadcast;
    /// returns its answer (address, PDU, CRC), none for a broadcast.
    fn execute(&mut self, frame: &[u8]) -> Option<Vec<u8>> {
        let (address, pdu) = (frame[0], &frame[1..frame.len() - 2]);
        let function = pdu[0];
        let in_map = |start: u16, qty: u16| usize::from(start) + usize::from(qty) <= REGISTERS;
        let answer = match function {
            0x03 | 0x04 if pdu.len() == 5 => {
                let (start, qty) = (word(pdu, 1), word(pdu, 3));
                if qty == 0 || !in_map(start, qty) {
                    vec![function | 0x80, ILLEGAL_ADDRESS]
                } else {
                    let from = usize::from(start);
                    registers_pdu(function, &self.registers[from..from + usize::from(qty)])
                }
            }
            0x06 if pdu.len() == 5 => {
                let (at, value) = (word(pdu, 1), word(pdu, 3));
                if in_map(at, 1) {
                    self.registers[usize::from(at)] = value;
                    pdu.to_vec()
                } else {
                    vec![0x86, ILLEGAL_ADDRESS]
                }
            }
            0x10 if pdu.len() >= 6 && pdu.len() == 6 + usize::from(pdu[5]) => {
                let (start, qty) = (word(pdu, 1), word(pdu, 3));
                if qty == 0 || usize::from(pdu[5]) != 2 * usize::from(qty) || !in_map(start, qty) {
                    vec![0x90, ILLEGAL_ADDRESS]
                } else {
                    for i in 0..usize::from(qty) {
                        self.registers[usize::from(start) + i] = word(pdu, 6 + 2 * i);
                    }
                    pdu[..5].to_vec()
                }
            }
            _ => vec![function | 0x80, ILLEGAL_FUNCTION],
        };
        if address == 0 {
            return None;
        }
        let mut out = vec![self.id];
        out.extend_from_slice(&answer);
        Some(with_crc(&out))
    }
}

/// Slave `id`'s registers at power-up.
fn initial_registers(id: u8) -> [u16; REGISTERS] {
    std::array::from_fn(|i| (u16::from(id) << 12) | (0x0100 * i as u16) | u16::from(id))
}

// ---------------------------------------------------------------------------------------
// The TCP masters

/// A request a TCP master sent and not yet got its answer to.
#[derive(Clone, Debug)]
struct Asked {
    transaction: u16,
    unit: u8,
    pdu: Vec<u8>,
    /// When its last byte landed in the chip.
    landed: u64,
}

/// An answer a TCP master got, with the request it answers.
#[derive(Clone, Debug)]
struct Answer {
    asked: Asked,
    /// The answer's PDU.
    pdu: Vec<u8>,
    /// The cycle of the SEND command that carried its last byte.
    sent: u64,
}

/// A TCP master on one socket: what it asked, what it got.
struct Master {
    /// Its socket (`usize::MAX` once its connection is gone).
    socket: usize,
    next_transaction: u16,
    /// In the order they were sent: answers must come in that order.
    outstanding: VecDeque<Asked>,
    /// Bytes the chip sent and not yet parsed into answers.
    inbox: Vec<u8>,
    /// SENDs of its socket already read.
    sends_seen: usize,
    answers: Vec<Answer>,
    /// Where the last request landed (the next lands no earlier).
    last_landing: u64,
}

/// The peer address of master `i`.
fn peer(i: u8) -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + i), 40_000 + u16::from(i))
}

// ---------------------------------------------------------------------------------------
// The rig: the gateway, its line, its masters

struct Rig {
    uno: Uno,
    line: Line,
    /// One character on the line, in cycles.
    char_cycles: u64,
    slaves: Vec<Slave>,
    /// Every frame on the line, in order of start.
    log: Vec<Frame>,
    /// Characters the gateway is sending (not yet a whole frame).
    chars: Vec<TxByte>,
    masters: Vec<Master>,
}

impl Rig {
    /// Boots the gateway `build` with slaves 1, 2 and 3 on its line, until its sockets
    /// listen.
    fn boot(build: Build) -> Rig {
        let (variant, int) = build;
        eprintln!("tcp_gateway{variant}:");
        let elf = chip_variant_firmware(Chip::Atmega328p, 0, variant, "tcp_gateway");
        let mut options = Options::new().wiznet(Wiznet::W5100);
        if int {
            // The W5100 shield's solder jumper: INT to pin 2 (PD2).
            options = options.wiznet_int('D', 2);
        }
        let mut uno = Uno::load_with(elf, options).expect("firmware loads");
        while !(0..4).all(|n| uno.wiznet().unwrap().status(n) == state::LISTEN) {
            assert!(uno.now() < ms(100), "the sockets never listened");
            uno.run_for(us_to_cycles(100)).unwrap();
        }
        uno.run_for(ms(5)).unwrap();
        let cfg = uno.serial_config().expect("USART0 enabled");
        assert!(cfg.matches(19_200, 8, Parity::Even, 1), "USART0: {cfg:?}");
        let de = uno.port_pin(DE.0, DE.1).unwrap();
        assert!(de.output && !de.level, "DE is a low output while the line listens: {de:?}");
        let char_cycles = uno.wire_char_cycles().unwrap();
        let slaves = [1, 2, 3].into_iter().map(Slave::new).collect();
        Rig {
            uno,
            line: Line::B19200_8E1,
            char_cycles,
            slaves,
            log: Vec::new(),
            chars: Vec::new(),
            masters: Vec::new(),
        }
    }

    fn t35(&self) -> u64 {
        self.line.t35()
    }

    fn t15(&self) -> u64 {
        self.line.t15()
    }

    fn now(&self) -> u64 {
        self.uno.now()
    }

    /// A new TCP master, connected and seen by the gateway; its index.
    fn connect(&mut self) -> usize {
        let i = self.masters.len();
        let socket = self.uno.wiznet_mut().unwrap().connect(PORT, peer(i as u8)).expect("a socket listens");
        self.masters.push(Master {
            socket,
            next_transaction: 0x1000 * (i as u16 + 1),
            outstanding: VecDeque::new(),
            inbox: Vec::new(),
            sends_seen: 0,
            answers: Vec::new(),
            last_landing: 0,
        });
        self.run_for(ms(3));
        i
    }

    /// Master `m` sends `pdu` for `unit` as one segment landing at `at` (not before its
    /// previous one); returns its transaction id.
    fn ask_at(&mut self, m: usize, unit: u8, pdu: &[u8], at: u64) -> u16 {
        self.ask_split(m, unit, pdu, at, &[])
    }

    /// Master `m` sends `pdu` for `unit`, the ADU cut before each offset in `cuts`, the
    /// first piece landing at `at` and each next 300 µs later; returns its transaction id.
    fn ask_split(&mut self, m: usize, unit: u8, pdu: &[u8], at: u64, cuts: &[usize]) -> u16 {
        let master = &mut self.masters[m];
        let transaction = master.next_transaction;
        master.next_transaction = master.next_transaction.wrapping_add(1);
        let bytes = adu(transaction, unit, pdu);
        let mut at = at.max(master.last_landing).max(self.uno.now());
        let mut from = 0;
        let socket = master.socket;
        let chip = self.uno.wiznet_mut().unwrap();
        let ends: Vec<usize> = cuts.iter().copied().chain([bytes.len()]).collect();
        for cut in ends {
            if cut > from {
                chip.deliver_at(socket, &bytes[from..cut], at);
                from = cut;
                at += us_to_cycles(300);
            }
        }
        let landed = at - us_to_cycles(300);
        let master = &mut self.masters[m];
        master.last_landing = landed;
        // A broadcast gets no answer: one would be taken for the next request's.
        // A broadcast write gets no answer; a read to unit 0 gets 0A.
        if unit != 0 || !matches!(pdu[0], 0x05 | 0x06 | 0x0F | 0x10 | 0x16) {
            master.outstanding.push_back(Asked { transaction, unit, pdu: pdu.to_vec(), landed });
        }
        transaction
    }

    /// Master `m` sends several requests in one segment landing at `at`; their transaction
    /// ids.
    fn ask_pipelined(&mut self, m: usize, requests: &[(u8, Vec<u8>)], at: u64) -> Vec<u16> {
        let master = &mut self.masters[m];
        let at = at.max(master.last_landing).max(self.uno.now());
        let mut segment = Vec::new();
        let mut ids = Vec::new();
        for (unit, pdu) in requests {
            let transaction = master.next_transaction;
            master.next_transaction = master.next_transaction.wrapping_add(1);
            segment.extend(adu(transaction, *unit, pdu));
            if *unit != 0 {
                master.outstanding.push_back(Asked { transaction, unit: *unit, pdu: pdu.clone(), landed: at });
            }
            ids.push(transaction);
        }
        master.last_landing = at;
        let socket = master.socket;
        self.uno.wiznet_mut().unwrap().deliver_at(socket, &segment, at);
        ids
    }

    /// Takes what the gateway sent on the line and on the sockets. A frame on the line is
    /// over after two characters of idle line; the slave it addresses (every slave, for
    /// address 0) executes it and, powered, answers T3.5 + 0.5 ms after its end.
    fn collect(&mut self) {
        let now = self.uno.now();
        self.chars.extend(self.uno.take_tx());
        if let Some(last) = self.chars.last() {
            let busy = self.uno.tx_busy_until().unwrap_or(0).max(last.end_cycle);
            if now >= busy + 2 * self.char_cycles {
                let frame = Frame::from_chars(&std::mem::take(&mut self.chars));
                self.log.push(frame.clone());
                self.answer(&frame);
            }
        }
        for m in 0..self.masters.len() {
            self.read_answers(m);
        }
    }

    /// The slaves' side of a request on the line.
    fn answer(&mut self, frame: &Frame) {
        let bytes = &frame.bytes;
        if bytes.len() < 4 || crc16(&bytes[..bytes.len() - 2]).to_le_bytes() != bytes[bytes.len() - 2..] {
            return; // the log check reports it
        }
        let mut reply = None;
        for slave in self.slaves.iter_mut().filter(|s| s.on && (bytes[0] == 0 || bytes[0] == s.id)) {
            if let Some((rng, n)) = &mut slave.loses {
                if rng.below(*n) == 0 {
                    continue;
                }
            }
            let after = slave.late_once.take().unwrap_or(self.line.t35() + us_to_cycles(SLAVE_DELAY_US));
            reply = slave.execute(bytes).map(|reply| (reply, after));
        }
        if let Some((reply, after)) = reply {
            let start = frame.end + after;
            let end = self.uno.send_frame(&reply, start + self.char_cycles, 0).expect("reply scheduled");
            self.log.push(Frame { who: Who::Slave(bytes[0]), bytes: reply, start, end, max_gap: 0 });
        }
    }

    /// Master `m`'s answers out of its socket's SENDs: each must be the answer to the
    /// oldest request it has not had answered, with its transaction id and unit id.
    fn read_answers(&mut self, m: usize) {
        let master = &mut self.masters[m];
        let chip = self.uno.wiznet_mut().unwrap();
        chip.take_sent(master.socket);
        let sends = chip.sends(master.socket);
        for send in &sends[master.sends_seen..] {
            master.inbox.extend_from_slice(&send.data);
            while master.inbox.len() >= 7 && master.inbox.len() >= 6 + usize::from(word(&master.inbox, 4)) {
                let len = 6 + usize::from(word(&master.inbox, 4));
                let got: Vec<u8> = master.inbox.drain(..len).collect();
                let Some(asked) = master.outstanding.pop_front() else {
                    panic!("master {m}: an answer {got:02X?} to no request");
                };
                assert_eq!(
                    got[..4],
                    adu(asked.transaction, asked.unit, &[])[..4],
                    "master {m}: the answer {got:02X?} to {asked:02X?}: not its transaction id (or protocol id)"
                );
                assert_eq!(got[6], asked.unit, "master {m}: the answer {got:02X?} to {asked:02X?}: not its unit");
                let pdu = got[7..].to_vec();
                assert_eq!(
                    pdu[0] & 0x7F,
                    asked.pdu[0],
                    "master {m}: the answer {got:02X?} to {asked:02X?}: not its function code"
                );
                master.answers.push(Answer { asked, pdu, sent: send.cycle });
            }
        }
        master.sends_seen = sends.len();
    }

    /// Runs until `cycle`, half a character at a time, collecting both sides.
    fn run_until(&mut self, cycle: u64) {
        while self.uno.now() < cycle {
            let slice = (self.uno.now() + self.char_cycles / 2).min(cycle);
            self.uno.run_until(slice).expect("firmware runs");
            self.collect();
        }
    }

    fn run_for(&mut self, cycles: u64) {
        self.run_until(self.uno.now() + cycles);
    }

    /// Runs until master `m` has no request left unanswered (panics after `within`).
    fn settle(&mut self, m: usize, within: u64) {
        let deadline = self.uno.now() + within;
        while !self.masters[m].outstanding.is_empty() {
            assert!(
                self.uno.now() < deadline,
                "master {m}: no answer to {:02X?} by {}",
                self.masters[m].outstanding,
                fmt_ms(deadline)
            );
            self.run_for(self.char_cycles / 2);
        }
    }

    /// Master `m` asks `pdu` of `unit` and waits for the answer (at most 500 ms); its PDU.
    fn ask(&mut self, m: usize, unit: u8, pdu: &[u8]) -> Vec<u8> {
        let now = self.uno.now();
        self.ask_at(m, unit, pdu, now);
        self.settle(m, ms(500));
        self.masters[m].answers.last().unwrap().pdu.clone()
    }

    /// The gateway's requests on the line (its master's frames).
    fn requests(&self) -> impl Iterator<Item = &Frame> {
        self.log.iter().filter(|f| f.who == Who::Gateway)
    }

    /// Checks the line's log: every frame of the gateway is one frame (no gap over T1.5),
    /// with its CRC right, and starts T3.5 or more after the end of every frame before it;
    /// returns the shortest silence before one.
    fn check_line(&self) -> u64 {
        let (t15, t35) = (self.t15(), self.t35());
        let mut shortest = u64::MAX;
        let mut log: Vec<&Frame> = self.log.iter().collect();
        log.sort_by_key(|f| f.start);
        for (i, frame) in log.iter().enumerate() {
            if frame.who != Who::Gateway {
                continue;
            }
            let b = &frame.bytes;
            assert!(
                b.len() >= 4 && crc16(&b[..b.len() - 2]).to_le_bytes() == b[b.len() - 2..],
                "the gateway's frame {b:02X?} at {} has a wrong CRC",
                fmt_ms(frame.start)
            );
            assert!(frame.max_gap <= t15, "a gap of {} inside the gateway's {b:02X?}", fmt_ms(frame.max_gap));
            if let Some(before) = log[..i].iter().map(|f| f.end).max() {
                assert!(
                    frame.start >= before + t35,
                    "the gateway's {b:02X?} at {} started {} after the previous frame's end (T3.5 = {})",
                    fmt_ms(frame.start),
                    fmt_ms(frame.start.saturating_sub(before)),
                    fmt_ms(t35)
                );
                shortest = shortest.min(frame.start - before);
            }
        }
        shortest
    }

    /// Prints the line's log (with `GATEWAY_DUMP` set).
    fn dump(&self) {
        if std::env::var_os("GATEWAY_DUMP").is_none() {
            return;
        }
        for f in &self.log {
            eprintln!("  {:>12} .. {:>12} {:?} {:02X?}", fmt_ms(f.start), fmt_ms(f.end), f.who, f.bytes);
        }
    }
}

/// Exception `code` for function `function`, as an answer PDU.
fn exception(function: u8, code: u8) -> Vec<u8> {
    vec![function | 0x80, code]
}

/// Percentile `pct` of sorted `values`.
fn percentile(sorted: &[u64], pct: usize) -> u64 {
    sorted[(sorted.len() * pct / 100).min(sorted.len() - 1)]
}

// ---------------------------------------------------------------------------------------
// (a) four masters, three slaves, one switched off and on again

/// What master `m` expects of the registers it owns (2m, 2m + 1) on each slave: the values
/// it wrote and had acknowledged, `None` once a write of its may or may not have happened.
type Owned = [Option<[u16; 2]>; 3];

/// Four TCP masters poll slaves 1, 2 and 3 with two requests under way each (reads of the
/// two registers each owns, and writes of them), for 6 simulated seconds; slave 2 is
/// switched off at 1.5 s and on again at 4.5 s. Every request gets exactly one answer, on
/// its own connection, in order, with its own transaction id (checked as the answers come):
/// the slave's data, or for slave 2 while off 0B, the first three after a try and its retry
/// each (a response timeout apart), the others at once but for one try (no retry) every
/// `recheck_ms`; once slave 2 answers again (at its next recheck) its data again. Slaves 1
/// and 3 are never starved: the masters' shares are even, and while a request waits, at
/// most the dead slave's six tries before it is down and 8 requests of the others go on the
/// line, and at most those six tries (1.2 s) and 200 ms pass.
#[test]
fn four_masters_three_slaves_one_switched_off_every_request_one_answer() {
    for build in BUILDS {
        four_masters_three_slaves_one_switched_off_every_request_one_answer_on(build);
    }
}

fn four_masters_three_slaves_one_switched_off_every_request_one_answer_on(build: Build) {
    let mut rig = Rig::boot(build);
    let masters: Vec<usize> = (0..4).map(|_| rig.connect()).collect();
    let mut rng = Rng(0x5EED_6A7E);
    let start = rig.now();
    let (off_at, on_at, stop_at) = (start + ms(1500), start + ms(4500), start + ms(6000));
    let mut owned: Vec<Owned> = vec![[None; 3]; 4];
    for (m, owned) in owned.iter_mut().enumerate() {
        for (s, slot) in owned.iter_mut().enumerate() {
            let regs = initial_registers(s as u8 + 1);
            *slot = Some([regs[2 * m], regs[2 * m + 1]]);
        }
    }
    // Each master's next unit, in turn 1, 2, 3 from a different one.
    let mut next_unit: Vec<u8> = (0..4).map(|m| (m % 3) as u8 + 1).collect();
    let mut checked = [0usize; 4];
    let mut slave2 = true;
    let slice = rig.char_cycles / 2;
    while rig.now() < stop_at + ms(600) {
        if slave2 && rig.now() >= off_at {
            rig.slaves[1].on = false;
            slave2 = false;
        }
        if !slave2 && rig.now() >= on_at && rig.now() < on_at + slice {
            rig.slaves[1].on = true;
        }
        if rig.now() < stop_at {
            for &m in &masters {
                if rig.masters[m].outstanding.len() < 2 && rng.chance(20) {
                    let unit = next_unit[m];
                    next_unit[m] = unit % 3 + 1;
                    let first = 2 * m as u16;
                    let pdu = match rng.below(10) {
                        0..=6 => read_pdu(0x03, first, 2),
                        7 | 8 => write_pdu(first + rng.below(2) as u16, rng.u16()),
                        _ => write_multiple_pdu(first, &[rng.u16(), rng.u16()]),
                    };
                    let at = rig.now() + rng.below(slice);
                    rig.ask_at(m, unit, &pdu, at);
                }
            }
        }
        rig.run_for(slice);
        // The answers, checked against the slaves as each master knows them.
        for m in 0..4 {
            for answer in &rig.masters[m].answers[checked[m]..] {
                check_polled_answer(m, answer, &mut owned[m], off_at);
            }
            checked[m] = rig.masters[m].answers.len();
        }
    }
    rig.dump();
    let shortest = rig.check_line();

    // Slave 2 while off: three requests with a try and its retry each, then one try a
    // recheck.
    let tries: Vec<&Frame> = rig.requests().filter(|f| f.address() == 2 && f.start >= off_at).collect();
    let starts: Vec<String> = tries.iter().map(|f| fmt_ms(f.start - off_at)).collect();
    eprintln!("slave 2 off at {}: tried at +{}", fmt_ms(off_at - start), starts.join(", +"));
    assert!(tries.len() >= TRIES_BEFORE_DOWN + 2, "slave 2 tried {} times while off and after", tries.len());
    let retry = tries[1].start - tries[0].end;
    assert!(
        (ms(RESPONSE_TIMEOUT_MS)..=ms(RESPONSE_TIMEOUT_MS + 3)).contains(&retry),
        "the retry {} after the first try",
        fmt_ms(retry)
    );
    let rechecks: Vec<&&Frame> = tries[TRIES_BEFORE_DOWN..].iter().take_while(|f| f.start < on_at).collect();
    // Three misses (1.2 s) before it is down, then a recheck a second.
    assert!(!rechecks.is_empty(), "no recheck in 3 s off");
    let mut previous = tries[TRIES_BEFORE_DOWN - 1].end;
    for f in &rechecks {
        let after = f.start - previous;
        assert!(
            (ms(RECHECK_MS - RESPONSE_TIMEOUT_MS)..=ms(RECHECK_MS + 2 * RESPONSE_TIMEOUT_MS + 100)).contains(&after),
            "a recheck of slave 2 {} after its previous try",
            fmt_ms(after)
        );
        previous = f.end;
    }
    let back = tries.iter().find(|f| f.start >= on_at).expect("slave 2 tried again once on");
    assert!(
        back.start - on_at <= ms(RECHECK_MS + 2 * RESPONSE_TIMEOUT_MS),
        "slave 2 back after {}",
        fmt_ms(back.start - on_at)
    );

    // Slave 2's answers: 0B only while off; 0B without a try on the line at once.
    let mut at_once = Vec::new();
    let mut zero_b = 0;
    for master in &rig.masters {
        for a in master.answers.iter().filter(|a| a.asked.unit == 2) {
            if a.pdu == exception(a.asked.pdu[0], NO_RESPONSE) {
                zero_b += 1;
                assert!(a.sent > off_at && a.asked.landed < back.end + ms(10), "0B for slave 2 at {}", fmt_ms(a.sent));
                let tried = tries.iter().any(|f| f.start >= a.asked.landed && f.end <= a.sent);
                if !tried {
                    at_once.push(a.sent - a.asked.landed);
                }
            }
        }
    }
    at_once.sort_unstable();
    eprintln!(
        "slave 2: {zero_b} answers 0B, {} without a try on the line, their latency p50 {}, max {}",
        at_once.len(),
        fmt_ms(percentile(&at_once, 50)),
        fmt_ms(*at_once.last().unwrap())
    );
    assert!(at_once.len() >= 20, "only {} answers 0B without a try", at_once.len());

    // Slaves 1 and 3 never starved: shares, requests of others while waiting, latency.
    let mut latencies = Vec::new();
    let mut worst_crowd = 0;
    let mut shares = Vec::new();
    for master in &rig.masters {
        let live: Vec<&Answer> = master.answers.iter().filter(|a| a.asked.unit != 2).collect();
        shares.push(live.len());
        for a in live {
            latencies.push(a.sent - a.asked.landed);
            let crowd = rig.requests().filter(|f| f.start > a.asked.landed && f.start < a.sent).count();
            worst_crowd = worst_crowd.max(crowd);
        }
    }
    latencies.sort_unstable();
    eprintln!(
        "slaves 1 and 3: answers per master {shares:?}; request in the chip -> answer's SEND p50 {}, p99 {}, max {}; \
         at most {worst_crowd} requests on the line meanwhile; shortest silence before a request {}; simulated {}",
        fmt_ms(percentile(&latencies, 50)),
        fmt_ms(percentile(&latencies, 99)),
        fmt_ms(*latencies.last().unwrap()),
        fmt_ms(shortest),
        fmt_ms(rig.now())
    );
    // Each answer with a slave's data is sent at once after the line's outcome (its reply's
    // end + T3.5), never a poll (1.024 ms) later.
    let replies: Vec<&Frame> = rig.log.iter().filter(|f| f.who != Who::Gateway).collect();
    let mut passed_back = Vec::new();
    for a in rig.masters.iter().flat_map(|m| &m.answers).filter(|a| a.pdu[0] & 0x80 == 0) {
        let reply = replies.iter().filter(|f| f.end < a.sent).max_by_key(|f| f.end).expect("a reply before it");
        passed_back.push(a.sent - (reply.end + rig.t35()));
    }
    passed_back.sort_unstable();
    eprintln!(
        "answers from the line: reply's end + T3.5 -> SEND p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs",
        cycles_to_us(percentile(&passed_back, 50)),
        cycles_to_us(percentile(&passed_back, 99)),
        cycles_to_us(*passed_back.last().unwrap())
    );
    assert!(
        *passed_back.last().unwrap() <= us_to_cycles(600),
        "an answer sent {:.0} µs after its reply's end + T3.5",
        cycles_to_us(*passed_back.last().unwrap())
    );
    let (least, most) = (*shares.iter().min().unwrap(), *shares.iter().max().unwrap());
    assert!(least >= 40 && 10 * least >= 8 * most, "uneven shares of the line: {shares:?}");
    // The dead slave's tries before it is down, and the others' turns.
    assert!(worst_crowd <= TRIES_BEFORE_DOWN + 8, "a request waited while {worst_crowd} others went on the line");
    // At worst behind the dead slave's misses before it is down, and a few live requests.
    assert!(
        *latencies.last().unwrap() <= ms(TRIES_BEFORE_DOWN as u64 * RESPONSE_TIMEOUT_MS + 200),
        "a request to slave 1 or 3 waited {}",
        fmt_ms(*latencies.last().unwrap())
    );
    for (m, master) in rig.masters.iter().enumerate() {
        assert!(master.outstanding.is_empty(), "master {m}: unanswered {:02X?}", master.outstanding);
    }
}

/// One answer of the polling test: data as master `m` knows its registers (and its
/// knowledge updated by a write's acknowledgement), or 0B for slave 2 once switched off.
fn check_polled_answer(m: usize, answer: &Answer, owned: &mut Owned, off_at: u64) {
    let asked = &answer.asked;
    let slot = &mut owned[usize::from(asked.unit) - 1];
    let function = asked.pdu[0];
    if answer.pdu == exception(function, NO_RESPONSE) {
        assert!(asked.unit == 2 && answer.sent > off_at, "master {m}: 0B for {asked:02X?} at {}", fmt_ms(answer.sent));
        if function != 0x03 {
            *slot = None; // tried, maybe executed
        }
        return;
    }
    let first = 2 * m as u16;
    match function {
        0x03 => {
            let values = [word(&answer.pdu, 2), word(&answer.pdu, 4)];
            assert_eq!(answer.pdu.len(), 6, "master {m}: {:02X?} to {asked:02X?}", answer.pdu);
            if let Some(expected) = slot {
                assert_eq!(answer.pdu, registers_pdu(3, expected), "master {m}: the read {asked:02X?}");
            }
            *slot = Some(values);
        }
        0x06 => {
            assert_eq!(answer.pdu, asked.pdu, "master {m}: the write {asked:02X?}");
            if let Some(values) = slot {
                values[usize::from(word(&asked.pdu, 1) - first)] = word(&asked.pdu, 3);
            }
        }
        _ => {
            assert_eq!(answer.pdu, asked.pdu[..5], "master {m}: the write {asked:02X?}");
            *slot = Some([word(&asked.pdu, 6), word(&asked.pdu, 8)]);
        }
    }
}

// ---------------------------------------------------------------------------------------
// (b) split and pipelined requests

/// A request split over segments (its header in two, then byte by byte) waits in the chip
/// until it is whole, and is answered once; three requests in one segment (slave 1, slave 3,
/// the gateway's own unit) are answered in order, each with its transaction id, while
/// another master's requests take their turns.
#[test]
fn split_and_pipelined_requests_are_answered_once_whole_and_in_order() {
    for build in BUILDS {
        split_and_pipelined_requests_are_answered_once_whole_and_in_order_on(build);
    }
}

fn split_and_pipelined_requests_are_answered_once_whole_and_in_order_on(build: Build) {
    let mut rig = Rig::boot(build);
    let (a, b) = (rig.connect(), rig.connect());
    // Split: the header cut in two, then the PDU byte by byte, 300 µs apart.
    for cuts in [vec![3, 7, 8, 9, 10, 11], (1..12).collect::<Vec<usize>>()] {
        let at = rig.now() + us_to_cycles(100);
        rig.ask_split(a, 1, &read_pdu(3, 2, 3), at, &cuts);
        let landed = rig.masters[a].outstanding[0].landed;
        let before = rig.requests().count();
        rig.settle(a, ms(100));
        let answer = rig.masters[a].answers.last().unwrap().clone();
        assert_eq!(answer.pdu, registers_pdu(3, &initial_registers(1)[2..5]), "cut at {cuts:?}");
        let sent: Vec<&Frame> = rig.requests().skip(before).collect();
        assert_eq!(sent.len(), 1, "cut at {cuts:?}: {} requests on the line", sent.len());
        assert_eq!(sent[0].bytes, with_crc(&[1, 3, 0, 2, 0, 3]), "cut at {cuts:?}");
        assert!(sent[0].start > landed, "cut at {cuts:?}: sent before it was whole");
    }
    // Pipelined, three in one segment, while master b asks slave 1 too.
    for round in 0..5u16 {
        let at = rig.now() + us_to_cycles(137 * u64::from(round));
        rig.ask_at(b, 1, &read_pdu(3, 0, 1), at);
        let requests = [
            (1, read_pdu(3, 6, 2)),
            (3, write_pdu(5, 0xBE00 + round)),
            (3, read_pdu(3, 4, 2)),
            (0xFF, read_pdu(4, 7, 1)),
        ];
        let ids = rig.ask_pipelined(a, &requests, at);
        rig.settle(a, ms(200));
        rig.settle(b, ms(200));
        let got: Vec<&Answer> = rig.masters[a].answers.iter().rev().take(4).rev().collect();
        let got_ids: Vec<u16> = got.iter().map(|g| g.asked.transaction).collect();
        assert_eq!(got_ids, ids, "round {round}: in order");
        assert_eq!(got[0].pdu, registers_pdu(3, &initial_registers(1)[6..8]), "round {round}");
        assert_eq!(got[1].pdu, write_pdu(5, 0xBE00 + round), "round {round}");
        assert_eq!(got[2].pdu, registers_pdu(3, &[initial_registers(3)[4], 0xBE00 + round]), "round {round}");
        // Register 7: the connections waiting for the line as the poll began.
        assert_eq!(got[3].pdu[..2], [4, 2], "round {round}");
        assert!(got.windows(2).all(|w| w[0].sent <= w[1].sent), "round {round}: answers out of order");
        assert_eq!(rig.masters[b].answers.last().unwrap().pdu, registers_pdu(3, &initial_registers(1)[..1]));
        rig.run_for(ms(3));
    }
    rig.dump();
    rig.check_line();
}

// ---------------------------------------------------------------------------------------
// (c) the units the gateway answers itself: 248-254, 0xFF, and 0

/// The gateway's own registers at unit 0xFF (FC 4 and FC 3): `qty` from `first` (0–7 its
/// counters, 8 the connections waiting; from 1000 + 4n slave n's health).
fn status(rig: &mut Rig, m: usize, function: u8, first: u16, qty: u16) -> Vec<u16> {
    let pdu = rig.ask(m, 0xFF, &read_pdu(function, first, qty));
    assert_eq!(pdu[..2], [function, 2 * qty as u8], "{pdu:02X?}");
    pdu[2..].chunks(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect()
}

/// Units 248–254 get 0A without the line; unit 0 is a broadcast: a write goes out with
/// address 0 (every slave executes it) and gets no TCP answer, a read gets 0A without the
/// line; a unit with no slave gets 0B after a try and its retry, three times, then 0B at
/// once; unit 0xFF reads the gateway's registers, which count all of it.
#[test]
fn units_248_to_254_get_0a_unit_0_is_a_broadcast_and_0xff_the_gateways_registers() {
    for build in BUILDS {
        units_248_to_254_get_0a_unit_0_is_a_broadcast_and_0xff_the_gateways_registers_on(build);
    }
}

fn units_248_to_254_get_0a_unit_0_is_a_broadcast_and_0xff_the_gateways_registers_on(build: Build) {
    let mut rig = Rig::boot(build);
    let m = rig.connect();
    assert_eq!(status(&mut rig, m, 4, 0, 9), [0; 9], "at start");
    // 1. A read of slave 1, and one past slave 3's registers (its exception 02).
    assert_eq!(rig.ask(m, 1, &read_pdu(3, 0, 2)), registers_pdu(3, &initial_registers(1)[..2]));
    assert_eq!(rig.ask(m, 3, &read_pdu(3, 124, 2)), exception(3, ILLEGAL_ADDRESS));
    // 2. Units 248 and 254: 0A, nothing on the line.
    let before = rig.requests().count();
    assert_eq!(rig.ask(m, 248, &read_pdu(3, 0, 1)), exception(3, PATH_UNAVAILABLE));
    assert_eq!(rig.ask(m, 254, &write_pdu(0, 1)), exception(6, PATH_UNAVAILABLE));
    assert_eq!(rig.requests().count(), before, "a request for 248 or 254 went on the line");
    // 3. Unit 0: a write goes out with address 0, no answer comes.
    let now = rig.now();
    rig.ask_at(m, 0, &write_pdu(4, 0x1234), now);
    rig.run_for(ms(60));
    let broadcast = rig.requests().last().unwrap().clone();
    assert_eq!(broadcast.bytes, with_crc(&[0, 0x06, 0, 4, 0x12, 0x34]), "the broadcast on the line");
    assert_eq!(rig.masters[m].answers.len(), 5, "no answer to a broadcast");
    for id in [1, 2, 3] {
        assert_eq!(rig.ask(m, id, &read_pdu(3, 4, 1)), registers_pdu(3, &[0x1234]), "slave {id} after the broadcast");
    }
    // A broadcast read gets 0A at once, and nothing goes on the line.
    let before = rig.requests().count();
    let asked = rig.now();
    assert_eq!(rig.ask(m, 0, &read_pdu(3, 0, 1)), exception(3, PATH_UNAVAILABLE));
    let waited = rig.masters[m].answers.last().unwrap().sent - asked;
    assert!(waited <= ms(3), "0A for a broadcast read took {}", fmt_ms(waited));
    assert_eq!(rig.requests().count(), before, "a broadcast read went on the line");
    // 4. Unit 4, no slave there: 0B after a try and its retry, three times; then 0B at
    // once.
    for tried in 1..=DOWN_AFTER {
        let asked = rig.now();
        assert_eq!(rig.ask(m, 4, &read_pdu(3, 0, 1)), exception(3, NO_RESPONSE));
        let waited = rig.masters[m].answers.last().unwrap().sent - asked;
        assert!(waited >= ms((RETRIES as u64 + 1) * RESPONSE_TIMEOUT_MS), "0B after {}", fmt_ms(waited));
        assert_eq!(rig.requests().filter(|f| f.address() == 4).count(), tried * (RETRIES + 1), "tries of unit 4");
    }
    let asked = rig.now();
    assert_eq!(rig.ask(m, 4, &read_pdu(3, 0, 1)), exception(3, NO_RESPONSE));
    let waited = rig.masters[m].answers.last().unwrap().sent - asked;
    assert!(waited <= ms(3), "0B at once took {}", fmt_ms(waited));
    assert_eq!(rig.requests().filter(|f| f.address() == 4).count(), TRIES_BEFORE_DOWN, "unit 4 tried again at once");
    // 5. The gateway's registers: forwarded (broadcast and unit 4's first tries included,
    // retries not), answers, exceptions, 0A, 0B, broadcasts, orphaned, malformed, waiting;
    // unit 4's health (answers, misses, in a row, down) and slave 1's.
    let forwarded = 2 + 1 + 3 + DOWN_AFTER as u16;
    let answers = 2 + 3;
    let expected = [forwarded, answers, 1, 3, DOWN_AFTER as u16 + 1, 1, 0, 0, 0];
    assert_eq!(status(&mut rig, m, 4, 0, 9), expected, "FC 4 of 0xFF");
    assert_eq!(status(&mut rig, m, 3, 0, 9), expected, "FC 3 of 0xFF");
    assert_eq!(
        status(&mut rig, m, 4, 1000 + 4 * 4, 4),
        [0, DOWN_AFTER as u16, DOWN_AFTER as u16, 1],
        "unit 4's health"
    );
    assert_eq!(status(&mut rig, m, 3, 1000 + 4, 4), [2, 0, 0, 0], "slave 1's health");
    assert_eq!(rig.ask(m, 0xFF, &read_pdu(4, 8, 5)), exception(4, ILLEGAL_ADDRESS), "past register 11");
    assert_eq!(rig.ask(m, 0xFF, &write_pdu(0, 1)), exception(6, ILLEGAL_FUNCTION), "a write of 0xFF");
    let line_requests = rig.requests().count() as u16;
    assert_eq!(line_requests, forwarded + DOWN_AFTER as u16, "the line's log: forwarded and the retries");
    rig.dump();
    rig.check_line();
}

// ---------------------------------------------------------------------------------------
// (d) the line: silences, frames, and the driver enable

/// The edges of DE (PD3) while the gateway runs, instruction by instruction.
fn watch_de(rig: &mut Rig, until: u64) -> Vec<(u64, bool)> {
    let mut edges = Vec::new();
    let mut high = rig.uno.port_pin(DE.0, DE.1).unwrap().level;
    let mut next_collect = rig.now() + rig.char_cycles / 2;
    while rig.now() < until {
        rig.uno.step().expect("firmware runs");
        let level = rig.uno.port_pin(DE.0, DE.1).unwrap().level;
        if level != high {
            edges.push((rig.now(), level));
            high = level;
        }
        if rig.now() >= next_collect {
            rig.collect();
            next_collect = rig.now() + rig.char_cycles / 2;
        }
    }
    edges
}

/// Two masters' reads, writes and a broadcast go out one frame each, T3.5 after the frame
/// before, CRC right; DE (PD3) rises before each request's first start bit and falls after
/// its last stop bit, once per request, and is low whenever a slave answers.
#[test]
fn each_request_is_one_frame_after_t35_with_de_high_around_it_and_only_it() {
    for build in BUILDS {
        each_request_is_one_frame_after_t35_with_de_high_around_it_and_only_it_on(build);
    }
}

fn each_request_is_one_frame_after_t35_with_de_high_around_it_and_only_it_on(build: Build) {
    let mut rig = Rig::boot(build);
    let (a, b) = (rig.connect(), rig.connect());
    let now = rig.now();
    rig.ask_at(a, 1, &read_pdu(3, 0, 8), now);
    rig.ask_at(b, 3, &write_multiple_pdu(0, &[1, 2, 3, 4, 5, 6]), now);
    rig.ask_at(a, 0, &write_pdu(7, 0x0707), now + ms(1));
    rig.ask_at(b, 2, &write_pdu(6, 0x0606), now + ms(1));
    rig.ask_at(a, 3, &read_pdu(4, 0, 7), now + ms(2));
    let until = now + ms(150);
    let edges = watch_de(&mut rig, until);
    rig.settle(a, ms(10));
    rig.settle(b, ms(10));
    rig.dump();
    let requests: Vec<Frame> = rig.requests().cloned().collect();
    assert_eq!(requests.len(), 5, "requests on the line");
    assert_eq!(edges.len(), 2 * requests.len(), "DE edges {edges:?}");
    for (f, pair) in requests.iter().zip(edges.chunks(2)) {
        let [(rose, true), (fell, false)] = pair else { panic!("DE edges {pair:?} around {:02X?}", f.bytes) };
        assert!(*rose < f.start, "DE rose {} after the first start bit of {:02X?}", fmt_ms(rose - f.start), f.bytes);
        assert!(*fell >= f.end, "DE fell {} before the end of {:02X?}", fmt_ms(f.end - fell), f.bytes);
        eprintln!(
            "{:02X?}: DE high {:.1} µs before its first start bit, low {:.1} µs after its last stop bit",
            &f.bytes[..2],
            cycles_to_us(f.start - rose),
            cycles_to_us(fell - f.end)
        );
    }
    for f in rig.log.iter().filter(|f| f.who != Who::Gateway) {
        let high_during = edges.windows(2).any(|w| w[0].1 && w[0].0 < f.end && w[1].0 > f.start);
        assert!(!high_during, "DE high while slave {:?} answered", f.who);
    }
    rig.check_line();
}

/// A slave that answers late, its reply still on the line as the response timeout passes:
/// the gateway's retry waits until T3.5 after that reply's end (Serial Line v1.02 §2.5.1.1:
/// T3.5 between any two frames), and its answer is the one passed back.
#[test]
fn a_retry_waits_t35_after_a_late_reply_still_on_the_line() {
    for build in BUILDS {
        a_retry_waits_t35_after_a_late_reply_still_on_the_line_on(build);
    }
}

fn a_retry_waits_t35_after_a_late_reply_still_on_the_line_on(build: Build) {
    let mut rig = Rig::boot(build);
    let m = rig.connect();
    let now = rig.now();
    let mut answers = Vec::new();
    for late_ms in [190, 195, 198] {
        // FC 4 of 7 registers: a reply of 19 characters, 10.9 ms on the line.
        rig.slaves[2].late_once = Some(ms(late_ms));
        answers.push(rig.ask(m, 3, &read_pdu(4, 0, 7)));
    }
    rig.dump();
    // The line first: a retry sent into the late reply shows there.
    rig.check_line();
    // With a response timeout that covers the whole answer (as now), each late answer is cut
    // short and retried: 6 requests; one that stops at the answer's first character would
    // take them: 3.
    let requests: Vec<&Frame> = rig.requests().filter(|f| f.start > now).collect();
    assert!((3..=6).contains(&requests.len()), "{} requests for 3", requests.len());
    for (late_ms, answer) in [190, 195, 198].into_iter().zip(answers) {
        assert_eq!(answer, registers_pdu(4, &initial_registers(3)[..7]), "{late_ms} ms");
    }
}

// ---------------------------------------------------------------------------------------
// (e) connections that close while their request is on the line

/// A connection reset while its request is on the line: its answer is dropped and counted
/// (register 6 at unit 0xFF), never sent to the next connection on that socket, whose own
/// request is answered.
#[test]
fn an_answer_for_a_connection_reset_meanwhile_is_dropped_not_sent_to_its_successor() {
    for build in BUILDS {
        an_answer_for_a_connection_reset_meanwhile_is_dropped_not_sent_to_its_successor_on(build);
    }
}

fn an_answer_for_a_connection_reset_meanwhile_is_dropped_not_sent_to_its_successor_on(build: Build) {
    let mut rig = Rig::boot(build);
    let (old, other) = (rig.connect(), rig.connect());
    let now = rig.now();
    rig.ask_at(old, 1, &read_pdu(3, 0, 8), now);
    let before = rig.requests().count();
    rig.run_for(ms(8));
    assert_eq!(rig.requests().count(), before + 1, "the request went on the line");
    let socket = rig.masters[old].socket;
    rig.uno.wiznet_mut().unwrap().peer_reset(socket);
    // Gone: its socket is no longer its own.
    rig.masters[old].outstanding.clear();
    rig.masters[old].socket = usize::MAX;
    rig.run_for(ms(3));
    let new = rig.connect();
    assert_eq!(rig.masters[new].socket, socket, "the newcomer on the same socket");
    assert_eq!(rig.ask(new, 3, &read_pdu(3, 0, 1)), registers_pdu(3, &initial_registers(3)[..1]));
    assert!(rig.masters[old].answers.is_empty());
    let registers = status(&mut rig, other, 4, 0, 9);
    assert_eq!(registers[6], 1, "answers whose connection had closed: {registers:?}");
    rig.check_line();
}

/// A master that closes its side (FIN) right after its request still reads: it gets its
/// answer, then the gateway's FIN, and the socket listens again (as the plain TCP server
/// does, tests/sim_tcp.rs).
#[test]
fn a_master_that_sends_its_fin_after_its_request_gets_the_answer_then_a_fin() {
    for build in BUILDS {
        a_master_that_sends_its_fin_after_its_request_gets_the_answer_then_a_fin_on(build);
    }
}

fn a_master_that_sends_its_fin_after_its_request_gets_the_answer_then_a_fin_on(build: Build) {
    let mut rig = Rig::boot(build);
    let m = rig.connect();
    let socket = rig.masters[m].socket;
    let now = rig.now();
    rig.ask_at(m, 1, &read_pdu(3, 0, 2), now);
    rig.uno.wiznet_mut().unwrap().peer_fin(socket);
    rig.run_for(ms(60));
    let chip = rig.uno.wiznet().unwrap();
    let conn = chip.connection(socket).unwrap();
    assert!(conn.fin_from_chip() && !conn.reset_by_chip(), "{conn:?}");
    assert_eq!(chip.status(socket), state::LISTEN);
    let got: Vec<Vec<u8>> = rig.masters[m].answers.iter().map(|a| a.pdu.clone()).collect();
    assert_eq!(got, [registers_pdu(3, &initial_registers(1)[..2])], "the answer before the FIN");
    rig.check_line();
}

// ---------------------------------------------------------------------------------------
// (f) the longest requests and answers

/// Requests and answers longer than the gateway's 64-byte TCP buffer go through it a piece
/// at a time: FC 16 of 123 registers (an RTU frame of 255 bytes, 146 ms on the line), then
/// a read of 60 of them back (an answer of 125 bytes).
#[test]
fn requests_and_answers_longer_than_the_buffer_go_through_whole() {
    for build in BUILDS {
        requests_and_answers_longer_than_the_buffer_go_through_whole_on(build);
    }
}

fn requests_and_answers_longer_than_the_buffer_go_through_whole_on(build: Build) {
    let mut rig = Rig::boot(build);
    let m = rig.connect();
    let values: Vec<u16> = (0..123).map(|i| 0xA000 + i).collect();
    let write = write_multiple_pdu(2, &values);
    assert_eq!(rig.ask(m, 1, &write), write[..5], "FC 16 of 123 registers");
    let sent = rig.requests().last().unwrap().clone();
    assert_eq!(sent.bytes.len(), 255);
    assert_eq!(sent.bytes[..sent.bytes.len() - 2], [&[1][..], &write].concat());
    let mut expected: Vec<u16> = initial_registers(1).to_vec();
    expected[2..125].copy_from_slice(&values);
    assert_eq!(rig.ask(m, 1, &read_pdu(3, 0, 60)), registers_pdu(3, &expected[..60]), "FC 3 of 60 registers");
    rig.check_line();
}

/// The longest answer, FC 3 of 125 registers (255 bytes: 146 ms on the line at 19200 8E1),
/// from a slave that answers at once, is passed back whole: the example's response timeout
/// (200 ms) covers it (with 100 ms, which it had, the answer was cut short, retried, cut
/// short again and answered 0B).
#[test]
fn a_read_of_125_registers_is_answered_at_19200() {
    for build in BUILDS {
        a_read_of_125_registers_is_answered_at_19200_on(build);
    }
}

fn a_read_of_125_registers_is_answered_at_19200_on(build: Build) {
    let mut rig = Rig::boot(build);
    let m = rig.connect();
    let answer = rig.ask(m, 1, &read_pdu(3, 0, 125));
    rig.dump();
    rig.check_line();
    assert_eq!(answer, registers_pdu(3, &initial_registers(1)), "FC 3 of 125 registers");
    assert_eq!(rig.ask(m, 1, &read_pdu(3, 0, 1)), registers_pdu(3, &initial_registers(1)[..1]), "slave 1 after it");
}

// ---------------------------------------------------------------------------------------
// (g) the answer passed back at once

/// The line's outcome (a reply's end + T3.5) may come while the chip is being served for
/// another master's request (the poll that saw it, interrupts enabled): the answer still
/// goes back at once, not at the next poll 1.024 ms later. Master B's request lands at 48
/// times before master A's reply's end + T3.5, 23 µs apart, so that the poll serving it
/// meets the outcome at every phase.
#[test]
fn an_answer_is_passed_back_at_once_when_its_outcome_comes_while_the_chip_is_served() {
    for build in BUILDS {
        an_answer_is_passed_back_at_once_when_its_outcome_comes_while_the_chip_is_served_on(build);
    }
}

fn an_answer_is_passed_back_at_once_when_its_outcome_comes_while_the_chip_is_served_on(build: Build) {
    let mut rig = Rig::boot(build);
    let (a, b) = (rig.connect(), rig.connect());
    let mut late = Vec::new();
    for k in 0..48u64 {
        let now = rig.now();
        rig.ask_at(a, 1, &read_pdu(3, 0, 1), now);
        let replies = rig.log.iter().filter(|f| f.who != Who::Gateway).count();
        while rig.log.iter().filter(|f| f.who != Who::Gateway).count() == replies {
            assert!(rig.now() < now + ms(50), "no reply on the line");
            rig.run_for(rig.char_cycles / 2);
        }
        let outcome = rig.log.last().unwrap().end + rig.t35();
        rig.ask_at(b, 3, &read_pdu(3, 0, 1), outcome - us_to_cycles(23 * k));
        rig.settle(a, ms(50));
        rig.settle(b, ms(50));
        let sent = rig.masters[a].answers.last().unwrap().sent;
        late.push((k, cycles_to_us(sent - outcome)));
    }
    let worst = late.iter().map(|&(_, us)| us).fold(0.0, f64::max);
    eprintln!("reply's end + T3.5 -> SEND: at most {worst:.0} µs");
    let slow: Vec<_> = late.iter().filter(|&&(_, us)| us > 600.0).collect();
    assert!(slow.is_empty(), "(B's request 23 µs × k before the outcome, µs after it): {slow:?}");
    rig.check_line();
}

// ---------------------------------------------------------------------------------------
// (h) a lossy line, and what never reaches it

/// Slaves 1, 2 and 3 each lose one request in eight (noise on the line), while four masters
/// poll them for 4 simulated seconds: every request gets its answer (the retry's, when the
/// first try is lost), or 0B where the try and its retry were both lost; no slave is ever
/// taken to be down (no 0B without a try on the line for it), and at the end the gateway's
/// health registers show each slave up with its misses counted.
#[test]
fn a_line_that_loses_one_request_in_eight_takes_no_slave_down() {
    let mut rig = Rig::boot(BUILDS[0]);
    for (i, slave) in rig.slaves.iter_mut().enumerate() {
        slave.loses = Some((Rng(0x105E + i as u64), 8));
    }
    let masters: Vec<usize> = (0..4).map(|_| rig.connect()).collect();
    let mut rng = Rng(0x1055_11E5);
    let stop_at = rig.now() + ms(4000);
    let slice = rig.char_cycles / 2;
    while rig.now() < stop_at + ms(1000) {
        if rig.now() < stop_at {
            for &m in &masters {
                if rig.masters[m].outstanding.len() < 2 && rng.chance(20) {
                    let unit = rng.range(1, 3) as u8;
                    let at = rig.now() + rng.below(slice);
                    rig.ask_at(m, unit, &read_pdu(0x03, 2 * m as u16, 2), at);
                }
            }
        }
        rig.run_for(slice);
    }
    let lost = rig.requests().filter(|f| f.address() != 0).count() as u64;
    let (mut data, mut zero_b) = (0u64, 0u16);
    for master in &rig.masters {
        assert!(master.outstanding.is_empty(), "requests never answered: {:02X?}", master.outstanding);
        for a in &master.answers {
            if a.pdu == exception(3, NO_RESPONSE) {
                zero_b += 1;
                let tried = rig
                    .requests()
                    .filter(|f| f.address() == a.asked.unit && f.start >= a.asked.landed && f.end <= a.sent)
                    .count();
                assert!(tried > RETRIES, "0B after {tried} tries: the slave was taken to be down");
            } else {
                data += 1;
                let regs = initial_registers(a.asked.unit);
                let first = usize::from(word(&a.asked.pdu, 1));
                assert_eq!(a.pdu, registers_pdu(3, &regs[first..first + 2]), "{:02X?}", a.asked);
            }
        }
    }
    let m = masters[0];
    let mut misses = 0;
    for unit in 1..=3u16 {
        let health = status(&mut rig, m, 4, 1000 + 4 * unit, 4);
        assert_eq!(health[3], 0, "slave {unit} down: {health:?}");
        assert!(health[2] < DOWN_AFTER as u16, "slave {unit}: {health:?}");
        misses += health[1];
    }
    eprintln!(
        "a lossy line: {} requests on the line, {data} answers with data, {zero_b} 0B (try and retry lost), \
         the slaves' misses {misses}",
        lost
    );
    assert!(data >= 100, "only {data} answers");
    assert!(zero_b > 0, "no try and retry were both lost: the test tested no miss");
    assert_eq!(misses, zero_b, "misses counted");
    assert!(lost > data + u64::from(zero_b), "no request was lost: the test tested nothing");
    rig.check_line();
}

/// What a slave would refuse for its form never reaches the line: the gateway answers it as
/// the slave would (03, 02), and the next good request goes out as usual.
#[test]
fn a_malformed_request_is_answered_by_the_gateway_and_never_reaches_the_line() {
    let mut rig = Rig::boot(BUILDS[0]);
    let m = rig.connect();
    let before = rig.requests().count();
    // A read with two bytes of padding (what a buggy master sent), FC 16 whose byte count
    // disagrees with its quantity, FC 3 of 126 registers, FC 6 with a byte too many, FC 3
    // past 65535.
    let malformed: [(&[u8], u8); 5] = [
        (&[0x03, 0, 0, 0, 4, 0xAA, 0xBB], 0x03),
        (&[0x10, 0, 0, 0, 2, 3, 1, 2, 3], 0x03),
        (&[0x03, 0, 0, 0, 126], 0x03),
        (&[0x06, 0, 1, 0, 2, 0], 0x03),
        (&[0x03, 0xFF, 0xFF, 0, 2], 0x02),
    ];
    for (pdu, code) in malformed {
        assert_eq!(rig.ask(m, 1, pdu), exception(pdu[0], code), "{pdu:02X?}");
    }
    assert_eq!(rig.requests().count(), before, "a malformed request went on the line");
    assert_eq!(rig.ask(m, 1, &read_pdu(3, 0, 4)), registers_pdu(3, &initial_registers(1)[..4]));
    assert_eq!(status(&mut rig, m, 4, 7, 1), [5], "the malformed requests counted");
    assert_eq!(status(&mut rig, m, 4, 1000 + 4, 4), [1, 0, 0, 0], "slave 1: one answer, nothing against it");
    rig.check_line();
}
