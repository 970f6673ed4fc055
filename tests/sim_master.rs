//! The master's side of Modbus over Serial Line v1.02 on the real firmware: §2.4.1 (the
//! master's states: one request at a time, the response timeout, a retry after a timeout
//! or a damaged reply, a frame from another slave ignored, a broadcast answered by nobody
//! and followed by the turnaround delay), §2.5.1.1 (T3.5 of silence before every frame, a
//! gap over T1.5 breaks one), §2.5.1.2 (CRC), Application Protocol v1.1b3 §6 (requests of
//! FC 1–6, 15, 16, 23 byte for byte) and §7 (exception replies).
//!
//! The release `master_mirror` firmware (`make firmware` builds it with feature `master`)
//! runs on the simulated ATmega328P at 19200 8E1: fifteen steps of requests to slave 1,
//! each outcome written to slave 2 with FC 16 at registers 16 × step (status, then what
//! was read), and after the last step its counters at registers 240–248. The test plays
//! both slaves: it collects each frame the master puts on the line with the cycle times of
//! its characters, compares it byte for byte with the request the spec gives (CRC from
//! `sim::crc16`, not the crate's), and answers as a scripted slave would, its characters
//! scheduled on simulated time. Times are simulated cycles at 16 MHz; a frame's start is
//! its first start bit, its end the last stop bit's end.
//!
//! One char at 19200 8E1 is 11 bits = 572 µs (UBRR 51: 9152 cycles); T1.5 = 859 µs,
//! T3.5 = 2005 µs. The firmware's response timeout is 100 ms, its broadcast turnaround
//! 20 ms, one retry.

mod sim;

use avr_modbus::master::MasterCounters;
use sim::{cycles_to_us, read_request, registers_reply, us_to_cycles, with_crc, Line, Rtu};
use uno_sim::{TxByte, CYCLES_PER_US};

/// Slave 1: the one the master polls.
const POLLED: u8 = 1;
/// Slave 2: the one told each outcome.
const TOLD: u8 = 2;
/// The broadcast address.
const BROADCAST: u8 = 0;

/// The firmware's response timeout, from the request's end.
const RESPONSE_MS: u64 = 100;
/// The firmware's turnaround delay after a broadcast.
const TURNAROUND_MS: u64 = 20;

/// Status of a step's report: answered.
const ANSWERED: u16 = 0;
/// Status: no reply within the response timeout, on the last try.
const TIMEOUT: u16 = 0x100;
/// Status of a report whose try ended with a damaged reply.
const BAD_REPLY: u16 = 0x200;
/// Status: the request was refused before a byte was sent.
const REFUSED: u16 = 0x300;

/// How long the test waits for the master's next frame: the response timeout of a try
/// and of its retry, with room to spare.
const FRAME_WITHIN_MS: u64 = 300;

fn ms(n: u64) -> u64 {
    us_to_cycles(1000 * n)
}

fn fmt_us(cycles: u64) -> String {
    format!("{:.1} µs", cycles_to_us(cycles))
}

// ---------------------------------------------------------------------------------------
// The line as the test sees it

/// Who put a frame on the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Who {
    /// The firmware.
    Master,
    /// The test, as the slave with this address (the frame's first byte).
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

/// The simulated master, and every frame on the line so far.
struct Bus {
    rtu: Rtu,
    log: Vec<Frame>,
    /// How long after a request's end the scripted slaves answer, beyond T3.5.
    slave_delay: u64,
}

/// What preceded one of the master's frames on the line.
#[derive(Clone, Debug)]
struct Silence {
    /// Index of the master's frame in the log.
    index: usize,
    /// Index in the log of the frame before it on the line (None: the first frame since
    /// power-up).
    before: Option<usize>,
    /// Idle cycles from the end of the last character before it to its first start bit
    /// (negative: it started while another frame was still on the line).
    gap: i64,
}

impl Bus {
    fn boot() -> Bus {
        Bus { rtu: Rtu::boot("master_mirror", Line::B19200_8E1), log: Vec::new(), slave_delay: us_to_cycles(500) }
    }

    fn char_cycles(&self) -> u64 {
        self.rtu.char_cycles
    }

    fn t15(&self) -> u64 {
        self.rtu.line.t15()
    }

    fn t35(&self) -> u64 {
        self.rtu.line.t35()
    }

    /// Runs until the master has sent a frame (its characters followed by two characters
    /// of idle line) and returns it, or `None` if none started within `within` cycles.
    fn next_frame(&mut self, within: u64) -> Option<Frame> {
        let idle = 2 * self.char_cycles();
        let uno = &mut self.rtu.uno;
        let deadline = uno.now() + within;
        let mut chars = uno.run_until_tx_idle(idle, deadline).expect("firmware runs");
        // The deadline may have cut a frame short: run on until it is over.
        while let Some(last) = chars.last() {
            let busy = uno.tx_busy_until().unwrap_or(0).max(last.end_cycle);
            if uno.now() >= busy + idle {
                break;
            }
            uno.run_until(busy + idle).expect("firmware runs");
            chars.extend(uno.take_tx());
        }
        let (first, last) = (chars.first()?, chars.last()?);
        let frame = Frame {
            who: Who::Master,
            bytes: chars.iter().map(|c| c.byte).collect(),
            start: first.start_cycle,
            end: last.end_cycle,
            max_gap: max_gap(&chars),
        };
        self.log.push(frame.clone());
        Some(frame)
    }

