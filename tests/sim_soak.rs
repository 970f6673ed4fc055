//! Soak: a long seeded mix of requests against the release `uno_slave` at 19200 8E1, each
//! reply compared byte for byte with a reference model of its bank written from the
//! Application Protocol v1.1b3 (§6.1–6.6, §6.11–6.12 and the exceptions of §7) and Serial
//! Line v1.02 §2.4.1 (broadcasts are executed, never answered).
//!
//! The model of the bank (see the table in `examples/uno_slave.rs`):
//! - coils 00001–00005 and holding registers 40001–40010 change only by the master's writes;
//! - discrete inputs 10001–10004 follow the switches on pins 6–9, which the test opens and
//!   closes between requests;
//! - input registers 30001–30003 follow the voltages the test sets on A0–A2;
//! - 30005 is 1 while 30001 > 40002;
//! - 30006–30012 are the slave's counters: on a clean bus they count exactly the requests
//!   sent before the current one (frames, exceptions, replies; no errors);
//! - 30004 (seconds since start-up) is only checked to be within a second of simulated time.
//!
//! The LEDs on pins 2–5 are checked against coils 00002–00005 after every transaction.
//!
//! `SOAK_TRANSACTIONS` sets the length (default 2000, about 28 s of simulated time), and
//! `SOAK_SEED` the seed (default fixed, so that a failure repeats). One line of summary is
//! printed; see it with `-- --nocapture`.

mod sim;

use std::time::Instant;

use sim::{with_crc, Line, Rng, Rtu, ID};
use uno_sim::F_CPU;

/// Transactions when `SOAK_TRANSACTIONS` is not set: small enough for `make test`.
const DEFAULT_TRANSACTIONS: u64 = 2000;
/// Seed when `SOAK_SEED` is not set.
const DEFAULT_SEED: u64 = 0x5eed_50a4;

/// Coils 00001–00005.
const COILS: usize = 5;
/// Discrete inputs 10001–10004 (switches on pins 6–9).
const INPUTS: usize = 4;
/// Input registers 30001–30012.
const INPUT_REGISTERS: usize = 12;
/// Holding registers 40001–40010.
const HOLDING: usize = 10;
/// Address of 30004 (seconds since start-up), checked loosely.
const SECONDS: usize = 3;
/// How far past a whole second 30004 may still show the previous one, in seconds.
const SECONDS_SLACK: f64 = 0.05;
/// First of the 7 counter registers (30006).
const FIRST_COUNTER: usize = 5;

/// Arduino pin of the switch for discrete input `i` (10001 + i).
const fn switch_pin(i: usize) -> u8 {
    6 + i as u8
}

/// Arduino pin of the LED for coil `i` (00001 + i), `i` in 1..5.
const fn led_pin(i: usize) -> u8 {
    1 + i as u8
}

fn env_u64(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(text) => {
            let text = text.trim();
            let parsed = match text.strip_prefix("0x") {
                Some(hex) => u64::from_str_radix(hex, 16),
                None => text.parse(),
            };
            parsed.unwrap_or_else(|_| panic!("{name}={text} is not a number"))
        }
        Err(_) => default,
    }
}

// ---------------------------------------------------------------------------------------
// The reference model

/// Exception codes, Application Protocol §7.
const ILLEGAL_FUNCTION: u8 = 0x01;
const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
const ILLEGAL_DATA_VALUE: u8 = 0x03;

/// The slave's bank and counters as the master should see them.
#[derive(Clone, Debug)]
struct Model {
    coils: [bool; COILS],
    /// Switch closed = 1.
    inputs: [bool; INPUTS],
    /// 30001–30003: A0–A2 as the ADC reads them.
    analog: [u16; 3],
    holding: [u16; HOLDING],
    /// 30006–30012: frames, CRC errors, parity/framing errors, overruns, malformed,
    /// exceptions, replies.
    counters: [u16; 7],
}

const FRAMES: usize = 0;
const EXCEPTIONS: usize = 5;
const REPLIES: usize = 6;

