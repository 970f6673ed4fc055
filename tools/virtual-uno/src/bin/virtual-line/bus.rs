//! The half-duplex line and everything on it, on one simulated clock.
//!
//! Every board runs up to the same cycle in small slices (a tenth of a character). After
//! each slice the characters the boards started are collected (`take_tx`: known from the
//! UDRn write, before their start bit), each board's DE pin is sampled, and every character
//! whose decision time has come is put on the line, or not:
//!
//! * Its **decision time** is two bit times before its end: after the receivers have sampled
//!   its data and parity bits and before any of them flags it (half a bit before the end,
//!   1.5 bits with two stop bits), so it can still be handed to them with real-wire timing.
//! * A board with `de=PIN` drives the line only while PIN is high: DE low at the first
//!   sample after the start bit began: the character never reaches the line ("muted");
//!   high then, but low at a later sample before the decision: it is cut off, and reaches
//!   the receivers with a framing error ("cut").
//! * Two characters from different transmitters overlap when their spans from start bit to
//!   decision time overlap: both are garbled, and reach the receivers with a framing error
//!   (two characters ending at the same cycle reach them once).
//! * Each character reaches every board and pty except its sender (an RS-485 transceiver
//!   with /RE tied to DE does not hear itself): a board gets it with the error its line
//!   settings imply against the sender's, a pty once its stop bit has ended.
//!
//! A frame on the line ends with 3.5 character times of silence (1750 us above 19200 bps),
//! or when another transmitter starts without it (reported).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use uno_sim::{Error, LineError, Uno, F_CPU};

use crate::args::{char_cycles, DePin};
use crate::control::Command;
use crate::line::{receive_error, Settings};
use crate::net::Net;
use crate::pty::{Link, Pty};
use crate::side::Side;

/// `[   1.234567] ` for a cycle.
pub fn stamp(cycle: u64) -> String {
    format!("[{:11.6}]", cycle as f64 / F_CPU as f64)
}

/// A simulated board.
pub struct Board {
    /// Its name.
    pub name: String,
    /// The chip.
    pub uno: Uno,
    /// The DE pin, if any.
    pub de: Option<DePin>,
    /// A USART off the line, on a pty of its own.
    pub side: Option<Side>,
    /// Watched pins.
    pub watch: Vec<u8>,
    /// Its shield's TCP bridge, if it has one.
    pub net: Option<Net>,
    pins_shown: String,
    serial: Option<Settings>,
    stopped: bool,
    resets: u64,
    /// End cycle of the last character handed to it.
    last_rx_end: u64,
    /// Characters it sent with DE low, not yet reported: (first start, bytes, last end).
    muted: Option<(u64, Vec<u8>, u64)>,
    /// DE high since this sample, if it is.
    de_high_from: Option<u64>,
    /// Recent spans of DE high: (first sample high, first sample low again).
    de_spans: VecDeque<(u64, u64)>,
    /// End of the last character it started.
    last_tx_end: u64,
    /// DE rose (first sample high) and no character has started since.
    de_rise: Option<u64>,
    /// Longest DE lead before a first start bit, and tail after a last stop bit, in cycles
    /// (at the resolution of the DE samples).
    de_lead: Option<(u64, u64)>,
    de_tail: Option<(u64, u64)>,
}

impl Board {
    /// A board around a loaded chip.
    pub fn new(name: String, uno: Uno, de: Option<DePin>, side: Option<Side>, watch: Vec<u8>) -> Board {
        let resets = uno.resets().0;
        Board {
            name,
            uno,
            de,
            side,
            watch,
            net: None,
            pins_shown: String::new(),
            serial: None,
            stopped: false,
            resets,
            last_rx_end: 0,
            muted: None,
            de_high_from: None,
            de_spans: VecDeque::new(),
            last_tx_end: 0,
            de_rise: None,
            de_lead: None,
            de_tail: None,
        }
    }

    /// The DE pin's level: an output driven high (no DE pin: always).
    fn de_level(&self) -> bool {
        match self.de {
            None => true,
            Some(pin) => pin.state(&self.uno).map(|s| s.output && s.level).unwrap_or(false),
        }
    }

