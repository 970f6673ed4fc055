//! The Modbus TCP to RTU gateway (features `tcp` and `master`: `examples/tcp_gateway.rs` as
//! `make tcp-firmware` builds it, an Uno with a W5100, RS-485 on USART0 at 19200 8E1, the
//! chip polled or, `tcp_gateway!(…; pin2_int)`, served from its INT line on pin 2): its flash
//! and static RAM, and the three overheads issue 36 sets targets for, at p99 with four TCP
//! masters polling three slaves:
//!
//! 1. to the line: from a TCP request's last byte in the chip to the RTU request's first
//!    start bit, less the part of T3.5 the line was still owed after the frame before it
//!    (≤ 200 µs);
//! 2. to TCP: from the RTU reply's end plus T3.5 (where the spec puts the frame's end: its
//!    last stop bit, then T3.5 of silence) to the TCP reply's SEND command (≤ 300 µs);
//! 3. the next request: with requests queued, from the last reply's end plus T3.5 to the
//!    next RTU request's first start bit (≤ 25 µs).
//!
//! Each master asks one of the slaves for one or two holding registers, waits for the
//! answer, then thinks 0–60 ms: the line is now idle (overhead 1), now has requests queued
//! (overhead 3). Each request lands in the chip at a random phase of the firmware's poll.
//! Everything is taken in simulated cycles: the requests' landing (`W5x00::deliver_at`),
//! the SENDs the chip records, the line's characters, and every SPI access
//! (`W5x00::record_spi`), from which the report says where the time goes.

use std::fmt::Write as _;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::path::Path;

use uno_sim::wiznet::regs::state;
use uno_sim::wiznet::SpiAccess;
use uno_sim::{cycles_to_us, us_to_cycles, Options, TxByte, Uno, Wiznet};

use crate::elf::{avr_size, chip_build_path};
use crate::log::Log;
use crate::modbus::crc16;
use crate::random::Lcg;
use crate::Result;

/// `make tcp-firmware`'s builds of the gateway: build directory, INT line wired.
const VARIANTS: [(&str, bool); 2] = [("atmega328p-tcp-gateway", false), ("atmega328p-tcp-gateway-int", true)];
const NAME: &str = "tcp_gateway";
/// TCP masters, each on a socket of its own (the W5100 has four).
const MASTERS: usize = 4;
/// Simulated time the masters poll.
const SECONDS: u64 = 20;
/// A slave answers this long after T3.5 following a request's end.
const SLAVE_DELAY_US: u64 = 500;
/// The longest a master thinks between an answer and its next request.
const THINK_MS: u64 = 60;
/// The targets, at p99.
const TO_LINE_US: f64 = 200.0;
const TO_TCP_US: f64 = 300.0;
const NEXT_US: f64 = 25.0;
/// Issue 36's flash and static RAM targets for the gateway on the Uno (the goal), and the
/// ceiling issue 43 set once the gateway had to check what it forwards and follow each
/// slave's health.
const FLASH_TARGET: u64 = 6144;
const RAM_TARGET: u64 = 700;
const FLASH_CEILING: u64 = 8704;
const RAM_CEILING: u64 = 850;

/// T3.5 at 19200 8E1: 3.5 characters of 11 bits, in cycles.
const T35: u64 = (35 * 11 * uno_sim::F_CPU).div_ceil(10 * 19_200);

/// One overhead's samples and the SPI accesses within them.
pub(crate) struct Overhead {
    /// Cycles, sorted.
    cycles: Vec<u64>,
    /// Per sample: cycles from the window's start to its first SPI access.
    before_spi: Vec<u64>,
    /// SPI accesses in all the windows, by kind ([`Kind`]).
    accesses: [u64; KINDS],
}

impl Overhead {
    fn new() -> Overhead {
        Overhead { cycles: Vec::new(), before_spi: Vec::new(), accesses: [0; KINDS] }
    }

    /// A window from `from` to `to`, with the SPI accesses of `log` (sorted) inside it.
    fn add(&mut self, from: u64, to: u64, log: &[SpiAccess]) {
        self.cycles.push(to.saturating_sub(from));
        let first = log.partition_point(|a| a.cycle <= from);
        let last = log.partition_point(|a| a.cycle <= to);
        let inside = &log[first..last];
        self.before_spi.push(inside.first().map_or(to, |a| a.cycle).saturating_sub(from));
        for a in inside {
            self.accesses[kind(a) as usize] += 1;
        }
    }

    fn percentile(&self, pct: usize) -> u64 {
        let sorted = &self.cycles;
        sorted.get((sorted.len() * pct / 100).min(sorted.len().saturating_sub(1))).copied().unwrap_or(0)
    }

