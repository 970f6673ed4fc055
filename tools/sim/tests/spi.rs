//! The SPI port's byte time (csrc/spi.c): 8 SPI clocks from the SPDR write to SPIF, as on the
//! chip (ATmega328P datasheet §19, SPCR/SPSR), not simavr 1.6's 100 µs (1600 cycles) a byte.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{compile, scratch};
use uno_sim::Uno;

/// SPSR's and SPDR's data-space addresses on the ATmega328P.
const SPSR: u16 = 0x4D;
const SPIF: u8 = 0x80;
/// `OUT 0x2E, Rr` (SPDR is I/O address 0x2E): 1011 1AAr rrrr AAAA.
const OUT_SPDR_MASK: u16 = 0xF80F | 0x0600;
const OUT_SPDR: u16 = 0xB800 | (0x2E & 0x30) << 5 | (0x2E & 0x0F);

fn spi_elf() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| {
        let out = scratch("spi.elf");
        compile(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fw/spi.c"), "atmega328p", &[], &out);
        out
    })
}

/// Cycles from the end of the instruction writing SPDR to the end of the instruction after
/// which SPIF reads set (the polling loop adds at most 2), for SPR1:0 = `spr` and SPI2X.
fn byte_time(spr: u8, spi2x: bool) -> u64 {
    let mut uno = Uno::load(spi_elf()).unwrap();
    while uno.read_symbol("ready").unwrap() != [1] {
        uno.run_for(100).unwrap();
    }
    let flash = uno.flash();
    uno.write_symbol("spr", &[spr]).unwrap();
    uno.write_symbol("spi2x", &[u8::from(spi2x)]).unwrap();
    uno.write_symbol("go", &[1]).unwrap();
    let mut written = None;
    for _ in 0..100_000 {
        let pc = uno.pc() as usize;
        let opcode = u16::from_le_bytes([flash[pc], flash[pc + 1]]);
        uno.step().unwrap();
        match written {
            None if opcode & OUT_SPDR_MASK == OUT_SPDR => written = Some(uno.now()),
            Some(at) if uno.read_ram(SPSR, 1).unwrap()[0] & SPIF != 0 => return uno.now() - at,
            _ => {}
        }
    }
    panic!("no SPI byte completed (SPDR written: {written:?})");
}

#[test]
fn a_byte_at_fosc_2_takes_16_cycles() {
    let t = byte_time(0, true);
    assert!((16..=18).contains(&t), "{t} cycles");
}

#[test]
fn a_byte_takes_8_spi_clocks_at_every_divisor() {
    // SPR1:0 and SPI2X -> divisor: fosc/4, /16, /64, /128, halved with SPI2X
    for (spr, spi2x, divisor) in
        [(0, false, 4), (1, false, 16), (1, true, 8), (2, false, 64), (3, false, 128), (3, true, 64)]
    {
        let t = byte_time(spr, spi2x);
        assert!(
            (8 * divisor..=8 * divisor + 2).contains(&t),
            "SPR {spr} SPI2X {spi2x}: {t} cycles, not {}",
            8 * divisor
        );
    }
}

#[test]
fn without_a_part_the_master_reads_zero() {
    let mut uno = Uno::load(spi_elf()).unwrap();
    uno.run_for(1000).unwrap();
    uno.write_symbol("tx", &[0xA5]).unwrap();
    uno.write_symbol("go", &[1]).unwrap();
    uno.run_for(1000).unwrap();
    assert_eq!(uno.read_symbol("done").unwrap(), [1]);
    assert_eq!(uno.read_symbol("rx").unwrap(), [0]);
}
