//! The README's claims: the figure in its table of optional features for a feature.

use std::path::Path;

/// The README's cell for `feature` in the table of optional features (the row that starts
/// with "| `feature` |"), and the claimed cost in it: the first "+N B" or "+N.N KB" figure,
/// or with `total`, the "N B in all" figure.
pub(crate) fn readme_claim(root: &Path, feature: &str, total: bool) -> Option<(String, i64)> {
    let readme = std::fs::read_to_string(root.join("README.md")).ok()?;
    // The first row of a table for the feature whose last cell has a figure (other tables,
    // QModMaster's for one, name the `ascii` example in their first column too).
    readme.lines().filter(|l| l.starts_with(&format!("| `{feature}` |"))).find_map(|row| {
        let cell = row.trim_end().trim_end_matches('|').rsplit('|').next()?.trim().to_owned();
        let figure = if total { figure_before(&cell, " B in all")? } else { signed_figure(&cell)? };
        Some((cell, figure))
    })
}

/// The number (digits, spaces as thousands separators) that ends right before `suffix`.
fn figure_before(text: &str, suffix: &str) -> Option<i64> {
    let head = &text[..text.find(suffix)?];
    let digits: String = head.chars().rev().take_while(|c| c.is_ascii_digit() || *c == ' ').collect();
    digits.chars().rev().filter(char::is_ascii_digit).collect::<String>().parse().ok()
}

/// The first "+N B" or "+N.N KB" (1 KB = 1000 B) in `text`.
fn signed_figure(text: &str) -> Option<i64> {
    let rest = &text[text.find('+')? + 1..];
    let number: String = rest.chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    let value: f64 = number.parse().ok()?;
    let unit = rest[number.len()..].trim_start();
    let scale = if unit.starts_with("KB") || unit.starts_with("kB") { 1000.0 } else { 1.0 };
    Some((value * scale).round() as i64)
}
