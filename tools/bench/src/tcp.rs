//! Modbus TCP (feature `tcp`): the server's flash and RAM beside the Arduino Ethernet
//! library and the Arduino Modbus TCP libraries, from a request's last byte in the chip to
//! the reply's SEND command on each chip, polled and with the INT line, the CPU an idle
//! chip costs, and the RTU slave's receive interrupt and reply turnaround in a firmware that
//! serves one model on both (TCP requests landing around each RTU request).
//!
//! Every figure is taken in simulated cycles on the simulated shield (`uno_sim::wiznet`),
//! whose SPI bytes take the chip's time (8 SPI clocks: 1 µs at 8 MHz).

use std::fmt::Write as _;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::path::Path;

use uno_sim::wiznet::regs::state;
use uno_sim::{cycles_to_us, us_to_cycles, vector, Options, Uno, Wiznet};

use crate::elf::{avr_size, chip_build_path};
use crate::log::Log;
use crate::Result;

/// The Arduino libraries the issue compares with, built with Arduino's flags on an Uno with
/// the contract map: (library, flash B, static RAM). Quoted from the issue, not measured here.
const LIBRARIES: [(&str, u64, &str); 5] = [
    ("Arduino Ethernet 2.0.2 alone (a server that accepts and does nothing)", 11_856, "299 B"),
    ("andresarmento ModbusIP", 14_114, "319 B + 448 B heap"),
    ("Mudbus (current copy)", 13_276, "955 B"),
    ("emelianov ModbusEthernet 4.1", 21_232, "398 B"),
    ("ArduinoModbus 1.0.7 (AVR dropped since)", 22_450, "1 421 B"),
];

/// The targets: flash and static RAM of the contract, the stretch, and the latency bounds.
const FLASH_TARGET: u64 = 4096;
const FLASH_STRETCH: u64 = 3072;
/// The TCP client's sketch (`tcp_poll`): its target, and the Arduino masters' figures quoted
/// in the issue (Uno, reading 10 holding registers every 100 ms).
const CLIENT_TARGET: u64 = 4096;
const CLIENT_PEERS: [(&str, u64); 2] = [("modbus-esp8266", 22_048), ("ArduinoModbus", 23_224)];
const RAM_TARGET: u64 = 400;
const W5100_P99_US: f64 = 300.0;
const W5500_P99_US: f64 = 150.0;

/// The TCP builds the bench runs (`make chips`): build directory, chip, INT line wired.
const VARIANTS: [(&str, Wiznet, bool); 4] = [
    ("atmega328p-w5100", Wiznet::W5100, false),
    ("atmega328p-w5100-int", Wiznet::W5100, true),
    ("atmega328p-w5500", Wiznet::W5500, false),
    ("atmega328p-w5500-int", Wiznet::W5500, true),
];

/// Requests per latency series.
const REQUESTS: u16 = 1000;

/// One variant's latency: request in the chip to SEND, in cycles, sorted.
pub(crate) struct Latency {
    build: &'static str,
    chip: Wiznet,
    int: bool,
    cycles: Vec<u64>,
    /// Share of the CPU the server took with no master connected, over a second.
    idle_share: f64,
}

impl Latency {
    fn percentile(&self, pct: usize) -> u64 {
        self.cycles[(self.cycles.len() * pct / 100).min(self.cycles.len() - 1)]
    }
}

/// Everything measured.
pub(crate) struct Measured {
    sizes: Vec<(String, Option<(u64, u64)>)>,
    latency: Vec<Latency>,
    /// The RTU slave alone (`sixteen_each`) and beside the TCP server (`tcp_rtu`), polling
    /// and with TCP requests.
    rtu: Vec<RtuBeside>,
    /// The README's figure for the contract (its features table's `tcp` row), if it has one.
    claim: Option<i64>,
}

fn peer(i: u8) -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + i), 40_000 + u16::from(i))
}

/// Read holding registers `start`, `qty`, as an ADU with transaction id `t`.
fn read_adu(t: u16, start: u16, qty: u16) -> Vec<u8> {
    let [t0, t1] = t.to_be_bytes();
    let [s0, s1] = start.to_be_bytes();
    let [q0, q1] = qty.to_be_bytes();
    vec![t0, t1, 0, 0, 0, 6, 1, 0x03, s0, s1, q0, q1]
}