fn word(pdu: &[u8], at: usize) -> Option<u16> {
    pdu.get(at..at + 2).map(|b| u16::from_be_bytes([b[0], b[1]]))
}

/// `bits` packed LSB first, unused high bits zero.
fn pack(bits: &[bool]) -> Vec<u8> {
    let mut bytes = vec![0u8; bits.len().div_ceil(8)];
    for (i, &on) in bits.iter().enumerate() {
        if on {
            bytes[i / 8] |= 1 << (i % 8);
        }
    }
    bytes
}

/// `start` and `qty` within a table of `size` entries?
fn fits(start: u16, qty: u16, size: usize) -> bool {
    usize::from(start) + usize::from(qty) <= size
}

impl Model {
    /// `uno_slave` after reset: 40001 = 500, 40002 = 512, the rest zero; switches open.
    fn new() -> Model {
        let mut holding = [0; HOLDING];
        holding[0] = 500;
        holding[1] = 512;
        Model { coils: [false; COILS], inputs: [false; INPUTS], analog: [0; 3], holding, counters: [0; 7] }
    }

    /// 30001–30012, with 30004 as `seconds`.
    fn input_registers(&self, seconds: u16) -> [u16; INPUT_REGISTERS] {
        let mut regs = [0; INPUT_REGISTERS];
        regs[..3].copy_from_slice(&self.analog);
        regs[SECONDS] = seconds;
        regs[4] = u16::from(self.analog[0] > self.holding[1]);
        regs[FIRST_COUNTER..].copy_from_slice(&self.counters);
        regs
    }

    /// Runs request `pdu` against the model: the response PDU, or an exception code.
    /// The checks follow the spec's order: function (01), then quantity, byte count,
    /// value and length (03), then addresses (02). A failed request changes nothing.
    fn execute(&mut self, pdu: &[u8], seconds: u16) -> Result<Vec<u8>, u8> {
        let function = pdu[0];
        match function {
            0x01..=0x04 => {
                let (Some(start), Some(qty), 5) = (word(pdu, 1), word(pdu, 3), pdu.len()) else {
                    return Err(ILLEGAL_DATA_VALUE);
                };
                let max = if function <= 0x02 { 2000 } else { 125 };
                if qty == 0 || qty > max {
                    return Err(ILLEGAL_DATA_VALUE);
                }
                let (first, last) = (usize::from(start), usize::from(start) + usize::from(qty));
                let mut reply = vec![function];
                match function {
                    0x01 | 0x02 => {
                        let bits: &[bool] = if function == 0x01 { &self.coils } else { &self.inputs };
                        let data = pack(bits.get(first..last).ok_or(ILLEGAL_DATA_ADDRESS)?);
                        reply.push(data.len() as u8);
                        reply.extend(data);
                    }
                    _ => {
                        let inputs = self.input_registers(seconds);
                        let table: &[u16] = if function == 0x03 { &self.holding } else { &inputs };
                        let values = table.get(first..last).ok_or(ILLEGAL_DATA_ADDRESS)?;
                        reply.push(2 * values.len() as u8);
                        reply.extend(values.iter().flat_map(|v| v.to_be_bytes()));
                    }
                }
                Ok(reply)
            }
            0x05 | 0x06 => {
                let (Some(address), Some(value), 5) = (word(pdu, 1), word(pdu, 3), pdu.len()) else {
                    return Err(ILLEGAL_DATA_VALUE);
                };
                if function == 0x05 {
                    if value != 0x0000 && value != 0xFF00 {
                        return Err(ILLEGAL_DATA_VALUE);
                    }
                    *self.coils.get_mut(usize::from(address)).ok_or(ILLEGAL_DATA_ADDRESS)? = value == 0xFF00;
                } else {
                    *self.holding.get_mut(usize::from(address)).ok_or(ILLEGAL_DATA_ADDRESS)? = value;
                }
                Ok(pdu.to_vec())
            }
            0x0F | 0x10 => {
                let (Some(start), Some(qty), Some(&count)) = (word(pdu, 1), word(pdu, 3), pdu.get(5)) else {
                    return Err(ILLEGAL_DATA_VALUE);
                };
                let (max, bytes) =
                    if function == 0x0F { (1968, usize::from(qty).div_ceil(8)) } else { (123, 2 * usize::from(qty)) };
                if qty == 0 || qty > max || usize::from(count) != bytes || pdu.len() != 6 + bytes {
                    return Err(ILLEGAL_DATA_VALUE);
                }
                let size = if function == 0x0F { COILS } else { HOLDING };
                if !fits(start, qty, size) {
                    return Err(ILLEGAL_DATA_ADDRESS);
                }
                let data = &pdu[6..];
                for i in 0..usize::from(qty) {
                    let at = usize::from(start) + i;
                    if function == 0x0F {
                        self.coils[at] = data[i / 8] & (1 << (i % 8)) != 0;
                    } else {
                        self.holding[at] = u16::from_be_bytes([data[2 * i], data[2 * i + 1]]);
                    }
                }
                Ok(pdu[..5].to_vec())
            }
            _ => Err(ILLEGAL_FUNCTION),
        }
    }

