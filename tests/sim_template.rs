//! The crate as a user's firmware takes it: `fixtures/` holds a firmware crate in the
//! avr-hal template's form (target `avr-none`, `build-std`, LTO, `panic-halt`), outside
//! this workspace, built by `make fixtures` against avr-device 0.8.1 (the version
//! arduino-hal pins) and 0.9, for three of the template's boards: the Uno (USART0 on pins
//! 0/1), the Mega 2560 with the slave on Serial1 (USART1) and the Leonardo (USART1 on pins
//! 0/1, the `slave!` without `on`), and for the Uno once more against the crate as `cargo
//! package` packs it (`make package`). Each ELF must answer FC 3 in simavr on its board's
//! chip and USART.

mod sim;

use std::path::PathBuf;

use sim::{built, read_request, registers_reply, target_dir, Line, Rtu, ID};
use uno_sim::Chip;

/// The fixture ELF built against avr-device `version` ("0.8" or "0.9") for `board`.
fn fixture(board: &str, version: &str) -> PathBuf {
    let name = format!("template-avr-device-{}.elf", version.replace('.', ""));
    built(target_dir().join("fixtures").join(board).join("avr-none/release").join(name), "make fixtures")
}

/// Reads 40001–40004 on `usart`: the fixture sets 40001 to 0x1234 before it starts the slave.
fn answers_fc3(board: &str, chip: Chip, usart: u8, version: &str) {
    let mut rtu = Rtu::boot_elf_on(&fixture(board, version), usart, Line::B19200_8E1, |_| {});
    assert_eq!(rtu.uno.chip(), chip, "{board}: the ELF's chip");
    let reply = rtu.ask(&read_request(ID, 0x03, 0, 4));
    assert_eq!(reply, registers_reply(ID, 0x03, &[0x1234, 0, 0, 0]), "{board}, avr-device {version}");
}

#[test]
fn uno_template_firmware_with_avr_device_0_8_answers_fc3() {
    answers_fc3("uno", Chip::Atmega328p, 0, "0.8");
}

#[test]
fn uno_template_firmware_with_avr_device_0_9_answers_fc3() {
    answers_fc3("uno", Chip::Atmega328p, 0, "0.9");
}

#[test]
fn mega2560_template_firmware_on_serial1_with_avr_device_0_8_answers_fc3() {
    answers_fc3("mega2560", Chip::Atmega2560, 1, "0.8");
}

#[test]
fn mega2560_template_firmware_on_serial1_with_avr_device_0_9_answers_fc3() {
    answers_fc3("mega2560", Chip::Atmega2560, 1, "0.9");
}

#[test]
fn leonardo_template_firmware_with_avr_device_0_8_answers_fc3() {
    answers_fc3("leonardo", Chip::Atmega32u4, 1, "0.8");
}

#[test]
fn leonardo_template_firmware_with_avr_device_0_9_answers_fc3() {
    answers_fc3("leonardo", Chip::Atmega32u4, 1, "0.9");
}

#[test]
fn uno_template_firmware_built_against_the_packaged_crate_answers_fc3() {
    answers_fc3("packaged", Chip::Atmega328p, 0, "0.8");
}
