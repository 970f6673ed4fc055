//! Shared helpers: builds the test firmware with avr-gcc and boots it.

#![allow(dead_code)] // each test binary uses a different subset

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use uno_sim::Uno;

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

fn compile(source: &Path, out: &Path) {
    let status = Command::new("avr-gcc")
        .args(["-mmcu=atmega328p", "-DF_CPU=16000000UL", "-Os", "-g", "-Wall", "-Werror", "-o"])
        .arg(out)
        .arg(source)
        .status()
        .expect("avr-gcc not found (install gcc-avr and avr-libc)");
    assert!(status.success(), "avr-gcc failed on {}", source.display());
}

/// The echo firmware (tests/fw/echo.c), compiled once per test binary.
pub fn echo_elf() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| {
        let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fw/echo.c");
        let exe = std::env::current_exe().expect("test binary path");
        let tag = exe.file_stem().and_then(|s| s.to_str()).unwrap_or("test").to_owned();
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("echo-{tag}-{}.elf", std::process::id()));
        compile(&source, &out);
        out
    })
}

/// Loads the echo firmware in `mode` and runs it until its USART is set up.
pub fn boot(mode: u8) -> Uno {
    let mut uno = Uno::load(echo_elf()).expect("load echo firmware");
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