    fn mean_accesses(&self, kind: Kind) -> f64 {
        self.accesses[kind as usize] as f64 / self.cycles.len().max(1) as f64
    }
}

/// What a W5100 SPI access reaches.
#[derive(Clone, Copy)]
enum Kind {
    /// IR (0x0015): which sockets have news, the poll's first question.
    Ir,
    /// A socket's Sn_IR, Sn_SR or Sn_CR.
    SocketState,
    /// A socket's pointers and sizes (Sn_TX_FSR … Sn_RX_RD).
    Pointers,
    /// The TX buffer: an answer written.
    TxBuffer,
    /// The RX buffer: a request read.
    RxBuffer,
    /// Anything else.
    Other,
}

const KINDS: usize = Kind::Other as usize + 1;
const KIND_NAMES: [&str; KINDS] = ["IR", "Sn_IR/SR/CR", "pointers", "TX buffer", "RX buffer", "other"];

fn kind(a: &SpiAccess) -> Kind {
    match a.addr {
        0x0015 => Kind::Ir,
        0x0400..=0x07FF if a.addr & 0xFF <= 0x03 => Kind::SocketState,
        0x0400..=0x07FF if (0x20..=0x29).contains(&(a.addr & 0xFF)) => Kind::Pointers,
        0x4000..=0x5FFF => Kind::TxBuffer,
        0x6000..=0x7FFF => Kind::RxBuffer,
        _ => Kind::Other,
    }
}

/// Everything measured: each variant built.
pub(crate) type Measured = Vec<Variant>;

/// One build's figures.
pub(crate) struct Variant {
    build: &'static str,
    int: bool,
    size: Option<(u64, u64)>,
    to_line: Overhead,
    to_tcp: Overhead,
    next: Overhead,
    /// Median cycles between two SPI accesses in one burst (less than 20 µs apart).
    per_access: u64,
    transactions: usize,
}

/// A request of a TCP master, from its landing to its answer.
struct Request {
    transaction: u16,
    /// Address (unit) and PDU: the RTU request without its CRC.
    frame: Vec<u8>,
    landed: u64,
    /// The RTU request's first start bit, and the slave's reply's last stop bit.
    on_line: Option<u64>,
    reply_end: Option<u64>,
    /// The answer it must get (MBAP header and PDU).
    expected: Vec<u8>,
}

struct Master {
    socket: usize,
    transaction: u16,
    pending: Option<Request>,
    next_at: u64,
    inbox: Vec<u8>,
    sends_seen: usize,
}

/// Slave `id`'s holding register `at`.
fn register(id: u8, at: u16) -> u16 {
    u16::from(id) << 12 | at << 4 | 0x5
}

