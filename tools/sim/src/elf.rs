//! Just enough ELF32 parsing to vet a file before simavr sees it, to read its symbol table and
//! the device it was linked for.

use crate::Error;
use std::path::Path;

/// `e_machine` of Atmel AVR ELF files.
pub const EM_AVR: u16 = 83;

/// Offset the GNU AVR toolchain adds to data-space (SRAM) addresses.
const DATA_OFFSET: u32 = 0x80_0000;
/// Offset of the EEPROM space.
const EEPROM_OFFSET: u32 = 0x81_0000;
/// End of the pseudo address spaces the toolchain uses (fuses, lock bits, signature follow EEPROM).
const EEPROM_END: u32 = 0x82_0000;

/// Which memory a symbol lives in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// Program memory; `addr` is a byte address.
    Flash,
    /// Data space (registers, I/O, SRAM); `addr` is what `read_ram` takes.
    Ram,
    /// EEPROM; `addr` is the EEPROM byte address.
    Eeprom,
    /// Anything else (absolute symbols, fuses, ...); `addr` is the raw ELF value.
    Other,
}

/// A symbol from the firmware's ELF symbol table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Symbol {
    /// The symbol's name.
    pub name: String,
    /// Its memory space.
    pub space: Space,
    /// Its address within `space`.
    pub addr: u32,
    /// Its size in bytes (0 if the toolchain did not record one).
    pub size: u32,
}

fn u16_at(b: &[u8], off: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(off..off.checked_add(2)?)?.try_into().ok()?))
}

fn u32_at(b: &[u8], off: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(off..off.checked_add(4)?)?.try_into().ok()?))
}

fn usize_at(b: &[u8], off: usize) -> Option<usize> {
    usize::try_from(u32_at(b, off)?).ok()
}

/// Checks that `bytes` is a 32-bit little-endian AVR ELF file.
pub fn check_avr(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let bad = |why: String| Error::BadElf { path: path.to_owned(), reason: why };
    if bytes.len() < 4 || &bytes[..4] != b"\x7fELF" {
        return Err(bad("not an ELF file (no ELF magic)".into()));
    }
    if bytes.len() < 52 {
        return Err(bad("truncated ELF header".into()));
    }
    let machine = u16_at(bytes, 18).unwrap_or(0);
    if machine != EM_AVR {
        return Err(bad(format!("ELF file is for machine {machine}, not AVR ({EM_AVR})")));
    }
    if bytes[4] != 1 || bytes[5] != 1 {
        return Err(bad("not a 32-bit little-endian ELF file".into()));
    }
    if u16_at(bytes, 16) != Some(2) {
        return Err(bad("not an executable (ET_EXEC) ELF file".into()));
    }
    Ok(())
}

/// The device a linked AVR executable was built for (`atmega2560`), from the
/// `.note.gnu.avr.deviceinfo` note that avr-libc's start-up code (crt*.o) puts into every file
/// avr-gcc links, Rust firmware included. `None` if the file has no such note.
///
/// The note (owner `AVR`, type 1) describes flash, SRAM and EEPROM as six 32-bit words, then a
/// table of string offsets whose first word is the table's size in bytes and whose second is
/// the device name's offset in the string table that follows the offset table.
pub fn device_name(bytes: &[u8]) -> Option<String> {
    const SHT_NOTE: u32 = 7;
    let shoff = usize_at(bytes, 32)?;
    let shentsize = usize::from(u16_at(bytes, 46)?);
    let shnum = usize::from(u16_at(bytes, 48)?);
    (0..shnum).find_map(|i| {
        let sh = shoff.checked_add(i.checked_mul(shentsize)?)?;
        if u32_at(bytes, sh.checked_add(4)?)? != SHT_NOTE {
            return None;
        }
        let off = usize_at(bytes, sh.checked_add(16)?)?;
        let size = usize_at(bytes, sh.checked_add(20)?)?;
        avr_note_device(bytes.get(off..off.checked_add(size)?)?)
    })
}