/// The firmware in `build` on a board with its shield, until its sockets listen.
fn boot(root: &Path, build: &str, name: &str, chip: Wiznet, int: bool) -> Result<Uno> {
    let mut options = Options::new().wiznet(chip);
    if int {
        options = options.wiznet_int('D', 2);
    }
    let mut uno = Uno::load_with(chip_build_path(root, build, name), options)?;
    let sockets = if chip == Wiznet::W5500 { 8 } else { 4 };
    while !(0..sockets).all(|n| uno.wiznet().is_some_and(|w| w.status(n) == state::LISTEN)) {
        if uno.now() > us_to_cycles(100_000) {
            return Err(format!("{build}/{name}: the sockets never listened").into());
        }
        uno.run_for(us_to_cycles(100))?;
    }
    Ok(uno)
}

/// One request on socket `n`: its reply's length when it came (within 20 ms).
fn ask(uno: &mut Uno, n: usize, adu: &[u8], expected: usize) -> Result<usize> {
    let chip = uno.wiznet_mut().ok_or("no shield")?;
    chip.deliver(n, adu);
    let until = uno.now() + us_to_cycles(20_000);
    let mut got = 0;
    while got < expected && uno.now() < until {
        uno.run_for(us_to_cycles(50))?;
        got += uno.wiznet_mut().ok_or("no shield")?.take_sent(n).len();
    }
    Ok(got)
}