    /// The master's next frame, which must be `expected` (address to CRC), sent as one
    /// frame (no gap over T1.5 inside).
    fn expect(&mut self, expected: &[u8], what: &str) -> Frame {
        let frame = self
            .next_frame(ms(FRAME_WITHIN_MS))
            .unwrap_or_else(|| panic!("{what}: the master sent nothing within {FRAME_WITHIN_MS} ms"));
        assert_eq!(
            frame.bytes,
            expected,
            "{what}: the master sent {:02X?} at {} (as FC 16 to slave 2: {:?}), expected {expected:02X?}",
            frame.bytes,
            fmt_us(frame.start),
            decode_write_multiple(&frame.bytes),
        );
        assert!(
            frame.max_gap <= self.t15(),
            "{what}: a gap of {} inside the request (T1.5 = {})",
            fmt_us(frame.max_gap),
            fmt_us(self.t15())
        );
        frame
    }

    /// Puts `bytes` on the line from the slave: the first start bit `delay` cycles after
    /// `request`'s end, the characters back to back except, with `gap` = (i, idle), for
    /// `idle` cycles of idle line before character i. Returns the frame as logged.
    fn answer_with(&mut self, request: &Frame, delay: u64, bytes: &[u8], gap: Option<(usize, u64)>) -> Frame {
        self.answer_from(request.end + delay, bytes, gap)
    }

    /// [`Bus::answer_with`], the first start bit at cycle `start`.
    fn answer_from(&mut self, start: u64, bytes: &[u8], gap: Option<(usize, u64)>) -> Frame {
        let char_cycles = self.char_cycles();
        let mut end = start;
        let mut max_gap = 0;
        for (i, &byte) in bytes.iter().enumerate() {
            if let Some((before, idle)) = gap {
                if i == before {
                    end += idle;
                    max_gap = idle;
                }
            }
            end += char_cycles;
            self.rtu.uno.send_byte(byte, end).expect("byte scheduled");
        }
        let frame = Frame { who: Who::Slave(bytes[0]), bytes: bytes.to_vec(), start, end, max_gap };
        self.log.push(frame.clone());
        frame
    }

    /// Answers `request` as a prompt slave: T3.5 and `slave_delay` (half a millisecond)
    /// after its end.
    fn answer(&mut self, request: &Frame, bytes: &[u8]) -> Frame {
        let delay = self.t35() + self.slave_delay;
        self.answer_with(request, delay, bytes, None)
    }

    /// Expects the report of `step` carrying `values` (status first) and acknowledges it
    /// as slave 2 does (the FC 16 echo).
    fn report(&mut self, step: u16, values: &[u16]) -> Frame {
        let address = 16 * step;
        let frame = self.expect(&write_multiple_request(TOLD, address, values), &format!("report of step {step}"));
        self.answer(&frame, &write_multiple_reply(TOLD, address, values.len() as u16));
        frame
    }

    /// Expects the report of `step` with status `status` (its values are not looked at)
    /// and acknowledges it. Returns the report's registers.
    fn report_status(&mut self, step: u16, status: u16) -> Vec<u16> {
        let what = format!("report of step {step}");
        let frame = self
            .next_frame(ms(FRAME_WITHIN_MS))
            .unwrap_or_else(|| panic!("{what}: the master sent nothing within {FRAME_WITHIN_MS} ms"));
        let (address, values) = decode_write_multiple(&frame.bytes)
            .unwrap_or_else(|| panic!("{what}: the master sent {:02X?}, not an FC 16 to slave 2", frame.bytes));
        assert_eq!((address, values[0]), (16 * step, status), "{what}: address and status of {values:04X?}");
        assert_eq!(frame.bytes, write_multiple_request(TOLD, address, &values), "{what}: the frame");
        self.answer(&frame, &write_multiple_reply(TOLD, address, values.len() as u16));
        values
    }

    /// Expects the counters' report (registers 240–250), acknowledges it, and returns
    /// what it says.
    fn counters(&mut self) -> (MasterCounters, u16) {
        let frame = self
            .next_frame(ms(FRAME_WITHIN_MS))
            .unwrap_or_else(|| panic!("counters: the master sent nothing within {FRAME_WITHIN_MS} ms"));
        let (address, values) = decode_write_multiple(&frame.bytes)
            .unwrap_or_else(|| panic!("counters: the master sent {:02X?}, not an FC 16 to slave 2", frame.bytes));
        assert_eq!((address, values.len()), (240, 11), "counters: report at {address} of {values:04X?}");
        assert_eq!(frame.bytes, write_multiple_request(TOLD, 240, &values), "counters: the frame");
        self.answer(&frame, &write_multiple_reply(TOLD, 240, 11));
        (counters_from_registers(&values), values[10])
    }

    /// Serves `step` as a good slave 1: its request (if one goes out) answered with the
    /// plan's reply (if any), then its report acknowledged, its address and status
    /// checked. Returns the report's registers (status, then the values).
    fn serve(&mut self, step: &Step) -> Vec<u16> {
        if let Some(request) = &step.request {
            let sent = self.expect(request, &format!("step {}: {}", step.number, step.what));
            if let Some(reply) = &step.reply {
                self.answer(&sent, reply);
            }
        }
        self.report_status(step.number, step.report[0])
    }