/// The gateway of `build`, its three slaves and four masters, run for [`SECONDS`].
fn run(root: &Path, (build, int): (&'static str, bool), log: &mut Log) -> Result<Variant> {
    let elf = chip_build_path(root, build, NAME);
    let mut options = Options::new().wiznet(Wiznet::W5100);
    if int {
        // The W5100 shield's solder jumper: INT to pin 2 (PD2).
        options = options.wiznet_int('D', 2);
    }
    let mut uno = Uno::load_with(&elf, options)?;
    while !(0..4).all(|n| uno.wiznet().is_some_and(|w| w.status(n) == state::LISTEN)) {
        if uno.now() > us_to_cycles(100_000) {
            return Err(format!("{build}/{NAME}: the sockets never listened").into());
        }
        uno.run_for(us_to_cycles(100))?;
    }
    let char_cycles = uno.wire_char_cycles().ok_or("USART0 is not set up")?;
    let mut masters = Vec::new();
    for i in 0..MASTERS {
        let peer = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + i as u8), 40_000 + i as u16);
        let socket = uno.wiznet_mut().ok_or("no shield")?.connect(502, peer).ok_or("no socket listens")?;
        masters.push(Master { socket, transaction: 0, pending: None, next_at: 0, inbox: Vec::new(), sends_seen: 0 });
    }
    uno.run_for(us_to_cycles(5_000))?;
    uno.wiznet_mut().ok_or("no shield")?.record_spi(true);
    let mut rng = Lcg(0x6A7E_3600);
    let mut spi: Vec<SpiAccess> = Vec::new();
    // Every frame on the line: (first start bit, last stop bit).
    let mut line: Vec<(u64, u64)> = Vec::new();
    let mut chars: Vec<TxByte> = Vec::new();
    let mut done: Vec<(Request, u64)> = Vec::new();
    let slice = char_cycles / 2;
    let stop = uno.now() + us_to_cycles(SECONDS * 1_000_000);
    let mut units = 0u8;
    while uno.now() < stop || masters.iter().any(|m| m.pending.is_some()) {
        let now = uno.now();
        for (i, m) in masters.iter_mut().enumerate() {
            if m.pending.is_some() || now < m.next_at || now >= stop {
                continue;
            }
            units = units % 3 + 1;
            let (start, qty) = (i as u16 * 2, 1 + (m.transaction % 2));
            m.transaction = m.transaction.wrapping_add(1);
            let [t0, t1] = m.transaction.to_be_bytes();
            let frame = vec![units, 0x03, 0, start as u8, 0, qty as u8];
            let mut adu = vec![t0, t1, 0, 0, 0, 6];
            adu.extend_from_slice(&frame);
            let mut expected = vec![t0, t1, 0, 0, 0, 3 + 2 * qty as u8, units, 0x03, 2 * qty as u8];
            for r in start..start + qty {
                expected.extend_from_slice(&register(units, r).to_be_bytes());
            }
            let landed = now + rng.below(slice);
            uno.wiznet_mut().ok_or("no shield")?.deliver_at(m.socket, &adu, landed);
            m.pending =
                Some(Request { transaction: m.transaction, frame, landed, on_line: None, reply_end: None, expected });
        }
        uno.run_until(now + slice)?;
        // The line: the gateway's request, once two characters of idle line follow it, is
        // matched to its TCP request and answered by its slave.
        chars.extend(uno.take_tx());
        if let Some(last) = chars.last() {
            let busy = uno.tx_busy_until().unwrap_or(0).max(last.end_cycle);
            if uno.now() >= busy + 2 * char_cycles {
                let bytes: Vec<u8> = chars.iter().map(|c| c.byte).collect();
                let (start, end) = (chars[0].start_cycle, last.end_cycle);
                chars.clear();
                line.push((start, end));
                let body = &bytes[..bytes.len().saturating_sub(2)];
                let Some(request) = masters
                    .iter_mut()
                    .filter_map(|m| m.pending.as_mut())
                    .find(|r| r.on_line.is_none() && r.frame == body)
                else {
                    log.problems.push(format!("{NAME}: the line carried {bytes:02X?}, which no master asked"));
                    continue;
                };
                if crc16(body).to_le_bytes() != bytes[bytes.len() - 2..] {
                    log.problems.push(format!("{NAME}: a wrong CRC on {bytes:02X?}"));
                }
                request.on_line = Some(start);
                let (id, first, qty) = (body[0], u16::from(body[3]), u16::from(body[5]));
                let mut reply = vec![id, 0x03, 2 * qty as u8];
                for r in first..first + qty {
                    reply.extend_from_slice(&register(id, r).to_be_bytes());
                }
                reply.extend_from_slice(&crc16(&reply).to_le_bytes());
                let reply_start = end + T35 + us_to_cycles(SLAVE_DELAY_US);
                let reply_end = uno.send_frame(&reply, reply_start + char_cycles, 0)?;
                request.reply_end = Some(reply_end);
                line.push((reply_start, reply_end));
            }
        }
        // The TCP side: each master's answer, with the SEND that carried it.
        let now = uno.now();
        let chip = uno.wiznet_mut().ok_or("no shield")?;
        spi.extend(chip.take_spi_log());
        for (i, m) in masters.iter_mut().enumerate() {
            chip.take_sent(m.socket);
            let sends = chip.sends(m.socket);
            for send in &sends[m.sends_seen..] {
                m.inbox.extend_from_slice(&send.data);
                let Some(request) = m.pending.take_if(|r| m.inbox.len() >= r.expected.len()) else { continue };
                let got: Vec<u8> = m.inbox.drain(..request.expected.len()).collect();
                if got != request.expected {
                    log.problems.push(format!(
                        "{NAME}: master {i}, transaction {}: {got:02X?}, not {:02X?}",
                        request.transaction, request.expected
                    ));
                }
                m.next_at = now + rng.below(us_to_cycles(THINK_MS * 1000));
                done.push((request, send.cycle));
            }
            m.sends_seen = sends.len();
        }
        if uno.now() > stop + us_to_cycles(2_000_000) {
            return Err(format!("{NAME}: requests still unanswered 2 s after the masters stopped").into());
        }
    }
    line.sort_unstable();
    let mut per_access: Vec<u64> =
        spi.windows(2).map(|w| w[1].cycle - w[0].cycle).filter(|&d| d < us_to_cycles(20)).collect();
    per_access.sort_unstable();
    let (mut to_line, mut to_tcp, mut next) = (Overhead::new(), Overhead::new(), Overhead::new());
    for (request, sent) in &done {
        let (Some(start), Some(reply_end)) = (request.on_line, request.reply_end) else { continue };
        // The frame before this request on the line.
        let before = line.iter().take_while(|(s, _)| *s < start).map(|&(_, e)| e).max().unwrap_or(0);
        if request.landed < before {
            next.add(before + T35, start, &spi);
        } else {
            to_line.add(request.landed.max(before + T35), start, &spi);
        }
        to_tcp.add(reply_end + T35, *sent, &spi);
    }
    for o in [&mut to_line, &mut to_tcp, &mut next] {
        o.cycles.sort_unstable();
    }
    Ok(Variant {
        build,
        int,
        size: avr_size(&elf).ok(),
        to_line,
        to_tcp,
        next,
        per_access: per_access.get(per_access.len() / 2).copied().unwrap_or(0),
        transactions: done.len(),
    })
}

