//! `examples/gateway.rs` on a simulated Mega 2560: a Modbus slave (id 1) toward the SCADA on
//! USART0 and a Modbus master on USART1 polling field device 1 (FC 3 of holding registers
//! 0–9 every 100 ms, FC 15 of coils 0–7 when the SCADA changes coils 00001–00008), both
//! lines 19200 8E1, both timed as real wires (`uno_sim::Options::second_usart`).
//!
//! The test plays both peers on simulated time: the field device on USART1 (it answers each
//! request T3.5 + 0.5 ms after its end, or keeps silent) and the SCADA on USART0 (requests
//! scheduled character by character, the gateway's replies collected with the cycle times
//! of their characters). Every frame on either line is logged; at the end of each test the
//! log is checked: every frame the gateway sent is one frame (no gap over T1.5 inside), its
//! master's requests are all FC 3 or FC 15 to device 1 and each starts T3.5 or more after
//! anything else on the field line, and its slave's replies start T3.5 after the SCADA's
//! request and within [`TURNAROUND_SLACK_US`] of that.
//!
//! Build: `.ci/chip-build atmega2560 "" atmega2560-gateway examples,master gateway`.
//! One character at 19200 8E1 is 11 bits = 572 µs; T1.5 = 859 µs, T3.5 = 2005 µs.

mod sim;

use sim::{chip_variant_firmware, cycles_to_us, read_request, registers_reply, us_to_cycles, with_crc, Line};
use uno_sim::{Chip, Options, Parity, TxByte, Uno};

/// The SCADA side's USART (Serial, the USB port).
const SCADA: u8 = 0;
/// The field line's USART (Serial1).
const FIELD: u8 = 1;
/// The gateway's id toward the SCADA.
const GATEWAY_ID: u8 = 1;
/// The field device the gateway polls.
const DEVICE_ID: u8 = 1;
/// How far past T3.5 after a request's end the gateway's slave may start its reply.
const TURNAROUND_SLACK_US: u64 = 100;
/// The field device answers this long after T3.5 following a request's end.
const DEVICE_DELAY_US: u64 = 500;
/// The gateway's poll period.
const POLL_MS: u64 = 100;
/// The master's response timeout (`Timeouts::DEFAULT`: the gateway keeps it).
const RESPONSE_TIMEOUT_MS: u64 = 1000;

fn ms(n: u64) -> u64 {
    us_to_cycles(1000 * n)
}

fn fmt_ms(cycles: u64) -> String {
    format!("{:.3} ms", cycles_to_us(cycles) / 1000.0)
}

// ---------------------------------------------------------------------------------------
// Frames

/// Who put a frame on a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Who {
    /// The firmware (its master on the field line, its slave on the SCADA side).
    Gateway,
    /// The test as the field device.
    Device,
    /// The test as the SCADA.
    Scada,
}

/// A frame on one line with its times.
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
    fn from_chars(who: Who, chars: &[TxByte]) -> Frame {
        Frame {
            who,
            bytes: chars.iter().map(|c| c.byte).collect(),
            start: chars[0].start_cycle,
            end: chars[chars.len() - 1].end_cycle,
            max_gap: chars.windows(2).map(|w| w[1].start_cycle - w[0].end_cycle).max().unwrap_or(0),
        }
    }
}

/// An FC 15 request (or, with `values` empty, its reply) for coils `address`.. to `id`.
fn write_coils_request(id: u8, address: u16, quantity: u16, bits: &[u8]) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [q_hi, q_lo] = quantity.to_be_bytes();
    let mut frame = vec![id, 0x0F, a_hi, a_lo, q_hi, q_lo];
    if !bits.is_empty() {
        frame.push(bits.len() as u8);
        frame.extend_from_slice(bits);
    }
    with_crc(&frame)
}

/// An FC 01 reply carrying `bits`.
fn coils_reply(id: u8, bits: &[u8]) -> Vec<u8> {
    let mut frame = vec![id, 0x01, bits.len() as u8];
    frame.extend_from_slice(bits);
    with_crc(&frame)
}

