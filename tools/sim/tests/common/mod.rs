//! Shared helpers: builds the test firmware with avr-gcc and boots it.

#![allow(dead_code)] // each test binary uses a different subset

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};
use uno_sim::{Chip, Options, Uno};

/// Idle loop polls GPIO and the ADC.
pub const MODE_POLL: u8 = 0;
/// Idle loop sleeps.
pub const MODE_SLEEP: u8 = 1;
/// Every byte echoed twice; idle loop sleeps.
pub const MODE_DOUBLE: u8 = 2;
/// No RX interrupt; reads the USART when `drain` is set.
pub const MODE_DRAIN: u8 = 3;
/// Sleeps with interrupts off: simavr stops.
pub const MODE_STOP: u8 = 4;
/// Like [`MODE_DOUBLE`], but 8N1 configured after UBRR0.
pub const MODE_8N1_LATE: u8 = 5;

/// USART_RX_vect's byte address.
pub const RX_VECTOR_ADDR: u32 = 18 * 4;
/// 19200 baud 8E1 at 16 MHz: UBRR0 = 51, 832 cycles per bit, 11 bits.
pub const CHAR: u64 = 832 * 11;
/// Half a bit at 19200 baud: RXC0 rises this much before a character's end (8E1, one stop bit).
pub const HALF_BIT: u64 = 832 / 2;

/// Compiles `source` for `mcu` with the `-D` definitions `defines` into `out`.
pub fn compile(source: &Path, mcu: &str, defines: &[String], out: &Path) {
    let status = Command::new("avr-gcc")
        .arg(format!("-mmcu={mcu}"))
        .args(["-DF_CPU=16000000UL", "-Os", "-g", "-Wall", "-Werror"])
        .args(defines.iter().map(|d| format!("-D{d}")))
        .arg("-o")
        .arg(out)
        .arg(source)
        .status()
        .expect("avr-gcc not found (install gcc-avr and avr-libc)");
    assert!(status.success(), "avr-gcc failed on {} for {mcu} {defines:?}", source.display());
}

/// A fresh path in the test's scratch directory for `name`.
pub fn scratch(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test binary path");
    let tag = exe.file_stem().and_then(|s| s.to_str()).unwrap_or("test").to_owned();
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{tag}-{}-{name}", std::process::id()))
}

/// The echo firmware (tests/fw/echo.c) for the ATmega328P, compiled once per test binary.
pub fn echo_elf() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| echo_elf_for(Chip::Atmega328p, 0, None))
}

/// The echo firmware for `chip` on USART`usart`, with `debug` (`Some(k)`) writing "boot\r\n"
/// on USARTk at start-up; compiled once per test binary and combination.
pub fn echo_elf_for(chip: Chip, usart: u8, debug: Option<u8>) -> PathBuf {
    type Key = (Chip, u8, Option<u8>);
    static ELFS: Mutex<Vec<(Key, PathBuf)>> = Mutex::new(Vec::new());
    let mut elfs = ELFS.lock().unwrap_or_else(|p| p.into_inner());
    let key = (chip, usart, debug);
    if let Some((_, path)) = elfs.iter().find(|(k, _)| *k == key) {
        return path.clone();
    }
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fw/echo.c");
    let debug_tag = debug.map(|k| format!("-debug{k}")).unwrap_or_default();
    let out = scratch(&format!("echo-{chip}-usart{usart}{debug_tag}.elf"));
    let mut defines = vec![format!("USART_N={usart}")];
    defines.extend(debug.map(|k| format!("DEBUG_USART={k}")));
    compile(&source, chip.name(), &defines, &out);
    elfs.push((key, out.clone()));
    out
}

/// Loads the echo firmware in `mode` and runs it until its USART is set up.
pub fn boot(mode: u8) -> Uno {
    ready(Uno::load(echo_elf()).expect("load echo firmware"), mode)
}

/// Loads the echo firmware built for `chip` and USART`usart` (the wire there too) in `mode`
/// and runs it until its USART is set up.
pub fn boot_on(chip: Chip, usart: u8, mode: u8) -> Uno {
    let elf = echo_elf_for(chip, usart, None);
    ready(Uno::load_with(elf, Options::new().usart(usart)).expect("load echo firmware"), mode)
}

/// Sets `mode` in a freshly loaded echo firmware and runs it until its USART is set up.
pub fn ready(mut uno: Uno, mode: u8) -> Uno {
    uno.write_symbol("mode", &[mode]).expect("set mode");
    while uno.read_symbol("ready").unwrap() != [1] {
        assert!(uno.now() < 1_000_000, "firmware never got ready");
        uno.run_for(100).unwrap();
    }
    uno
}

/// The `rx_log` entries recorded so far: (byte, UCSR0A error bits).
pub fn rx_log(uno: &Uno) -> Vec<(u8, u8)> {
    let count = uno.read_symbol("rx_count").unwrap()[0] as usize;
    let log = uno.read_symbol("rx_log").unwrap();
    log.chunks(2).take(count).map(|c| (c[0], c[1])).collect()
}

/// Reads a little-endian u16 array variable.
pub fn read_u16s(uno: &Uno, name: &str) -> Vec<u16> {
    uno.read_symbol(name).unwrap().chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect()
}

/// The baud rate the chip's wire USART runs at now, rounded (None: off).
pub fn baud(uno: &Uno) -> Option<u32> {
    uno.serial_config().map(|c| c.baud().round() as u32)
}

