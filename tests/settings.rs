//! Line settings kept in EEPROM (feature `eeprom-settings`): the record's encoding (and
//! the format-1 record of earlier firmware), blank and damaged records, and the settings
//! block a master reads and writes with FC 03, 06
//! and 16, with exception 03 for settings the slave can't run.

// Feature `eeprom-settings` (Cargo.toml); the blocks with `ascii` or `reply-delay` are other files.
#![cfg(not(any(feature = "ascii", feature = "reply-delay")))]

mod common;

use avr_modbus::internal::settings::{
    decode, decode_legacy, encode, Configurable, LineSettings, Record, LEGACY_LEN, LEGACY_MAGIC, MAGIC, RECORD_LEN,
};
use avr_modbus::internal::EndOfFrame;
use avr_modbus::{bit_bytes, Bank, Config, DataModel, Error, Parity, Reference, StopBits};
use common::{ask, exception_reply, read_pdu, slave, to_slave, with_crc, write_multiple_pdu, ID};

const DEFAULT: Config = Config::new(ID, 19_200, Parity::Even, StopBits::One);

type Model = Configurable<Bank<2, 4, { bit_bytes(0) }>>;

/// Holding registers 40001–40002 in the bank, the settings block at 40101–40104.
fn model() -> Model {
    let mut bank = Bank::new();
    bank.add_range(40001, 2).unwrap();
    Configurable::new(bank, 40101, DEFAULT).unwrap()
}

/// The main loop's part (`avr::Shared::poll_settings` on the Uno): computes the pending
/// settings' configuration and hands it over; then the slave's part after a reply.
fn switch(model: &mut Model) -> Option<Config> {
    let settings = model.pending()?;
    model.offer(settings, settings.to_config().expect("the write was checked"));
    model.take_new_settings()
}

/// An FC 06 request PDU.
fn write_single_pdu(address: u16, value: u16) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [v_hi, v_lo] = value.to_be_bytes();
    vec![0x06, a_hi, a_lo, v_hi, v_lo]
}

/// Registers as big-endian bytes.
fn words(values: &[u16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_be_bytes()).collect()
}

// ---- the EEPROM record ---------------------------------------------------------------------

#[test]
fn record_round_trips_every_format() {
    for baud in [1200, 9600, 19_200, 31_250, 57_600, 115_200, 1_000_000] {
        for parity in [Parity::None, Parity::Odd, Parity::Even] {
            for stop in [StopBits::One, StopBits::Two] {
                for (id, sequence) in [(1, 0), (17, 128), (247, 255)] {
                    let config = Config::try_new(id, baud, parity, stop).unwrap();
                    assert_eq!(decode(&encode(&config, sequence)), Some(Record { sequence, config }), "{config:?}");
                }
            }
        }
    }
}

#[test]
fn record_layout_is_magic_sequence_id_baud_parity_stop_crc() {
    let record = encode(&Config::new(17, 9600, Parity::Odd, StopBits::Two), 0xA5);
    assert_eq!(
        record[..9],
        [
            MAGIC, // format 2
            0xA5,  // sequence number
            17,    // slave id
            0x80, 0x25, 0x00, 0x00, // 9600, u32 little-endian
            1,    // parity: odd
            2,    // stop bits
        ]
    );
    assert_eq!(MAGIC, 0x4E);
    let crc = common::reference_crc(&record[..9]);
    assert_eq!(record[9..], crc.to_le_bytes());
}

#[test]
fn blank_eeprom_decodes_to_none() {
    assert_eq!(decode(&[0xFF; RECORD_LEN]), None);
    assert_eq!(decode(&[0x00; RECORD_LEN]), None);
    assert_eq!(decode_legacy(&[0xFF; LEGACY_LEN]), None);
}

