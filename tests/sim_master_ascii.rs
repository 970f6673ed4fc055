//! The master in Modbus ASCII (Serial Line v1.02 §2.5.2) on the real firmware: the release
//! `ascii_master` example (features `master` and `ascii`, `make firmware` builds it) on the
//! simulated ATmega328P at 9600 bps 7E1. It reads holding registers 0–3 of slave 1, writes
//! 0xBEEF to its register 4, and reports each outcome with its counters to slave 2 (FC 16 at
//! 16 × step: status, four registers, requests, replies, exceptions, timeouts, retries, LRC
//! errors, malformed, unexpected).
//!
//! The test plays both slaves: it reads each frame the master puts on the line as
//! characters (`:`, upper-case hex pairs, CR LF) and checks its LRC with its own (the
//! spec's) arithmetic, then answers in ASCII with characters scheduled on simulated time:
//! good replies, an exception, a bad LRC, a frame from another slave, a frame cut short by
//! a `:`, silence, and a late reply still on the line when the retry is due. The master's
//! counters, as it reports them, are checked against the test's own count of each event,
//! and no request of the master ever starts while a frame is on the line.

mod ascii_frames;
mod sim;

use ascii_frames::{ascii, lrc};
use avr_modbus::master::MasterCounters;
use sim::{cycles_to_us, us_to_cycles, Line, Rtu};
use uno_sim::Parity;

const POLLED: u8 = 1;
const TOLD: u8 = 2;
/// The firmware's response timeout.
const RESPONSE_MS: u64 = 100;
/// How long the test waits for the master's next frame: two tries and room to spare.
const FRAME_WITHIN_MS: u64 = 400;
/// How long after a request's end the scripted slaves start their answer.
const SLAVE_DELAY_US: u64 = 1_000;

const VALUES: [u16; 4] = [0x1111, 0xA5C3, 0xFFFF, 0x0001];

fn ms(n: u64) -> u64 {
    us_to_cycles(1000 * n)
}

/// The master's counters in the order of the report's registers (examples/ascii_master.rs
/// reports these eight of [`MasterCounters`]'s ten: no UART error or overrun occurs here).
fn report_registers(counts: &MasterCounters) -> [u16; 8] {
    [
        counts.requests,
        counts.replies,
        counts.exceptions,
        counts.timeouts,
        counts.retries,
        counts.crc_errors,
        counts.malformed,
        counts.unexpected,
    ]
}

/// The line: the simulated master, the end of the last frame either side put on it, and
/// the test's count of what the master should have counted.
struct Bus {
    rtu: Rtu,
    /// End of the last character on the line (cycles).
    line_busy_until: u64,
    counts: MasterCounters,
}

/// A frame the master sent: its bytes (address and PDU, the LRC checked and removed) and
/// when it started and ended.
struct Sent {
    bytes: Vec<u8>,
    start: u64,
    end: u64,
}

impl Bus {
    fn boot() -> Bus {
        let rtu = Rtu::boot("ascii_master", Line::B9600_7E1);
        Bus { rtu, line_busy_until: 0, counts: MasterCounters::default() }
    }

    /// Runs until the master has sent a frame and returns it: `:`, upper-case hex pairs,
    /// CR LF, its LRC right, started after the line's last frame had ended.
    fn next(&mut self, what: &str) -> Sent {
        let idle = 2 * self.rtu.char_cycles;
        let deadline = self.rtu.uno.now() + ms(FRAME_WITHIN_MS);
        let chars = self.rtu.uno.run_until_tx_idle(idle, deadline).expect("firmware runs");
        let (Some(first), Some(last)) = (chars.first(), chars.last()) else {
            panic!("{what}: the master sent nothing within {FRAME_WITHIN_MS} ms");
        };
        let (start, end) = (first.start_cycle, last.end_cycle);
        let text: Vec<u8> = chars.iter().map(|c| c.byte).collect();
        let shown = String::from_utf8_lossy(&text).into_owned();
        assert!(
            start >= self.line_busy_until,
            "{what}: {shown:?} started {:.1} µs before the frame on the line had ended",
            cycles_to_us(self.line_busy_until - start)
        );
        assert!(text.len() >= 7 && text[0] == b':' && text.ends_with(b"\r\n"), "{what}: {shown:?}");
        let hex = &text[1..text.len() - 2];
        assert!(hex.len() % 2 == 0, "{what}: odd count in {shown:?}");
        assert!(hex.iter().all(|c| c.is_ascii_digit() || (b'A'..=b'F').contains(c)), "{what}: {shown:?}");
        let bytes: Vec<u8> =
            hex.chunks(2).map(|pair| u8::from_str_radix(std::str::from_utf8(pair).unwrap(), 16).unwrap()).collect();
        let (body, check) = bytes.split_at(bytes.len() - 1);
        assert_eq!(check[0], lrc(body), "{what}: the LRC of {shown:?}");
        self.line_busy_until = end;
        self.counts.requests += 1;
        Sent { bytes: body.to_vec(), start, end }
    }

