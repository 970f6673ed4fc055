//! What each optional feature costs, measured on `minimal` (`make bench-features`), against
//! what the README says.

use std::path::Path;

use crate::elf::{avr_size, firmware_path};
use crate::readme::readme_claim;

/// Where `make bench-features` puts `minimal` built with each optional feature.
pub(crate) const FEATURES_DIR: &str = "target/bench-features";

/// Optional features measured on `minimal` (`make bench-features`).
const FEATURES: [&str; 7] = ["extra-fc", "diagnostics", "write-protect", "device-id", "millis", "ascii", "reply-delay"];

/// A feature's cost meets the README's claim within this share of the claim or
/// [`FEATURE_SLACK_BYTES`], whichever is larger.
pub(crate) const FEATURE_SLACK_PCT: u64 = 10;
pub(crate) const FEATURE_SLACK_BYTES: u64 = 64;

/// An optional feature: what it costs as measured, and what the README says.
pub(crate) struct FeatureCost {
    pub(crate) feature: String,
    /// What was measured, e.g. "`minimal` + feature − `minimal`".
    pub(crate) how: String,
    /// (flash, RAM) measured: a difference, or a total for `total` rows; `None` if not built.
    pub(crate) measured: Option<(i64, i64)>,
    /// The README's claim (its table's cell) and the figure in it compared with.
    pub(crate) claim: Option<(String, i64)>,
    /// Whether `measured` is a total (configurable) rather than a difference.
    pub(crate) total: bool,
}

impl FeatureCost {
    /// Whether the flash measured is within the slack of the README's figure; `None` if
    /// either is missing.
    pub(crate) fn met(&self) -> Option<bool> {
        let ((flash, _), (_, claim)) = (self.measured?, self.claim.as_ref()?);
        let slack = (claim.unsigned_abs() * FEATURE_SLACK_PCT / 100).max(FEATURE_SLACK_BYTES);
        Some(flash.abs_diff(*claim) <= slack)
    }
}

/// Flash and RAM of `minimal` with each optional feature against the plain build (both
/// from `make bench-features`), and `configurable`'s total from `make firmware`.
pub(crate) fn feature_costs(root: &Path) -> Vec<FeatureCost> {
    let features = root.join(FEATURES_DIR);
    let plain = avr_size(&features.join("minimal.elf")).ok();
    let minimal_src = std::fs::read_to_string(root.join("examples/minimal.rs")).unwrap_or_default();
    let mut out: Vec<FeatureCost> = FEATURES
        .iter()
        .map(|feature| {
            let with = avr_size(&features.join(format!("minimal+{feature}.elf"))).ok();
            let measured = plain.zip(with).map(|((f0, r0), (f1, r1))| (f1 as i64 - f0 as i64, r1 as i64 - r0 as i64));
            let mut how = format!("`minimal` with `{feature}` − `minimal`");
            let mut claim = readme_claim(root, feature, false);
            // A cost that only comes with a call (write-protect: `Bank::protect`) is not
            // there in a build that never makes it: then the README's "0 B unless enabled"
            // is what this build can check.
            if let Some((cell, figure)) = &mut claim {
                if cell.contains("0 B unless enabled") && !minimal_src.contains(".protect(") {
                    *figure = 0;
                    how.push_str(
                        "; minimal never calls `Bank::protect`, so this checks the README's \"0 B unless enabled\" \
                         (its one-range figure needs a build that protects a range)",
                    );
                }
            }
            FeatureCost { feature: (*feature).to_owned(), how, measured, claim, total: false }
        })
        .collect();
    let configurable = avr_size(&firmware_path(root, "configurable")).ok();
    out.push(FeatureCost {
        feature: "eeprom-settings".into(),
        how:
            "`configurable` in all (`make firmware`: with eeprom-settings, diagnostics, extra-fc, write-protect, ascii, device-id)"
                .into(),
        measured: configurable.map(|(f, r)| (f as i64, r as i64)),
        claim: readme_claim(root, "eeprom-settings", true),
        total: true,
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `make bench` compares each feature's cost with the README's feature table: every
    /// feature it measures must find its row and figure there.
    #[test]
    fn readme_names_a_cost_for_every_feature_measured() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for feature in FEATURES {
            let claim = readme_claim(&root, feature, false);
            assert!(claim.is_some_and(|(_, figure)| figure > 0), "no \"+N B\" in the README's row for `{feature}`");
        }
        let total = readme_claim(&root, "eeprom-settings", true);
        assert!(
            total.is_some_and(|(_, figure)| figure > 0),
            "no \"N B in all\" in the README's row for `eeprom-settings`"
        );
    }
}