#[test]
fn any_flipped_bit_decodes_to_none() {
    let record = encode(&DEFAULT, 7);
    for byte in 0..RECORD_LEN {
        for bit in 0..8 {
            let mut damaged = record;
            damaged[byte] ^= 1 << bit;
            assert_eq!(decode(&damaged), None, "byte {byte} bit {bit}");
        }
    }
}

#[test]
fn record_with_good_crc_but_settings_the_slave_cant_run_decodes_to_none() {
    let resealed = |mut record: [u8; RECORD_LEN]| {
        let crc = common::reference_crc(&record[..9]).to_le_bytes();
        record[9..].copy_from_slice(&crc);
        record
    };
    let good = encode(&DEFAULT, 0);
    let mut id_zero = good;
    id_zero[2] = 0;
    let mut parity_3 = good;
    parity_3[7] = 3;
    let mut stop_3 = good;
    stop_3[8] = 3;
    let mut baud_230400 = good;
    baud_230400[3..7].copy_from_slice(&230_400u32.to_le_bytes());
    for record in [id_zero, parity_3, stop_3, baud_230400] {
        assert_eq!(decode(&resealed(record)), None, "{record:02X?}");
    }
    assert_eq!(decode(&resealed(good)), Some(Record { sequence: 0, config: DEFAULT }));
}

/// A format-1 record, as earlier firmware wrote it.
fn legacy_record() -> [u8; LEGACY_LEN] {
    let mut record = [
        0x4D, // format 1 ('M')
        17,   // slave id
        0x80, 0x25, 0x00, 0x00, // 9600, u32 little-endian
        1,    // parity: odd
        2,    // stop bits
        0, 0, // CRC of bytes 0-7, below
    ];
    let crc = common::reference_crc(&record[..8]);
    record[8..].copy_from_slice(&crc.to_le_bytes());
    record
}

#[test]
fn format_1_record_of_earlier_firmware_still_decodes() {
    assert_eq!(LEGACY_MAGIC, 0x4D);
    assert_eq!(decode_legacy(&legacy_record()), Some(Config::new(17, 9600, Parity::Odd, StopBits::Two)));
    for byte in 0..LEGACY_LEN {
        let mut damaged = legacy_record();
        damaged[byte] ^= 0x01;
        assert_eq!(decode_legacy(&damaged), None, "byte {byte}");
    }
}

#[test]
fn neither_format_decodes_as_the_other() {
    let mut padded = [0xFF; RECORD_LEN];
    padded[..LEGACY_LEN].copy_from_slice(&legacy_record());
    assert_eq!(decode(&padded), None);
    let record = encode(&DEFAULT, LEGACY_MAGIC);
    assert_eq!(decode_legacy(record[..LEGACY_LEN].try_into().unwrap()), None);
}

// ---- the block as registers ----------------------------------------------------------------

fn registers(config: &Config) -> [u16; 4] {
    LineSettings::of(config).to_registers()
}

#[test]
fn block_registers_are_id_baud_100_parity_stop() {
    assert_eq!(registers(&Config::new(5, 115_200, Parity::None, StopBits::Two)), [5, 1152, 0, 2]);
    assert_eq!(registers(&Config::new(247, 1200, Parity::Odd, StopBits::One)), [247, 12, 1, 1]);
    assert_eq!(registers(&DEFAULT), [u16::from(ID), 192, 2, 1]);
}

#[test]
fn unchanged_baud_register_keeps_a_rate_that_is_not_a_multiple_of_100() {
    let midi = LineSettings::of(&Config::new(1, 31_250, Parity::None, StopBits::One));
    let registers = midi.to_registers();
    assert_eq!(registers[1], 312);
    assert_eq!(LineSettings::from_registers(&midi, registers), Ok(midi));
    let [_, baud, parity, stop] = registers;
    assert_eq!(LineSettings::from_registers(&midi, [9, baud, parity, stop]).map(|s| s.baud), Ok(31_250));
}