    /// The reply frame to unicast request `pdu` (the model's bank changes as the slave's
    /// should), and the counters move on.
    fn unicast(&mut self, pdu: &[u8], seconds: u16) -> Vec<u8> {
        let mut reply = vec![ID];
        match self.execute(pdu, seconds) {
            Ok(body) => reply.extend(body),
            Err(code) => {
                reply.extend([pdu[0] | 0x80, code]);
                self.counters[EXCEPTIONS] = self.counters[EXCEPTIONS].wrapping_add(1);
            }
        }
        self.counters[FRAMES] = self.counters[FRAMES].wrapping_add(1);
        self.counters[REPLIES] = self.counters[REPLIES].wrapping_add(1);
        with_crc(&reply)
    }

    /// Broadcast write `pdu`: executed, not answered; an exception is still counted.
    fn broadcast(&mut self, pdu: &[u8]) {
        if self.execute(pdu, 0).is_err() {
            self.counters[EXCEPTIONS] = self.counters[EXCEPTIONS].wrapping_add(1);
        }
        self.counters[FRAMES] = self.counters[FRAMES].wrapping_add(1);
    }
}

// ---------------------------------------------------------------------------------------
// Requests

/// What a generated request is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A request the slave should carry out.
    Valid,
    /// A request built to draw an exception.
    Exception,
    /// A broadcast write (valid or not).
    Broadcast,
}

/// Function codes no build of the firmware supports (optional ones like 7, 8, 11, 17,
/// 22, 23 left out).
const UNSUPPORTED: [u8; 10] = [0x09, 0x0A, 0x0C, 0x0D, 0x12, 0x13, 0x14, 0x18, 0x41, 0x64];

/// A start and quantity inside a table of `size`.
fn span(rng: &mut Rng, size: usize) -> (u16, u16) {
    let start = rng.below(size as u64);
    let qty = rng.range(1, size as u64 - start);
    (start as u16, qty as u16)
}

/// A start and quantity that leave a table of `size` by at least one entry.
fn span_outside(rng: &mut Rng, size: usize) -> (u16, u16) {
    match rng.below(3) {
        0 => (rng.range(size as u64, 0xFFFF) as u16, 1),
        1 => {
            let start = rng.below(size as u64);
            (start as u16, (size as u64 - start + rng.range(1, 4)) as u16)
        }
        _ => (rng.range(size as u64, 0xFFF0) as u16, rng.range(1, 16) as u16),
    }
}

fn read_pdu(function: u8, start: u16, qty: u16) -> Vec<u8> {
    let mut pdu = vec![function];
    pdu.extend(start.to_be_bytes());
    pdu.extend(qty.to_be_bytes());
    pdu
}

/// FC 0F: `coils` written from `start`, unused bits of the last byte zero.
fn write_coils_pdu(start: u16, coils: &[bool]) -> Vec<u8> {
    let data = pack(coils);
    let mut pdu = read_pdu(0x0F, start, coils.len() as u16);
    pdu.push(data.len() as u8);
    pdu.extend(data);
    pdu
}

