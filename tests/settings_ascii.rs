//! The transmission mode among the line settings a master writes and the EEPROM keeps
//! (features `eeprom-settings` and `ascii`): a fifth register in the settings block, and the
//! high nibble of the record's stop-bits byte, which RTU firmware writes as 0.
//! `tests/settings.rs` covers the four-register block of firmware without `ascii`.

// Features `eeprom-settings` and `ascii` (Cargo.toml); the block with `reply-delay` is another file.
#![cfg(not(feature = "reply-delay"))]

mod common;

use avr_modbus::internal::settings::{decode, decode_legacy, encode, Configurable, Record, LEGACY_LEN, LEGACY_MAGIC};
use avr_modbus::{bit_bytes, Bank, Config, DataModel, Mode, Parity, StopBits};
use common::{ask, exception_reply, read_pdu, slave, to_slave, with_crc, write_multiple_pdu, ID};

const DEFAULT: Config = Config::new(ID, 19_200, Parity::Even, StopBits::One);

type Model = Configurable<Bank<2, 4, { bit_bytes(0) }>>;

/// Holding registers 40001–40002 in the bank, the settings block at 40101–40105.
fn model(config: Config) -> Model {
    let mut bank = Bank::new();
    bank.add_range(40001, 2).unwrap();
    Configurable::new(bank, 40101, config).unwrap()
}

/// The main loop's part and the slave's, as in `tests/settings.rs`.
fn switch(model: &mut Model) -> Option<Config> {
    let settings = model.pending()?;
    model.offer(settings, settings.to_config().expect("the write was checked"));
    model.take_new_settings()
}

fn write_single_pdu(address: u16, value: u16) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [v_hi, v_lo] = value.to_be_bytes();
    vec![0x06, a_hi, a_lo, v_hi, v_lo]
}

#[test]
fn the_block_has_a_fifth_register_the_mode() {
    let mut rtu = model(DEFAULT);
    let reply = ask(&mut slave(), &mut rtu, &to_slave(&read_pdu(0x03, 100, 5)));
    assert_eq!(
        reply,
        with_crc(&[
            ID, 0x03, 0x0A, // slave address, function, byte count
            0x00, ID, // 40101 slave id
            0x00, 0xC0, // 40102 baud / 100
            0x00, 0x02, // 40103 parity even
            0x00, 0x01, // 40104 one stop bit
            0x00, 0x00, // 40105 mode: RTU
        ])
    );
    let ascii = model(Config::ascii(ID, 9600, Parity::Even, StopBits::One));
    assert_eq!(ascii.get(40105), Ok(1));
    assert_eq!(model(DEFAULT.with_mode(Mode::Ascii8)).get(40105), Ok(2));
}

#[test]
fn writing_the_mode_switches_to_ascii_after_the_reply_keeping_the_line() {
    let mut model = model(DEFAULT);
    let write = to_slave(&write_single_pdu(104, 1));
    // The reply goes out in the old mode, RTU.
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    let new = switch(&mut model).expect("settings to switch to");
    assert_eq!((new.mode(), new.baud(), new.parity(), new.line().data_bits()), (Mode::Ascii, 19_200, Parity::Even, 7));
    assert_eq!(new.line().char_timeout_ms(), Config::ASCII_CHAR_TIMEOUT_MS);
    assert_eq!(model.get(40105), Ok(1));
    assert_eq!(model.take_unsaved(), Some(new));
}

#[test]
fn the_whole_block_with_mode_2_is_ascii_with_8_data_bits() {
    let mut model = model(DEFAULT);
    let values: Vec<u8> = [9u16, 96, 0, 2, 2].iter().flat_map(|v| v.to_be_bytes()).collect();
    let write = to_slave(&write_multiple_pdu(0x10, 100, 5, &values));
    assert_eq!(ask(&mut slave(), &mut model, &write), with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x05]));
    assert_eq!(switch(&mut model), Some(Config::new(9, 9600, Parity::None, StopBits::Two).with_mode(Mode::Ascii8)));
}

#[test]
fn an_unknown_mode_is_illegal_data_value_and_changes_nothing() {
    let mut model = model(DEFAULT);
    for mode in [3, 0x10, 0xFFFF] {
        assert_eq!(ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(104, mode))), exception_reply(0x06, 0x03));
    }
    assert_eq!(switch(&mut model), None);
    assert_eq!(model.master_writes(), 0);
}

#[test]
fn the_record_keeps_the_mode_in_the_stop_bits_byte() {
    for mode in [Mode::Rtu, Mode::Ascii, Mode::Ascii8] {
        for stop in [StopBits::One, StopBits::Two] {
            let config = Config::try_new(17, 9600, Parity::Odd, stop).unwrap().with_mode(mode);
            let record = encode(&config, 7);
            let count = if stop == StopBits::One { 1 } else { 2 };
            assert_eq!(record[8], count | ((mode as u8) << 4), "{config:?}");
            assert_eq!(decode(&record), Some(Record { sequence: 7, config }));
        }
    }
    // An RTU record is byte for byte what firmware without `ascii` writes: stop bits 1 or 2.
    assert_eq!(encode(&DEFAULT, 3)[8], 1);
}

#[test]
fn records_of_earlier_firmware_are_rtu() {
    // Format 1: magic, id, baud, parity, stop, CRC.
    let mut legacy = [LEGACY_MAGIC, 5, 0x80, 0x25, 0x00, 0x00, 2, 1, 0, 0];
    let crc = common::reference_crc(&legacy[..LEGACY_LEN - 2]).to_le_bytes();
    legacy[LEGACY_LEN - 2..].copy_from_slice(&crc);
    let config = decode_legacy(&legacy).expect("a format-1 record");
    assert_eq!((config.mode(), config.baud()), (Mode::Rtu, 9600));
}

#[test]
fn a_record_with_an_unknown_mode_is_refused() {
    let mut record = encode(&DEFAULT, 1);
    record[8] = 0x31;
    let crc = common::reference_crc(&record[..9]).to_le_bytes();
    record[9..].copy_from_slice(&crc);
    assert_eq!(decode(&record), None);
}