/// The interrupt's quick check must refuse exactly what `Config::try_new` refuses, for
/// every rate up to past the maximum (the format does not change the divisor).
#[test]
fn quick_check_agrees_with_config_try_new_for_every_rate() {
    for baud in 0..=1_100_000 {
        let settings = LineSettings { slave_id: 1, baud, parity: Parity::Even, stop_bits: StopBits::One };
        let slow = Config::try_new(1, baud, Parity::Even, StopBits::One).is_ok();
        assert_eq!(settings.is_runnable(), slow, "{baud} bps");
    }
    for baud_100 in 0..=u16::MAX {
        let baud = u32::from(baud_100) * 100;
        let settings = LineSettings { slave_id: 1, baud, parity: Parity::None, stop_bits: StopBits::Two };
        assert_eq!(settings.is_runnable(), settings.to_config().is_some(), "{baud} bps");
    }
    for id in 0..=u8::MAX {
        let settings = LineSettings { slave_id: id, ..LineSettings::of(&DEFAULT) };
        assert_eq!(settings.is_runnable(), settings.to_config().is_some(), "id {id}");
    }
}

// ---- reading the block ---------------------------------------------------------------------

#[test]
fn fc3_reads_the_block() {
    let mut model = model();
    let reply = ask(&mut slave(), &mut model, &to_slave(&read_pdu(0x03, 100, 4)));
    assert_eq!(
        reply,
        with_crc(&[
            ID,   // slave address
            0x03, // function
            0x08, // byte count
            0x00, ID, // 40101 slave id
            0x00, 0xC0, // 40102 baud / 100 = 192
            0x00, 0x02, // 40103 parity even
            0x00, 0x01, // 40104 one stop bit
        ])
    );
}

#[test]
fn fc3_reads_part_of_the_block() {
    let mut model = model();
    let reply = ask(&mut slave(), &mut model, &to_slave(&read_pdu(0x03, 102, 2)));
    assert_eq!(reply, with_crc(&[ID, 0x03, 0x04, 0x00, 0x02, 0x00, 0x01]));
}

#[test]
fn fc3_across_the_end_of_the_block_is_illegal_data_address() {
    let mut model = model();
    let reply = ask(&mut slave(), &mut model, &to_slave(&read_pdu(0x03, 102, 3)));
    assert_eq!(reply, exception_reply(0x03, 0x02));
    let reply = ask(&mut slave(), &mut model, &to_slave(&read_pdu(0x03, 99, 2)));
    assert_eq!(reply, exception_reply(0x03, 0x02));
}

#[test]
fn bank_registers_still_read_and_write_through_the_wrapper() {
    let mut model = model();
    let write = to_slave(&write_single_pdu(1, 0xBEEF));
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    assert_eq!(model.get(40002), Ok(0xBEEF));
    assert_eq!(model.inner().get(40002), Ok(0xBEEF));
    let reply = ask(&mut slave(), &mut model, &to_slave(&read_pdu(0x03, 0, 2)));
    assert_eq!(reply, with_crc(&[ID, 0x03, 0x04, 0x00, 0x00, 0xBE, 0xEF]));
    assert_eq!(switch(&mut model), None);
}

#[test]
fn application_reads_the_block_but_cannot_set_it() {
    let mut model = model();
    assert_eq!(model.get(40102), Ok(192));
    assert_eq!(model.set(40102, 96), Err(Error::BadReference));
    assert_eq!(model.set(40001, 96), Ok(()));
    assert_eq!(model.get(40105), Err(Error::NotFound));
}

#[test]
fn block_must_be_holding_registers_not_already_in_the_model() {
    let mut bank: Bank<1, 4, 0> = Bank::new();
    bank.add_range(40001, 4).unwrap();
    assert_eq!(Configurable::new(bank.clone(), 40004, DEFAULT).err(), Some(Error::Duplicate));
    assert_eq!(Configurable::new(bank.clone(), 30101, DEFAULT).err(), Some(Error::BadReference));
    let past_end = Reference::holding_register(65533);
    assert_eq!(Configurable::new(bank.clone(), past_end, DEFAULT).err(), Some(Error::BadRange));
    assert!(Configurable::new(bank.clone(), Reference::holding_register(65532), DEFAULT).is_ok());
    assert!(Configurable::new(bank, 40005, DEFAULT).is_ok());
}