    /// The master's next frame, which must be `expected` (address and PDU).
    fn expect(&mut self, expected: &[u8], what: &str) -> Sent {
        let sent = self.next(what);
        assert_eq!(sent.bytes, expected, "{what}");
        sent
    }

    /// Puts `chars` on the line back to back, the first start bit at cycle `start`;
    /// returns the end of the last one.
    fn put(&mut self, start: u64, chars: &[u8]) -> u64 {
        let char_cycles = self.rtu.char_cycles;
        let mut end = start;
        for &c in chars {
            end += char_cycles;
            self.rtu.uno.send_byte(c, end).expect("character scheduled");
        }
        self.line_busy_until = self.line_busy_until.max(end);
        end
    }

    /// Answers `request` with `chars`, [`SLAVE_DELAY_US`] after its end (or now, when the
    /// test has run past that to see the request end).
    fn answer(&mut self, request: &Sent, chars: &[u8]) -> u64 {
        let start = (request.end + us_to_cycles(SLAVE_DELAY_US)).max(self.rtu.uno.now());
        self.put(start, chars)
    }

    /// Expects the report of `step` with `status` and `values`, and the counters as the
    /// test counted them; acknowledges it (the FC 16 echo).
    fn report(&mut self, step: u16, status: u16, values: [u16; 4], what: &str) {
        let mut registers = vec![status];
        registers.extend(values);
        registers.extend(report_registers(&self.counts));
        let mut frame = vec![TOLD, 0x10, 0x00, (16 * step) as u8, 0x00, 13, 26];
        for r in &registers {
            frame.extend(r.to_be_bytes());
        }
        let sent = self.next(&format!("report of {what}"));
        if sent.bytes != frame {
            let got: Vec<u16> =
                sent.bytes.get(7..).unwrap_or(&[]).chunks(2).map(|p| u16::from_be_bytes([p[0], p[1]])).collect();
            panic!("report of {what}: registers {got:04X?}, expected {registers:04X?} (status, 4 values, requests, replies, exceptions, timeouts, retries, LRC errors, malformed, unexpected)");
        }
        self.answer(&sent, &ascii(&[TOLD, 0x10, 0x00, (16 * step) as u8, 0x00, 13]));
        self.counts.replies += 1;
    }
}

/// Step 0's request: FC 3, holding registers 0–3 of slave 1.
const READ: [u8; 6] = [POLLED, 0x03, 0x00, 0x00, 0x00, 0x04];
/// Step 1's request: FC 6, register 4 = 0xBEEF; its echo is the answer.
const WRITE: [u8; 6] = [POLLED, 0x06, 0x00, 0x04, 0xBE, 0xEF];

fn values_reply() -> Vec<u8> {
    let mut reply = vec![POLLED, 0x03, 0x08];
    for v in VALUES {
        reply.extend(v.to_be_bytes());
    }
    ascii(&reply)
}