    /// The silence before each of the master's frames, in order.
    fn silences(&self) -> Vec<Silence> {
        let mut out = Vec::new();
        for (index, frame) in self.log.iter().enumerate() {
            if frame.who != Who::Master {
                continue;
            }
            // The frame that ended last among those that started before this one.
            let before = (0..self.log.len())
                .filter(|&i| i != index && self.log[i].start < frame.start)
                .max_by_key(|&i| self.log[i].end);
            let gap = match before {
                Some(i) => frame.start as i64 - self.log[i].end as i64,
                None => frame.start as i64,
            };
            out.push(Silence { index, before, gap });
        }
        out
    }

    /// "after slave 1's [01, 03, 08, …]": the frame at `index` (None: the power-up), for
    /// messages.
    fn describe(&self, index: Option<usize>) -> String {
        let Some(i) = index else { return "after power-up".into() };
        let frame = &self.log[i];
        let who = match frame.who {
            Who::Master => "the master's own".to_string(),
            Who::Slave(id) => format!("slave {id}'s"),
        };
        format!("after {who} {:02X?}", frame.bytes)
    }
}

/// Signed cycles in µs.
fn cycles_to_us_signed(cycles: i64) -> f64 {
    cycles as f64 / CYCLES_PER_US as f64
}

/// Milliseconds from the firmware's start of Timer0 (the clock of its `millis()`) to
/// `cycle`.
fn timer0_ms(rtu: &Rtu, cycle: u64) -> f64 {
    (cycle - rtu.timer0_started) as f64 / ms(1) as f64
}

/// `gap` cycles, negative ones too.
fn fmt_gap(gap: i64) -> String {
    if gap < 0 {
        format!("-{}", fmt_us(gap.unsigned_abs()))
    } else {
        fmt_us(gap as u64)
    }
}

fn max_gap(chars: &[TxByte]) -> u64 {
    chars.windows(2).map(|w| w[1].start_cycle.saturating_sub(w[0].end_cycle)).max().unwrap_or(0)
}

// ---------------------------------------------------------------------------------------
// Frames

/// FC 16 to `id`: `values` from `address`.
fn write_multiple_request(id: u8, address: u16, values: &[u16]) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [q_hi, q_lo] = (values.len() as u16).to_be_bytes();
    let mut frame = vec![
        id,                       // slave address
        0x10,                     // function: write multiple registers
        a_hi,                     // starting address hi
        a_lo,                     // starting address lo
        q_hi,                     // quantity hi
        q_lo,                     // quantity lo
        (2 * values.len()) as u8, // byte count
    ];
    for value in values {
        frame.extend_from_slice(&value.to_be_bytes());
    }
    with_crc(&frame)
}

/// The FC 16 reply of `id`: the echo of address and quantity.
fn write_multiple_reply(id: u8, address: u16, quantity: u16) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [q_hi, q_lo] = quantity.to_be_bytes();
    with_crc(&[
        id,   // slave address
        0x10, // function
        a_hi, // starting address hi
        a_lo, // starting address lo
        q_hi, // quantity hi
        q_lo, // quantity lo
    ])
}

/// Starting address and values of an FC 16 frame to slave 2 (for messages).
fn decode_write_multiple(frame: &[u8]) -> Option<(u16, Vec<u16>)> {
    if frame.len() < 9 || frame[0] != TOLD || frame[1] != 0x10 || frame.len() != 9 + usize::from(frame[6]) {
        return None;
    }
    let values = frame[7..frame.len() - 2].chunks_exact(2).map(|p| u16::from_be_bytes([p[0], p[1]])).collect();
    Some((u16::from_be_bytes([frame[2], frame[3]]), values))
}

/// `frame` with one bit of its CRC's high byte flipped.
fn with_bad_crc(frame: &[u8]) -> Vec<u8> {
    let mut bad = frame.to_vec();
    *bad.last_mut().unwrap() ^= 0x10;
    bad
}

/// One step of the firmware: what it sends, what slave 1 answers, what the report says.
struct Step {
    number: u16,
    what: &'static str,
    /// The request on the line (None: refused before sending).
    request: Option<Vec<u8>>,
    /// The scripted slave's answer (None: broadcast, or nothing goes out).
    reply: Option<Vec<u8>>,
    /// The report's registers: status, then the values read.
    report: Vec<u16>,
}

/// Step 0's request: FC 3, holding registers 0–3.
fn step0_request() -> Vec<u8> {
    read_request(POLLED, 0x03, 0, 4)
}

/// What the scripted slave 1 serves to step 0 (and the report carries).
const STEP0_VALUES: [u16; 4] = [0x1111, 0xA5C3, 0xFFFF, 0x0001];

/// Other values for step 0: those of a reply that must not be taken.
const STEP0_WRONG: [u16; 4] = [0xDEAD, 0xBEEF, 0x0BAD, 0xF00D];

