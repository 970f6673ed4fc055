//! A Modbus master on the simulated wire: sends requests at exact cycles, collects the
//! replies with their timing, and accumulates the firmware's interrupt cycles.

use std::path::Path;

use uno_sim::{us_to_cycles, Error, Options, Uno};

use crate::modbus::Request;

/// Last byte of SRAM.
pub const RAMEND: u16 = 0x08FF;

/// The slave's interrupts, in table order (their vector numbers are the chip's:
/// [`Bus::vectors`]).
pub const VECTORS: [&str; 4] = ["USART_RX", "TIMER0_COMPB (T1.5, T3.5)", "USART_UDRE", "USART_TX"];

/// Cycles spent in one interrupt handler, summed over transactions.
#[derive(Clone, Copy, Debug, Default)]
pub struct IsrTotal {
    /// Handler runs.
    pub entries: u64,
    /// Cycles, interrupt response to RETI.
    pub cycles: u64,
    /// Longest single run.
    pub max: u64,
}

impl IsrTotal {
    /// Mean cycles per run.
    pub fn mean(&self) -> f64 {
        self.cycles as f64 / self.entries.max(1) as f64
    }
}

/// One request and what came back.
#[derive(Clone, Debug)]
pub struct Transaction {
    /// The reply bytes (empty: no reply).
    pub reply: Vec<u8>,
    /// First reply start bit minus the end of T3.5 after the request's true end on the line
    /// (its last stop bit), in cycles.
    pub turnaround: Option<i64>,
    /// Longest TIMER0_COMPB run up to T3.5: the gap deadline's, which checked the frame's
    /// CRC.
    pub gap_isr: u64,
    /// Longest TIMER0_COMPB run from T3.5 on: the one that processed the frame and started
    /// the reply.
    pub t35_isr: u64,
    /// Longest silence between two characters of the reply, in cycles.
    pub max_gap: u64,
}

/// The simulated Uno with a master attached to its USART.
pub struct Bus {
    uno: Uno,
    name: String,
    /// Character time on the wire, cycles.
    pub char_cycles: u64,
    /// Bits per character.
    pub char_bits: u32,
    /// T3.5 as the master counts it, from the end of the request's last stop bit, cycles: 3.5
    /// characters, 1750 µs above 19200 bps.
    pub t35: u64,
    /// T1.5, the longest silence allowed inside a frame: 1.5 characters, 750 µs above 19200 bps.
    pub t15: u64,
    /// Actual bit rate (from UBRR0).
    pub baud: f64,
    /// Earliest start of the next request's first start bit.
    idle_from: u64,
    /// Interrupt cycles per entry of [`VECTORS`] since boot.
    pub isr: [IsrTotal; VECTORS.len()],
    /// The vector numbers of [`VECTORS`] on this chip and USART.
    vectors: [u8; VECTORS.len()],
}

impl Bus {
    /// Loads `elf`, drives `low_pins` low (switches closed), optionally paints the free RAM
    /// above `.bss` with `paint`, and runs past the firmware's set-up and power-up silence.
    pub fn boot(elf: &Path, low_pins: &[u8], paint: Option<u8>) -> Result<Bus, Error> {
        Bus::boot_with(elf, Options::new(), low_pins, paint)
    }

    /// [`Bus::boot`] with the master on USART `usart` of the chip the firmware names.
    pub fn boot_on(elf: &Path, usart: u8) -> Result<Bus, Error> {
        Bus::boot_with(elf, Options::new().usart(usart), &[], None)
    }

    fn boot_with(elf: &Path, options: Options, low_pins: &[u8], paint: Option<u8>) -> Result<Bus, Error> {
        let mut uno = Uno::load_with(elf, options)?;
        for &pin in low_pins {
            uno.drive_pin(pin, Some(false))?;
        }
        if let Some(pattern) = paint {
            let start = stack_floor(&uno)?;
            uno.write_ram(start, &vec![pattern; usize::from(RAMEND + 1 - start)])?;
        }
        uno.run_until(us_to_cycles(50_000))?;
        let cfg = uno.serial_config().ok_or(Error::UartNotConfigured)?;
        let fixed = cfg.baud() > 19_200.0 * 1.05;
        let t35 = if fixed { us_to_cycles(1750) } else { cfg.char_cycles() * 7 / 2 };
        let t15 = if fixed { us_to_cycles(750) } else { cfg.char_cycles() * 3 / 2 };
        let idle_from = uno.now();
        let name = elf.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let v = uno.vectors();
        Ok(Bus {
            vectors: [v.usart_rx, v.timer0_compb, v.usart_udre, v.usart_tx],
            uno,
            name,
            char_cycles: cfg.char_cycles(),
            char_bits: cfg.char_bits(),
            t35,
            t15,
            baud: cfg.baud(),
            idle_from,
            isr: [IsrTotal::default(); VECTORS.len()],
        })
    }

