//! Two slaves on one chip, one model (`examples/two_lines.rs` on the simulated Mega 2560,
//! built by `make chips` into `atmega2560-two-lines`): the contract's map on Serial (USART0,
//! slave 1, 19200 8E1, silences on Timer0's compare B) and on Serial1 (USART1, slave 2,
//! 9600 8N1, compare A). A write on one line is read back on the other at once; each line
//! keeps its own T1.5 and T3.5 (the two baud rates' differ) while requests overlap on both
//! lines, at every phase of the other line's frame; each line answers to its own id alone and
//! executes broadcasts.

mod sim;

use sim::{chip_variant_firmware, read_request, registers_reply, us_to_cycles, with_crc, write_register_request, Line};
use uno_sim::{Chip, Options, TxByte, Uno};

/// A line of the firmware's: its USART, slave id and settings.
#[derive(Clone, Copy)]
struct Side {
    usart: u8,
    id: u8,
    line: Line,
}

/// Serial: slave 1, 19200 8E1.
const SERIAL: Side = Side { usart: 0, id: 1, line: Line::B19200_8E1 };
/// Serial1: slave 2, 9600 8N1.
const SERIAL1: Side = Side { usart: 1, id: 2, line: Line::B9600_8N1 };

/// How late after T3.5 a reply may start: Timer0's two ticks and the compare interrupt's
/// cycles (25 µs, as for one slave: `tests/sim_boards.rs`), plus the other line's longest
/// interrupt that may hold this one's off: its compare interrupt processing a request (FC 3
/// of 16 registers here: 96 µs late at worst was seen, 19–26 µs else).
const LATE_US: u64 = 25 + 100;

/// The firmware on the simulated Mega, both lines timed.
struct Two {
    uno: Uno,
    /// One character, in cycles, per line (index: the USART).
    char_cycles: [u64; 2],
    /// The end of the last character on each line, either way.
    quiet_since: [u64; 2],
}

/// A request sent on a line and the reply it got.
struct Answer {
    request_end: u64,
    reply: Vec<TxByte>,
}

impl Answer {
    fn bytes(&self) -> Vec<u8> {
        self.reply.iter().map(|t| t.byte).collect()
    }

    /// Cycles from the request's last stop bit to the reply's first start bit.
    fn turnaround(&self) -> u64 {
        let first = self.reply.first().expect("a reply");
        first.start_cycle.checked_sub(self.request_end).expect("the reply started before the request ended")
    }
}

impl Two {
    fn boot() -> Two {
        let elf = chip_variant_firmware(Chip::Atmega2560, 0, "-two-lines", "two_lines");
        let mut uno = Uno::load_with(elf, Options::new().usart(0).second_usart(1)).expect("the firmware loads");
        uno.run_for(us_to_cycles(2000)).unwrap();
        let char_cycles = [0, 1].map(|u| uno.wire_char_cycles_on(u).expect("both USARTs are set up"));
        for side in [SERIAL, SERIAL1] {
            let config = uno.serial_config_on(side.usart).unwrap();
            let l = side.line;
            assert!(config.matches(l.baud, l.data_bits, l.parity, l.stop_bits), "USART{} is {}", side.usart, l.name());
        }
        let now = uno.now();
        Two { uno, char_cycles, quiet_since: [now; 2] }
    }

    /// The earliest end of a request's first character on `side` after T3.5 and `margin`
    /// cycles of silence there.
    fn first_end(&self, side: Side, margin: u64) -> u64 {
        let u = usize::from(side.usart);
        (self.quiet_since[u] + side.line.t35() + margin).max(self.uno.now()) + self.char_cycles[u]
    }

    /// Schedules `bytes` on `side`, the first character ending at `first_end`, `gap` idle
    /// cycles after the first `split` characters; returns the last one's end.
    fn send_at(&mut self, side: Side, bytes: &[u8], first_end: u64, split: usize, gap: u64) -> u64 {
        let u = usize::from(side.usart);
        let mut end = self.uno.send_frame_on(side.usart, &bytes[..split], first_end, 0).unwrap();
        if split < bytes.len() {
            end = self.uno.send_frame_on(side.usart, &bytes[split..], end + gap + self.char_cycles[u], 0).unwrap();
        }
        self.quiet_since[u] = self.quiet_since[u].max(end);
        end
    }

