//! The contract beside the Arduino slave libraries, on the same register set.

use std::fmt::Write as _;

use crate::firmware::CONTRACTS;
use crate::report::Report;
use crate::Result;

/// The Arduino libraries the issue compares with, on the same register set at 19200 8E1:
/// (library, flash B, static RAM). Quoted from the issue, not measured here.
const LIBRARIES: [(&str, u64, &str); 3] = [
    ("smarmengol ModbusRtu", 3746, "319 B"),
    ("CMB27 ModbusRTUSlave 3.1", 4986, "309 B"),
    ("emelianov modbus-esp8266 4.1", 10038, "270 B + heap"),
];

/// How each contract keeps its map, in the order of [`CONTRACTS`].
const MAPS: [&str; 2] = ["`register_map!`, fixed at build time", "a run-time `Bank`"];

/// The table: the libraries' flash and RAM, then the contract's as the template builds it.
pub(crate) fn section(md: &mut String, r: &Report) -> Result<()> {
    writeln!(md, "\n### sixteen_each beside the Arduino libraries\n")?;
    writeln!(
        md,
        "The same register set (16 coils, 16 discrete inputs, 8 input registers, 16 holding registers, slave 1, \
         19200 8E1, idle main loop). The libraries' figures are quoted from the issue, not measured here (there \
         they reply 0.8–2.9 ms after T3.5, and 127–308 ms (median) after it once the loop calls delay(200)).\n"
    )?;
    writeln!(
        md,
        "This crate's flash is the example built as the avr-hal template builds it (target `avr-none`, \
         `-Zbuild-std=core`, `-C target-cpu=atmega328p`: `make chips`), what a user of the template meets; the \
         repository's own target (`avr-atmega328p.json`, `make firmware`) beside it. Both link the crate's \
         compact `memcpy` and `memset` (src/avr/mem.rs) in place of compiler_builtins' and avr-libc's.\n"
    )?;
    writeln!(
        md,
        "| firmware | flash (text+data) B | flash, the repository's target B | static RAM (data+bss) |\n\
         |---|---:|---:|---:|"
    )?;
    for (library, flash, ram) in LIBRARIES {
        writeln!(md, "| {library} | {flash} | – | {ram} |")?;
    }
    for (name, map) in CONTRACTS.into_iter().zip(MAPS) {
        let Some(p) = r.profile(name) else {
            writeln!(md, "| this crate ({name}: {map}) | not built | not built | not built |")?;
            continue;
        };
        let template = p.template.map_or("not built (`make chips`)".into(), |(flash, _)| flash.to_string());
        writeln!(md, "| this crate ({name}: {map}; measured) | {template} | {} | {} B |", p.flash, p.ram)?;
    }
    Ok(())
}