/// FC 10: `values` written from `start`.
fn write_registers_pdu(start: u16, values: &[u16]) -> Vec<u8> {
    let mut pdu = read_pdu(0x10, start, values.len() as u16);
    pdu.push(2 * values.len() as u8);
    pdu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    pdu
}

/// A register value: half of them 0–1023, so that 30005 (A0 > 40002) flips now and then.
fn register_value(rng: &mut Rng) -> u16 {
    if rng.chance(50) {
        rng.below(1024) as u16
    } else {
        rng.u16()
    }
}

/// A write that the slave carries out (FC 05, 06, 0F, 10).
fn valid_write(rng: &mut Rng) -> Vec<u8> {
    match rng.below(4) {
        0 => read_pdu(0x05, rng.below(COILS as u64) as u16, rng.pick(&[0x0000, 0xFF00])),
        1 => read_pdu(0x06, rng.below(HOLDING as u64) as u16, register_value(rng)),
        2 => {
            let (start, qty) = span(rng, COILS);
            let coils: Vec<bool> = (0..qty).map(|_| rng.chance(50)).collect();
            write_coils_pdu(start, &coils)
        }
        _ => {
            let (start, qty) = span(rng, HOLDING);
            let values: Vec<u16> = (0..qty).map(|_| register_value(rng)).collect();
            write_registers_pdu(start, &values)
        }
    }
}

/// A request the slave carries out: a read (FC 01–04) or a write.
fn valid_request(rng: &mut Rng) -> Vec<u8> {
    match rng.below(8) {
        0 => {
            let (start, qty) = span(rng, COILS);
            read_pdu(0x01, start, qty)
        }
        1 => {
            let (start, qty) = span(rng, INPUTS);
            read_pdu(0x02, start, qty)
        }
        2 | 3 => {
            let (start, qty) = span(rng, HOLDING);
            read_pdu(0x03, start, qty)
        }
        4 | 5 => {
            let (start, qty) = span(rng, INPUT_REGISTERS);
            read_pdu(0x04, start, qty)
        }
        _ => valid_write(rng),
    }
}

/// A request that draws exception 01, 02 or 03.
fn exception_request(rng: &mut Rng) -> Vec<u8> {
    let sizes = [COILS, INPUTS, HOLDING, INPUT_REGISTERS];
    match rng.below(10) {
        // 01: unsupported function, with a read-like body.
        0 => read_pdu(rng.pick(&UNSUPPORTED), 0, 1),
        // 02: a read outside its table.
        1 | 2 => {
            let function = rng.range(1, 4) as u8;
            let (start, qty) = span_outside(rng, sizes[usize::from(function) - 1]);
            read_pdu(function, start, qty)
        }
        // 03: a read quantity of 0 or above the limit.
        3 => {
            let function = rng.range(1, 4) as u8;
            let qty = match (rng.chance(50), function <= 0x02) {
                (true, _) => 0,
                (false, true) => rng.range(2001, 0xFFFF) as u16,
                (false, false) => rng.range(126, 0xFFFF) as u16,
            };
            read_pdu(function, 0, qty)
        }
        // 02: single writes to a missing coil or register.
        4 => read_pdu(0x05, rng.range(COILS as u64, 0xFFFF) as u16, 0xFF00),
        5 => read_pdu(0x06, rng.range(HOLDING as u64, 0xFFFF) as u16, rng.u16()),
        // 03: FC 05 with a value other than 0000 or FF00.
        6 => read_pdu(0x05, rng.below(COILS as u64) as u16, rng.range(1, 0xFEFF) as u16),
        // 02: multiple writes running past the end of their table.
        7 => {
            let (start, qty) = span_outside(rng, HOLDING);
            let qty = qty.min(20);
            write_registers_pdu(start, &vec![0xBAD0; usize::from(qty)])
        }
        8 => {
            let (start, qty) = span_outside(rng, COILS);
            write_coils_pdu(start, &vec![true; usize::from(qty.min(20))])
        }
        // 03: FC 10 whose byte count is not twice the quantity (the frame length agrees
        // with the byte count), or FC 0F whose byte count is not ceil(qty / 8).
        _ => {
            let (start, qty) = span(rng, HOLDING);
            let mut pdu = write_registers_pdu(start, &vec![0xBAD1; usize::from(qty)]);
            if rng.chance(50) {
                pdu[3..5].copy_from_slice(&(qty + 1).to_be_bytes());
            } else {
                pdu[0] = 0x0F;
            }
            pdu
        }
    }
}