    /// Runs until `side`'s reply to a request that ended at `request_end` has left the line
    /// (what the other line sends meanwhile stays for it), or T3.5 and ten characters after
    /// the request when none has started by then.
    fn reply(&mut self, side: Side, request_end: u64) -> Answer {
        let u = usize::from(side.usart);
        let char = self.char_cycles[u];
        let deadline = request_end + side.line.t35() + 10 * char;
        let mut reply = self.uno.run_until_tx_idle_on(side.usart, 4 * char, deadline).unwrap();
        // A reply goes on until its line has been quiet for four characters.
        while let Some(last) = reply.last() {
            let quiet_at = last.end_cycle + 4 * char;
            if self.uno.now() >= quiet_at {
                break;
            }
            self.uno.run_until(quiet_at).unwrap();
            reply.extend(self.uno.take_tx_on(side.usart).unwrap());
        }
        if let Some(last) = reply.last() {
            self.quiet_since[u] = self.quiet_since[u].max(last.end_cycle);
        }
        Answer { request_end, reply }
    }

    /// Sends `request` on `side` after T3.5 of silence and returns the reply.
    fn ask(&mut self, side: Side, request: &[u8]) -> Answer {
        let first = self.first_end(side, 0);
        let end = self.send_at(side, request, first, request.len(), 0);
        self.reply(side, end)
    }

    /// Sends `a` on `side_a` and `b` on `side_b` so that `b`'s last character ends `offset`
    /// cycles after `a`'s (before it when negative); returns both answers, each checked to
    /// start T3.5 after its request at the earliest and [`LATE_US`] after it at the latest.
    fn overlap(
        &mut self,
        (side_a, a): (Side, &[u8]),
        (side_b, b): (Side, &[u8]),
        offset: i64,
        what: &str,
    ) -> [Answer; 2] {
        let (ua, ub) = (usize::from(side_a.usart), usize::from(side_b.usart));
        let len_a = (a.len() as u64 - 1) * self.char_cycles[ua];
        let len_b = (b.len() as u64 - 1) * self.char_cycles[ub];
        // The earliest end of `a`'s last character, and of `b`'s, each after T3.5 of silence.
        let end_a = self.first_end(side_a, 0) + len_a;
        let end_b = self.first_end(side_b, 0) + len_b;
        let end_a = end_a.max((end_b as i64 - offset) as u64);
        let end_b = (end_a as i64 + offset) as u64;
        let sent_a = self.send_at(side_a, a, end_a - len_a, a.len(), 0);
        let sent_b = self.send_at(side_b, b, end_b - len_b, b.len(), 0);
        let answers = [self.reply(side_a, sent_a), self.reply(side_b, sent_b)];
        for (answer, side) in answers.iter().zip([side_a, side_b]) {
            let t35 = side.line.t35();
            assert!(!answer.reply.is_empty(), "{what}: USART{} gave no reply", side.usart);
            let turnaround = answer.turnaround();
            assert!(
                turnaround >= t35 && turnaround <= t35 + us_to_cycles(LATE_US),
                "{what}: USART{}'s reply started {} µs after its request, T3.5 is {} µs",
                side.usart,
                turnaround / 16,
                t35 / 16
            );
        }
        answers
    }

    /// Runs `us` microseconds.
    fn run_us(&mut self, us: u64) {
        self.uno.run_for(us_to_cycles(us)).unwrap();
    }

    /// Nothing was sent on either line since the last take.
    fn assert_silent(&mut self, what: &str) {
        for u in [0, 1] {
            let tx = self.uno.take_tx_on(u).unwrap();
            assert!(tx.is_empty(), "{what}: USART{u} sent {:02X?}", tx.iter().map(|t| t.byte).collect::<Vec<_>>());
        }
    }
}

