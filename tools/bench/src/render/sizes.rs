//! Flash, static RAM and stack of each of the Uno's examples.

use std::fmt::Write as _;

use crate::bus::RAMEND;
use crate::profile::Profile;
use crate::Result;

/// The ATmega328P's SRAM, bytes.
const SRAM: i64 = 2048;

/// The table: flash as the template builds each example, then the rest as measured on the
/// repository's build.
pub(crate) fn section(md: &mut String, profiles: &[Profile]) -> Result<()> {
    writeln!(md, "## Size and stack\n")?;
    writeln!(
        md,
        "Flash and static RAM from `avr-size`: flash first as the avr-hal template builds the example (`make \
         chips`), then as the repository's own target does (`make firmware`: the builds the simulator runs, \
         whose static RAM and stack these are). Stack: the free RAM above `.bss` painted before reset, then the \
         workload (one request of every function code, below); bytes from the lowest one changed up to RAMEND \
         (0x{RAMEND:03X}). Register values: 2 B per register, 1 bit per coil or input of the example's register \
         table.\n"
    )?;
    writeln!(
        md,
        "| firmware | flash (text+data) B | flash, the repository's target B | static RAM (data+bss) B | register \
         values B | stack high-water B | RAM left B |\n|---|---:|---:|---:|---:|---:|---:|"
    )?;
    for p in profiles {
        let left = SRAM - p.ram as i64 - i64::from(p.stack);
        let template = p.template.map_or("not built".into(), |(flash, _)| flash.to_string());
        writeln!(md, "| {} | {template} | {} | {} | {} | {} | {left} |", p.name, p.flash, p.ram, p.values, p.stack)?;
    }
    Ok(())
}
