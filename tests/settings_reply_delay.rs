//! The reply delay among the line settings a master writes and the EEPROM keeps (features
//! `eeprom-settings` and `reply-delay`): the last register of the settings block, in
//! milliseconds (0–255), and the high byte of the record's baud rate, which firmware
//! without the feature writes as 0 (rates stop at 1 000 000).
//! `tests/settings.rs` and `tests/settings_ascii.rs` cover the blocks without it.

mod common;

use avr_modbus::internal::settings::{decode, encode, Configurable, Record, RECORD_LEN};
use avr_modbus::{bit_bytes, Bank, Config, DataModel, Parity, StopBits};
use common::{ask, exception_reply, slave, to_slave, ID};

const DEFAULT: Config = Config::new(ID, 19_200, Parity::Even, StopBits::One);
/// The block's last register: 40105, or 40106 with `ascii`.
const DELAY_REGISTER: u16 = if cfg!(feature = "ascii") { 105 } else { 104 };

type Model = Configurable<Bank<2, 4, { bit_bytes(0) }>>;

fn model(config: Config) -> Model {
    let mut bank = Bank::new();
    bank.add_range(40001, 2).unwrap();
    Configurable::new(bank, 40101, config).unwrap()
}

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
fn the_block_ends_with_the_reply_delay_in_milliseconds() {
    assert_eq!(model(DEFAULT).get(40001 + DELAY_REGISTER), Ok(0));
    assert_eq!(model(DEFAULT.with_reply_delay(12_000)).get(40001 + DELAY_REGISTER), Ok(12));
}

#[test]
fn writing_the_delay_switches_to_it_after_the_reply() {
    let mut model = model(DEFAULT);
    let write = to_slave(&write_single_pdu(DELAY_REGISTER, 7));
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    let new = switch(&mut model).expect("settings to switch to");
    assert_eq!(new.reply_delay_us(), 7_000);
    assert_eq!((new.baud(), new.parity(), new.slave_id().get()), (19_200, Parity::Even, ID));
    assert_eq!(model.get(40001 + DELAY_REGISTER), Ok(7));
}

#[test]
fn a_delay_over_255_ms_is_illegal_data_value_and_changes_nothing() {
    let mut model = model(DEFAULT.with_reply_delay(3_000));
    let write = to_slave(&write_single_pdu(DELAY_REGISTER, 256));
    assert_eq!(ask(&mut slave(), &mut model, &write), exception_reply(0x06, 0x03));
    assert_eq!(model.pending(), None);
    assert_eq!(model.get(40001 + DELAY_REGISTER), Ok(3));
}

#[test]
fn the_record_keeps_the_delay_in_the_baud_rates_high_byte() {
    let config = Config::new(17, 9600, Parity::Odd, StopBits::Two).with_reply_delay(200_000);
    let record = encode(&config, 9);
    assert_eq!(record.len(), RECORD_LEN);
    // Baud rate 9600 = 0x002580 little-endian in bytes 3–5, the delay (200 ms) in byte 6.
    assert_eq!(&record[3..7], &[0x80, 0x25, 0x00, 200]);
    assert_eq!(decode(&record), Some(Record { sequence: 9, config }));
    // A record written without the feature (byte 6 zero) reads as no delay.
    let plain = encode(&Config::new(17, 9600, Parity::Odd, StopBits::Two), 9);
    assert_eq!(plain[6], 0);
    assert_eq!(decode(&plain).map(|r| r.config.reply_delay_us()), Some(0));
}