/// Runs the gateway's measurements on each variant built; nothing if none is.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Option<Measured>> {
    let mut measured = Vec::new();
    for variant in VARIANTS.into_iter().filter(|(build, _)| chip_build_path(root, build, NAME).is_file()) {
        eprintln!("bench: {NAME} ({}), four TCP masters and three RTU slaves, {SECONDS} s", variant.0);
        measured.push(run(root, variant, log)?);
    }
    Ok((!measured.is_empty()).then_some(measured))
}

fn us(cycles: u64) -> String {
    format!("{:.0} µs", cycles_to_us(cycles))
}

/// The section.
pub(crate) fn section(md: &mut String, measured: &Option<Measured>) -> Result<()> {
    writeln!(md, "\n## The Modbus TCP to RTU gateway (features `tcp` and `master`)\n")?;
    let Some(variants) = measured else {
        writeln!(md, "Not measured: `{NAME}` is not built (`make tcp-firmware`).")?;
        return Ok(());
    };
    writeln!(
        md,
        "`{NAME}`: an Uno, a W5100, RS-485 on USART0 at 19200 8E1, DE on pin 3, as `make tcp-firmware` builds it; \
         the chip polled every Timer0 overflow (1.024 ms) or served from its INT line on pin 2.\n"
    )?;
    writeln!(md, "| firmware | flash B | static RAM |\n|---|---:|---:|")?;
    for v in variants {
        match v.size {
            Some((flash, ram)) => writeln!(md, "| {NAME} ({}) | {flash} | {ram} B |", v.build)?,
            None => writeln!(md, "| {NAME} ({}) | ? | ? |", v.build)?,
        }
    }
    if let Some((flash, ram)) = variants.first().and_then(|v| v.size) {
        let verdict = |met: bool| if met { "met" } else { "**not met**" };
        writeln!(
            md,
            "\nTargets (polled build): flash ≤ {FLASH_TARGET} B: {flash} B, {}; static RAM ≤ {RAM_TARGET} B: {ram} B, {}. \
             Ceilings: flash ≤ {FLASH_CEILING} B, {}; static RAM ≤ {RAM_CEILING} B, {}. \
             The peers, quoted from the issue: budulinek arduino-modbus-rtu-tcp-gateway 8.1 31 998 B / 1 599 B, \
             emelianov modbus-esp8266 4.1's bridge 25 580 B / 645 B.",
            verdict(flash <= FLASH_TARGET),
            verdict(ram <= RAM_TARGET),
            verdict(flash <= FLASH_CEILING),
            verdict(ram <= RAM_CEILING)
        )?;
    }
    writeln!(
        md,
        "\nFour TCP masters, each on its own connection, ask three slaves (answering T3.5 + {SLAVE_DELAY_US} µs after \
         a request's end) for one or two holding registers, each waiting for its answer and then 0–{THINK_MS} ms, for \
         {SECONDS} simulated seconds; each request lands in the chip at a random phase of the firmware's poll. \
         T3.5 = {}. The overheads of issue 36, in simulated cycles:\n\n\
         1. to the line: a request's last byte in the chip (or, if later, the end of the T3.5 the line still owed \
         after the frame before it) → the RTU request's first start bit;\n\
         2. to TCP: the RTU reply's last stop bit + T3.5 → the TCP reply's SEND;\n\
         3. the next request, with requests queued: the last reply's last stop bit + T3.5 → the next RTU \
         request's first start bit.\n",
        us(T35)
    )?;
    writeln!(md, "| chip served | transactions | overhead | samples | p50 | p99 | max | target (p99) |")?;
    writeln!(md, "|---|---:|---|---:|---:|---:|---:|---|")?;
    for v in variants {
        for (name, o, target) in v.rows() {
            let p99 = o.percentile(99);
            writeln!(
                md,
                "| {} | {} | {name} | {} | {} | {} | {} | ≤ {target:.0} µs: {} |",
                served(v),
                v.transactions,
                o.cycles.len(),
                us(o.percentile(50)),
                us(p99),
                us(o.cycles.last().copied().unwrap_or(0)),
                crate::render::met_text(!o.cycles.is_empty() && cycles_to_us(p99) <= target)
            )?;
        }
    }
    writeln!(
        md,
        "\nWhere the time goes, on average per sample: the time from the window's start to its first SPI access \
         (overhead 1 polled: mostly the wait for the next poll; 2 and 3: Timer0's compare interrupt at T3.5, the \
         reply judged, the chip's service begun), the W5100 SPI accesses inside the window by what they reach (one \
         4-byte frame each, even for one byte of a buffer), their time at the median spacing of two accesses in a \
         burst, and the rest (the firmware's work between accesses).\n"
    )?;
    write!(md, "| chip served | overhead | mean | before the first access |")?;
    for name in KIND_NAMES {
        write!(md, " {name} |")?;
    }
    writeln!(md, " accesses | their time | the rest |\n|---|---|---:|---:|{}---:|---:|---:|", "---:|".repeat(KINDS))?;
    for v in variants {
        for (name, o, _) in v.rows() {
            let n = o.cycles.len().max(1) as u64;
            let (mean, before) = (o.cycles.iter().sum::<u64>() / n, o.before_spi.iter().sum::<u64>() / n);
            write!(md, "| {} | {name} | {} | {} |", served(v), us(mean), us(before))?;
            for k in [Kind::Ir, Kind::SocketState, Kind::Pointers, Kind::TxBuffer, Kind::RxBuffer, Kind::Other] {
                write!(md, " {:.1} |", o.mean_accesses(k))?;
            }
            let accesses = o.accesses.iter().sum::<u64>() as f64 / n as f64;
            let spi = (accesses * v.per_access as f64) as u64;
            writeln!(
                md,
                " {accesses:.1} | {} ({:.1} µs each) | {} |",
                us(spi),
                cycles_to_us(v.per_access),
                us(mean.saturating_sub(before + spi))
            )?;
        }
    }
    Ok(())
}