// ---- writing the block ---------------------------------------------------------------------

#[test]
fn fc16_of_the_whole_block_is_taken_once_after_the_reply() {
    let mut model = model();
    let mut slave = slave();
    let write = to_slave(&write_multiple_pdu(0x10, 100, 4, &words(&[9, 96, 0, 2])));
    let reply = ask(&mut slave, &mut model, &write);
    // The reply is built, from the old address, before anything switches.
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x04]));
    assert_eq!(slave.id().get(), ID);
    // The block already shows what the master wrote; the slave runs the old settings.
    assert_eq!(model.get(40101), Ok(9));
    assert_eq!(model.config(), DEFAULT);
    let new = Config::new(9, 9600, Parity::None, StopBits::Two);
    assert_eq!(switch(&mut model), Some(new));
    assert_eq!(switch(&mut model), None);
    assert_eq!(model.take_unsaved(), Some(new));
    assert_eq!(model.take_unsaved(), None);
    assert_eq!(model.config(), new);
    // The write went to the settings block, and counts as one master write.
    assert_eq!(model.master_writes(), 1);
    assert_eq!(model.inner().master_writes(), 0);
}

#[test]
fn nothing_is_unsaved_until_the_slave_took_the_settings() {
    let mut model = model();
    let write = to_slave(&write_single_pdu(101, 96));
    ask(&mut slave(), &mut model, &write);
    assert_eq!(model.take_unsaved(), None);
    assert!(switch(&mut model).is_some());
    assert!(model.take_unsaved().is_some());
}

#[test]
fn slave_gets_nothing_to_switch_to_until_the_main_loop_offered_the_config() {
    let mut model = model();
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(101, 96)));
    let pending = model.pending().expect("written");
    assert_eq!(pending.baud, 9600);
    assert_eq!(model.take_new_settings(), None, "no config yet");
    assert_eq!(model.config(), DEFAULT, "still running the old settings");
    model.offer(pending, pending.to_config().unwrap());
    assert_eq!(model.pending(), None, "nothing left to compute");
    assert_eq!(model.take_new_settings().map(|c| c.baud()), Some(9600));
    assert_eq!(model.config().baud(), 9600);
}

#[test]
fn an_offer_for_settings_overwritten_since_is_ignored() {
    let mut model = model();
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(101, 96)));
    let first = model.pending().unwrap();
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(101, 48)));
    model.offer(first, first.to_config().unwrap());
    assert_eq!(model.take_new_settings(), None);
    assert_eq!(switch(&mut model).map(|c| c.baud()), Some(4800));
}

#[test]
fn a_write_after_the_offer_replaces_it() {
    let mut model = model();
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(101, 96)));
    let first = model.pending().unwrap();
    model.offer(first, first.to_config().unwrap());
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(103, 2)));
    assert_eq!(model.take_new_settings(), None, "the offer was for the old write");
    assert_eq!(switch(&mut model), Some(Config::new(ID, 9600, Parity::Even, StopBits::Two)));
}

#[test]
fn fc6_changes_one_setting_and_keeps_the_others() {
    let mut model = model();
    let write = to_slave(&write_single_pdu(101, 1152)); // 40102: 115200 bps
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    assert_eq!(switch(&mut model), Some(Config::new(ID, 115_200, Parity::Even, StopBits::One)));

    let write = to_slave(&write_single_pdu(102, 0)); // 40103: no parity
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    assert_eq!(switch(&mut model), Some(Config::new(ID, 115_200, Parity::None, StopBits::One)));
}