/// A request that would draw an exception, except reads (a broadcast read is ignored).
fn broadcast_exception_request(rng: &mut Rng) -> Vec<u8> {
    loop {
        let pdu = exception_request(rng);
        if !(0x01..=0x04).contains(&pdu[0]) {
            return pdu;
        }
    }
}

// ---------------------------------------------------------------------------------------
// The run

struct Soak {
    rtu: Rtu,
    model: Model,
    rng: Rng,
    transactions: u64,
    exceptions: u64,
    broadcasts: u64,
    missed: u64,
    wrong: u64,
    leds_wrong: u64,
}

impl Soak {
    /// Opens or closes a switch, or turns a potentiometer, now and then.
    fn move_inputs(&mut self) {
        if self.rng.chance(10) {
            let i = self.rng.below(INPUTS as u64) as usize;
            let closed = !self.model.inputs[i];
            // A closed switch pulls its pin to GND; an open one leaves it to the pull-up.
            self.rtu.uno.drive_pin(switch_pin(i), if closed { Some(false) } else { None }).unwrap();
            self.model.inputs[i] = closed;
        }
        if self.rng.chance(10) {
            let channel = self.rng.below(3) as u8;
            let mv = self.rng.range(0, 5000) as u32;
            self.rtu.uno.set_analog_mv(channel, mv).unwrap();
            // The harness's ADC: mv * 1023 / 5000 with the 5 V reference.
            self.model.analog[usize::from(channel)] = (mv * 1023 / 5000).min(1023) as u16;
        }
    }

    /// Seconds since start-up at `cycle`, as 30004 should show it (from Timer1 counting
    /// 1024-cycle ticks since just after reset).
    fn seconds_at(cycle: u64) -> u16 {
        (cycle / F_CPU) as u16
    }

    /// Copies 30004 from `actual` into `expected` if it is the whole seconds elapsed at
    /// `cycle`, or one less.
    fn accept_seconds(pdu: &[u8], expected: &mut [u8], actual: &[u8], cycle: u64) {
        let (Some(start), Some(qty)) = (word(pdu, 1), word(pdu, 3)) else { return };
        if pdu[0] != 0x04 || !(start..start.saturating_add(qty)).contains(&(SECONDS as u16)) {
            return;
        }
        let at = 3 + 2 * (SECONDS - usize::from(start));
        let Some(seconds) = word(actual, at) else { return };
        // Timer1 starts a moment after reset and the main loop copies the count once per
        // pass, so 30004 may lag simulated time by a second and a little.
        let lag = cycle as f64 / F_CPU as f64 - f64::from(seconds);
        if (0.0..1.0 + SECONDS_SLACK).contains(&lag) && expected.len() == actual.len() {
            expected[at..at + 2].copy_from_slice(&seconds.to_be_bytes());
            let crc = sim::crc16(&expected[..expected.len() - 2]);
            let n = expected.len();
            expected[n - 2..].copy_from_slice(&crc.to_le_bytes());
        }
    }

    fn report(&mut self, what: &str, request: &[u8], expected: &[u8], actual: &[u8]) {
        if self.missed + self.wrong <= 10 {
            eprintln!(
                "transaction {}: {what}\n  request  {request:02X?}\n  expected {expected:02X?}\n  got      {actual:02X?}",
                self.transactions
            );
        }
    }

