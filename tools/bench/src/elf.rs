//! Where the builds put each ELF file, and its flash and static RAM from `avr-size`.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::Result;

/// Where `make firmware` puts the ELF files, relative to the workspace: the repository's
/// own target (`avr-atmega328p.json`).
const FIRMWARE_DIR: &str = "target/avr-atmega328p/release/examples";

/// `make chips`' builds of the Uno's examples as the avr-hal template builds them (target
/// `avr-none`, `-Zbuild-std=core`, `-C target-cpu=atmega328p`): plain, with feature
/// `millis`, and the master's.
const TEMPLATE_BUILDS: [&str; 3] = ["atmega328p", "atmega328p-millis", "atmega328p-master"];

/// Example `name` as `make firmware` builds it for the Uno.
pub(crate) fn firmware_path(root: &Path, name: &str) -> PathBuf {
    root.join(FIRMWARE_DIR).join(format!("{name}.elf"))
}

/// Example `name` of `make chips`' build `build` (`CHIP`, `CHIP-usartN`; `.ci/chip-build`).
pub(crate) fn chip_build_path(root: &Path, build: &str, name: &str) -> PathBuf {
    root.join("target/chips").join(build).join("avr-none/release/examples").join(format!("{name}.elf"))
}

/// `name` as the avr-hal template builds it for the Uno (`make chips`): its (flash, static
/// RAM), or `None` if not built.
pub(crate) fn template_size(root: &Path, name: &str) -> Option<(u64, u64)> {
    let elf = TEMPLATE_BUILDS.iter().map(|build| chip_build_path(root, build, name)).find(|elf| elf.is_file())?;
    avr_size(&elf).ok()
}

/// (flash = text + data, static RAM = data + bss) from `avr-size`.
pub(crate) fn avr_size(elf: &Path) -> Result<(u64, u64)> {
    let out = Command::new("avr-size").arg(elf).output().map_err(|e| format!("avr-size: {e}"))?;
    if !out.status.success() {
        return Err(format!("avr-size {}: {}", elf.display(), String::from_utf8_lossy(&out.stderr).trim()).into());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let nums: Vec<u64> =
        text.lines().nth(1).unwrap_or("").split_whitespace().take(3).filter_map(|w| w.parse().ok()).collect();
    match nums[..] {
        [text, data, bss] => Ok((text + data, data + bss)),
        _ => Err(format!("cannot read avr-size output: {text}").into()),
    }
}