/// The registers of an FC 03/04 reply from `id` (None: not one, or a bad CRC).
fn decode_registers(id: u8, function: u8, frame: &[u8]) -> Option<Vec<u16>> {
    let n = usize::from(*frame.get(2)?);
    if frame.len() != 5 + n || frame[..2] != [id, function] || with_crc(&frame[..3 + n]) != frame {
        return None;
    }
    Some(frame[3..3 + n].chunks(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect())
}

// ---------------------------------------------------------------------------------------
// The field device

/// How the test's field device behaves and what it saw.
struct Device {
    /// Its holding registers 0–9, as it answers FC 3.
    registers: [u16; 10],
    /// Its coils 0–7, as the last FC 15 set them.
    coils: u8,
    /// Whether it answers at all.
    silent: bool,
    /// Answers it has put on the line.
    answers: u32,
    /// Every request it got (the master's frames), in order.
    requests: Vec<Frame>,
}

impl Device {
    /// The answer to `request`, which must be an FC 3 of registers 0–9 or an FC 15 of coils
    /// 0–7 to device 1, byte for byte.
    fn answer(&mut self, request: &[u8]) -> Vec<u8> {
        if request == read_request(DEVICE_ID, 0x03, 0, 10) {
            return registers_reply(DEVICE_ID, 0x03, &self.registers);
        }
        assert!(
            request.len() == 10 && request == write_coils_request(DEVICE_ID, 0, 8, &request[7..8]),
            "the gateway's master sent {request:02X?}: neither FC 3 of registers 0–9 nor FC 15 of coils 0–7"
        );
        self.coils = request[7];
        write_coils_request(DEVICE_ID, 0, 8, &[])
    }
}

// ---------------------------------------------------------------------------------------
// The gateway between its two lines

/// The simulated gateway, the field device, and every frame on either line so far.
struct Gateway {
    uno: Uno,
    line: Line,
    /// One character on either line, in cycles.
    char_cycles: u64,
    device: Device,
    /// Frames on the field line (USART1), in order of their end.
    field: Vec<Frame>,
    /// Frames on the SCADA side (USART0), in order of their end.
    scada: Vec<Frame>,
    /// Characters the gateway is sending on each line (not yet a whole frame).
    field_chars: Vec<TxByte>,
    scada_chars: Vec<TxByte>,
    /// End of the last character the test put on each line.
    device_busy_until: u64,
    scada_busy_until: u64,
}

impl Gateway {
    /// Boots the gateway with a field device holding `registers`, answering if `!silent`.
    fn boot(registers: [u16; 10], silent: bool) -> Gateway {
        let elf = chip_variant_firmware(Chip::Atmega2560, 0, "-gateway", "gateway");
        let uno = Uno::load_with(&elf, Options::new().usart(SCADA).second_usart(FIELD)).expect("firmware loads");
        assert_eq!(uno.chip(), Chip::Atmega2560);
        assert_eq!((uno.usart(), uno.second_usart()), (SCADA, Some(FIELD)));
        let mut uno = uno;
        // Both wires' bytes come from take_tx / take_tx_on; USART2 is no wire.
        assert!(matches!(uno.take_usart_output(FIELD), Err(uno_sim::Error::WireUsart(FIELD))));
        assert!(matches!(uno.take_usart_output(SCADA), Err(uno_sim::Error::WireUsart(SCADA))));
        assert_eq!(uno.take_usart_output(2).unwrap(), b"");
        assert!(uno.send_byte_on(2, 0, ms(1)).is_err() && uno.take_tx_on(2).is_err());
        let line = Line::B19200_8E1;
        let mut gw = Gateway {
            uno,
            line,
            char_cycles: 0,
            device: Device { registers, coils: 0, silent, answers: 0, requests: Vec::new() },
            field: Vec::new(),
            scada: Vec::new(),
            field_chars: Vec::new(),
            scada_chars: Vec::new(),
            device_busy_until: 0,
            scada_busy_until: 0,
        };
        gw.uno.run_until(ms(5)).expect("firmware runs");
        for usart in [SCADA, FIELD] {
            let cfg = gw.uno.serial_config_on(usart).unwrap_or_else(|| panic!("USART{usart} enabled"));
            assert!(cfg.matches(19_200, 8, Parity::Even, 1), "USART{usart}: {cfg:?}");
        }
        gw.char_cycles = gw.uno.wire_char_cycles_on(FIELD).unwrap();
        assert_eq!(gw.uno.wire_char_cycles_on(SCADA), Some(gw.char_cycles));
        // The SCADA starts talking T3.5 after the gateway is up.
        gw.scada_busy_until = gw.uno.now();
        gw
    }

    fn t35(&self) -> u64 {
        self.line.t35()
    }

    fn t15(&self) -> u64 {
        self.line.t15()
    }

    /// Takes what the gateway sent on both lines; a frame is over after two characters of
    /// idle line. The field device answers each request as soon as it is over.
    fn collect(&mut self) {
        let idle = 2 * self.char_cycles;
        let now = self.uno.now();
        self.field_chars.extend(self.uno.take_tx_on(FIELD).unwrap());
        self.scada_chars.extend(self.uno.take_tx_on(SCADA).unwrap());
        if let Some(last) = self.field_chars.last() {
            let busy = self.uno.tx_busy_until_on(FIELD).unwrap().unwrap_or(0).max(last.end_cycle);
            if now >= busy + idle {
                let frame = Frame::from_chars(Who::Gateway, &std::mem::take(&mut self.field_chars));
                self.field.push(frame.clone());
                self.device.requests.push(frame.clone());
                let reply = self.device.answer(&frame.bytes);
                if !self.device.silent {
                    let start = frame.end + self.t35() + us_to_cycles(DEVICE_DELAY_US);
                    let end =
                        self.uno.send_frame_on(FIELD, &reply, start + self.char_cycles, 0).expect("reply scheduled");
                    self.device_busy_until = end;
                    self.device.answers += 1;
                    self.field.push(Frame { who: Who::Device, bytes: reply, start, end, max_gap: 0 });
                }
            }
        }
        if let Some(last) = self.scada_chars.last() {
            let busy = self.uno.tx_busy_until_on(SCADA).unwrap().unwrap_or(0).max(last.end_cycle);
            if now >= busy + idle {
                let frame = Frame::from_chars(Who::Gateway, &std::mem::take(&mut self.scada_chars));
                self.scada.push(frame);
            }
        }
    }

    /// Runs until `cycle`, half a character at a time, collecting both lines.
    fn run_until(&mut self, cycle: u64) {
        while self.uno.now() < cycle {
            let slice = (self.uno.now() + self.char_cycles / 2).min(cycle);
            self.uno.run_until(slice).expect("firmware runs");
            self.collect();
        }
    }

    /// Runs until `done` holds (checked every half character) or `deadline`; returns whether
    /// it held.
    fn run_until_or(&mut self, deadline: u64, mut done: impl FnMut(&Gateway) -> bool) -> bool {
        loop {
            if done(self) {
                return true;
            }
            if self.uno.now() >= deadline {
                return false;
            }
            let slice = (self.uno.now() + self.char_cycles / 2).min(deadline);
            self.uno.run_until(slice).expect("firmware runs");
            self.collect();
        }
    }

    /// Runs until the field device has got `n` requests in all (panics after `within`).
    fn until_requests(&mut self, n: usize, within: u64) {
        let deadline = self.uno.now() + within;
        let ok = self.run_until_or(deadline, |gw| gw.device.requests.len() >= n);
        assert!(ok, "the field device got {} requests, not {n}, by {}", self.device.requests.len(), fmt_ms(deadline));
    }

    /// Runs until the field device has got its next request and returns it.
    fn next_request(&mut self, within: u64) -> Frame {
        let n = self.device.requests.len() + 1;
        self.until_requests(n, within);
        self.device.requests[n - 1].clone()
    }

    /// The earliest start of a SCADA request: T3.5 after the last frame on the SCADA side.
    fn scada_free_at(&self) -> u64 {
        let last = self.scada.iter().map(|f| f.end).chain([self.scada_busy_until]).max().unwrap_or(0);
        (last + self.t35() + us_to_cycles(10)).max(self.uno.now())
    }

    /// The SCADA sends `request` with its first start bit at `start` (not before
    /// [`Gateway::scada_free_at`]), and collects the gateway's reply. Returns the request's
    /// end and the reply.
    fn scada_at(&mut self, start: u64, request: &[u8]) -> (u64, Frame) {
        let start = start.max(self.scada_free_at());
        let end = self.uno.send_frame_on(SCADA, request, start + self.char_cycles, 0).expect("request scheduled");
        self.scada_busy_until = end;
        self.scada.push(Frame { who: Who::Scada, bytes: request.to_vec(), start, end, max_gap: 0 });
        let n = self.scada.len();
        let deadline = end + self.t35() + 40 * self.char_cycles;
        let answered = self.run_until_or(deadline, |gw| gw.scada.len() > n);
        assert!(answered, "the gateway did not answer {request:02X?} (ending at {})", fmt_ms(end));
        let reply = self.scada[n].clone();
        assert_eq!(reply.who, Who::Gateway);
        (end, reply)
    }

    /// The SCADA sends `request` as soon as the line allows; returns the reply's bytes.
    fn scada(&mut self, request: &[u8]) -> Vec<u8> {
        let (_, reply) = self.scada_at(0, request);
        reply.bytes
    }

    /// 40001–40010 as the SCADA reads them.
    fn holding(&mut self) -> Vec<u16> {
        let reply = self.scada(&read_request(GATEWAY_ID, 0x03, 0, 10));
        decode_registers(GATEWAY_ID, 0x03, &reply).unwrap_or_else(|| panic!("FC 3 reply {reply:02X?}"))
    }

    /// 30001–30003 as the SCADA reads them: answers, failures, last failure.
    fn counters(&mut self) -> [u16; 3] {
        let reply = self.scada(&read_request(GATEWAY_ID, 0x04, 0, 3));
        let r = decode_registers(GATEWAY_ID, 0x04, &reply).unwrap_or_else(|| panic!("FC 4 reply {reply:02X?}"));
        [r[0], r[1], r[2]]
    }

    /// Checks every frame logged on both lines (see the crate docs); returns the
    /// turnarounds of the gateway's replies past T3.5 and the shortest silence before a
    /// request of its master (cycles).
    fn check_lines(&self) -> (Vec<u64>, u64) {
        let mut shortest = u64::MAX;
        let (t15, t35) = (self.t15(), self.t35());
        // The field line: the master's frames whole, each T3.5 after anything before it.
        for (i, frame) in self.field.iter().enumerate() {
            if frame.who != Who::Gateway {
                continue;
            }
            assert!(
                frame.max_gap <= t15,
                "a gap of {} inside the master's {:02X?}",
                fmt_ms(frame.max_gap),
                frame.bytes
            );
            let before = self
                .field
                .iter()
                .enumerate()
                .filter(|&(j, f)| j != i && f.start < frame.start)
                .map(|(_, f)| f.end)
                .max();
            if let Some(before) = before {
                assert!(
                    frame.start >= before + t35,
                    "the master's {:02X?} at {} started {} after the last frame on the field line (T3.5 = {})",
                    frame.bytes,
                    fmt_ms(frame.start),
                    fmt_ms(frame.start.saturating_sub(before)),
                    fmt_ms(t35)
                );
                shortest = shortest.min(frame.start - before);
            }
        }
        // The SCADA side: every gateway frame is the reply to the request just before it.
        let mut pasts = Vec::new();
        for pair in self.scada.windows(2) {
            let (request, reply) = (&pair[0], &pair[1]);
            if reply.who != Who::Gateway {
                continue;
            }
            assert_eq!(request.who, Who::Scada, "the gateway sent {:02X?} unasked", reply.bytes);
            assert!(reply.max_gap <= t15, "a gap of {} inside the reply {:02X?}", fmt_ms(reply.max_gap), reply.bytes);
            assert!(
                reply.start >= request.end + t35,
                "the reply to {:02X?} started {} after the request's end (T3.5 = {})",
                request.bytes,
                fmt_ms(reply.start.saturating_sub(request.end)),
                fmt_ms(t35)
            );
            let past = reply.start - request.end - t35;
            assert!(
                past <= us_to_cycles(TURNAROUND_SLACK_US),
                "the reply to {:02X?} started T3.5 + {:.1} µs after the request's end",
                request.bytes,
                cycles_to_us(past)
            );
            pasts.push(past);
        }
        (pasts, shortest)
    }

    /// Prints the field line's log.
    fn dump_field(&self) {
        let mut all: Vec<(&str, &Frame)> = self.field.iter().map(|f| ("field", f)).collect();
        all.extend(self.scada.iter().map(|f| ("scada", f)));
        all.sort_by_key(|(_, f)| f.start);
        for (line, f) in all {
            eprintln!("  {line} {:>12} .. {:>12} {:?} {:02X?}", fmt_ms(f.start), fmt_ms(f.end), f.who, f.bytes);
        }
    }

    /// [`Gateway::check_lines`] and a summary line.
    fn check_and_report(&self, what: &str) {
        if std::env::var_os("GATEWAY_DUMP").is_some() {
            self.dump_field();
        }
        let (pasts, shortest) = self.check_lines();
        let field_requests = self.field.iter().filter(|f| f.who == Who::Gateway).count();
        let (min, max) = (pasts.iter().min().copied().unwrap_or(0), pasts.iter().max().copied().unwrap_or(0));
        eprintln!(
            "{what}: {} SCADA replies at T3.5 + {:.1}..{:.1} µs after the request's end; {field_requests} requests \
             on the field line ({} answered), the shortest silence before one {}; simulated {}",
            pasts.len(),
            cycles_to_us(min),
            cycles_to_us(max),
            self.device.answers,
            if shortest == u64::MAX { "-".into() } else { fmt_ms(shortest) },
            fmt_ms(self.uno.now())
        );
    }
}

/// Register values for poll `round`.
fn values(round: u16) -> [u16; 10] {
    std::array::from_fn(|i| 0x1000 * (round + 1) + 0x0101 * i as u16 + round)
}

// ---------------------------------------------------------------------------------------
// Tests

/// The gateway's first request writes the coils it holds (all off); then it polls the
/// device's registers every 100 ms and the SCADA reads them at 40001–40010; 30001 counts
/// the answers.
#[test]
fn the_field_devices_registers_are_mirrored_at_40001_and_30001_counts_the_answers() {
    let mut gw = Gateway::boot(values(0), false);
    let first = gw.next_request(ms(50));
    assert_eq!(first.bytes, write_coils_request(DEVICE_ID, 0, 8, &[0]), "first request: the coils, all off");
    let mut poll_starts = Vec::new();
    for round in 0..5u16 {
        gw.device.registers = values(round);
        let poll = gw.next_request(ms(POLL_MS + 50));
        assert_eq!(poll.bytes, read_request(DEVICE_ID, 0x03, 0, 10), "round {round}");
        poll_starts.push(poll.start);
        // The answer is on the line T3.5 + 0.5 ms after the request; give the loop 10 ms.
        let answered = gw.field.last().unwrap().end;
        gw.run_until(answered + ms(10));
        assert_eq!(gw.holding(), values(round), "40001–40010 after poll {round}");
        let [answers, failures, last] = gw.counters();
        assert_eq!(u32::from(answers), gw.device.answers, "30001 after poll {round}");
        assert_eq!((failures, last), (0, 0), "30002, 30003 after poll {round}");
    }
    let periods: Vec<String> = poll_starts.windows(2).map(|w| fmt_ms(w[1] - w[0])).collect();
    eprintln!("FC 3 polls every {}", periods.join(", "));
    for w in poll_starts.windows(2) {
        let period = w[1] - w[0];
        // millis() ticks every 1.024 ms: a period is 100 ms give or take a tick.
        assert!(period >= ms(POLL_MS - 2) && period <= ms(POLL_MS + 5), "poll period {}", fmt_ms(period));
    }
    gw.check_and_report("mirror");
}

/// What became of the SCADA's coil writes on the field line.
struct CoilWrites {
    /// (written, sent): FC 15 requests to the field device carrying coils the SCADA never
    /// wrote, sent before the right one.
    torn: Vec<(u8, u8)>,
}

/// The SCADA writes each of `patterns` to 00001–00008 (reading them back) while the
/// gateway polls, each write `phase` into the poll cycle; the field device must get an
/// FC 15 with those coils before its next poll (a poll started before the gateway took
/// the write may come first), and acknowledges it; then the polls go on without the
/// coils being written again.
fn write_coils_through(gw: &mut Gateway, patterns: &[u8], phase: u64) -> CoilWrites {
    let mut torn = Vec::new();
    for &bits in patterns {
        // Line the write up with the poll cycle: `phase` after the start of the next poll.
        let poll = gw.next_request(ms(POLL_MS + 50));
        assert_eq!(poll.bytes, read_request(DEVICE_ID, 0x03, 0, 10));
        let mut seen = gw.device.requests.len();
        let (written_at, reply) = gw.scada_at(poll.start + phase, &write_coils_request(GATEWAY_ID, 0, 8, &[bits]));
        assert_eq!(reply.bytes, write_coils_request(GATEWAY_ID, 0, 8, &[]), "FC 15 reply");
        assert_eq!(gw.scada(&read_request(GATEWAY_ID, 0x01, 0, 8)), coils_reply(GATEWAY_ID, &[bits]), "00001–00008");
        // The gateway took the write T3.5 after the request's end.
        let taken_by = written_at + gw.t35() + us_to_cycles(TURNAROUND_SLACK_US);
        let request = loop {
            gw.until_requests(seen + 1, ms(POLL_MS + 50));
            let request = gw.device.requests[seen].clone();
            seen += 1;
            if request.bytes == write_coils_request(DEVICE_ID, 0, 8, &[bits]) {
                break request;
            }
            if request.bytes == read_request(DEVICE_ID, 0x03, 0, 10) {
                assert!(
                    request.start < taken_by,
                    "a poll at {} instead of the coils written at {}",
                    fmt_ms(request.start),
                    fmt_ms(written_at)
                );
            } else {
                // Another FC 15 (`Device::answer` checked its form).
                eprintln!(
                    "coils {bits:#04x}: the field device got coils {:#04x} first, at {}",
                    request.bytes[7],
                    fmt_ms(request.start)
                );
                torn.push((bits, request.bytes[7]));
            }
        };
        eprintln!(
            "coils {bits:#04x}: FC 15 on the field line {} after the SCADA's write ended",
            fmt_ms(request.start - written_at)
        );
        assert_eq!(gw.device.coils, bits);
        // Acknowledged (by `collect`): then polls again, without writing the coils again.
        gw.until_requests(seen + 1, ms(POLL_MS + 50));
        let next = &gw.device.requests[seen];
        assert_eq!(next.bytes, read_request(DEVICE_ID, 0x03, 0, 10), "after the FC 15 of {bits:#04x}");
    }
    CoilWrites { torn }
}

/// Coil patterns that change every coil, or one, or several, at once.
const PATTERNS: [u8; 6] = [0xA5, 0x5A, 0x01, 0xFF, 0x00, 0x80];

/// Coils written by the SCADA go to the field device with FC 15, at several phases of
/// the poll cycle (during the FC 3 exchange, between polls).
#[test]
fn coils_written_by_the_scada_are_sent_on_to_the_field_device_with_fc15() {
    let mut gw = Gateway::boot(values(7), false);
    gw.next_request(ms(50)); // the coils, all off
    let mut torn = 0;
    for phase_ms in [0, 8, 17, 40] {
        torn += write_coils_through(&mut gw, &PATTERNS, ms(phase_ms)).torn.len();
    }
    let [answers, failures, last] = gw.counters();
    eprintln!(
        "30001 = {answers} (the device answered {}), 30002 = {failures}, 30003 = {last:#x}; {torn} torn FC 15",
        gw.device.answers
    );
    assert_eq!((failures, last), (0, 0));
    gw.check_and_report("coils");
}

/// The gateway reads coils 00001–00008 one by one in its loop (`SLAVE.get(1 + i)`) while
/// the slave's interrupt may apply a SCADA write between two reads: the field device then
/// gets an FC 15 mixing old and new coils (e.g. 0x02 after 0x5A → 0x01) before the right
/// one. Fails until `examples/gateway.rs` reads the eight coils at once.
#[test]
fn the_field_device_never_gets_coils_the_scada_did_not_write() {
    let mut gw = Gateway::boot(values(7), false);
    gw.next_request(ms(50));
    let mut torn = Vec::new();
    for phase_ms in [0, 8, 17, 40] {
        torn.extend(write_coils_through(&mut gw, &PATTERNS, ms(phase_ms)).torn);
    }
    assert_eq!(torn, [], "(written, sent to the field device first)");
}

/// When the SCADA writes coils during a poll, the gateway's loop may find the master idle
/// (`is_busy()` is false once the outcome is there) between its `poll` and its `is_busy`
/// check, and `send` the FC 15 at once: the poll's outcome, not yet collected, is dropped
/// (`Master::send`: "An outcome not yet collected is dropped"), so 30001 misses an answer
/// and 40001–40010 miss the values it carried. Fails until `examples/gateway.rs` collects
/// the outcome before it sends.
#[test]
fn every_field_answer_is_counted_and_mirrored_when_coils_are_written_during_a_poll() {
    let mut gw = Gateway::boot(values(0), false);
    gw.next_request(ms(50));
    let mut lost = Vec::new();
    for (round, phase_ms) in [0u64, 4, 8, 12, 17].into_iter().enumerate() {
        let round = round as u16 + 1;
        gw.device.registers = values(round);
        write_coils_through(&mut gw, &[round as u8], ms(phase_ms));
        let answered = gw.field.last().unwrap().end;
        gw.run_until(answered + ms(10));
        let [answers, _, _] = gw.counters();
        let holding = gw.holding();
        if u32::from(answers) != gw.device.answers || holding != values(round) {
            lost.push(format!(
                "write at +{phase_ms} ms: 30001 = {answers} for {} answers, 40001 = {:#06x} for {:#06x}",
                gw.device.answers,
                holding[0],
                values(round)[0]
            ));
        }
    }
    assert!(lost.is_empty(), "{}", lost.join("; "));
}

/// SCADA requests overlapping the master's exchanges on the field line, at 16 offsets from
/// the start of the master's request (its request, the device's 25-byte answer, the
/// silences around them): each reply is right and on time, and the master keeps T3.5.
#[test]
fn scada_requests_during_field_exchanges_are_answered_right_and_on_time() {
    let mut gw = Gateway::boot(values(3), false);
    gw.next_request(ms(50)); // the coils
    gw.next_request(ms(POLL_MS + 50)); // the first poll, answered
    let step = us_to_cycles(1300);
    let mut kinds = Vec::new();
    for k in 0..16u64 {
        // Wait for the master to start its next request.
        let t0 = gw.uno.now();
        let deadline = t0 + ms(POLL_MS + 50);
        let new_start = |gw: &Gateway| {
            let logged = gw.device.requests.iter().map(|f| f.start);
            logged.chain(gw.field_chars.first().map(|c| c.start_cycle)).find(|&start| start >= t0)
        };
        let started = gw.run_until_or(deadline, |gw| new_start(gw).is_some());
        assert!(started, "no request on the field line");
        let master_start = new_start(&gw).unwrap();
        let start = master_start + gw.char_cycles + k * step;
        let answers_before = gw.device.answers;
        let (request, kind) = match k % 4 {
            0 | 2 => (read_request(GATEWAY_ID, 0x03, 0, 10), "FC 3"),
            1 => (read_request(GATEWAY_ID, 0x04, 0, 3), "FC 4"),
            _ => (read_request(GATEWAY_ID, 0x01, 0, 8), "FC 1"),
        };
        let (end, reply) = gw.scada_at(start, &request);
        let field_busy = gw.field.iter().any(|f| f.start <= end + gw.t35() && f.end >= end)
            || gw.field_chars.first().is_some_and(|c| c.start_cycle <= end + gw.t35());
        match k % 4 {
            0 | 2 => assert_eq!(reply.bytes, registers_reply(GATEWAY_ID, 0x03, &values(3)), "offset {k}"),
            1 => {
                let r =
                    decode_registers(GATEWAY_ID, 0x04, &reply.bytes).unwrap_or_else(|| panic!("{:02X?}", reply.bytes));
                let answers = u32::from(r[0]);
                assert!(
                    (answers_before.saturating_sub(1)..=gw.device.answers).contains(&answers),
                    "offset {k}: 30001 = {answers}, the device answered {answers_before}..{}",
                    gw.device.answers
                );
                assert_eq!(r[1..], [0, 0], "offset {k}: 30002, 30003");
            }
            _ => assert_eq!(reply.bytes, coils_reply(GATEWAY_ID, &[0]), "offset {k}"),
        }
        let past = reply.start - end - gw.t35();
        kinds.push(format!(
            "{kind} +{:.1} ms: T3.5 + {:.1} µs{}",
            cycles_to_us(start - master_start) / 1000.0,
            cycles_to_us(past),
            if field_busy { " (field line busy)" } else { "" }
        ));
    }
    eprintln!("SCADA requests from the start of the master's request:\n  {}", kinds.join("\n  "));
    let fc3_v = gw.uno.vectors();
    let rx0 = gw.uno.isr_stats(fc3_v.usart_rx);
    let rx1 = gw.uno.isr_stats(36);
    let compa = gw.uno.isr_stats(21);
    let compb = gw.uno.isr_stats(fc3_v.timer0_compb);
    eprintln!(
        "ISR max cycles: USART0_RX {} USART1_RX {} TIMER0_COMPA {} TIMER0_COMPB {}",
        rx0.max_cycles, rx1.max_cycles, compa.max_cycles, compb.max_cycles
    );
    let [answers, failures, _] = gw.counters();
    assert_eq!((u32::from(answers), failures), (gw.device.answers, 0), "30001, 30002");
    gw.check_and_report("both lines");
}

/// The SCADA polls the gateway (FC 3 of 40001–40010, FC 4 of 30001–30003) about every
/// 25 ms until `until`; returns the counters as last read and when 30002 first read
/// non-zero. 30001 must stay `answers`; 30003 must be 0x100 once 30002 is not 0.
fn scada_polls_until(gw: &mut Gateway, until: u64, answers: u16) -> ([u16; 3], Option<u64>) {
    let mut first_failure = None;
    loop {
        assert_eq!(gw.holding(), [0; 10], "40001–40010 before any answer");
        let counters = gw.counters();
        let [a, failures, last] = counters;
        assert_eq!(a, answers, "30001");
        if failures > 0 {
            assert_eq!(last, 0x100, "30003 after {failures} failures");
            first_failure.get_or_insert(gw.uno.now());
        }
        if gw.uno.now() >= until {
            return (counters, first_failure);
        }
        gw.run_until(gw.uno.now() + ms(10));
    }
}

/// A silent field device: the master tries each request twice (its one retry), the
/// response timeout (1000 ms, `Timeouts::DEFAULT`) apart, starting with the coils' FC 15;
/// the SCADA is answered on time throughout (checked at the end). Then the device answers
/// again: the next request is answered, the polls resume and 40001–40010 mirror it.
#[test]
fn a_silent_field_device_is_retried_and_the_scada_side_keeps_answering() {
    let mut gw = Gateway::boot(values(9), true);
    let until = 3 * ms(RESPONSE_TIMEOUT_MS) + ms(200);
    let ([_, failures, last], _) = scada_polls_until(&mut gw, until, 0);
    let requests: Vec<&Frame> = gw.device.requests.iter().collect();
    let exchanges = gw.scada.iter().filter(|f| f.who == Who::Gateway).count();
    eprintln!(
        "silent device: tries {} by {}; 30002 = {failures}, 30003 = {last:#x}; {exchanges} SCADA replies",
        requests.iter().map(|r| format!("FC {} at {}", r.bytes[1], fmt_ms(r.start))).collect::<Vec<_>>().join(", "),
        fmt_ms(gw.uno.now()),
    );
    assert_eq!(requests.len(), 4, "two requests, each tried twice");
    for request in &requests[..2] {
        assert_eq!(request.bytes, write_coils_request(DEVICE_ID, 0, 8, &[0]), "the coils first, and their retry");
    }
    // Each try waits the response timeout after the previous one.
    for w in requests.windows(2) {
        let after = w[1].start - w[0].end;
        assert!(after >= ms(RESPONSE_TIMEOUT_MS), "a try {} after the previous one", fmt_ms(after));
        assert!(after <= ms(RESPONSE_TIMEOUT_MS + 5), "a try {} after the previous one", fmt_ms(after));
    }
    // The device answers again.
    gw.device.silent = false;
    let answered = loop {
        let request = gw.next_request(ms(2 * RESPONSE_TIMEOUT_MS + 100));
        if gw.device.answers > 0 {
            break request;
        }
    };
    let poll = if answered.bytes == read_request(DEVICE_ID, 0x03, 0, 10) {
        answered
    } else {
        assert_eq!(answered.bytes, write_coils_request(DEVICE_ID, 0, 8, &[0]));
        gw.next_request(ms(POLL_MS + 50))
    };
    assert_eq!(poll.bytes, read_request(DEVICE_ID, 0x03, 0, 10));
    gw.run_until(gw.field.last().unwrap().end + ms(10));
    assert_eq!(gw.holding(), values(9));
    let [answers, _, _] = gw.counters();
    assert_eq!(u32::from(answers), gw.device.answers, "30001 once the device answers");
    gw.check_and_report("silent device");
}

/// A silent field device shows at the SCADA side: once the coils' FC 15 and its retry have
/// timed out, 30002 counts the failure and 30003 reads 0x100, and the coils, never
/// acknowledged, are sent again. The gateway's loop drops that outcome instead: the
/// master is idle (`is_busy()` false) between its `poll` and its `is_busy` check (the two
/// `SLAVE.set` in between run with interrupts off, so the timeout's interrupt comes right
/// after one of them), a poll is due, and `send` drops the outcome not yet collected. So
/// 30002 stays 0, 30003 stays 0, and an FC 3 follows the failed FC 15 (0.5 ms after the
/// timeout), the coils never written. Fails until `examples/gateway.rs` collects the
/// outcome before it sends.
#[test]
fn a_silent_field_device_shows_in_30002_and_30003_and_the_coils_are_sent_again() {
    let mut gw = Gateway::boot(values(9), true);
    let until = 2 * ms(RESPONSE_TIMEOUT_MS) + ms(200);
    let ([_, failures, last], first_failure) = scada_polls_until(&mut gw, until, 0);
    let requests: Vec<&Frame> = gw.device.requests.iter().collect();
    eprintln!(
        "silent device: tries {} by {}; 30002 = {failures} (first at {}), 30003 = {last:#x}",
        requests.iter().map(|r| format!("FC {} at {}", r.bytes[1], fmt_ms(r.start))).collect::<Vec<_>>().join(", "),
        fmt_ms(gw.uno.now()),
        first_failure.map_or("-".into(), fmt_ms),
    );
    assert_eq!((failures, last), (1, 0x100), "30002, 30003 after the coils' FC 15 and its retry timed out");
    for request in &requests {
        assert_eq!(request.bytes, write_coils_request(DEVICE_ID, 0, 8, &[0]), "only the coils are tried");
    }
}
