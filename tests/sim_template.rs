//! The crate as a user's firmware takes it: `fixtures/` holds a firmware crate in the
//! avr-hal template's form (target `avr-none`, `build-std`, LTO, `panic-halt`), outside
//! this workspace, built by `make fixtures` once against avr-device 0.8.1 (the version
//! arduino-hal pins) and once against 0.9. Each ELF must answer FC 3 in simavr.

mod sim;

use std::path::PathBuf;

use sim::{read_request, registers_reply, Line, Rtu, ID};

/// The fixture ELF built against avr-device `version` ("0.8" or "0.9").
fn fixture(version: &str) -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let name = format!("template-avr-device-{version}");
    let elf = target.join("fixtures/avr-none/release").join(format!("{}.elf", name.replace('.', "")));
    assert!(elf.is_file(), "{} is missing: run `make fixtures` first", elf.display());
    elf
}

/// Reads 40001–40004: the fixture sets 40001 to 0x1234 before it starts the slave.
fn answers_fc3(version: &str) {
    let mut rtu = Rtu::boot_elf(&fixture(version), Line::B19200_8E1, |_| {});
    let reply = rtu.ask(&read_request(ID, 0x03, 0, 4));
    assert_eq!(reply, registers_reply(ID, 0x03, &[0x1234, 0, 0, 0]), "avr-device {version}");
}

#[test]
fn template_firmware_with_avr_device_0_8_answers_fc3() {
    answers_fc3("0.8");
}

#[test]
fn template_firmware_with_avr_device_0_9_answers_fc3() {
    answers_fc3("0.9");
}
