//! The serial line on Timer1's input capture (feature `capture-line`): the contract slave on
//! the Uno's pins 8/9 (`sixteen_each_capture`) beside the same on the USART (`sixteen_each`),
//! their flash and RAM; the interrupts each received character takes and their cycles; the
//! reply's start after T3.5 over requests at every phase of the timers; the CPU a stream of
//! back-to-back frames takes.
//!
//! Every figure is taken in simulated cycles, each edge on pin 8 scheduled at its cycle and
//! each level pin 9 took logged at its cycle (`uno_sim::PinUart`).

use std::fmt::Write as _;
use std::path::Path;

use uno_sim::{cycles_to_us, us_to_cycles, vector, Options, Parity, PinUart, Uno};

use crate::elf::{avr_size, chip_build_path};
use crate::log::Log;
use crate::Result;

/// The builds (`make chips`).
const BUILD: &str = "atmega328p-capture-uno";
const NAME: &str = "sixteen_each_capture";
const USART_BUILD: &str = "atmega328p";
const USART_NAME: &str = "sixteen_each";

/// The targets: the flash over the USART's contract, the reply past T3.5 at p99.
const FLASH_OVER_USART: u64 = 400;
const REPLY_P99_US: f64 = 50.0;

/// The contract's line: 19200 8E1.
const BAUD: u32 = 19_200;
const UART: PinUart = PinUart::new(BAUD).parity(Parity::Even);

/// Requests in the latency series.
const REQUESTS: u64 = 400;

/// The Uno's vectors of Timer1 (the 328P's table).
const TIMER1_CAPT: u8 = 10;
const TIMER1_COMPA: u8 = 11;
const TIMER1_COMPB: u8 = 12;

/// What was measured.
pub(crate) struct Measured {
    /// (flash, static RAM) of the capture line's contract and the USART's.
    sizes: ((u64, u64), Option<(u64, u64)>),
    /// Edge interrupts (TIMER1_CAPT) and stop-bit interrupts (TIMER1_COMPB): runs, total
    /// cycles, longest run; characters received.
    edges: (u64, u64, u64),
    stop_bits: (u64, u64, u64),
    received: u64,
    /// The transmitter's interrupts (TIMER1_COMPA): runs, total cycles, longest; characters sent.
    transmit: (u64, u64, u64),
    sent: u64,
    /// The reply's first start bit past T3.5, cycles, sorted.
    past_t35: Vec<u64>,
    /// The CPU share the line's interrupts and Timer0's take while frames to another slave
    /// come back to back, at 19200 and at 38 400.
    share: f64,
    share_38400: f64,
}

/// T3.5 at 19200 8E1: 3.5 characters of 11 bits.
fn t35() -> u64 {
    us_to_cycles(1_000_000) * 11 * 7 / (2 * u64::from(BAUD))
}

fn read16() -> Vec<u8> {
    let mut frame = vec![1, 0x03, 0x00, 0x00, 0x00, 0x10];
    frame.extend_from_slice(&crate::modbus::crc16(&frame).to_le_bytes());
    frame
}

/// Sends `frame` on pin 8 from `start` and reads the reply on pin 9: its characters' (start,
/// end) cycles.
fn exchange(uno: &mut Uno, frame: &[u8], start: u64) -> Result<(u64, Vec<(u64, u64)>)> {
    let end = uno.send_pin_uart(('B', 0), frame, UART, start, 0)?;
    uno.run_until(end + t35() + us_to_cycles(30_000))?;
    let reply = uno.take_pin_uart(('B', 1), UART)?;
    Ok((end, reply.iter().map(|b| (b.start_cycle, b.end_cycle)).collect()))
}

