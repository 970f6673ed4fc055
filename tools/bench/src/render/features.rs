//! What each optional feature costs against what the README says: its targets' rows, and
//! its table.

use std::fmt::Write as _;

use crate::features::{FeatureCost, FEATURES_DIR, FEATURE_SLACK_BYTES, FEATURE_SLACK_PCT};
use crate::Result;

use super::targets::Row;

/// A target per feature: costs what the README says (`eeprom-settings`: `configurable`'s
/// total).
pub(crate) fn target_rows(row: Row, features: &[FeatureCost]) -> std::fmt::Result {
    for f in features {
        let (target, claim) = match &f.claim {
            Some((_, figure)) if f.total => {
                (format!("`{}`: `configurable` in all as the README says", f.feature), format!("{figure} B"))
            }
            Some((_, figure)) => (format!("`{}` costs what the README says", f.feature), format!("{figure:+} B")),
            None => (format!("`{}` costs what the README says", f.feature), "no claim found in README.md".into()),
        };
        let measured = match f.measured {
            Some((flash, ram)) if f.total => format!("{flash} B flash, {ram} B RAM"),
            Some((flash, ram)) => format!("{flash:+} B flash, {ram:+} B RAM"),
            None if f.total => "not built (`make firmware`)".into(),
            None => "not built (`make bench-features`)".into(),
        };
        row(format!("{target} ({claim})"), format!("{measured}; {}", f.how), f.met())?;
    }
    Ok(())
}

/// The table: each feature's flash and RAM beside the README's cell.
pub(crate) fn section(md: &mut String, features: &[FeatureCost]) -> Result<()> {
    writeln!(md, "\n### Optional features against the README\n")?;
    writeln!(
        md,
        "`minimal` built with each feature (`make bench-features`, the `firmware` target's cargo invocation with \
         `--features examples,<feature>` into `{FEATURES_DIR}`) against the same plain build; `eeprom-settings` \
         as `configurable`'s total from `make firmware` (the example needs the feature). Met: within \
         {FEATURE_SLACK_PCT} % of the README's figure or {FEATURE_SLACK_BYTES} B, whichever is larger. The \
         README's cells:\n"
    )?;
    writeln!(md, "| feature | flash | RAM | README says |\n|---|---:|---:|---|")?;
    for f in features {
        let (flash, ram) = match f.measured {
            Some((flash, ram)) if f.total => (format!("{flash} B in all"), format!("{ram} B in all")),
            Some((flash, ram)) => (format!("{flash:+} B"), format!("{ram:+} B")),
            None => ("not built".into(), "not built".into()),
        };
        let cell = f.claim.as_ref().map_or("–", |(cell, _)| cell.as_str());
        writeln!(md, "| `{}` | {flash} | {ram} | {cell} |", f.feature)?;
    }
    writeln!(md)?;
    Ok(())
}