    /// Records the DE level sampled at `now`.
    fn sample_de(&mut self, now: u64, level: bool, keep_after: u64) {
        match (self.de_high_from, level) {
            (None, true) => {
                self.de_high_from = Some(now);
                self.de_rise = Some(now);
            }
            (Some(from), false) => {
                self.de_spans.push_back((from, now));
                self.de_high_from = None;
                if self.last_tx_end > from {
                    let tail = now.saturating_sub(self.last_tx_end);
                    self.de_tail = Some(self.de_tail.map_or((tail, tail), |(lo, hi)| (lo.min(tail), hi.max(tail))));
                }
            }
            _ => {}
        }
        while self.de_spans.front().is_some_and(|&(_, to)| to < keep_after) {
            self.de_spans.pop_front();
        }
    }

    /// Whether its DE pin (if it has one) was seen high between `from` and `to`: its driver
    /// was on, driving the line (idle if it sent nothing), and its receiver off.
    fn de_high_during(&self, from: u64, to: u64) -> bool {
        self.de.is_some()
            && (self.de_high_from.is_some_and(|f| f < to) || self.de_spans.iter().any(|&(f, t)| f < to && t > from))
    }

    /// `2=off 3=off 4=on ...`
    pub fn pins_line(&self) -> String {
        let states: Vec<String> = self
            .watch
            .iter()
            .map(|&p| {
                let on = self.uno.pin(p).map(|s| s.level).unwrap_or(false);
                format!("{p}={}", if on { "on" } else { "off" })
            })
            .collect();
        states.join(" ")
    }
}

/// A pty on the line.
pub struct PtyPort {
    /// Its name.
    pub name: String,
    /// The pty.
    pub pty: Pty,
    /// The symlink.
    pub _link: Option<Link>,
    /// End of the last character it put on the line.
    tx_last_end: u64,
    /// Bytes from the line waiting for their end: (end, byte).
    out: VecDeque<(u64, u8)>,
    /// Settings last reported.
    reported: Option<Settings>,
    /// When the program was last handed bytes: the wall time and the simulated cycle.
    heard: Option<(Instant, u64)>,
}

/// How long after it was handed bytes a program's own bytes count as its reaction to them
/// ([`Bus::reaction`]).
const REACTION: Duration = Duration::from_millis(200);

impl PtyPort {
    /// A pty port.
    pub fn new(name: String, pty: Pty, link: Option<Link>) -> PtyPort {
        PtyPort { name, pty, _link: link, tx_last_end: 0, out: VecDeque::new(), reported: None, heard: None }
    }
}

/// One character some transmitter started.
#[derive(Clone, Debug)]
struct Char {
    /// Index of the sender (boards first, then ptys).
    src: usize,
    byte: u8,
    start: u64,
    end: u64,
    decide: u64,
    settings: Settings,
    de_first: Option<bool>,
    de_dropped: bool,
    garbled: bool,
    /// Boards whose DE was high while it was sent, though they sent nothing then.
    contention: Vec<usize>,
}

/// A frame on the line, being collected.
struct Frame {
    start: u64,
    last_end: u64,
    bytes: Vec<u8>,
    senders: Vec<usize>,
    garbled: usize,
    cut: usize,
    max_gap: u64,
    silence_before: Option<u64>,
    contention: Vec<usize>,
}

/// Counters for the summary.
#[derive(Default, Debug)]
pub struct Stats {
    /// Frames per sender (index), collided frames not counted.
    pub frames: Vec<u64>,
    /// Frames with garbled characters.
    pub collisions: u64,
    /// Garbled characters.
    pub garbled: u64,
    /// Characters cut by DE going low.
    pub cut: u64,
    /// Characters sent with DE low.
    pub muted: u64,
    /// Characters garbled by another board's DE high while they were sent (no character of its own).
    pub contention: u64,
    /// Frames with a bad CRC (collided ones not counted).
    pub bad_crc: u64,
}

/// Everything on the line.
pub struct Bus {
    /// The boards.
    pub boards: Vec<Board>,
    /// The ptys.
    pub ptys: Vec<PtyPort>,
    /// The line's settings.
    pub line: Settings,
    /// The shared clock.
    pub now: u64,
    char_cycles: u64,
    t35: u64,
    slice: u64,
    decide_lead: u64,
    pending: Vec<Char>,
    recent: VecDeque<Char>,
    frame: Option<Frame>,
    last_frame_end: Option<u64>,
    /// Counters.
    pub stats: Stats,
}