    fn transaction(&mut self) {
        self.move_inputs();
        let kind = match self.rng.below(100) {
            0..=79 => Kind::Valid,
            80..=91 => Kind::Exception,
            _ => Kind::Broadcast,
        };
        let pdu = match kind {
            Kind::Valid => valid_request(&mut self.rng),
            Kind::Exception => exception_request(&mut self.rng),
            Kind::Broadcast if self.rng.chance(80) => valid_write(&mut self.rng),
            Kind::Broadcast => broadcast_exception_request(&mut self.rng),
        };
        let address = if kind == Kind::Broadcast { 0 } else { ID };
        let mut request = vec![address];
        request.extend(&pdu);
        let request = with_crc(&request);

        let exchange = self.rtu.exchange(&request);
        let actual = exchange.bytes();
        self.transactions += 1;
        let exceptions_before = self.model.counters[EXCEPTIONS];
        if kind == Kind::Broadcast {
            self.broadcasts += 1;
            self.model.broadcast(&pdu);
            if !actual.is_empty() {
                self.wrong += 1;
                self.report("a broadcast was answered", &request, &[], &actual);
            }
        } else {
            let cycle = exchange.reply.first().map_or(exchange.request_end, |t| t.start_cycle);
            let mut expected = self.model.unicast(&pdu, Self::seconds_at(cycle));
            Self::accept_seconds(&pdu, &mut expected, &actual, cycle);
            if actual.is_empty() {
                self.missed += 1;
                self.report("no reply", &request, &expected, &actual);
            } else if actual != expected {
                self.wrong += 1;
                self.report("wrong reply", &request, &expected, &actual);
            }
        }
        if self.model.counters[EXCEPTIONS] != exceptions_before {
            self.exceptions += 1;
        }
        self.check_leds();
    }

    /// The LEDs on pins 2–5 show coils 00002–00005 (the main loop copies them).
    fn check_leds(&mut self) {
        for coil in 1..COILS {
            let lit = self.rtu.uno.pin(led_pin(coil)).unwrap().level;
            if lit != self.model.coils[coil] {
                self.leds_wrong += 1;
                if self.leds_wrong <= 10 {
                    eprintln!(
                        "transaction {}: LED on pin {} is {lit}, coil {} is {}",
                        self.transactions,
                        led_pin(coil),
                        coil + 1,
                        self.model.coils[coil]
                    );
                }
            }
        }
    }
}

#[test]
fn soak_mixed_requests_are_all_answered_as_the_model_says() {
    let transactions = env_u64("SOAK_TRANSACTIONS", DEFAULT_TRANSACTIONS);
    let seed = env_u64("SOAK_SEED", DEFAULT_SEED);
    let mut soak = Soak {
        rtu: Rtu::boot("uno_slave", Line::B19200_8E1),
        model: Model::new(),
        rng: Rng(seed),
        transactions: 0,
        exceptions: 0,
        broadcasts: 0,
        missed: 0,
        wrong: 0,
        leds_wrong: 0,
    };
    let (start_cycle, wall) = (soak.rtu.uno.now(), Instant::now());
    while soak.transactions < transactions {
        soak.transaction();
        if soak.transactions.is_multiple_of(10_000) {
            let simulated = (soak.rtu.uno.now() - start_cycle) as f64 / F_CPU as f64;
            eprintln!(
                "soak: {} transactions, {} missed, {} wrong, {simulated:.1} s simulated, {:.1} s wall",
                soak.transactions,
                soak.missed,
                soak.wrong,
                wall.elapsed().as_secs_f64()
            );
        }
    }
    let simulated = (soak.rtu.uno.now() - start_cycle) as f64 / F_CPU as f64;
    println!(
        "soak: {} transactions ({} exceptions, {} broadcasts), {} missed, {} wrong, {} LED mismatches, \
         {simulated:.1} s simulated, {:.1} s wall, seed {seed:#x}",
        soak.transactions,
        soak.exceptions,
        soak.broadcasts,
        soak.missed,
        soak.wrong,
        soak.leds_wrong,
        wall.elapsed().as_secs_f64()
    );
    assert_eq!((soak.missed, soak.wrong), (0, 0), "missed and wrong replies in {transactions} transactions");
    assert_eq!(soak.leds_wrong, 0, "LEDs that did not follow their coils");
}