fn served(v: &Variant) -> &'static str {
    if v.int {
        "INT line"
    } else {
        "polled"
    }
}

impl Variant {
    /// The three overheads with their names and targets.
    fn rows(&self) -> [(&'static str, &Overhead, f64); 3] {
        [
            ("1. to the line", &self.to_line, TO_LINE_US),
            ("2. to TCP", &self.to_tcp, TO_TCP_US),
            ("3. the next request", &self.next, NEXT_US),
        ]
    }
}

/// `bench gateway`: the section alone.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let measured = measure(root, log)?;
    let mut md = String::new();
    section(&mut md, &measured)?;
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t35_at_19200_8e1_is_2005_us() {
        assert_eq!(T35, 32_084);
        assert_eq!(format!("{:.0}", cycles_to_us(T35)), "2005");
    }

    #[test]
    fn accesses_are_told_apart_by_address() {
        let at = |addr| kind(&SpiAccess { cycle: 0, addr, block: 0, write: false }) as usize;
        let kinds: Vec<usize> = [0x0015, 0x0401, 0x0702, 0x0520, 0x0629, 0x4000, 0x5FFF, 0x6000, 0x7FFF, 0x0009]
            .into_iter()
            .map(at)
            .collect();
        assert_eq!(kinds, [0, 1, 1, 2, 2, 3, 3, 4, 4, 5]);
    }

    #[test]
    fn a_window_counts_the_accesses_inside_it_and_the_wait_before_the_first() {
        let log: Vec<SpiAccess> = [100, 200, 300, 400]
            .into_iter()
            .map(|cycle| SpiAccess { cycle, addr: 0x4000, block: 0, write: true })
            .collect();
        let mut o = Overhead::new();
        o.add(150, 300, &log);
        o.add(500, 600, &log);
        assert_eq!(o.cycles, [150, 100]);
        assert_eq!(o.before_spi, [50, 100]);
        assert_eq!(o.accesses[Kind::TxBuffer as usize], 2);
        assert_eq!(o.mean_accesses(Kind::TxBuffer), 1.0);
    }
}