/// FC 16 of `values` at holding register `start` (0-based) for `id`.
fn write_registers(id: u8, start: u16, values: &[u16]) -> Vec<u8> {
    let mut frame = vec![id, 0x10];
    frame.extend_from_slice(&start.to_be_bytes());
    frame.extend_from_slice(&(values.len() as u16).to_be_bytes());
    frame.push(2 * values.len() as u8);
    for v in values {
        frame.extend_from_slice(&v.to_be_bytes());
    }
    with_crc(&frame)
}

/// A write on either line is read on the other at once: the read's request ends just
/// after the write's T3.5 (when it ran), while the write's reply is still on its line.
/// The loop's 30001/30002 show how many master writes and which line made the last.
#[test]
fn a_write_on_one_line_is_read_on_the_other_at_once() {
    let mut two = Two::boot();
    let values = [0x1234, 0xABCD];
    let write = write_registers(SERIAL.id, 4, &values);
    let read = read_request(SERIAL1.id, 0x03, 4, 2);
    // The read on Serial1 ends 150 µs after the write's T3.5 on Serial.
    let offset = (SERIAL.line.t35() + us_to_cycles(150)) as i64;
    let [w, r] = two.overlap((SERIAL, &write), (SERIAL1, &read), offset, "write on Serial, read on Serial1");
    assert_eq!(w.bytes(), with_crc(&[SERIAL.id, 0x10, 0, 4, 0, 2]), "the write's reply");
    assert_eq!(r.bytes(), registers_reply(SERIAL1.id, 0x03, &values), "Serial1 reads Serial's write");

    // And back: FC 6 on Serial1, read on Serial right after its T3.5.
    let write = write_register_request(SERIAL1.id, 4, 0x5A5A);
    let read = read_request(SERIAL.id, 0x03, 4, 2);
    let offset = (SERIAL1.line.t35() + us_to_cycles(150)) as i64;
    let [w, r] = two.overlap((SERIAL1, &write), (SERIAL, &read), offset, "write on Serial1, read on Serial");
    assert_eq!(w.bytes(), write, "FC 6 echoes");
    assert_eq!(r.bytes(), registers_reply(SERIAL.id, 0x03, &[0x5A5A, 0xABCD]), "Serial reads Serial1's write");

    // Coils: FC 5 on Serial, FC 1 on Serial1.
    let fc5 = with_crc(&[SERIAL.id, 0x05, 0x00, 0x02, 0xFF, 0x00]);
    assert_eq!(two.ask(SERIAL, &fc5).bytes(), fc5, "FC 5 echoes");
    let fc1 = two.ask(SERIAL1, &read_request(SERIAL1.id, 0x01, 0, 16));
    assert_eq!(fc1.bytes(), with_crc(&[SERIAL1.id, 0x01, 2, 0x04, 0x00]), "Serial1 reads Serial's coil");

    // Three master writes; the last on Serial (1).
    two.run_us(1000);
    let info = two.ask(SERIAL1, &read_request(SERIAL1.id, 0x04, 0, 2));
    assert_eq!(info.bytes(), registers_reply(SERIAL1.id, 0x04, &[3, 1]), "30001: writes, 30002: the last line");
    two.ask(SERIAL1, &write_register_request(SERIAL1.id, 0, 7));
    two.run_us(1000);
    let info = two.ask(SERIAL, &read_request(SERIAL.id, 0x04, 0, 2));
    assert_eq!(info.bytes(), registers_reply(SERIAL.id, 0x04, &[4, 2]), "30001: writes, 30002: the last line");
}