impl Bus {
    /// A line with these settings; boards and ptys are added before the first step.
    pub fn new(line: Settings, boards: Vec<Board>, ptys: Vec<PtyPort>) -> Bus {
        let char_cycles = char_cycles(&line);
        let bit_cycles = F_CPU / u64::from(line.baud.max(1));
        let t35 = if line.baud > 19200 { 1750 * 16 } else { char_cycles * 7 / 2 };
        let n = boards.len() + ptys.len();
        Bus {
            boards,
            ptys,
            line,
            now: 0,
            char_cycles,
            t35,
            slice: (char_cycles / 10).max(16),
            decide_lead: 2 * bit_cycles,
            pending: Vec::new(),
            recent: VecDeque::new(),
            frame: None,
            last_frame_end: None,
            stats: Stats { frames: vec![0; n], ..Stats::default() },
        }
    }

    /// The name of participant `i`.
    pub fn name(&self, i: usize) -> &str {
        if i < self.boards.len() {
            &self.boards[i].name
        } else {
            &self.ptys[i - self.boards.len()].name
        }
    }

    /// Prints with the current simulated time.
    pub fn say(&self, msg: &str) {
        println!("{} {msg}", stamp(self.now));
    }

    /// Carries out a command for a board.
    pub fn command(&mut self, name: &str, cmd: Command, text: &str) -> Result<(), String> {
        let board =
            self.boards.iter_mut().find(|b| b.name == name).ok_or_else(|| format!("no board named `{name}`"))?;
        cmd.apply(&mut board.uno).map_err(|e| e.to_string())?;
        if cmd == Command::Reset {
            board.stopped = false;
        }
        self.say(&format!("set: {}", text.trim()));
        Ok(())
    }

    /// Prints every board's watched pins.
    pub fn show_pins(&self) {
        for b in &self.boards {
            self.say(&format!("{} pins: {}", b.name, b.pins_line()));
        }
    }

    /// The cycle the next step should not pass: a decision or the frame's end.
    fn next_event(&self) -> u64 {
        let mut t = self.now + self.slice;
        for c in &self.pending {
            t = t.min(c.decide.max(self.now + 1));
        }
        t
    }

    /// The cycle at which an outside program on pty `k` that writes now reacts to the bytes it
    /// was last handed, if that was less than [`REACTION`] ago: the cycle they reached it plus
    /// the wall time since. Its reaction time is kept in simulated time, whatever the
    /// simulation's speed: a slow simulation that was not running while pymodbus answered
    /// (2 cores, several programs) would otherwise see it answer at once, in the answer's
    /// own turnaround, colliding with the master's DE still high.
    pub fn reaction(&self, k: usize) -> Option<u64> {
        let (wall, cycle) = self.ptys[k].heard?;
        let since = wall.elapsed();
        (since < REACTION)
            .then(|| cycle + u64::try_from(since.as_nanos() * u128::from(F_CPU) / 1_000_000_000).unwrap_or(0))
    }

    /// Bytes an outside program wrote to pty `k`: on the line from cycle `at` (not before
    /// now), back to back. Paced, `at` is the cycle the wall clock says: a simulation that
    /// fell behind (a busy machine) does not see an outside program answer sooner, in
    /// simulated time, than it could have.
    pub fn pty_sent(&mut self, k: usize, bytes: &[u8], at: u64) -> Result<(), String> {
        let port = &mut self.ptys[k];
        let settings =
            port.pty.master_settings().map_err(|e| format!("{}: reading the pty's settings: {e}", port.name))?;
        if port.reported != Some(settings) {
            port.reported = Some(settings);
            let same = settings.baud == self.line.baud && settings.stop_bits == self.line.stop_bits;
            let msg = format!(
                "{} sends at {settings}{}",
                port.name,
                if same {
                    String::new()
                } else {
                    format!(", the line is {}: its characters arrive garbled", self.line)
                }
            );
            println!("{} {msg}", stamp(self.now));
        }
        // A pty shows even parity as none: the line's character time when the rates agree.
        let same = settings.baud == self.line.baud && settings.stop_bits == self.line.stop_bits;
        let (char_cycles, tx_settings) =
            if same { (self.char_cycles, self.line) } else { (settings.char_cycles().max(1), settings) };
        let src = self.boards.len() + k;
        for &byte in bytes {
            let start = self.ptys[k].tx_last_end.max(self.now).max(at);
            let end = start + char_cycles;
            self.ptys[k].tx_last_end = end;
            self.pending.push(Char {
                src,
                byte,
                start,
                end,
                decide: end.saturating_sub(self.decide_lead.min(char_cycles / 2)),
                settings: tx_settings,
                de_first: Some(true),
                de_dropped: false,
                garbled: false,
                contention: Vec::new(),
            });
        }
        Ok(())
    }

