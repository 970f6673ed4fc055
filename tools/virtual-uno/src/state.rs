//! `--state DIR`: the board's flash and EEPROM in files, kept as a chip keeps them unplugged.
//! Both are written back whenever they changed (checked at each reset, twice a second and
//! on exit), so a firmware flashed through the bootloader and the settings it wrote to
//! EEPROM are there when the virtual board starts again.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use uno_sim::Uno;

/// The two files and what they held when last written.
pub struct State {
    flash_path: PathBuf,
    eeprom_path: PathBuf,
    flash: Vec<u8>,
    eeprom: Vec<u8>,
}

impl State {
    /// Opens (or creates) DIR. Loads its EEPROM into the chip, and its flash unless
    /// `keep_program` (a firmware file was given and replaces the program). A file of
    /// another size is another chip's: refused.
    pub fn open(dir: &Path, uno: &mut Uno, keep_program: bool) -> Result<State, String> {
        fs::create_dir_all(dir).map_err(|e| format!("--state {}: {e}", dir.display()))?;
        let flash_path = dir.join("flash.bin");
        let eeprom_path = dir.join("eeprom.bin");
        let chip = uno.chip();
        if let Some(eeprom) = read(&eeprom_path, uno.eeprom_size(), chip)? {
            uno.write_eeprom(0, &eeprom).map_err(|e| e.to_string())?;
        }
        if !keep_program {
            if let Some(flash) = read(&flash_path, uno.flash_size(), chip)? {
                uno.write_flash(0, &flash).map_err(|e| e.to_string())?;
            }
        }
        let mut state = State { flash_path, eeprom_path, flash: Vec::new(), eeprom: Vec::new() };
        state.save(uno).map_err(|e| format!("--state {}: {e}", dir.display()))?;
        Ok(state)
    }

    /// Writes whatever changed since the last call.
    pub fn save(&mut self, uno: &Uno) -> io::Result<()> {
        let flash = uno.flash();
        if flash != self.flash {
            write(&self.flash_path, &flash)?;
            self.flash = flash;
        }
        let eeprom = uno.eeprom();
        if eeprom != self.eeprom {
            write(&self.eeprom_path, &eeprom)?;
            self.eeprom = eeprom;
        }
        Ok(())
    }
}

/// The file's bytes; `None` if there is none yet.
fn read(path: &Path, size: usize, chip: uno_sim::Chip) -> Result<Option<Vec<u8>>, String> {
    match fs::read(path) {
        Ok(bytes) if bytes.len() == size => Ok(Some(bytes)),
        Ok(bytes) => Err(format!(
            "{} holds {} bytes, the {chip} has {size}: another chip's state (use another --state)",
            path.display(),
            bytes.len()
        )),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Replaces the file in one step (written beside it, then renamed), so a reader or a
/// killed run never sees half of it.
fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = path.with_extension("bin.new");
    fs::write(&tmp, bytes)?;
    fs::rename(&tmp, path)
}