/// The plan of every step, each answered correctly by slave 1 (step 10 with exception 02).
fn steps() -> Vec<Step> {
    vec![
        Step {
            number: 0,
            what: "FC 3, holding registers 0-3",
            request: Some(step0_request()),
            reply: Some(registers_reply(POLLED, 0x03, &STEP0_VALUES)),
            report: [&[ANSWERED][..], &STEP0_VALUES].concat(),
        },
        Step {
            number: 1,
            what: "FC 1, coils 0-9",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x01,   // function: read coils
                0x00,   // starting address hi
                0x00,   // starting address lo: 0
                0x00,   // quantity hi
                0x0A,   // quantity lo: 10
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0x01,   // function
                0x02,   // byte count
                0xCD,   // coils 7..0 = 1100 1101
                0x02,   // coils 9..8 = 10, unused high bits zero
            ])),
            report: vec![ANSWERED, 0x02CD],
        },
        Step {
            number: 2,
            what: "FC 5, coil 3 on",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x05,   // function: write single coil
                0x00,   // address hi
                0x03,   // address lo: 3
                0xFF,   // value hi: ON
                0x00,   // value lo
            ])),
            reply: Some(with_crc(&[POLLED, 0x05, 0x00, 0x03, 0xFF, 0x00])), // the echo
            report: vec![ANSWERED],
        },
        Step {
            number: 3,
            what: "FC 16, holding registers 10-11 = 0x1234, 0x5678",
            request: Some(write_multiple_request(POLLED, 10, &[0x1234, 0x5678])),
            reply: Some(write_multiple_reply(POLLED, 10, 2)),
            report: vec![ANSWERED],
        },
        Step {
            number: 4,
            what: "FC 4, input registers 0-2",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x04,   // function: read input registers
                0x00,   // starting address hi
                0x00,   // starting address lo: 0
                0x00,   // quantity hi
                0x03,   // quantity lo: 3
            ])),
            reply: Some(registers_reply(POLLED, 0x04, &[0x0BAD, 0xF00D, 0x7FFF])),
            report: vec![ANSWERED, 0x0BAD, 0xF00D, 0x7FFF],
        },
        Step {
            number: 5,
            what: "FC 2, discrete inputs 0-7",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x02,   // function: read discrete inputs
                0x00,   // starting address hi
                0x00,   // starting address lo: 0
                0x00,   // quantity hi
                0x08,   // quantity lo: 8
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0x02,   // function
                0x01,   // byte count
                0x96,   // inputs 7..0 = 1001 0110
            ])),
            report: vec![ANSWERED, 0x0096],
        },
        Step {
            number: 6,
            what: "FC 6, holding register 12 = 0xBEEF",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x06,   // function: write single register
                0x00,   // address hi
                0x0C,   // address lo: 12
                0xBE,   // value hi
                0xEF,   // value lo
            ])),
            reply: Some(with_crc(&[POLLED, 0x06, 0x00, 0x0C, 0xBE, 0xEF])), // the echo
            report: vec![ANSWERED],
        },
        Step {
            number: 7,
            what: "FC 15, coils 4-7 = on, off, on, on",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x0F,   // function: write multiple coils
                0x00,   // starting address hi
                0x04,   // starting address lo: 4
                0x00,   // quantity hi
                0x04,   // quantity lo: 4
                0x01,   // byte count
                0x0D,   // coils 7..4 = 1101, unused high bits zero
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0x0F,   // function
                0x00,   // starting address hi
                0x04,   // starting address lo
                0x00,   // quantity hi
                0x04,   // quantity lo
            ])),
            report: vec![ANSWERED],
        },
        Step {
            number: 8,
            what: "FC 23, write 13 = 7, then read 10-13",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x17,   // function: read/write multiple registers
                0x00,   // read starting address hi
                0x0A,   // read starting address lo: 10
                0x00,   // quantity to read hi
                0x04,   // quantity to read lo: 4
                0x00,   // write starting address hi
                0x0D,   // write starting address lo: 13
                0x00,   // quantity to write hi
                0x01,   // quantity to write lo: 1
                0x02,   // write byte count
                0x00,   // register 13 hi
                0x07,   // register 13 lo: 7
            ])),
            // What a slave that took steps 3, 6 and this write holds at 10-13.
            reply: Some(registers_reply(POLLED, 0x17, &[0x1234, 0x5678, 0xBEEF, 0x0007])),
            report: vec![ANSWERED, 0x1234, 0x5678, 0xBEEF, 0x0007],
        },
        Step {
            number: 9,
            what: "FC 3, 126 holding registers (over the spec's 125)",
            request: None,
            reply: None,
            report: vec![REFUSED],
        },
        Step {
            number: 10,
            what: "FC 3, holding register 9999",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x03,   // function: read holding registers
                0x27,   // starting address hi
                0x0F,   // starting address lo: 9999
                0x00,   // quantity hi
                0x01,   // quantity lo: 1
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0x83,   // function 3 | 0x80: exception
                0x02,   // exception code: illegal data address
            ])),
            report: vec![0x0002],
        },
        Step {
            number: 11,
            what: "broadcast FC 6, holding register 14 = 0x0B0B",
            request: Some(with_crc(&[
                BROADCAST, // slave address: every slave
                0x06,      // function: write single register
                0x00,      // address hi
                0x0E,      // address lo: 14
                0x0B,      // value hi
                0x0B,      // value lo
            ])),
            reply: None,
            report: vec![ANSWERED],
        },
        Step {
            number: 12,
            what: "raw FC 0x41",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x41,   // function: none the slave has
                0x00,   // a byte of data
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0xC1,   // function 0x41 | 0x80: exception
                0x01,   // exception code: illegal function
            ])),
            report: vec![0x0001],
        },
        Step {
            number: 13,
            what: "raw FC 3 of 0 registers",
            request: Some(with_crc(&[
                POLLED, // slave address
                0x03,   // function: read holding registers
                0x00,   // starting address hi
                0x00,   // starting address lo
                0x00,   // quantity hi
                0x00,   // quantity lo: 0, outside 1-125
            ])),
            reply: Some(with_crc(&[
                POLLED, // slave address
                0x83,   // function 3 | 0x80: exception
                0x03,   // exception code: illegal data value
            ])),
            report: vec![0x0003],
        },
        Step {
            number: 14,
            what: "FC 3, holding registers 16-19: 1.5 as f32 high word first, then low word first",
            request: Some(read_request(POLLED, 0x03, 16, 4)),
            reply: Some(registers_reply(POLLED, 0x03, &[0x3FC0, 0x0000, 0x0000, 0x3FC0])),
            // Each read as the f32 it is in its word order (Reply::wide), doubled, and
            // reported high word first: 3.0 = 4040 0000.
            report: vec![ANSWERED, 0x4040, 0x0000, 0x4040, 0x0000],
        },
    ]
}