/// Runs every measurement; nothing if the capture build is missing.
pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Option<Measured>> {
    let elf = chip_build_path(root, BUILD, NAME);
    if !elf.is_file() {
        return Ok(None);
    }
    eprintln!("bench: {NAME}, {REQUESTS} requests on pins 8/9");
    let sizes = (avr_size(&elf)?, avr_size(&chip_build_path(root, USART_BUILD, USART_NAME)).ok());
    let mut uno = Uno::load_with(&elf, Options::new())?;
    uno.watch_pin(('B', 1))?;
    uno.run_for(us_to_cycles(10_000))?;
    let frame = read16();
    let mut past_t35 = Vec::new();
    uno.reset_isr_stats();
    let (mut received, mut sent) = (0, 0);
    for t in 0..REQUESTS {
        // Each request at another phase of Timer0 (1024 µs a turn) and of Timer1's ticks.
        let start = uno.now() + 100 + us_to_cycles(t * 61 % 1024) + t % 8;
        let (end, reply) = exchange(&mut uno, &frame, start)?;
        received += frame.len() as u64;
        sent += reply.len() as u64;
        if reply.len() != 37 {
            log.problems.push(format!("{NAME}: reply {t}: {} characters, 37 expected", reply.len()));
            continue;
        }
        past_t35.push(reply[0].0.saturating_sub(end + t35()));
    }
    past_t35.sort_unstable();
    let stats = |v: u8| {
        let s = uno.isr_stats(v);
        (s.entries, s.cycles, s.max_cycles)
    };
    let (edges, stop_bits, transmit) = (stats(TIMER1_CAPT), stats(TIMER1_COMPB), stats(TIMER1_COMPA));
    // Frames back to back: 50 requests to another slave (id 2), T3.5 and a character apart,
    // which this slave receives whole and leaves unanswered; the interrupts' share of the time.
    let begin = uno.now() + us_to_cycles(5_000);
    uno.run_until(begin)?;
    uno.reset_isr_stats();
    let mut other = vec![2, 0x03, 0x00, 0x00, 0x00, 0x10];
    other.extend_from_slice(&crate::modbus::crc16(&other).to_le_bytes());
    let mut at = begin + 100;
    for _ in 0..50 {
        let end = uno.send_pin_uart(('B', 0), &other, UART, at, 0)?;
        at = end + t35() + UART.bit_start(UART.char_bits());
    }
    uno.run_until(at)?;
    if !uno.take_pin_uart(('B', 1), UART)?.is_empty() {
        log.problems.push(format!("{NAME}: answered a request to slave 2"));
    }
    let elapsed = uno.now() - begin;
    let busy: u64 = [TIMER1_CAPT, TIMER1_COMPA, TIMER1_COMPB, vector::TIMER0_COMPA, vector::TIMER0_COMPB]
        .into_iter()
        .map(|v| uno.isr_stats(v).cycles)
        .sum();
    let share = busy as f64 / elapsed as f64;
    let share_38400 = share_at_38400(root, log)?;
    Ok(Some(Measured { sizes, edges, stop_bits, received, transmit, sent, past_t35, share, share_38400 }))
}

/// The same stream at 38 400 8E1: `boards` with the line settings in EEPROM on pins 8/9
/// (`make chips`' atmega328p-capture-settings), switched there by a write of 40101–40104.
fn share_at_38400(root: &Path, log: &mut Log) -> Result<f64> {
    let elf = chip_build_path(root, "atmega328p-capture-settings", "boards");
    let mut uno = Uno::load_with(&elf, Options::new())?;
    uno.watch_pin(('B', 1))?;
    uno.run_for(us_to_cycles(10_000))?;
    // Id 1, 38 400, even parity, 1 stop bit.
    let mut write = vec![1, 0x10, 0x00, 0x64, 0x00, 0x04, 0x08, 0, 1, 1, 128, 0, 2, 0, 1];
    write.extend_from_slice(&crate::modbus::crc16(&write).to_le_bytes());
    let start = uno.now() + 100;
    uno.send_pin_uart(('B', 0), &write, UART, start, 0)?;
    // The reply at 19200, the settings into EEPROM, the line switched.
    uno.run_for(us_to_cycles(300_000))?;
    let fast = PinUart::new(38_400).parity(Parity::Even);
    let mut other = vec![2, 0x03, 0x00, 0x00, 0x00, 0x10];
    other.extend_from_slice(&crate::modbus::crc16(&other).to_le_bytes());
    uno.take_pin_uart(('B', 1), UART)?;
    let begin = uno.now();
    uno.reset_isr_stats();
    let mut at = begin + 100;
    for _ in 0..50 {
        let end = uno.send_pin_uart(('B', 0), &other, fast, at, 0)?;
        // T3.5 is 1750 µs above 19 200.
        at = end + us_to_cycles(1_750) + fast.bit_start(fast.char_bits());
    }
    // And one to this slave, which must be answered at the new rate.
    let read = read16();
    let end = uno.send_pin_uart(('B', 0), &read, fast, at, 0)?;
    uno.run_until(end)?;
    let elapsed = uno.now() - begin;
    let busy: u64 = [TIMER1_CAPT, TIMER1_COMPA, TIMER1_COMPB, vector::TIMER0_COMPA, vector::TIMER0_COMPB]
        .into_iter()
        .map(|v| uno.isr_stats(v).cycles)
        .sum();
    uno.run_for(us_to_cycles(30_000))?;
    let reply = uno.take_pin_uart(('B', 1), fast)?;
    if reply.len() != 37 {
        log.problems.push(format!(
            "boards (settings) at 38 400: {} characters after the stream, 37 expected: {:02x?}",
            reply.len(),
            reply.iter().map(|b| b.byte).collect::<Vec<_>>()
        ));
    }
    Ok(busy as f64 / elapsed as f64)
}