/// The device name in one note section, if it is avr-libc's device-info note.
fn avr_note_device(note: &[u8]) -> Option<String> {
    let (namesz, descsz, kind) = (usize_at(note, 0)?, usize_at(note, 4)?, u32_at(note, 8)?);
    let desc_at = 12usize.checked_add(namesz.checked_next_multiple_of(4)?)?;
    if kind != 1 || note.get(12..12usize.checked_add(namesz)?)? != b"AVR\0" {
        return None;
    }
    let desc = note.get(desc_at..desc_at.checked_add(descsz)?)?;
    let table_size = usize_at(desc, 24)?;
    let name_off = usize_at(desc, 28)?;
    let strtab = desc.get(24usize.checked_add(table_size)?..)?;
    let name = strtab.get(name_off..)?;
    let name = &name[..name.iter().position(|&c| c == 0)?];
    let name = std::str::from_utf8(name).ok()?;
    (!name.is_empty()).then(|| name.to_owned())
}

/// Reads the symbol table (`.symtab`) of a 32-bit little-endian ELF file.
/// Returns an empty list for stripped or malformed files.
pub fn symbols(bytes: &[u8]) -> Vec<Symbol> {
    parse_symbols(bytes).unwrap_or_default()
}

fn parse_symbols(b: &[u8]) -> Option<Vec<Symbol>> {
    let shoff = usize_at(b, 32)?;
    let shentsize = usize::from(u16_at(b, 46)?);
    let shnum = usize::from(u16_at(b, 48)?);
    if shentsize < 40 {
        return None;
    }
    let section = |i: usize| -> Option<(u32, usize, usize, usize, usize)> {
        let sh = shoff.checked_add(i.checked_mul(shentsize)?)?;
        Some((
            u32_at(b, sh.saturating_add(4))?,
            usize_at(b, sh.saturating_add(16))?,
            usize_at(b, sh.saturating_add(20))?,
            usize_at(b, sh.saturating_add(24))?,
            usize_at(b, sh.saturating_add(36))?,
        ))
    };
    const SHT_SYMTAB: u32 = 2;
    let (_, sym_off, sym_size, link, entsize) = (0..shnum).filter_map(section).find(|s| s.0 == SHT_SYMTAB)?;
    let (_, str_off, str_size, _, _) = section(link)?;
    let strtab = b.get(str_off..str_off.checked_add(str_size)?)?;
    let entsize = if entsize >= 16 { entsize } else { 16 };
    let table = b.get(sym_off..sym_off.checked_add(sym_size)?)?;

    let mut out = Vec::new();
    for ent in table.chunks_exact(entsize) {
        let name_off = usize_at(ent, 0)?;
        let value = u32_at(ent, 4)?;
        let size = u32_at(ent, 8)?;
        let kind = ent[12] & 0x0f;
        let shndx = u16_at(ent, 14)?;
        // STT_NOTYPE, STT_OBJECT, STT_FUNC only (no sections, files)
        if kind > 2 {
            continue;
        }
        let name_bytes = strtab.get(name_off..)?;
        let end = name_bytes.iter().position(|&c| c == 0)?;
        let Ok(name) = std::str::from_utf8(&name_bytes[..end]) else { continue };
        if name.is_empty() {
            continue;
        }
        const SHN_ABS: u16 = 0xfff1;
        let (space, addr) = match value {
            v if shndx == SHN_ABS => (Space::Other, v),
            v if v < DATA_OFFSET => (Space::Flash, v),
            v if v < EEPROM_OFFSET => (Space::Ram, v - DATA_OFFSET),
            v if v < EEPROM_END => (Space::Eeprom, v - EEPROM_OFFSET),
            v => (Space::Other, v),
        };
        out.push(Symbol { name: name.to_owned(), space, addr, size });
    }
    Some(out)
}