#[test]
fn fc6_of_the_slave_id() {
    let mut model = model();
    let write = to_slave(&write_single_pdu(100, 247));
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    assert_eq!(switch(&mut model).map(|c| c.slave_id().get()), Some(247));
}

#[test]
fn fc16_of_two_block_registers() {
    let mut model = model();
    let write = to_slave(&write_multiple_pdu(0x10, 102, 2, &words(&[1, 2])));
    assert_eq!(ask(&mut slave(), &mut model, &write), with_crc(&[ID, 0x10, 0x00, 0x66, 0x00, 0x02]));
    assert_eq!(switch(&mut model), Some(Config::new(ID, 19_200, Parity::Odd, StopBits::Two)));
}

/// Each value is refused with exception 03 and changes nothing.
fn refused(address: u16, value: u16) {
    let mut model = model();
    let reply = ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(address, value)));
    assert_eq!(reply, exception_reply(0x06, 0x03), "40{:03} = {value}", address + 1);
    assert_eq!(switch(&mut model), None);
    assert_eq!(model.config(), DEFAULT);
    assert_eq!(model.pending(), None);
    assert_eq!(model.master_writes(), 0);
}

#[test]
fn slave_id_0_and_248_and_up_are_illegal_data_value() {
    for id in [0, 248, 255, 256, 0xFFFF] {
        refused(100, id);
    }
}

#[test]
fn baud_the_usart_cant_make_is_illegal_data_value() {
    // 1100 bps (below 1200), 2304 = 230400 (7.8 % off), 10001 (over 1 000 000), 0.
    for baud_100 in [11, 2304, 10_001, 0, 0xFFFF] {
        refused(101, baud_100);
    }
}

#[test]
fn unknown_parity_and_stop_codes_are_illegal_data_value() {
    refused(102, 3);
    refused(103, 0);
    refused(103, 3);
}

#[test]
fn fc16_with_one_bad_value_changes_nothing() {
    let mut model = model();
    let write = to_slave(&write_multiple_pdu(0x10, 100, 4, &words(&[9, 96, 7, 1])));
    assert_eq!(ask(&mut slave(), &mut model, &write), exception_reply(0x10, 0x03));
    assert_eq!(switch(&mut model), None);
    assert_eq!(model.get(40101), Ok(u16::from(ID)));
}

#[test]
fn fc16_across_the_block_and_the_bank_is_illegal_data_address() {
    let mut model = model();
    let write = to_slave(&write_multiple_pdu(0x10, 99, 2, &words(&[1, 1])));
    assert_eq!(ask(&mut slave(), &mut model, &write), exception_reply(0x10, 0x02));
    assert_eq!(switch(&mut model), None);
}

#[test]
fn broadcast_write_of_the_block_is_taken_without_a_reply() {
    let mut model = model();
    let mut slave = slave();
    let frame = with_crc(&[0x00, 0x06, 0x00, 0x65, 0x00, 0x60]); // 40102 = 96
    assert_eq!(slave.handle_frame(&frame, &mut model), EndOfFrame::Broadcast);
    assert_eq!(switch(&mut model).map(|c| c.baud()), Some(9600));
}

#[test]
fn a_pending_change_is_the_base_of_the_next_write() {
    let mut model = model();
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(101, 96)));
    ask(&mut slave(), &mut model, &to_slave(&write_single_pdu(103, 2)));
    assert_eq!(switch(&mut model), Some(Config::new(ID, 9600, Parity::Even, StopBits::Two)));
}

#[cfg(feature = "extra-fc")]
#[test]
fn fc22_mask_write_of_the_parity() {
    let mut model = model();
    // 40103 = (2 & 0x0000) | (0x0001 & !0x0000) = 1: odd.
    let write = to_slave(&[0x16, 0x00, 0x66, 0x00, 0x00, 0x00, 0x01]);
    assert_eq!(ask(&mut slave(), &mut model, &write), write);
    assert_eq!(switch(&mut model).map(|c| c.parity()), Some(Parity::Odd));
}