    /// The firmware's name (its file stem).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Cycle at which the line has been idle long enough for the next request.
    pub fn idle_from(&self) -> u64 {
        self.idle_from
    }

    /// Sends `req` with its first start bit `delay` cycles after the line allows it (T3.5
    /// after the previous reply), back to back, and runs until the reply is over and T3.5
    /// has passed after it (or, without a reply, until the longest reply would be over).
    pub fn transact(&mut self, req: &Request, delay: u64) -> Result<Transaction, Error> {
        self.uno.reset_isr_stats();
        let start = self.idle_from.max(self.uno.now()) + delay;
        // The end of the last character on the line: the USART flagged it earlier (uno-sim's
        // RXC at the middle of the first stop bit), T3.5 counts from here.
        let last_end = self.uno.send_frame(&req.frame, start + self.char_cycles, 0)?;
        let t35_end = last_end + self.t35;
        // The compare interrupt runs twice for a frame: at the gap deadline, which checks
        // its CRC, and at T3.5, which processes it and builds the reply. Just before T3.5 the
        // first run is over (the gap deadline comes a character or more earlier, and the
        // check of 256 bytes takes under 9000 cycles), so the two are told apart there.
        self.uno.run_until(t35_end - 16)?;
        let compare = self.vectors[1];
        let gap_isr = self.uno.isr_stats(compare).max_cycles;
        self.add_isr_stats();
        self.uno.reset_isr_stats();
        // The longest reply (256 characters), late by at most a few ms of processing.
        let deadline = t35_end + 256 * self.char_cycles + us_to_cycles(10_000);
        let tx = self.uno.run_until_tx_idle(self.t35, deadline)?;
        self.idle_from = tx.last().map_or(self.uno.now(), |b| b.end_cycle + self.t35);
        self.add_isr_stats();
        Ok(Transaction {
            reply: tx.iter().map(|b| b.byte).collect(),
            turnaround: tx.first().map(|b| b.start_cycle as i64 - t35_end as i64),
            gap_isr,
            t35_isr: self.uno.isr_stats(compare).max_cycles,
            max_gap: tx.windows(2).map(|w| w[1].start_cycle.saturating_sub(w[0].end_cycle)).max().unwrap_or(0),
        })
    }

    /// Adds the interrupt statistics gathered since they were last reset to the totals.
    fn add_isr_stats(&mut self) {
        for (total, &v) in self.isr.iter_mut().zip(self.vectors.iter()) {
            let s = self.uno.isr_stats(v);
            total.entries += s.entries;
            total.cycles += s.cycles;
            total.max = total.max.max(s.max_cycles);
        }
    }

    /// Stack bytes used since boot: from the lowest painted byte that changed up to RAMEND.
    pub fn stack_used(&self, pattern: u8) -> Result<u16, Error> {
        let start = stack_floor(&self.uno)?;
        let ram = self.uno.read_ram(start, usize::from(RAMEND + 1 - start))?;
        Ok(ram.iter().position(|&b| b != pattern).map_or(0, |i| RAMEND + 1 - start - i as u16))
    }
}

/// First byte above the static data: `__heap_start`, `__bss_end` or `_end`.
fn stack_floor(uno: &Uno) -> Result<u16, Error> {
    ["__heap_start", "__bss_end", "_end"]
        .iter()
        .find_map(|name| uno.symbol(name))
        // Data-space symbols may come with the toolchain's 0x800000 offset (absolute ones).
        .and_then(|s| u16::try_from(s.addr & 0xFFFF).ok())
        .ok_or_else(|| Error::UnknownSymbol("__bss_end".into()))
}