/// The firmware's counters, from registers 240–249 of its last report (the order of
/// [`MasterCounters`]'s fields).
fn counters_from_registers(r: &[u16]) -> MasterCounters {
    MasterCounters {
        requests: r[0],
        crc_errors: r[1],
        uart_errors: r[2],
        overruns: r[3],
        malformed: r[4],
        replies: r[5],
        exceptions: r[6],
        timeouts: r[7],
        retries: r[8],
        unexpected: r[9],
    }
}

/// After one pass where every request was answered at the first try: 14 requests to
/// slave 1 or broadcast (step 9 none) and 15 reports; 10 answers, the 3 exceptions and the
/// 15 acknowledgements (a broadcast gets no answer).
const CLEAN_PASS: MasterCounters = MasterCounters {
    requests: 29,
    replies: 28,
    exceptions: 3,
    timeouts: 0,
    retries: 0,
    crc_errors: 0,
    uart_errors: 0,
    overruns: 0,
    malformed: 0,
    unexpected: 0,
};

/// Serves the steps from `from` to the end ([`Bus::serve`]: the reports' status checked,
/// their values are the concern of the function-code test) and returns what the
/// counters' report says, after checking that it is the first pass's.
fn rest_of_pass(bus: &mut Bus, from: usize) -> MasterCounters {
    for step in &steps()[from..] {
        bus.serve(step);
    }
    let (counters, pass) = bus.counters();
    assert_eq!(pass, 1, "the pass count");
    counters
}

// ---------------------------------------------------------------------------------------
// Every function code (Application Protocol §6, §7; Serial Line §2.4.1)

/// Steps 0–8 answered, step 9 refused before sending, step 10 answered with exception 02,
/// step 11 broadcast, steps 12 and 13 answered with exceptions 01 and 03, step 14's floats
/// read in both word orders: every request is the spec's frame byte for byte (checked as it
/// comes), and every report carries what slave 1 served: the registers, the bits packed
/// LSB first, status 0 and nothing else for a write, 0x300 for step 9, 2 for step 10.
/// Step 9 puts no frame on the line: the frame after step 8's report is step 9's report.
/// The reports are all collected (and acknowledged as sent) before they are compared, so
/// that a failure lists every wrong one.
#[test]
fn every_function_code_is_sent_as_the_spec_says_and_the_reports_carry_what_slave_1_served() {
    let mut bus = Bus::boot();
    let steps = steps();
    let reports: Vec<(u16, Vec<u16>)> = steps.iter().map(|step| (step.number, bus.serve(step))).collect();
    let expected: Vec<(u16, Vec<u16>)> = steps.iter().map(|step| (step.number, step.report.clone())).collect();
    let wrong: Vec<String> = reports
        .iter()
        .zip(&expected)
        .filter(|(got, want)| got != want)
        .map(|((step, got), (_, want))| format!("step {step}: reported {got:04X?}, served {want:04X?}"))
        .collect();
    assert!(wrong.is_empty(), "reports that do not carry what slave 1 served:\n{}", wrong.join("\n"));
    let (counters, pass) = bus.counters();
    assert_eq!(counters, CLEAN_PASS, "the counters after a pass");
    assert_eq!(pass, 1, "the pass count");
}

