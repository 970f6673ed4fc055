//! The AVR backend's r0 clobber, caught by `.ci/firmware-check` (which `make firmware`,
//! `make chips` and `make fixtures` run over every ELF they build): `fixtures/r0-clobber`
//! runs one program twice, its buffer in `main`'s stack frame and in a static. The first
//! firmware, built by rustc 1.96 (LLVM 22.1.8), writes SREG where its result belongs; the
//! check must name it, and must pass the second.

use std::path::{Path, PathBuf};
use std::process::Command;

use uno_sim::built::{built, target_dir, workspace};
use uno_sim::{us_to_cycles, Uno};

/// GPIOR1 and GPIOR2 in data space: the result from its register and from the buffer.
const GPIOR1: u16 = 0x4A;

/// The fixture's input, as `fixtures/r0-clobber/src/lib.rs` has it.
const INPUT: [u8; 24] =
    [7, 200, 13, 99, 1, 254, 42, 17, 3, 77, 128, 64, 5, 250, 31, 8, 190, 11, 66, 23, 145, 9, 100, 2];

/// What the program computes, worked out here.
fn expected() -> u8 {
    (0..24).fold(0u8, |s, i| s.wrapping_add((INPUT[i] ^ INPUT[23 - i]) % 3).wrapping_mul(INPUT[(i + 5) % 24]))
}

fn fixture(name: &str) -> PathBuf {
    built(target_dir().join("fixtures/r0-clobber/avr-none/release").join(format!("{name}.elf")), "make fixtures")
}

/// GPIOR1 and GPIOR2 once the firmware has run 1 ms.
fn results(elf: &Path) -> (u8, u8) {
    let mut uno = Uno::load(elf).unwrap();
    uno.run_for(us_to_cycles(1_000)).unwrap();
    let bytes = uno.read_ram(GPIOR1, 2).unwrap();
    (bytes[0], bytes[1])
}

/// `.ci/firmware-check ELF`: whether it passed, and what it printed.
fn check(elf: &Path) -> (bool, String) {
    let out = Command::new(workspace().join(".ci/firmware-check")).arg(elf).output().expect("python3 and avr-objdump");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn the_buffer_on_the_stack_is_miscompiled_and_the_check_names_the_read() {
    let elf = fixture("r0-clobber-stack");
    let (from_register, from_buffer) = results(&elf);
    eprintln!("expected {}, from the buffer {from_buffer}, from the register {from_register}", expected());
    assert_eq!(from_buffer, expected());
    assert_ne!(
        from_register,
        expected(),
        "the firmware computed the right value: this toolchain no longer miscompiles the fixture \
         (update the toolchain note in docs/slave.md and find a new reproducer)"
    );
    let (passed, out) = check(&elf);
    assert!(!passed, "the check missed the miscompiled read:\n{out}");
    assert!(
        out.contains("r0-clobber-stack.elf (r0-clobber): main at 0x")
            && out.contains("reads r0, last written by the SREG save"),
        "{out}"
    );
}

#[test]
fn the_buffer_in_a_static_is_computed_right_and_passes_the_check() {
    let elf = fixture("r0-clobber-static");
    assert_eq!(results(&elf), (expected(), expected()));
    let (passed, out) = check(&elf);
    assert!(passed, "{out}");
}