/// Requests on both lines at once, the second line's ending at many points of the first's
/// frame, its T3.5 and its reply (both ways round): each line answers right, T3.5 after its
/// own request (its own baud rate's) and not later than [`LATE_US`] after. A gap inside a
/// frame is measured against each line's own T1.5: Serial1's 1.2 characters at 9600 (over
/// Serial's T1.5 in time, under its own) keeps the frame; 2 characters drop it.
#[test]
fn both_lines_keep_their_own_silences_while_both_are_busy() {
    let mut two = Two::boot();
    two.ask(SERIAL, &write_registers(SERIAL.id, 0, &[1, 2, 3, 4, 5, 6, 7, 8]));
    let long_read = read_request(SERIAL.id, 0x03, 0, 16);
    let short_read = read_request(SERIAL1.id, 0x03, 0, 2);
    let mut holding = [0u16; 16];
    holding[..8].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
    let long_reply = registers_reply(SERIAL.id, 0x03, &holding);
    let short_reply = registers_reply(SERIAL1.id, 0x03, &[1, 2]);
    let c0 = two.char_cycles[0] as i64;
    // Serial1's request ends from 8 Serial characters before Serial's to 12 after (past
    // Serial's T3.5 and into its reply), in steps that fall on every phase of Timer0's tick.
    for step in 0..24 {
        let offset = -8 * c0 + step * (20 * c0) / 23 + step * 37;
        let what = format!("Serial1's request ending {} µs after Serial's", offset / 16);
        let [a, b] = two.overlap((SERIAL, &long_read), (SERIAL1, &short_read), offset, &what);
        assert_eq!(a.bytes(), long_reply, "{what}: Serial's reply");
        assert_eq!(b.bytes(), short_reply, "{what}: Serial1's reply");
    }
    // The other way round: Serial's short request ends inside Serial1's long one and its T3.5.
    let long_read = read_request(SERIAL1.id, 0x03, 0, 16);
    let short_read = read_request(SERIAL.id, 0x03, 0, 2);
    let long_reply = registers_reply(SERIAL1.id, 0x03, &holding);
    let short_reply = registers_reply(SERIAL.id, 0x03, &[1, 2]);
    let c1 = two.char_cycles[1] as i64;
    for step in 0..12 {
        let offset = -6 * c1 + step * (10 * c1) / 11 + step * 53;
        let what = format!("Serial's request ending {} µs after Serial1's", offset / 16);
        let [a, b] = two.overlap((SERIAL1, &long_read), (SERIAL, &short_read), offset, &what);
        assert_eq!(a.bytes(), long_reply, "{what}: Serial1's reply");
        assert_eq!(b.bytes(), short_reply, "{what}: Serial's reply");
    }

    // T1.5 per line, with the other line busy meanwhile: Serial1's gap of 1.2 of its
    // characters (longer than Serial's T1.5) keeps its frame, 2 characters drop it; Serial's
    // gap of 2 of its characters (shorter than Serial1's T1.5) drops its frame.
    let c1 = two.char_cycles[1];
    let c0 = two.char_cycles[0];
    assert!(12 * c1 / 10 > SERIAL.line.t15() && 12 * c1 / 10 < SERIAL1.line.t15());
    for (gap, kept) in [(12 * c1 / 10, true), (2 * c1, false)] {
        let busy = read_request(SERIAL.id, 0x03, 0, 16);
        let first = two.first_end(SERIAL1, 0).max(two.first_end(SERIAL, 0));
        let end1 = two.send_at(SERIAL1, &short_read_for(SERIAL1.id), first, 3, gap);
        let end0 = two.send_at(SERIAL, &busy, first + c1, busy.len(), 0);
        let answer = two.reply(SERIAL1, end1);
        let what = format!("Serial1, a gap of {} µs", gap / 16);
        if kept {
            assert_eq!(answer.bytes(), registers_reply(SERIAL1.id, 0x03, &[1, 2]), "{what}: kept");
        } else {
            assert!(answer.reply.is_empty(), "{what}: answered {:02X?}", answer.bytes());
        }
        assert_eq!(two.reply(SERIAL, end0).bytes(), long_reply_for(SERIAL.id, &holding), "{what}: Serial meanwhile");
    }
    assert!(2 * c0 > SERIAL.line.t15() && 2 * c0 < SERIAL1.line.t15());
    let first = two.first_end(SERIAL, 0);
    let end0 = two.send_at(SERIAL, &short_read_for(SERIAL.id), first, 3, 2 * c0);
    let answer = two.reply(SERIAL, end0);
    assert!(answer.reply.is_empty(), "Serial, a gap of 2 characters: answered {:02X?}", answer.bytes());
    let answer = two.ask(SERIAL, &short_read_for(SERIAL.id));
    assert_eq!(answer.bytes(), registers_reply(SERIAL.id, 0x03, &[1, 2]), "Serial after the dropped frame");
}

