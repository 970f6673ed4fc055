//! Line settings in EEPROM and Modbus ASCII on the other chips: `examples/boards.rs` built
//! with features `eeprom-settings` and `ascii` (`make chips`) for a Mega 2560 on Serial1
//! (USART1, a 4 KiB EEPROM) and a Leonardo (ATmega32U4, USART1). The master writes a new id,
//! rate, parity, stop bits and the ASCII mode to 40101–40105; the reply leaves at the old
//! settings, the slave then speaks ASCII at the new ones on the same USART, and a reset
//! finds them in EEPROM. The whole settings logic is tested on the Uno (`sim_configurable`);
//! what differs here is the USART the switch reprograms, the 7-bit format on it, and the
//! chip's EEPROM.

mod configurable;
mod sim;

use std::path::PathBuf;

use configurable::{ascii_frame, Board, SLOT_LEN};
use sim::{chip_variant_firmware, with_crc, Line, ID};
use uno_sim::{Chip, Options, Parity, Uno};

/// `boards` with the settings for `chip`, the wire on `usart`, as `make chips` leaves it.
fn settings_firmware(chip: Chip, usart: u8) -> PathBuf {
    chip_variant_firmware(chip, usart, "-settings", "boards")
}

/// 9600 bps, 7 data bits, no parity, 2 stop bits: the new line, in ASCII.
const B9600_7N2: Line = Line { baud: 9600, parity: Parity::None, stop_bits: 2, data_bits: 7 };

fn switches_to_ascii_at_new_settings_and_keeps_them(chip: Chip, usart: u8) {
    let elf = settings_firmware(chip, usart);
    let uno = Uno::load_with(&elf, Options::new().usart(usart)).expect("firmware loads");
    assert_eq!(uno.chip(), chip);
    let mut board = Board::start(uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x03, 100, 5), Some(vec![1, 192, 2, 1, 0]), "{chip}: 40101-40105 at the default");
    // FC 16 to 40101-40105: id 7, 9600, parity none, 2 stop bits, ASCII.
    let write = with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x05, 0x0A, 0, 7, 0, 96, 0, 0, 0, 2, 0, 1]);
    assert_eq!(board.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x05]), "{chip}: the reply, in RTU");
    board.settle(B9600_7N2);
    let cfg = board.uno.serial_config().expect("the USART runs");
    assert!(cfg.matches(9600, 7, Parity::None, 2), "{chip}: {cfg:?}");
    let read = ascii_frame(&[7, 0x03, 0x00, 0x64, 0x00, 0x05]);
    let reply = ascii_frame(&[7, 0x03, 0x0A, 0, 7, 0, 96, 0, 0, 0, 2, 0, 1]);
    assert_eq!(board.ask(&read), reply, "{chip}: ASCII at 9600 7N2, id 7");
    // The record in the second slot: number 0, id 7, 9600, no parity, and 2 stop bits with
    // the mode (1, ASCII) in the high nibble; the first slot still blank.
    let stored = board.slots();
    assert_eq!(stored[..SLOT_LEN], [0xFF; SLOT_LEN], "{chip}: slot A {stored:02X?}");
    assert_eq!(stored[SLOT_LEN..SLOT_LEN + 9], [0x4E, 0, 7, 0x80, 0x25, 0, 0, 0, 0x12], "{chip}: slot B {stored:02X?}");

    let mut board = board.reset(B9600_7N2);
    assert_eq!(board.ask(&read), reply, "{chip}: ASCII at 9600 7N2 after a reset");
}

#[test]
fn mega2560_on_serial1_switches_to_ascii_at_new_settings_and_keeps_them_in_eeprom() {
    switches_to_ascii_at_new_settings_and_keeps_them(Chip::Atmega2560, 1);
}

#[test]
fn leonardo_switches_to_ascii_at_new_settings_and_keeps_them_in_eeprom() {
    switches_to_ascii_at_new_settings_and_keeps_them(Chip::Atmega32u4, 1);
}
