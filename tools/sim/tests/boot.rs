//! A board's flash from scratch: a program written into erased flash, and where a
//! bootloader may sit. The Uno's optiboot itself: `optiboot.rs`.

mod common;

use common::*;
use uno_sim::{us_to_cycles, Error, Options, ResetCause, Uno};

#[test]
fn a_program_written_into_erased_flash_runs_after_a_reset() {
    let program = Uno::load(echo_elf()).unwrap().flash();
    let mut uno = Uno::erased(Options::new()).unwrap();
    assert_eq!(uno.flash_size(), 32 * 1024);
    assert!(uno.flash().iter().all(|&b| b == 0xFF));
    // Erased flash runs as skips (0xFFFF) to its end, where a chip wraps around to 0 and
    // simavr stops; a reset starts it again.
    assert!(matches!(uno.run_for(us_to_cycles(5_000)), Err(Error::Stopped { cycle: 16_384, .. })));
    assert_eq!(baud(&uno), None);
    uno.write_flash(0, &program).unwrap();
    assert_eq!(uno.flash(), program);
    uno.hard_reset(ResetCause::External);
    uno.run_for(us_to_cycles(10_000)).unwrap();
    assert_eq!(baud(&uno), Some(19_231));
    assert!(matches!(uno.write_flash(0x7FFF, &[0, 0]), Err(Error::FlashOutOfRange { addr: 0x7FFF, len: 2 })));
}

#[test]
fn a_bootloader_must_sit_in_a_boot_section() {
    let hex = scratch("low.hex");
    std::fs::write(&hex, ":021000000102EB\n:00000001FF\n").unwrap();
    let mut uno = Uno::load(echo_elf()).unwrap();
    let err = uno.install_bootloader(&hex).unwrap_err().to_string();
    assert!(err.contains("starts at 0x01000, not at a boot section of the atmega328p's 32 KiB flash"), "{err}");
    std::fs::write(&hex, ":021000000102EC\n:00000001FF\n").unwrap();
    let err = uno.install_bootloader(&hex).unwrap_err().to_string();
    assert!(err.contains("line 1: checksum does not match"), "{err}");
}