/// FC 3 of 40001–40002 for `id`.
fn short_read_for(id: u8) -> Vec<u8> {
    read_request(id, 0x03, 0, 2)
}

/// The reply to FC 3 of 40001–40016 holding `holding`.
fn long_reply_for(id: u8, holding: &[u16; 16]) -> Vec<u8> {
    registers_reply(id, 0x03, holding)
}

/// Each line answers its own id alone; a broadcast on either is executed (seen on the
/// other) and answered on neither, even with the other line's request in progress; each
/// line counts its own frames.
#[test]
fn ids_broadcasts_and_counters_are_each_lines_own() {
    let mut two = Two::boot();
    for (side, other) in [(SERIAL, SERIAL1), (SERIAL1, SERIAL)] {
        let answer = two.ask(side, &read_request(other.id, 0x03, 0, 1));
        assert!(answer.reply.is_empty(), "USART{} answered id {}: {:02X?}", side.usart, other.id, answer.bytes());
        let answer = two.ask(side, &read_request(side.id, 0x03, 0, 1));
        assert_eq!(answer.reply.len(), 7, "USART{} answers its id {} next", side.usart, side.id);
    }
    two.assert_silent("after the ids");
    // A broadcast FC 6 on Serial1 while Serial reads: executed, unanswered.
    let broadcast = write_register_request(0, 9, 0x0B0B);
    let read = read_request(SERIAL.id, 0x03, 9, 1);
    let first1 = two.first_end(SERIAL1, 0).max(two.first_end(SERIAL, 0));
    let end1 = two.send_at(SERIAL1, &broadcast, first1, broadcast.len(), 0);
    let end0 = two.send_at(SERIAL, &read, first1, read.len(), 0);
    let answer = two.reply(SERIAL1, end1);
    assert!(answer.reply.is_empty(), "Serial1 answered a broadcast: {:02X?}", answer.bytes());
    two.reply(SERIAL, end0);
    let answer = two.ask(SERIAL, &read);
    assert_eq!(answer.bytes(), registers_reply(SERIAL.id, 0x03, &[0x0B0B]), "Serial reads Serial1's broadcast");
    // A broadcast FC 16 on Serial: Serial1 reads it.
    let broadcast = write_registers(0, 10, &[0xC0DE]);
    let first = two.first_end(SERIAL, 0);
    let end = two.send_at(SERIAL, &broadcast, first, broadcast.len(), 0);
    let answer = two.reply(SERIAL, end);
    assert!(answer.reply.is_empty(), "Serial answered a broadcast: {:02X?}", answer.bytes());
    let answer = two.ask(SERIAL1, &read_request(SERIAL1.id, 0x03, 10, 1));
    assert_eq!(answer.bytes(), registers_reply(SERIAL1.id, 0x03, &[0xC0DE]), "Serial1 reads Serial's broadcast");
    // Each line's counters (the loop keeps them in 30004–30007): Serial had 4 frames for it
    // (or broadcast), Serial1 3; a bad CRC on Serial1 counts there alone.
    let mut bad = read_request(SERIAL1.id, 0x03, 0, 1);
    bad[6] ^= 1;
    let answer = two.ask(SERIAL1, &bad);
    assert!(answer.reply.is_empty(), "Serial1 answered a bad CRC");
    let answer = two.ask(SERIAL, &read_request(SERIAL.id, 0x04, 3, 4));
    assert_eq!(answer.bytes(), registers_reply(SERIAL.id, 0x04, &[4, 3, 0, 1]), "messages and CRC errors per line");
    two.assert_silent("at the end");
}
