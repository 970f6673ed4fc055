//! The interrupt handlers' cycles: every handler over the workload, and the compare
//! interrupt's two jobs (the frame check at the gap deadline, the reply at T3.5) per request.

use std::fmt::Write as _;

use uno_sim::cycles_to_us;

use crate::bus::VECTORS;
use crate::firmware::firmware;
use crate::profile::Profile;
use crate::requests::{label, workload};
use crate::series::Series;
use crate::Result;

/// The compare interrupt's rows: (firmware, workload request).
const CASES: [(&str, &str); 7] = [
    ("minimal", "FC 3 × 4"),
    ("uno_slave", "FC 3 × 10"),
    ("dip_switch", "FC 3 × 10"),
    ("dip_switch", "FC 16 × 10"),
    ("dip_switch", "FC 1 × 16"),
    ("dip_switch", "FC 15 × 16"),
    ("dip_switch", "FC 3 × 125 → exception 02"),
];

/// Mean / max (runs) of each handler per firmware, and which took the most time.
pub(crate) fn handlers(md: &mut String, profiles: &[Profile]) -> Result<()> {
    writeln!(md, "\n## Interrupt handlers over the workload\n")?;
    let fcs: Vec<String> = workload(firmware("uno_slave")).iter().map(label).collect();
    writeln!(
        md,
        "Cycles from the interrupt response to the end of RETI: mean / max (runs). Workload: {} (addresses \
         that do not exist get exception 02).\n",
        fcs.join(", ")
    )?;
    write!(md, "| firmware |")?;
    for name in VECTORS {
        write!(md, " {name} |")?;
    }
    writeln!(md, " most interrupt time |\n|---|{}---|", "---:|".repeat(VECTORS.len()))?;
    for p in profiles {
        write!(md, "| {} |", p.name)?;
        for s in &p.isr {
            write!(md, " {:.1} / {} ({}) |", s.mean(), s.max, s.entries)?;
        }
        let total: u64 = p.isr.iter().map(|s| s.cycles).sum();
        let (top, name) = p.isr.iter().zip(VECTORS).map(|(s, n)| (s.cycles, n)).max().unwrap_or((0, ""));
        writeln!(md, " {name}: {:.0} % |", 100.0 * top as f64 / total.max(1) as f64)?;
    }
    Ok(())
}

/// The compare interrupt's longest runs per request of [`CASES`], and on `max_frame`'s
/// largest frames (`big`) if built.
pub(crate) fn compare(md: &mut String, profiles: &[Profile], big: &[Series]) -> Result<()> {
    writeln!(md, "\n## Compare interrupt: frame check at the gap deadline, processing and reply CRC at T3.5\n")?;
    if big.is_empty() {
        writeln!(
            md,
            "No example has 125 holding registers (no max_frame firmware): FC 3 × 125 is measured on its \
             exception path; the largest normal register cases are 10 registers.\n"
        )?;
    }
    writeln!(
        md,
        "| firmware | request | gap deadline cycles | µs | T3.5 cycles | µs |\n|---|---|---:|---:|---:|---:|"
    )?;
    for (name, case) in CASES {
        let hit = profiles.iter().filter(|p| p.name == name).flat_map(|p| &p.t35).find(|(l, _, _)| l == case);
        if let Some((_, gap, t35)) = hit {
            writeln!(
                md,
                "| {name} | {case} | {gap} | {:.1} | {t35} | {:.1} |",
                cycles_to_us(*gap),
                cycles_to_us(*t35)
            )?;
        }
    }
    for s in big {
        writeln!(
            md,
            "| max_frame ({}) | {} | {} | {:.1} | {} | {:.1} |",
            s.line,
            s.request,
            s.gap_isr,
            cycles_to_us(s.gap_isr),
            s.t35_isr,
            cycles_to_us(s.t35_isr)
        )?;
    }
    Ok(())
}