/// Step 11, a broadcast (slave 0) of FC 6: nobody answers, and the master awaits no
/// reply: its next request (step 11's report, status 0) starts no earlier than the 20 ms
/// turnaround delay after the broadcast's last stop bit, and well before the 100 ms
/// response timeout would have run out. Eight runs: in run k (0–7) step 10's exception
/// reply and its report's acknowledgement each come 125·k µs later than usual, which
/// moves the broadcast by 0–1.75 ms against the firmware's `millis()`.
#[test]
fn after_a_broadcast_the_master_waits_the_turnaround_delay_and_no_reply() {
    let steps = steps();
    let mut afters = Vec::new();
    for k in 0..8 {
        let mut bus = Bus::boot();
        for step in &steps[..10] {
            bus.serve(step);
        }
        bus.slave_delay = us_to_cycles(500 + 125 * k);
        bus.serve(&steps[10]);
        let step = &steps[11];
        let broadcast = bus.expect(step.request.as_ref().unwrap(), "step 11: broadcast");
        let report = bus.report(11, &step.report);
        let after = report.start - broadcast.end;
        println!(
            "broadcast ends at {:.3} ms of Timer0 (cycle {}), the next request starts {} later (cycle {})",
            timer0_ms(&bus.rtu, broadcast.end),
            broadcast.end,
            fmt_us(after),
            report.start
        );
        assert!(after < ms(RESPONSE_MS), "the master waited {} after the broadcast: a reply awaited?", fmt_us(after));
        afters.push((after, broadcast.end, report.start));
    }
    let &(least, end, start) = afters.iter().min().unwrap();
    assert!(
        least >= ms(TURNAROUND_MS),
        "the next request started {} after the broadcast's end (cycles {end} to {start}), under the {TURNAROUND_MS} ms turnaround",
        fmt_us(least)
    );
}

// ---------------------------------------------------------------------------------------
// T3.5 before every request (Serial Line §2.5.1.1)

/// A whole pass in which step 0's first reply is damaged (the retry is sent once the
/// damaged frame has been judged, T3.5 after it) and step 1's first try goes unanswered
/// (the retry follows the master's own request): every frame of the master starts T3.5
/// or more after the last character on the line, its own or a slave's.
#[test]
fn every_request_starts_after_t35_of_silence_on_the_line() {
    let mut bus = Bus::boot();
    let steps = steps();
    let first = bus.expect(&step0_request(), "step 0");
    bus.answer(&first, &with_bad_crc(&registers_reply(POLLED, 0x03, &STEP0_WRONG)));
    let retry = bus.expect(&step0_request(), "step 0: the retry after a damaged reply");
    bus.answer(&retry, steps[0].reply.as_ref().unwrap());
    bus.report_status(0, ANSWERED);
    let request = steps[1].request.as_ref().unwrap();
    bus.expect(request, "step 1: unanswered");
    let retry = bus.expect(request, "step 1: the retry after a timeout");
    bus.answer(&retry, steps[1].reply.as_ref().unwrap());
    bus.report_status(1, ANSWERED);
    rest_of_pass(&mut bus, 2);

    let t35 = bus.t35() as i64;
    let silences = bus.silences();
    let min_by = |slave: bool| {
        silences
            .iter()
            .filter(|s| s.before.is_some_and(|i| matches!(bus.log[i].who, Who::Slave(_)) == slave))
            .min_by_key(|s| s.gap)
    };
    println!("T3.5 = {}; {} requests", fmt_us(t35 as u64), silences.len());
    for (what, least) in [("a slave's frame", min_by(true)), ("the master's own frame", min_by(false))] {
        if let Some(s) = least {
            println!("  least silence after {what}: {} ({})", fmt_gap(s.gap), bus.describe(s.before));
        }
    }
    let least = silences.iter().filter(|s| s.before.is_some()).min_by_key(|s| s.gap).expect("requests");
    println!("  minimum gap seen: {} (T3.5 {:+.1} µs)", fmt_gap(least.gap), cycles_to_us_signed(least.gap - t35));
    for s in &silences {
        let frame = &bus.log[s.index];
        assert!(
            s.gap >= t35,
            "{:02X?} started at cycle {} after {} of silence ({}); T3.5 = {}",
            frame.bytes,
            frame.start,
            fmt_gap(s.gap),
            bus.describe(s.before),
            fmt_us(t35 as u64)
        );
    }
}

// ---------------------------------------------------------------------------------------
// Response timeout and retries (Serial Line §2.4.1)

/// Slave 1 answers neither step 0 nor its retry: the request goes out twice (one retry),
/// the retry no earlier than the 100 ms response timeout after the first try's end, and
/// the report, no earlier than the timeout after the retry's end, has status 0x100.
#[test]
fn a_silent_slave_gets_one_retry_after_the_response_timeout_and_the_report_says_timeout() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let retry = bus.expect(&step0_request(), "step 0: the retry");
    let report = bus.report(0, &[TIMEOUT]);
    let (first_wait, retry_wait) = (retry.start - first.end, report.start - retry.end);
    println!(
        "first try ended at cycle {}, the retry started at cycle {}: {} later; \
         the retry ended at cycle {}, the report started at cycle {}: {} later",
        first.end,
        retry.start,
        fmt_us(first_wait),
        retry.end,
        report.start,
        fmt_us(retry_wait)
    );
    for (wait, what) in [(first_wait, "the retry after the first try"), (retry_wait, "the report after the retry")] {
        assert!(wait >= ms(RESPONSE_MS), "{what} started {} after its end", fmt_us(wait));
    }
}