fn percentile(sorted: &[u64], p: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// The section of `bench/results.md`.
pub(crate) fn section(md: &mut String, measured: &Option<Measured>) -> Result<()> {
    writeln!(md, "\n## The serial line on pins 8/9 (feature `capture-line`)\n")?;
    let Some(m) = measured else {
        writeln!(md, "Not measured: `{NAME}` is not built (`make chips`).")?;
        return Ok(());
    };
    writeln!(
        md,
        "`{NAME}`: the contract map on the Uno's pins 8 (RX, ICP1) and 9 (TX, OC1A), Timer1 at clk/8, 19200 8E1, \
         as `make chips` builds it; `{USART_NAME}` the same on the USART.\n"
    )?;
    writeln!(md, "| firmware | flash B | static RAM |\n|---|---:|---:|")?;
    writeln!(md, "| `{NAME}` (pins 8/9) | {} | {} B |", m.sizes.0 .0, m.sizes.0 .1)?;
    if let Some((flash, ram)) = m.sizes.1 {
        writeln!(md, "| `{USART_NAME}` (USART0) | {flash} | {ram} B |")?;
        let over = m.sizes.0 .0.saturating_sub(flash);
        let met = if over <= FLASH_OVER_USART { "met" } else { "**not met**" };
        writeln!(md, "\nThe line costs {over} B of flash over the USART's (target ≤ {FLASH_OVER_USART} B: {met}).")?;
    }
    writeln!(md, "\n| interrupt | runs | per run, average | longest run | per character |\n|---|---:|---:|---:|---:|")?;
    let rows = [
        ("TIMER1_CAPT (each edge on RX)", m.edges, m.received),
        ("TIMER1_COMPB (a character's first stop bit; the role's receive handler)", m.stop_bits, m.received),
        ("TIMER1_COMPA (each level change on TX, a character's end)", m.transmit, m.sent),
    ];
    for (what, (runs, cycles, longest), chars) in rows {
        let chars = chars.max(1) as f64;
        let average = if runs == 0 { 0.0 } else { cycles as f64 / runs as f64 };
        writeln!(
            md,
            "| {what} | {runs} | {average:.0} cycles | {longest} cycles | {:.1} runs, {:.0} cycles |",
            runs as f64 / chars,
            cycles as f64 / chars
        )?;
    }
    let (p50, p99, max) =
        (percentile(&m.past_t35, 0.5), percentile(&m.past_t35, 0.99), m.past_t35.last().copied().unwrap_or(0));
    let p99_us = cycles_to_us(p99);
    let met = if p99_us <= REPLY_P99_US { "met" } else { "**not met**" };
    writeln!(
        md,
        "\nThe reply's first start bit past T3.5, {} requests at spread phases: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs \
         (target p99 ≤ {REPLY_P99_US} µs: {met}).",
        m.past_t35.len(),
        cycles_to_us(p50),
        p99_us,
        cycles_to_us(max)
    )?;
    writeln!(
        md,
        "\nFrames to another slave back to back (T3.5 and a character apart): the line's and Timer0's interrupts \
         take {:.1} % of the CPU at 19200, {:.1} % at 38 400 (`boards` switched there through its settings registers).",
        m.share * 100.0,
        m.share_38400 * 100.0
    )?;
    Ok(())
}

/// `bench capture`: this section alone, printed.
pub(crate) fn only(root: &Path, log: &mut Log) -> Result<String> {
    let measured = measure(root, log)?;
    let mut md = String::new();
    section(&mut md, &measured)?;
    Ok(md)
}