    /// Runs every board one slice on (up to `limit`), then moves the line on.
    pub fn step(&mut self, limit: u64) -> Result<(), String> {
        let target = self.next_event().min(limit).max(self.now + 1);
        for b in &mut self.boards {
            if b.stopped {
                continue;
            }
            match b.uno.run_until(target) {
                Ok(()) => {}
                Err(e @ Error::Stopped { .. }) => {
                    println!("{} {} stopped: {e}; it waits for a reset (`{} reset`)", stamp(target), b.name, b.name);
                    b.stopped = true;
                }
                Err(e) => return Err(format!("{}: {e}", b.name)),
            }
        }
        self.now = target;
        self.poll_networks();

        // DE samples.
        let levels: Vec<bool> = self.boards.iter().map(Board::de_level).collect();
        let keep_after = self.now.saturating_sub(4 * self.char_cycles);
        for (b, &level) in self.boards.iter_mut().zip(&levels) {
            b.sample_de(self.now, level, keep_after);
        }
        // New characters (a DE that rose in this slice counts as before them).
        for (i, b) in self.boards.iter_mut().enumerate() {
            let settings = b.serial.unwrap_or(self.line);
            for t in b.uno.take_tx() {
                if let Some(rise) = b.de_rise.take() {
                    let lead = t.start_cycle.saturating_sub(rise);
                    b.de_lead = Some(b.de_lead.map_or((lead, lead), |(lo, hi)| (lo.min(lead), hi.max(lead))));
                }
                b.last_tx_end = b.last_tx_end.max(t.end_cycle);
                self.pending.push(Char {
                    src: i,
                    byte: t.byte,
                    start: t.start_cycle,
                    end: t.end_cycle,
                    decide: t.end_cycle.saturating_sub(self.decide_lead),
                    settings,
                    de_first: None,
                    de_dropped: false,
                    garbled: false,
                    contention: Vec::new(),
                });
            }
        }
        for c in &mut self.pending {
            if c.src < levels.len() && c.start <= self.now {
                let level = levels[c.src];
                match c.de_first {
                    None => c.de_first = Some(level),
                    Some(true) if !level => c.de_dropped = true,
                    _ => {}
                }
            }
        }

        self.end_frame_if_quiet();
        // Decide what is due, in the order of the characters' ends.
        self.pending.sort_by_key(|c| (c.decide, c.src));
        while self.pending.first().is_some_and(|c| c.decide <= self.now) {
            let c = self.pending.remove(0);
            self.decide(c)?;
        }
        self.end_frame_if_quiet();
        self.flush_ptys()?;
        for b in &mut self.boards {
            if let Some(side) = &mut b.side {
                side.transmit(&mut b.uno).map_err(|e| format!("{} USART{}: {e}", b.name, side.usart))?;
            }
        }
        self.report_boards();
        Ok(())
    }

    /// The boards' TCP bridges that are due: connections and messages printed with the board's
    /// name and the simulated time.
    fn poll_networks(&mut self) {
        for b in &mut self.boards {
            let Some(net) = b.net.as_mut().filter(|net| b.uno.now() >= net.next_poll()) else { continue };
            for line in net.poll(&mut b.uno) {
                println!("{} {} {line}", stamp(self.now), b.name);
            }
        }
    }

    /// Bytes an outside program wrote to board `i`'s pty of its own: on their way to its USART.
    pub fn side_sent(&mut self, i: usize, bytes: &[u8]) -> Result<(), String> {
        let b = &mut self.boards[i];
        let Some(side) = &mut b.side else { return Ok(()) };
        let report = side.received(&mut b.uno, bytes).map_err(|e| format!("{} USART{}: {e}", b.name, side.usart))?;
        if let Some(report) = report {
            let msg = format!("{} USART{} pty: {report}", b.name, side.usart);
            self.say(&msg);
        }
        Ok(())
    }

