//! The master's sizes beside the Arduino masters, on the same benchmark sketch: 19200 8E1,
//! every 100 ms FC 3 × 10 registers, FC 16 × 2, FC 1 × 8 coils, FC 5 (`examples/poll_four.rs`),
//! and its read-only form, FC 3 × 10 alone (`examples/poll_holding.rs`).

use std::fmt::Write as _;
use std::path::Path;

use crate::elf::{avr_size, firmware_path, template_size};
use crate::Result;

/// The Arduino masters, built from source with Debian's arduino-core-avr and avr-gcc 5.4
/// `-Os -flto` on the same sketch: (library, flash with all four function codes, flash with
/// FC 3 only, static RAM). Quoted from the issue, not measured here: their sources stay
/// outside the repository.
const PEERS: [(&str, u64, u64, u64); 3] = [
    ("4-20ma/ModbusMaster 2.0.1", 3354, 2620, 493),
    ("CMB27/ModbusRTUMaster 2.0.1", 4738, 3534, 251),
    ("smarmengol ModbusRtu", 3592, 3172, 330),
];

/// The section: a table of flash and RAM, and whether ours is smaller than each peer's.
pub(crate) fn section(md: &mut String, root: &Path) -> Result<()> {
    writeln!(md, "\n### The master beside the Arduino masters\n")?;
    writeln!(
        md,
        "The benchmark sketch of the master issue: 19200 8E1, every 100 ms one of FC 3 × 10 registers, FC 16 × 2, \
         FC 1 × 8 coils, FC 5 (`poll_four`), and the read-only form, FC 3 × 10 alone (`poll_holding`). The \
         Arduino masters' figures are quoted from the issue (built from source with arduino-core-avr, avr-gcc 5.4 \
         `-Os -flto`), not measured here; `master_mirror` (every function code, outcomes reported on the line) \
         and `plc_poller` (pins, error LED) for scale. This crate's flash as the avr-hal template builds the \
         example (`make chips`), what a user of the template meets, then as the repository's own target \
         does.\n"
    )?;
    writeln!(md, "| firmware | flash, four FCs B | flash, FC 3 only B | static RAM B |\n|---|---:|---:|---:|")?;
    for (library, four, fc3, ram) in PEERS {
        writeln!(md, "| {library} | {four} | {fc3} | {ram} |")?;
    }
    // Ours as the avr-hal template builds it (`make chips`), then as the repository's own
    // target does; the goals are checked on the template's form when it is built.
    let repository = [avr_size(&firmware_path(root, "poll_four"))?, avr_size(&firmware_path(root, "poll_holding"))?];
    let template = template_size(root, "poll_four").zip(template_size(root, "poll_holding"));
    let [four, fc3] = template.map_or(repository, |(four, fc3)| [four, fc3]);
    let form =
        if template.is_some() { "as the avr-hal template builds it" } else { "not built as the template builds it" };
    writeln!(md, "| this crate ({form}; measured) | {} | {} | {} (four) / {} (FC 3) |", four.0, fc3.0, four.1, fc3.1)?;
    let [r_four, r_fc3] = repository;
    writeln!(
        md,
        "| this crate (the repository's target) | {} | {} | {} (four) / {} (FC 3) |",
        r_four.0, r_fc3.0, r_four.1, r_fc3.1
    )?;
    for name in ["master_mirror", "plc_poller"] {
        let (flash, ram) = avr_size(&firmware_path(root, name))?;
        let template = template_size(root, name).map_or("not built".into(), |(flash, _)| flash.to_string());
        writeln!(md, "| this crate, {name} | {template} (the repository's target: {flash}) | – | {ram} |")?;
    }
    writeln!(md, "\n| goal: smaller than | flash, four FCs | flash, FC 3 only | static RAM |\n|---|---|---|---|")?;
    let verdict = |ours: u64, theirs: u64| {
        if ours < theirs {
            format!("met ({ours} < {theirs})")
        } else {
            format!("**not met** ({ours} ≥ {theirs})")
        }
    };
    for (library, their_four, their_fc3, their_ram) in PEERS {
        let ram = verdict(four.1.max(fc3.1), their_ram);
        writeln!(md, "| {library} | {} | {} | {ram} |", verdict(four.0, their_four), verdict(fc3.0, their_fc3))?;
    }
    Ok(())
}