fn latency(root: &Path, (build, chip, int): (&'static str, Wiznet, bool), log: &mut Log) -> Result<Latency> {
    let mut uno = boot(root, build, "tcp_server", chip, int)?;
    // Idle: no master, a second; the server's handlers' share of the cycles.
    uno.reset_isr_stats();
    let start = uno.now();
    uno.run_for(us_to_cycles(1_000_000))?;
    let handlers = uno.isr_stats(vector::TIMER0_OVF).cycles + uno.isr_stats(vector::INT0).cycles;
    let idle_share = handlers as f64 / (uno.now() - start) as f64;
    let n = uno.wiznet_mut().ok_or("no shield")?.connect(502, peer(0)).ok_or("no socket listens")?;
    uno.run_for(us_to_cycles(3000))?;
    let mut cycles = Vec::new();
    for t in 0..REQUESTS {
        // Requests land at every phase of the firmware's poll.
        uno.run_for(us_to_cycles(u64::from(t % 13) * 83))?;
        let got = ask(&mut uno, n, &read_adu(t, t % 16, 1), 11)?;
        if got != 11 {
            log.problems.push(format!("{build}: request {t}: {got} bytes of reply, 11 expected"));
            continue;
        }
        let w = uno.wiznet().ok_or("no shield")?;
        let send = w.sends(n).last().map_or(0, |s| s.cycle);
        cycles.push(send.saturating_sub(w.last_delivery(n).unwrap_or(send)));
    }
    if cycles.is_empty() {
        return Err(format!("{build}: no reply").into());
    }
    cycles.sort_unstable();
    Ok(Latency { build, chip, int, cycles, idle_share })
}

/// RTU requests per series of the receive interrupt and the reply's turnaround.
const RTU_REQUESTS: u16 = 400;

/// The targets beside the TCP server: the RTU reply at p99 at most this late past T3.5, and
/// the USART receive handler's longest run as long as alone.
const TURNAROUND_P99_US: f64 = 25.0;

/// What the TCP side does while the RTU master polls.
#[derive(Clone, Copy, PartialEq)]
enum Beside {
    /// No shield: the RTU slave alone.
    Nothing,
    /// A TCP master connected and silent: the server polls the chip.
    Polling,
    /// A TCP request during each RTU request.
    Requests,
}

/// One firmware's RTU slave under a master reading 16 registers, with what is `beside`.
pub(crate) struct RtuBeside {
    name: &'static str,
    beside: Beside,
    /// The USART receive handler's longest run, cycles, and its runs.
    rx_max: u64,
    rx_runs: u64,
    /// Each reply's first start bit minus (the request's last byte's end + T3.5), cycles,
    /// sorted.
    turnaround: Vec<i64>,
    /// TCP requests sent beside, and those whose reply's SEND came between the RTU request's
    /// last byte and its reply's first start bit (their execution met the T3.5 window).
    tcp: u64,
    tcp_in_window: u64,
}

impl RtuBeside {
    fn percentile(&self, pct: usize) -> i64 {
        self.turnaround[(self.turnaround.len() * pct / 100).min(self.turnaround.len() - 1)]
    }

    fn max(&self) -> i64 {
        *self.turnaround.last().unwrap_or(&0)
    }
}

/// Write holding registers from 0 with `values` (FC 16), as an ADU with transaction id `t`.
fn write_adu(t: u16, values: &[u16]) -> Vec<u8> {
    let [t0, t1] = t.to_be_bytes();
    let [l0, l1] = (7 + 2 * values.len() as u16).to_be_bytes();
    let mut adu = vec![t0, t1, 0, 0, l0, l1, 1, 0x10, 0, 0, 0, values.len() as u8, 2 * values.len() as u8];
    adu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    adu
}

/// An RTU master reads 16 registers [`RTU_REQUESTS`] times, each request's first byte at a
/// phase of Timer0's overflow (the TCP server's poll) that moves by 61 µs a request; with
/// [`Beside::Requests`] a TCP master reads (even requests) or writes (odd) the same 16
/// registers on the shield, landing at moments spread over the RTU request and T3.5 after it
/// (from its first byte to a character past T3.5, a 401st of that span apart, in a shuffled
/// order). The USART receive handler's longest run and the reply's turnaround past T3.5.
fn rtu_beside(root: &Path, build: &str, name: &'static str, beside: Beside) -> Result<RtuBeside> {
    let mut uno = if beside == Beside::Nothing {
        let mut uno = Uno::load(chip_build_path(root, build, name))?;
        uno.run_for(us_to_cycles(10_000))?;
        uno
    } else {
        boot(root, build, name, Wiznet::W5100, false)?
    };
    let n = if beside == Beside::Nothing {
        None
    } else {
        let n = uno.wiznet_mut().ok_or("no shield")?.connect(502, peer(0)).ok_or("no socket listens")?;
        uno.run_for(us_to_cycles(3000))?;
        Some(n).filter(|_| beside == Beside::Requests)
    };
    let char_time = uno.wire_char_cycles().ok_or("the USART is not set up")?;
    // T3.5 as the master counts it at 19200: 3.5 characters (`bus.rs`).
    let t35 = char_time * 7 / 2;
    let mut frame = vec![1, 0x03, 0x00, 0x00, 0x00, 0x10];
    frame.extend_from_slice(&crate::modbus::crc16(&frame).to_le_bytes());
    // From the request's first byte's start to a character past T3.5.
    let span = char_time * (frame.len() as u64 + 1) + t35;
    let (mut turnaround, mut tcp_sent, mut tcp_in_window) = (Vec::new(), 0, 0);
    uno.reset_isr_stats();
    for t in 0..RTU_REQUESTS {
        uno.run_for(us_to_cycles(u64::from(t) * 61 % 1024))?;
        let start = uno.now();
        if let Some(n) = n {
            let at = start + span * (u64::from(t) * 163 % 401) / 400;
            let adu = if t % 2 == 0 { read_adu(t, 0, 16) } else { write_adu(t, &[t; 16]) };
            uno.wiznet_mut().ok_or("no shield")?.deliver_at(n, &adu, at);
            tcp_sent += 1;
        }
        let last = uno.send_frame(&frame, start + char_time, 0)?;
        let reply = uno.run_until_tx_idle(4 * char_time, last + us_to_cycles(100_000))?;
        if reply.len() != 37 {
            return Err(format!("{name}: RTU reply {t}: {} bytes, 37 expected", reply.len()).into());
        }
        turnaround.push(reply[0].start_cycle as i64 - (last + t35) as i64);
        if let Some(n) = n {
            // The TCP reply, if it is not out yet.
            let until = uno.now() + us_to_cycles(20_000);
            while uno.wiznet().ok_or("no shield")?.sends(n).last().is_none_or(|s| s.cycle < start) {
                if uno.now() > until {
                    return Err(format!("{name}: no TCP reply to request {t}").into());
                }
                uno.run_for(us_to_cycles(100))?;
            }
            let send = uno.wiznet().ok_or("no shield")?.sends(n).last().map_or(0, |s| s.cycle);
            if (last..reply[0].start_cycle).contains(&send) {
                tcp_in_window += 1;
            }
            uno.wiznet_mut().ok_or("no shield")?.take_sent(n);
        }
    }
    let stats = uno.isr_stats(vector::USART_RX);
    turnaround.sort_unstable();
    Ok(RtuBeside {
        name,
        beside,
        rx_max: stats.max_cycles,
        rx_runs: stats.entries,
        turnaround,
        tcp: tcp_sent,
        tcp_in_window,
    })
}

/// Runs every TCP measurement; nothing if the TCP builds are missing.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Option<Measured>> {
    if !chip_build_path(root, "atmega328p-tcp", "sixteen_each_tcp").is_file() {
        return Ok(None);
    }
    let mut sizes = vec![(
        "sixteen_each_tcp".to_owned(),
        avr_size(&chip_build_path(root, "atmega328p-tcp", "sixteen_each_tcp")).ok(),
    )];
    for (build, _, _) in VARIANTS {
        sizes.push((format!("tcp_server ({build})"), avr_size(&chip_build_path(root, build, "tcp_server")).ok()));
    }
    sizes.push(("tcp_rtu".to_owned(), avr_size(&chip_build_path(root, "atmega328p-tcp", "tcp_rtu")).ok()));
    sizes.push((
        "tcp_poll (the TCP client, W5100)".to_owned(),
        avr_size(&chip_build_path(root, "atmega328p-tcp-client", "tcp_poll")).ok(),
    ));
    let mut latency = Vec::new();
    for variant in VARIANTS {
        eprintln!("bench: tcp_server ({}) latency", variant.0);
        latency.push(self::latency(root, variant, log)?);
    }
    eprintln!("bench: tcp_rtu, the RTU slave's receive interrupt and turnaround");
    let rtu = vec![
        rtu_beside(root, "atmega328p", "sixteen_each", Beside::Nothing)?,
        rtu_beside(root, "atmega328p-tcp", "tcp_rtu", Beside::Polling)?,
        rtu_beside(root, "atmega328p-tcp", "tcp_rtu", Beside::Requests)?,
    ];
    Ok(Some(Measured {
        claim: crate::readme::readme_claim(root, "tcp", true).map(|(_, figure)| figure),
        sizes,
        latency,
        rtu,
    }))
}