    /// Puts character `c` on the line or not, at its decision time.
    fn decide(&mut self, mut c: Char) -> Result<(), String> {
        let driven = c.de_first.unwrap_or(true);
        if !driven {
            self.stats.muted += 1;
            let b = &mut self.boards[c.src];
            match &mut b.muted {
                Some((_, bytes, last)) => {
                    bytes.push(c.byte);
                    *last = c.end;
                }
                None => b.muted = Some((c.start, vec![c.byte], c.end)),
            }
            return Ok(());
        }
        // Overlaps with other transmitters' characters on the line.
        let overlaps = |o: &Char| o.src != c.src && o.start < c.decide && c.start < o.decide;
        for o in self.pending.iter_mut() {
            if o.de_first == Some(true) && o.start <= self.now && overlaps(o) {
                o.garbled = true;
                c.garbled = true;
            }
        }
        for o in self.recent.iter_mut() {
            if overlaps(o) {
                c.garbled = true;
                if !o.garbled {
                    // Already delivered clean, before the overlap was known: cannot happen
                    // (an overlapping start is known by this character's decision), counted anyway.
                    o.garbled = true;
                    self.stats.garbled += 1;
                }
            }
        }
        // A board driving the line (DE high) without sending a character of its own.
        for (j, b) in self.boards.iter().enumerate() {
            let sending = j == c.src
                || self
                    .pending
                    .iter()
                    .chain(self.recent.iter())
                    .any(|o| o.src == j && o.start < c.decide && c.start < o.decide);
            if !sending && b.de_high_during(c.start, c.decide) {
                c.contention.push(j);
            }
        }
        if !c.contention.is_empty() {
            c.garbled = true;
            self.stats.contention += 1;
        }
        let error = if c.garbled || c.de_dropped { Some(LineError::Framing) } else { None };
        if c.garbled {
            self.stats.garbled += 1;
        }
        if c.de_dropped && !c.garbled {
            self.stats.cut += 1;
        }

        // To every board but the sender.
        for (i, b) in self.boards.iter_mut().enumerate() {
            if i == c.src || b.stopped || b.de_high_during(c.start, c.decide) {
                continue; // its receiver is off while its DE is high (/RE tied to DE)
            }
            if c.garbled && b.last_rx_end >= c.end {
                continue; // one garbled character where two ended together
            }
            let cfg = b.uno.serial_config();
            let err = error.or_else(|| cfg.as_ref().and_then(|fw| receive_error(&c.settings, fw)));
            let lead = b.uno.rx_flag_lead().unwrap_or(0);
            let end = c.end.max(b.uno.now() + lead + 1).max(b.last_rx_end + 1);
            let sent = match err {
                None => b.uno.send_byte(c.byte, end),
                Some(e) => b.uno.send_byte_with_error(c.byte, end, e),
            };
            sent.map_err(|e| format!("{}: handing it a character: {e}", b.name))?;
            b.last_rx_end = end;
        }
        let first_pty = self.boards.len();
        for (k, p) in self.ptys.iter_mut().enumerate() {
            if first_pty + k != c.src {
                p.out.push_back((c.end, c.byte));
            }
        }

        // Into the frame.
        if let Some(f) = &self.frame {
            let new_sender = !f.senders.contains(&c.src);
            if (new_sender && !c.garbled) || c.start >= f.last_end + self.t35 {
                self.emit_frame();
            }
        }
        match &mut self.frame {
            Some(f) => {
                f.max_gap = f.max_gap.max(c.start.saturating_sub(f.last_end));
                f.last_end = f.last_end.max(c.end);
                f.bytes.push(c.byte);
                if !f.senders.contains(&c.src) {
                    f.senders.push(c.src);
                }
                f.garbled += usize::from(c.garbled);
                f.cut += usize::from(c.de_dropped && !c.garbled);
                for &j in &c.contention {
                    if !f.contention.contains(&j) {
                        f.contention.push(j);
                    }
                }
            }
            None => {
                self.frame = Some(Frame {
                    start: c.start,
                    last_end: c.end,
                    bytes: vec![c.byte],
                    senders: vec![c.src],
                    garbled: usize::from(c.garbled),
                    cut: usize::from(c.de_dropped && !c.garbled),
                    max_gap: 0,
                    silence_before: self.last_frame_end.map(|e| c.start.saturating_sub(e)),
                    contention: c.contention.clone(),
                });
            }
        }
        self.recent.push_back(c);
        while self.recent.front().is_some_and(|o| o.end + 4 * self.char_cycles < self.now) {
            self.recent.pop_front();
        }
        Ok(())
    }