/// Step 0's first reply has one bit of its CRC flipped (and other values): dropped and
/// counted, the request sent again; the good reply to the retry is the one reported. The
/// counters of the pass: one CRC error, one retry, one request more than a clean pass.
#[test]
fn a_reply_with_a_bad_crc_is_dropped_and_counted_and_the_retry_answer_is_taken() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    bus.answer(&first, &with_bad_crc(&registers_reply(POLLED, 0x03, &STEP0_WRONG)));
    let retry = bus.expect(&step0_request(), "step 0: the retry after a damaged reply");
    bus.answer(&retry, &registers_reply(POLLED, 0x03, &STEP0_VALUES));
    bus.report(0, &[&[ANSWERED][..], &STEP0_VALUES].concat());
    let counters = rest_of_pass(&mut bus, 1);
    assert_eq!(counters, MasterCounters { requests: CLEAN_PASS.requests + 1, retries: 1, crc_errors: 1, ..CLEAN_PASS });
}

/// Step 2's write (FC 5, coil 3 on) is answered first with the echo of another coil (4), a
/// good frame from the slave asked that does not answer the request: not taken, counted as
/// unexpected, and the request goes again; the right echo to the retry is the one reported.
/// (The echo is compared with the request byte for byte: on the AVR, a `memcmp`.)
#[test]
fn a_write_answered_with_a_wrong_echo_is_not_taken_and_the_retry_answer_is() {
    let mut bus = Bus::boot();
    let steps = steps();
    for step in &steps[..2] {
        bus.serve(step);
    }
    let (step, request) = (&steps[2], steps[2].request.clone().expect("step 2 sends a request"));
    let first = bus.expect(&request, "step 2");
    bus.answer(&first, &with_crc(&[POLLED, 0x05, 0x00, 0x04, 0xFF, 0x00]));
    let retry = bus.expect(&request, "step 2: the retry after a wrong echo");
    bus.answer(&retry, step.reply.as_ref().expect("step 2 is answered"));
    bus.report(2, &step.report);
    let counters = rest_of_pass(&mut bus, 3);
    assert_eq!(counters, MasterCounters { requests: CLEAN_PASS.requests + 1, retries: 1, unexpected: 1, ..CLEAN_PASS });
}

/// Step 0 answered first by slave 3 (a good frame, other values), then, within the
/// timeout, by slave 1: slave 3's frame is ignored and counted as unexpected, slave 1's is
/// taken, and no retry goes out (the next frame is the report).
#[test]
fn a_reply_from_another_slave_is_ignored_and_the_right_one_after_it_is_taken() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let other = bus.answer(&first, &registers_reply(3, 0x03, &STEP0_WRONG));
    let delay = bus.t35() + us_to_cycles(500);
    let right = bus.answer_from(other.end + delay, &registers_reply(POLLED, 0x03, &STEP0_VALUES), None);
    println!("slave 1's reply ends {} after the request", fmt_us(right.end - first.end));
    bus.report(0, &[&[ANSWERED][..], &STEP0_VALUES].concat());
    let counters = rest_of_pass(&mut bus, 1);
    assert_eq!(counters, MasterCounters { unexpected: 1, ..CLEAN_PASS });
}

/// Step 0's first reply (a good CRC over all its bytes, other values) has an idle gap of
/// T1.5 and two Timer0 ticks between its 4th and 5th characters: it is no frame (counted
/// as malformed), the request is sent again, and the answer to the retry is reported.
#[test]
fn a_reply_with_a_gap_over_t15_inside_is_dropped_as_malformed_and_the_request_sent_again() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let gap = bus.t15() + 2 * bus.rtu.tick;
    let delay = bus.t35() + us_to_cycles(500);
    bus.answer_with(&first, delay, &registers_reply(POLLED, 0x03, &STEP0_WRONG), Some((4, gap)));
    let retry = bus.expect(&step0_request(), &format!("step 0: the retry after a gap of {}", fmt_us(gap)));
    bus.answer(&retry, &registers_reply(POLLED, 0x03, &STEP0_VALUES));
    bus.report(0, &[&[ANSWERED][..], &STEP0_VALUES].concat());
    let counters = rest_of_pass(&mut bus, 1);
    assert_eq!(counters, MasterCounters { requests: CLEAN_PASS.requests + 1, retries: 1, malformed: 1, ..CLEAN_PASS });
}

/// Step 0's reply ends 90 ms after the request's end (its T3.5 is over by 92 ms, inside
/// the 100 ms timeout): it is taken, with no retry (the next frame is the report).
#[test]
fn a_reply_ending_90_ms_after_the_request_is_taken() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let reply = registers_reply(POLLED, 0x03, &STEP0_VALUES);
    let delay = ms(90) - reply.len() as u64 * bus.char_cycles();
    let sent = bus.answer_with(&first, delay, &reply, None);
    println!("the reply ends {} after the request", fmt_us(sent.end - first.end));
    bus.report(0, &[&[ANSWERED][..], &STEP0_VALUES].concat());
}