fn us(cycles: u64) -> String {
    format!("{:.0} µs", cycles_to_us(cycles))
}

/// The section.
pub(crate) fn section(md: &mut String, measured: &Option<Measured>) -> Result<()> {
    writeln!(md, "\n## Modbus TCP (feature `tcp`)\n")?;
    let Some(m) = measured else {
        writeln!(md, "Not measured: the TCP builds are missing (`make chips`).")?;
        return Ok(());
    };
    writeln!(
        md,
        "Flash and static RAM as the avr-hal template builds them (`make chips`), on the Uno. `sixteen_each_tcp` is \
         the contract: the map of 16 coils, 16 discrete inputs, 8 input and 16 holding registers on a W5100, polled, \
         an idle main loop. The libraries' figures are quoted from the issue (built with Arduino's flags), not \
         measured here.\n"
    )?;
    writeln!(md, "| firmware | flash B | static RAM |\n|---|---:|---:|")?;
    for (library, flash, ram) in LIBRARIES {
        writeln!(md, "| {library} | {flash} | {ram} |")?;
    }
    for (name, size) in &m.sizes {
        match size {
            Some((flash, ram)) => writeln!(md, "| this crate: {name} | {flash} | {ram} B |")?,
            None => writeln!(md, "| this crate: {name} | not built | not built |")?,
        }
    }
    if let Some((_, Some((flash, _)))) = m.sizes.iter().find(|(name, _)| name.starts_with("tcp_poll")) {
        writeln!(
            md,
            "\n`tcp_poll` is the TCP client (features `tcp` and `master`) reading 10 holding registers every 100 ms \
             from a server: {flash} B against a target of ≤ {CLIENT_TARGET} B, {}; the Arduino TCP masters' same \
             sketch, quoted from the issue: {}.",
            crate::render::met_text(*flash <= CLIENT_TARGET),
            CLIENT_PEERS.iter().map(|(name, flash)| format!("{name} {flash} B")).collect::<Vec<_>>().join(", ")
        )?;
    }
    if let Some((_, Some((flash, ram)))) = m.sizes.first() {
        writeln!(
            md,
            "\nTargets: flash ≤ {FLASH_TARGET} B: {flash} B, {}; static RAM ≤ {RAM_TARGET} B with 4 sockets: {ram} B, \
             {}; stretch ≤ {FLASH_STRETCH} B: {}.",
            crate::render::met_text(*flash <= FLASH_TARGET),
            crate::render::met_text(*ram <= RAM_TARGET),
            crate::render::met_text(*flash <= FLASH_STRETCH)
        )?;
        match m.claim {
            Some(said) if said == *flash as i64 => writeln!(md, "The README says {said} B: right.")?,
            Some(said) => writeln!(md, "The README says {said} B: **update it to {flash} B**.")?,
            None => writeln!(md, "The README's features table has no figure for `tcp`.")?,
        }
    }
    writeln!(
        md,
        "\n### From a request's last byte in the chip to the reply's SEND\n\n`tcp_server`, whose main loop blocks for \
         a second at a time; {REQUESTS} reads of one holding register on one connection, landing at every phase of \
         the poll. Polled: the chip is read every Timer0 overflow (1.024 ms); INT: the chip's INT line on pin 2 \
         (`tcp_server!(…, pin2_int)`). Idle: the server's interrupt handlers' share of the CPU over a second with no \
         master.\n"
    )?;
    writeln!(md, "| chip | served | p50 | p99 | max | p99 target | idle CPU |\n|---|---|---:|---:|---:|---|---:|")?;
    for l in &m.latency {
        let bound = if l.chip == Wiznet::W5100 { W5100_P99_US } else { W5500_P99_US };
        let p99 = l.percentile(99);
        writeln!(
            md,
            "| {} | {} | {} | {} | {} | ≤ {bound:.0} µs: {} | {:.2} % |",
            l.chip,
            if l.int { "INT line" } else { "polled" },
            us(l.percentile(50)),
            us(p99),
            us(*l.cycles.last().unwrap_or(&0)),
            crate::render::met_text(cycles_to_us(p99) <= bound),
            100.0 * l.idle_share
        )?;
        let _ = l.build;
    }
    writeln!(
        md,
        "\n### The RTU slave beside the TCP server\n\n{RTU_REQUESTS} RTU reads of 16 holding registers at 19200 \
         8E1, each starting at another phase of Timer0's overflow (the TCP server's poll). `tcp_rtu` serves one \
         `shared_model!` on both ports: first with a TCP master connected and silent (the server polls the chip \
         every overflow), then with a TCP request on the same 16 registers, a read and a write (FC 16) in turn, \
         landing on the shield during each RTU request, at moments spread from its first byte to a character past \
         T3.5. The TCP server polls with interrupts enabled and holds them off while a request runs against the \
         model. Turnaround: the reply's first start bit minus the end of T3.5 (3.5 characters) after the \
         request's last byte. The simulated shield's SPI bytes take the chip's time (8 SPI clocks, 1 µs at 8 MHz; \
         the simulator corrects simavr 1.6's 100 µs per byte, SIMAVR.md), so the TCP server's SPI work, and what \
         it delays, lasts as long as on a board.\n"
    )?;
    writeln!(
        md,
        "| firmware | TCP beside | USART_RX runs | longest run | turnaround p50 | p99 | max | TCP replies sent \
         between the RTU request's end and its reply |\n|---|---|---:|---:|---:|---:|---:|---:|"
    )?;
    let signed = |cycles: i64| format!("{:.1} µs", signed_us(cycles));
    for r in &m.rtu {
        let beside = match r.beside {
            Beside::Nothing => "no shield".to_owned(),
            Beside::Polling => "connected, silent".to_owned(),
            Beside::Requests => format!("{} requests, reads and writes", r.tcp),
        };
        writeln!(
            md,
            "| {} | {beside} | {} | {} cycles | {} | {} | {} | {} |",
            r.name,
            r.rx_runs,
            r.rx_max,
            signed(r.percentile(50)),
            signed(r.percentile(99)),
            signed(r.max()),
            if r.beside == Beside::Requests { r.tcp_in_window.to_string() } else { "–".to_owned() }
        )?;
    }
    if let (Some(alone), Some(beside)) = (m.rtu.first(), m.rtu.last()) {
        let p99 = signed_us(beside.percentile(99));
        writeln!(
            md,
            "\nTargets with TCP traffic beside: the RTU reply at p99 ≤ {TURNAROUND_P99_US:.0} µs past T3.5: {p99:.1} \
             µs, {}; the USART receive handler's longest run unchanged ({} cycles alone): {} cycles, {}.",
            crate::render::met_text(p99 <= TURNAROUND_P99_US),
            alone.rx_max,
            beside.rx_max,
            crate::render::met_text(beside.rx_max <= alone.rx_max)
        )?;
    }
    Ok(())
}

/// `cycles`, which may be negative, in µs.
fn signed_us(cycles: i64) -> f64 {
    cycles.signum() as f64 * cycles_to_us(cycles.unsigned_abs())
}

/// `bench tcp`: the section alone.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let measured = measure(root, log)?;
    let mut md = String::new();
    section(&mut md, &measured)?;
    Ok(md)
}