/// The timer UART firmware (tests/fw/timer_uart.c) and its commands.
pub mod timer_uart {
    use super::{compile, scratch};
    use std::path::{Path, PathBuf};
    use std::sync::Mutex;
    use uno_sim::{Chip, Uno};

    /// `command` values of tests/fw/timer_uart.c.
    pub const START: u8 = 1;
    pub const COMPARE: u8 = 2;
    pub const COMPARE_LOW_FIRST: u8 = 3;
    pub const FORCE: u8 = 4;
    pub const TX_OUTPUT: u8 = 5;
    pub const PORT: u8 = 6;
    pub const READ: u8 = 7;
    pub const ECHO: u8 = 8;

    /// TCCRnB: clock clk/8 (CSn1), the noise canceller (ICNCn), the rising edge (ICESn).
    pub const CLK_8: u32 = 0x02;
    pub const ICNC: u32 = 0x80;
    pub const ICES: u32 = 0x40;
    /// COMnA1:0 in `arg`'s top byte for COMPARE: clear or set OCnA at the match.
    pub const COM_CLEAR: u32 = 0x80 << 24;
    pub const COM_SET: u32 = 0xC0 << 24;
    /// Cycles per timer tick at clk/8.
    pub const TICK: u64 = 8;
    /// Cycles of a whole turn of the 16-bit counter at clk/8.
    pub const TURN: u64 = 65536 * TICK;
    /// Ticks from a captured edge to its replay on TX (ECHO_TICKS).
    pub const ECHO_TICKS: u64 = 200;

    /// The timer the firmware uses on `chip`, its RX and TX pins, and TCCRnB's address.
    pub struct Board {
        pub timer: u8,
        pub rx: (char, u8),
        pub tx: (char, u8),
        pub tccrb: u16,
    }

    pub fn board(chip: Chip) -> Board {
        match chip {
            Chip::Atmega32u4 => Board { timer: 3, rx: ('C', 7), tx: ('C', 6), tccrb: 0x91 },
            Chip::Atmega1280 | Chip::Atmega2560 => Board { timer: 5, rx: ('L', 1), tx: ('L', 3), tccrb: 0x121 },
            _ => Board { timer: 1, rx: ('B', 0), tx: ('B', 1), tccrb: 0x81 },
        }
    }

    /// The firmware for `chip`, compiled once per test binary.
    pub fn elf(chip: Chip) -> PathBuf {
        static ELFS: Mutex<Vec<(Chip, PathBuf)>> = Mutex::new(Vec::new());
        let mut elfs = ELFS.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((_, path)) = elfs.iter().find(|(c, _)| *c == chip) {
            return path.clone();
        }
        let out = scratch(&format!("timer_uart-{chip}.elf"));
        let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fw/timer_uart.c");
        compile(&source, chip.name(), &[format!("TIMER={}", board(chip).timer)], &out);
        elfs.push((chip, out.clone()));
        out
    }

    /// The firmware on `chip`, run until it is ready for commands.
    pub fn boot(chip: Chip) -> Uno {
        let mut uno = Uno::load(elf(chip)).expect("load timer_uart firmware");
        while uno.read_symbol("ready").unwrap() != [1] {
            assert!(uno.now() < 1_000_000, "firmware never got ready");
            uno.run_for(100).unwrap();
        }
        uno
    }

    /// Runs `cmd` with `arg` and waits until the firmware has done it.
    pub fn command(uno: &mut Uno, cmd: u8, arg: u32) {
        uno.write_symbol("arg", &arg.to_le_bytes()).unwrap();
        uno.write_symbol("command", &[cmd]).unwrap();
        while uno.read_symbol("command").unwrap() != [0] {
            uno.run_for(10).unwrap();
        }
    }

    /// Starts the timer with TCCRnB = `tccrb`; returns the cycle it starts counting from: the
    /// first cycle of the instruction writing TCCRnB (simavr's; on the chip the prescaler's
    /// phase is free), so that the counter reads `(cycle - base) / 8` at clk/8.
    pub fn start(uno: &mut Uno, tccrb: u32) -> u64 {
        let reg = board(uno.chip()).tccrb;
        uno.write_symbol("arg", &tccrb.to_le_bytes()).unwrap();
        uno.write_symbol("command", &[START]).unwrap();
        loop {
            let before = uno.now();
            uno.step().unwrap();
            if u32::from(uno.read_ram(reg, 1).unwrap()[0]) == tccrb {
                while uno.read_symbol("command").unwrap() != [0] {
                    uno.step().unwrap();
                }
                return before;
            }
        }
    }

    /// The captures logged so far: (ICRn, whether the rising edge was selected).
    pub fn captures(uno: &Uno) -> Vec<(u16, bool)> {
        let count = uno.read_symbol("capture_count").unwrap()[0] as usize;
        let log = uno.read_symbol("captures").unwrap();
        log.chunks(3).take(count).map(|c| (u16::from_le_bytes([c[0], c[1]]), c[2] != 0)).collect()
    }

    /// The counter's value at `cycle`, for a timer started at `base` at clk/8.
    pub fn count_at(base: u64, cycle: u64) -> u16 {
        ((cycle - base) / TICK) as u16
    }

    /// The first cycle at or after `after` at which the counter, started at `base`, moves on
    /// from `ocr`: where a compare match with OCRnA = `ocr` sets OCFnA and acts on OCnA.
    pub fn match_after(base: u64, ocr: u16, after: u64) -> u64 {
        let mut at = base + (u64::from(ocr) + 1) * TICK;
        while at < after {
            at += TURN;
        }
        at
    }
}