    /// Ends the frame once the line has been quiet for 3.5 characters (unless a character
    /// that started before that is still to be decided).
    fn end_frame_if_quiet(&mut self) {
        let Some(f) = &self.frame else { return };
        let quiet_at = f.last_end + self.t35;
        if self.now >= quiet_at && !self.pending.iter().any(|c| c.start < quiet_at) {
            self.emit_frame();
        }
        for i in 0..self.boards.len() {
            if let Some((start, bytes, last)) = &self.boards[i].muted {
                if self.now >= *last + self.t35 {
                    println!(
                        "{} {} sent with DE low (not on the line): {}",
                        stamp(*start),
                        self.boards[i].name,
                        hex(bytes)
                    );
                    self.boards[i].muted = None;
                }
            }
        }
    }

    fn emit_frame(&mut self) {
        let Some(f) = self.frame.take() else { return };
        self.last_frame_end = Some(f.last_end);
        let names: Vec<String> = f.senders.iter().map(|&i| self.name(i).to_owned()).collect();
        let mut notes = Vec::new();
        let char_cycles = self.char_cycles;
        let chars = |n: u64| n as f64 / char_cycles as f64;
        if f.garbled > 0 {
            self.stats.collisions += 1;
            let mut who = names.clone();
            who.extend(f.contention.iter().map(|&j| format!("{} (DE high, sending nothing)", self.name(j))));
            notes.push(format!(
                "COLLISION: {} of {} characters garbled, {} driving the line at once",
                f.garbled,
                f.bytes.len(),
                who.join(" and ")
            ));
        } else {
            self.stats.frames[f.senders[0]] += 1;
            if !crc_ok(&f.bytes) {
                self.stats.bad_crc += 1;
                notes.push(if f.bytes.len() < 4 { "too short".to_owned() } else { "bad CRC".to_owned() });
            }
        }
        if f.cut > 0 {
            notes.push(format!("{} characters cut: DE went low while they were sent", f.cut));
        }
        if f.max_gap * 2 > self.char_cycles * 3 {
            notes.push(format!("a gap of {:.1} character times inside", chars(f.max_gap)));
        }
        if let Some(s) = f.silence_before.filter(|&s| s < self.t35) {
            notes.push(format!("only {:.2} character times after the previous frame", chars(s)));
        }
        let notes = if notes.is_empty() { String::new() } else { format!(" ({})", notes.join("; ")) };
        println!("{} frame from {}: {}{notes}", stamp(f.start), names.join("+"), hex(&f.bytes));
    }

    fn flush_ptys(&mut self) -> Result<(), String> {
        for p in &mut self.ptys {
            let due = p.out.iter().take_while(|(end, _)| *end <= self.now).count();
            if due > 0 {
                let bytes: Vec<u8> = p.out.drain(..due).map(|(_, b)| b).collect();
                // Nobody reading: the pty's buffer fills and the rest is lost, as on a wire.
                p.pty.write(&bytes).map_err(|e| format!("{}: writing the pty: {e}", p.name))?;
                p.heard = Some((Instant::now(), self.now));
            }
        }
        Ok(())
    }