#[test]
fn the_ascii_master_speaks_7e1_and_takes_only_the_replies_that_answer_it() {
    let mut bus = Bus::boot();
    let cfg = bus.rtu.uno.serial_config().expect("USART0 configured");
    assert!(cfg.matches(9600, 7, Parity::Even, 1), "{cfg:?}");

    // A good reply. The request is 01 03 0000 0004, LRC F8.
    let sent = bus.expect(&READ, "read");
    bus.answer(&sent, &values_reply());
    bus.counts.replies += 1;
    bus.report(0, 0, VALUES, "a good read");

    // Another slave's frame first (ignored), then the echo.
    let sent = bus.expect(&WRITE, "write");
    let other_end = bus.answer(&sent, &ascii(&[3, 0x06, 0x00, 0x04, 0xBE, 0xEF]));
    bus.put(other_end + us_to_cycles(500), &ascii(&WRITE));
    bus.counts.unexpected += 1;
    bus.counts.replies += 1;
    bus.report(1, 0, [0; 4], "a write after another slave's frame");

    // A bad LRC: counted, and the request goes again once the frame has left the line.
    let sent = bus.expect(&READ, "read");
    let mut bad = values_reply();
    let at = bad.len() - 3;
    bad[at] = if bad[at] == b'0' { b'1' } else { b'0' };
    let bad_end = bus.answer(&sent, &bad);
    bus.counts.crc_errors += 1;
    bus.counts.retries += 1;
    let retry = bus.expect(&READ, "retry after a bad LRC");
    assert!(retry.start >= bad_end);
    bus.answer(&retry, &values_reply());
    bus.counts.replies += 1;
    bus.report(0, 0, VALUES, "a read after a bad LRC");

    // A frame cut short by a `:`: counted, and the echo right behind it taken.
    let sent = bus.expect(&WRITE, "write");
    let mut chars = b":0106".to_vec();
    chars.extend(ascii(&WRITE));
    bus.answer(&sent, &chars);
    bus.counts.malformed += 1;
    bus.counts.replies += 1;
    bus.report(1, 0, [0; 4], "a write answered after a fragment");

    // An exception.
    let sent = bus.expect(&READ, "read");
    bus.answer(&sent, &ascii(&[POLLED, 0x83, 0x02]));
    bus.counts.replies += 1;
    bus.counts.exceptions += 1;
    bus.report(0, 2, [0; 4], "an exception");

    // Silence: a retry after the response timeout, then the failure.
    let sent = bus.expect(&WRITE, "write");
    bus.counts.timeouts += 1;
    bus.counts.retries += 1;
    let retry = bus.expect(&WRITE, "retry after silence");
    let waited = retry.start - sent.end;
    assert!(waited >= ms(RESPONSE_MS), "the retry came {:.1} µs after the request", cycles_to_us(waited));
    bus.counts.timeouts += 1;
    bus.report(1, 0x100, [0; 4], "a timeout");

    // A late reply still on the line when the response timeout passes: the retry waits for
    // its LF, then goes out; the late reply is no answer to it.
    let sent = bus.expect(&READ, "read");
    let late_start = sent.end + ms(RESPONSE_MS - 20);
    let late_end = bus.put(late_start, &values_reply());
    assert!(late_end > sent.end + ms(RESPONSE_MS + 2), "the late reply ends after the timeout");
    bus.counts.timeouts += 1;
    bus.counts.retries += 1;
    bus.counts.unexpected += 1;
    let retry = bus.expect(&READ, "retry after a late reply");
    assert!(retry.start >= late_end, "the retry started over the late reply");
    bus.answer(&retry, &values_reply());
    bus.counts.replies += 1;
    bus.report(0, 0, VALUES, "a read retried after a late reply");

    // What the interrupts cost in ASCII (printed for the record, not a test of speed).
    let v = bus.rtu.uno.vectors();
    for (name, vector) in [("USART_RX", v.usart_rx), ("USART_UDRE", v.usart_udre), ("TIMER0_COMPA", v.timer0_compa)] {
        let stats = bus.rtu.uno.isr_stats(vector);
        let mean = stats.cycles as f64 / stats.entries.max(1) as f64;
        println!("{name}: {} entries, {mean:.1} cycles on average, {} at most", stats.entries, stats.max_cycles);
    }
}
