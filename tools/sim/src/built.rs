//! What a test needs `make` to have built first (the firmware, the fixtures, the
//! bootloaders, all under the target directory), found or skipped in one place.
//!
//! A plain `cargo test` on a fresh clone has none of them: a test binary that needs one
//! prints what to run, in one line, and ends there with success. Under `make` and in CI a
//! missing file is a failure instead, so that a skip never hides a broken build: `make`
//! sets `AVR_MODBUS_REQUIRE_FIRMWARE=1`, and CI services set `CI` (`true`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once};

/// The environment variable that makes a missing file a failure (any value but empty, `0`
/// or `false`); `CI` does the same.
pub const REQUIRE_ENV: &str = "AVR_MODBUS_REQUIRE_FIRMWARE";

/// The workspace's root (this crate is `tools/sim` in it), where `make` runs: `make
/// bootloaders` writes `target/bootloaders/` there whatever `$CARGO_TARGET_DIR` says.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The workspace's target directory: `$CARGO_TARGET_DIR`, else `target/` at the workspace's
/// root.
pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| workspace().join("target"), PathBuf::from)
}

/// Whether a missing file fails the test: [`REQUIRE_ENV`] or `CI` is set to something other
/// than empty, `0` or `false`.
pub fn required() -> bool {
    let set = |name: &str| std::env::var(name).is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"));
    set(REQUIRE_ENV) || set("CI")
}

/// Held by the thread that ends the process, so that one line is printed.
static SKIPPING: Mutex<()> = Mutex::new(());

/// Whether a test of this binary has failed (panicked) since the first [`built`].
static FAILED: AtomicBool = AtomicBool::new(false);

/// Notes every panic from the first [`built`] on, before the panic goes on as before.
fn watch_failures() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            FAILED.store(true, Ordering::SeqCst);
            previous(info);
        }));
    });
}

/// `path`, which `command` (`"make firmware"`) builds, if it is a file. If it is not: when
/// [`required`], panics with what to run; otherwise prints on stderr, past the test harness's
/// capture,
///
/// ```text
/// skipped: run `make firmware` first (target/avr-atmega328p/release/examples/minimal.elf missing)
/// ```
///
/// and ends the test binary with success: its other tests do not run. The first test to
/// miss a file decides, so a binary whose tests need different builds names one at a time;
/// one whose tests all need the file (every `tests/sim_*.rs`) is skipped as a whole, the
/// same way each time. If a test of the binary has failed already, it panics as when
/// required, so that the failure is reported rather than cut off with the rest.
pub fn built(path: impl Into<PathBuf>, command: &str) -> PathBuf {
    watch_failures();
    let path = path.into();
    if path.is_file() {
        return path;
    }
    let shown = shown(&path);
    if required() || FAILED.load(Ordering::SeqCst) {
        panic!("{shown} is missing: run `{command}` first");
    }
    let _one_line = SKIPPING.lock();
    let _ = writeln!(std::io::stderr(), "skipped: run `{command}` first ({shown} missing)");
    std::process::exit(0)
}

/// `path` from the workspace's root when it lies under it, else as it is.
fn shown(path: &Path) -> String {
    let relative = || {
        let root = workspace().canonicalize().ok()?;
        // The file is missing, and maybe some of its folders: resolve those that exist.
        let mut existing = path;
        let mut rest = Vec::new();
        while !existing.exists() {
            rest.push(existing.file_name()?);
            existing = existing.parent()?;
        }
        let mut full = existing.canonicalize().ok()?;
        full.extend(rest.into_iter().rev());
        full.strip_prefix(&root).ok().map(Path::to_path_buf)
    };
    relative().unwrap_or_else(|| path.to_path_buf()).display().to_string()
}