/// Step 0's reply starts 97 ms after the request's end and ends at 104.4 ms, past the
/// 100 ms timeout: it is not taken; the master does not talk over it (its retry starts
/// T3.5 or more after the reply's end), and with the retry unanswered the report says
/// timeout.
#[test]
fn a_reply_still_on_the_line_at_the_response_timeout_is_not_taken() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let late = bus.answer_with(&first, ms(97), &registers_reply(POLLED, 0x03, &STEP0_WRONG), None);
    let retry = bus.expect(&step0_request(), "step 0: the retry");
    println!(
        "the late reply: {} to {} after the request; the retry {} after it",
        fmt_us(late.start - first.end),
        fmt_us(late.end - first.end),
        fmt_gap(retry.start as i64 - late.end as i64)
    );
    assert!(
        retry.start >= late.end + bus.t35(),
        "the retry started at cycle {}, {} after the late reply's end (cycle {})",
        retry.start,
        fmt_gap(retry.start as i64 - late.end as i64),
        late.end
    );
    bus.report(0, &[TIMEOUT]);
}

/// Step 0's reply starts 104 ms after the request's end, past the 100 ms timeout, while the
/// retry (sent just over 100 ms after the first try's end) is still on the line: its first
/// characters come while the master sends, and are no reply to it (they are ignored, as a
/// transceiver's echo of the request would be); the rest, a frame without its head, fails
/// its CRC and ends the retry: the report says bad reply.
#[test]
fn a_late_reply_running_into_the_retry_is_no_answer_to_either_try() {
    let mut bus = Bus::boot();
    let first = bus.expect(&step0_request(), "step 0");
    let late = bus.answer_with(&first, ms(104), &registers_reply(POLLED, 0x03, &STEP0_WRONG), None);
    let retry = bus.expect(&step0_request(), "step 0: the retry");
    println!(
        "the retry: cycles {}..{}, {}..{} after the first try; the late reply starts at cycle {}, {} after the retry's start",
        retry.start,
        retry.end,
        fmt_us(retry.start - first.end),
        fmt_us(retry.end - first.end),
        late.start,
        fmt_gap(late.start as i64 - retry.start as i64)
    );
    // The premise: the late reply starts while the retry goes out.
    assert!(
        retry.start < late.start && late.start < retry.end,
        "the late reply (from cycle {}) does not start during the retry (cycles {}..{}): move it",
        late.start,
        retry.start,
        retry.end
    );
    bus.report(0, &[BAD_REPLY]);
}

/// The response timeout counted against the millisecond clock's phase: step 0's reply is
/// delayed by 0, 125, …, 875 µs, which moves step 1's request (sent after step 0's report
/// is acknowledged) across a millisecond of `millis()`; step 1's first try goes
/// unanswered. Each time the retry starts 100 ms or more after the first try's end.
#[test]
fn the_response_timeout_is_never_under_100_ms_whatever_the_phase_of_the_millisecond_clock() {
    let steps = steps();
    let mut waits = Vec::new();
    for k in 0..8 {
        let mut bus = Bus::boot();
        let first = bus.expect(&step0_request(), "step 0");
        let delay = bus.t35() + us_to_cycles(500 + 125 * k);
        bus.answer_with(&first, delay, steps[0].reply.as_ref().unwrap(), None);
        bus.report_status(0, ANSWERED);
        let request = steps[1].request.as_ref().unwrap();
        let first = bus.expect(request, "step 1: unanswered");
        let retry = bus.expect(request, "step 1: the retry");
        println!(
            "first try ends at {:.3} ms of Timer0 (cycle {}), the retry starts {} later (cycle {})",
            timer0_ms(&bus.rtu, first.end),
            first.end,
            fmt_us(retry.start - first.end),
            retry.start
        );
        waits.push((retry.start - first.end, first.end, retry.start));
    }
    let &(least, end, start) = waits.iter().min().unwrap();
    assert!(
        least >= ms(RESPONSE_MS),
        "the retry started {} after the first try's end (cycles {end} to {start})",
        fmt_us(least)
    );
}

// ---------------------------------------------------------------------------------------
// Latency (informational)

/// For every request the master sends right after an outcome that a slave's reply
/// brought (the reply judged T3.5 after its end), how long after that T3.5 point its
/// first start bit came: printed; the only assertion is that none came before it.
#[test]
fn latency_of_each_request_after_the_t35_that_ends_the_previous_reply() {
    let mut bus = Bus::boot();
    let counters = rest_of_pass(&mut bus, 0);
    assert_eq!(counters, CLEAN_PASS, "the counters after a pass");
    let t35 = bus.t35() as i64;
    let mut latencies = Vec::new();
    for s in bus.silences() {
        let Some(before) = s.before else { continue };
        if !matches!(bus.log[before].who, Who::Slave(_)) {
            continue;
        }
        let frame = &bus.log[s.index];
        let latency = s.gap - t35;
        println!(
            "{:>9}: {:02X?} {}",
            fmt_gap(latency),
            &frame.bytes[..frame.bytes.len().min(7)],
            bus.describe(Some(before))
        );
        assert!(latency >= 0, "{:02X?} started {} before the T3.5 point", frame.bytes, fmt_us(latency.unsigned_abs()));
        latencies.push(latency);
    }
    let (min, max) = (latencies.iter().min().unwrap(), latencies.iter().max().unwrap());
    let mean = latencies.iter().sum::<i64>() / latencies.len() as i64;
    println!(
        "{} requests after a reply: T3.5 + {} min, {} mean, {} max",
        latencies.len(),
        fmt_gap(*min),
        fmt_gap(mean),
        fmt_gap(*max)
    );
}