    fn report_boards(&mut self) {
        let line = self.line;
        for i in 0..self.boards.len() {
            let b = &self.boards[i];
            let (resets, _) = b.uno.resets();
            let serial = b.uno.serial_config().map(|cfg| Settings::of_firmware(&cfg));
            let pins = if b.watch.is_empty() { String::new() } else { b.pins_line() };
            if resets != b.resets {
                self.say(&format!("{} reset: the program starts again", b.name));
            }
            if serial != b.serial {
                match serial {
                    Some(s) if s.baud == line.baud && s.parity == line.parity && s.stop_bits == line.stop_bits => {
                        self.say(&format!("{} serial: {s} (USART{})", b.name, b.uno.usart()))
                    }
                    Some(s) => {
                        self.say(&format!("{} serial: {s} (USART{}); the line is {line}!", b.name, b.uno.usart()))
                    }
                    None => self.say(&format!("{} serial: off", b.name)),
                }
            }
            if pins != b.pins_shown {
                self.say(&format!("{} pins: {pins}", b.name));
            }
            if let Some(side) = &b.side {
                let serial = b.uno.serial_config_on(side.usart).map(|cfg| Settings::of_firmware(&cfg));
                if serial != side.serial {
                    let what = serial.map_or("off".to_owned(), |s| s.to_string());
                    self.say(&format!("{} serial: {what} (USART{}, on its pty)", b.name, side.usart));
                }
            }
            let b = &mut self.boards[i];
            if let Some(side) = &mut b.side {
                side.serial = b.uno.serial_config_on(side.usart).map(|cfg| Settings::of_firmware(&cfg));
            }
            b.resets = resets;
            b.serial = serial;
            b.pins_shown = pins;
        }
    }

    /// How long each board with a DE pin held it high around its frames.
    pub fn de_report(&self) -> Vec<String> {
        let us = |c: u64| c / uno_sim::CYCLES_PER_US;
        let range = |r: Option<(u64, u64)>| r.map_or("?".to_owned(), |(lo, hi)| format!("{}-{}", us(lo), us(hi)));
        self.boards
            .iter()
            .filter_map(|b| {
                let pin = b.de?;
                Some(match (b.de_lead, b.de_tail) {
                    (None, None) => format!("DE of {} ({pin}): never high around a character", b.name),
                    (lead, tail) => format!(
                        "DE of {} ({pin}): high {} us before a frame's first start bit, low {} us after its last stop bit (DE sampled every {} us)",
                        b.name,
                        range(lead),
                        range(tail),
                        us(self.slice)
                    ),
                })
            })
            .collect()
    }

    /// What went through each board's pty of its own.
    pub fn side_report(&self) -> Vec<String> {
        self.boards
            .iter()
            .filter_map(|b| {
                let side = b.side.as_ref()?;
                let (received, sent) = side.counts();
                Some(format!(
                    "{} USART{} on its pty ({}): {received} bytes received, {sent} sent",
                    b.name,
                    side.usart,
                    side.link_path.display()
                ))
            })
            .collect()
    }

    /// The summary line.
    pub fn summary(&self) -> String {
        let per: Vec<String> =
            self.stats.frames.iter().enumerate().map(|(i, n)| format!("{} {n}", self.name(i))).collect();
        format!(
            "summary: {:.3} s simulated; frames: {}; collisions: {} ({} characters garbled); bad CRC: {}; cut by DE: {}; sent with DE low: {}; DE high over another's characters: {}",
            self.now as f64 / F_CPU as f64,
            per.join(", "),
            self.stats.collisions,
            self.stats.garbled,
            self.stats.bad_crc,
            self.stats.cut,
            self.stats.muted,
            self.stats.contention
        )
    }

    /// At exit: the frame still in progress, which the end of the run may have cut short,
    /// printed as such and not counted.
    pub fn finish(&mut self) {
        if let Some(f) = self.frame.take() {
            let names: Vec<String> = f.senders.iter().map(|&i| self.name(i).to_owned()).collect();
            println!(
                "{} frame from {}: {} (still on the line when the run ended)",
                stamp(f.start),
                names.join("+"),
                hex(&f.bytes)
            );
        }
    }
}

/// `01 02 0A`
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

/// Modbus RTU CRC of the frame (its last two bytes, low byte first).
pub fn crc_ok(frame: &[u8]) -> bool {
    if frame.len() < 4 {
        return false;
    }
    let (body, crc) = frame.split_at(frame.len() - 2);
    let mut c: u16 = 0xFFFF;
    for &b in body {
        c ^= u16::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xA001 } else { c >> 1 };
        }
    }
    c.to_le_bytes() == [crc[0], crc[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_a_read_discrete_inputs_request() {
        assert!(crc_ok(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x02, 0xF9, 0xCB]));
        assert!(!crc_ok(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x02, 0xF9, 0xCC]));
        assert_eq!(hex(&[1, 0xab]), "01 AB");
    }
}
