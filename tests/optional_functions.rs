//! The optional function codes, each behind its feature: FC 22 and 23 = 0x16, 0x17
//! (`extra-fc`, Application Protocol v1.1b3 §6.16–6.17) and FC 7, 8, 11, 17 (`diagnostics`, §6.7–6.9,
//! §6.13, with the counters of Serial Line v1.02 §6.1.3).

mod common;

#[allow(unused_imports)] // only the feature-gated modules use it
use avr_modbus::internal::EndOfFrame;
#[allow(unused_imports)]
use avr_modbus::{Bank, Reference};
#[allow(unused_imports)]
use common::{ask, exception_reply, slave, to_slave, with_crc, ID};

#[cfg(feature = "extra-fc")]
mod extra {
    use super::*;

    type Registers = Bank<4, 32, 1>;

    /// Holding registers 0–8 and 14–16 (the spec's FC 23 example), 0x0012 at address 4.
    fn bank() -> Registers {
        let mut bank = Registers::new();
        bank.add_range(Reference::holding_register(0), 9).unwrap();
        bank.add_range(Reference::holding_register(14), 3).unwrap();
        for (address, value) in [(3, 0x00FE), (4, 0x0012), (5, 0x0ACD), (6, 0x0001), (7, 0x0003), (8, 0x000D)] {
            bank.set(Reference::holding_register(address), value).unwrap();
        }
        bank
    }

    fn holding(bank: &Registers, address: u16) -> u16 {
        bank.get(Reference::holding_register(address)).unwrap()
    }

    #[test]
    fn fc22_applies_and_then_or_masks_as_the_spec_example() {
        let mut bank = bank();
        let request = [
            0x16, // function: mask write register
            0x00, 0x04, // reference address 4
            0x00, 0xF2, // AND mask
            0x00, 0x25, // OR mask
        ];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), to_slave(&request));
        // (0x0012 AND 0x00F2) OR (0x0025 AND NOT 0x00F2) = 0x0017
        assert_eq!(holding(&bank, 4), 0x0017);
        assert_eq!(bank.master_writes(), 1);
    }

    #[test]
    fn fc22_on_a_missing_register_is_illegal_data_address() {
        let mut bank = bank();
        let request = [0x16, 0x00, 0x0A, 0x00, 0xF2, 0x00, 0x25];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), exception_reply(0x16, 0x02));
    }

    #[test]
    fn fc22_with_a_wrong_length_is_illegal_data_value() {
        let mut bank = bank();
        for request in [&[0x16, 0x00, 0x04, 0x00, 0xF2, 0x00][..], &[0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25, 0x00]] {
            assert_eq!(ask(&mut slave(), &mut bank, &to_slave(request)), exception_reply(0x16, 0x03));
        }
        assert_eq!(holding(&bank, 4), 0x0012);
    }

    #[test]
    fn fc23_writes_first_then_reads_as_the_spec_example() {
        let mut bank = bank();
        let request = [
            0x17, // function: read/write multiple registers
            0x00, 0x03, // read starting address 3
            0x00, 0x06, // quantity to read: 6
            0x00, 0x0E, // write starting address 14
            0x00, 0x03, // quantity to write: 3
            0x06, // write byte count
            0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF, // values
        ];
        let expected = [
            0x17, // function
            0x0C, // byte count: 12
            0x00, 0xFE, 0x0A, 0xCD, 0x00, 0x01, 0x00, 0x03, 0x00, 0x0D, 0x00, 0xFF,
        ];
        // The spec's register contents for this example.
        for (address, value) in [(3, 0x00FE), (4, 0x0ACD), (5, 0x0001), (6, 0x0003), (7, 0x000D), (8, 0x00FF)] {
            bank.set(Reference::holding_register(address), value).unwrap();
        }
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), to_slave(&expected));
        assert_eq!([holding(&bank, 14), holding(&bank, 15), holding(&bank, 16)], [0x00FF; 3]);
    }

    #[test]
    fn fc23_reads_what_it_just_wrote() {
        let mut bank = bank();
        let request = [0x17, 0x00, 0x00, 0x00, 0x02, 0x00, 0x01, 0x00, 0x01, 0x02, 0xBE, 0xEF];
        let reply = ask(&mut slave(), &mut bank, &to_slave(&request));
        assert_eq!(reply, to_slave(&[0x17, 0x04, 0x00, 0x00, 0xBE, 0xEF]));
    }

    #[test]
    fn fc23_with_a_missing_read_register_writes_nothing() {
        let mut bank = bank();
        // Read 8..9 (9 is a hole), write 0..0.
        let request = [0x17, 0x00, 0x08, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x02, 0x12, 0x34];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), exception_reply(0x17, 0x02));
        assert_eq!(holding(&bank, 0), 0);
        assert_eq!(bank.master_writes(), 0);
    }

    #[test]
    fn fc23_with_a_missing_write_register_is_illegal_data_address() {
        let mut bank = bank();
        let request = [0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x08, 0x00, 0x02, 0x04, 0, 1, 0, 2];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), exception_reply(0x17, 0x02));
        assert_eq!(holding(&bank, 8), 0x000D);
    }

    #[test]
    fn fc23_quantities_outside_the_limits_are_illegal_data_value() {
        let mut bank = bank();
        let read_126 = [0x17, 0x00, 0x00, 0x00, 0x7E, 0x00, 0x00, 0x00, 0x01, 0x02, 0, 1];
        let read_0 = [0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x02, 0, 1];
        let write_0 = [0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00];
        let count_mismatch = [0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x04, 0, 1];
        for request in [&read_126[..], &read_0, &write_0, &count_mismatch] {
            assert_eq!(ask(&mut slave(), &mut bank, &to_slave(request)), exception_reply(0x17, 0x03), "{request:02X?}");
        }
        assert_eq!(bank.master_writes(), 0);
    }

    #[test]
    fn fc23_write_quantity_122_is_illegal_data_value() {
        let request = {
            let mut pdu = vec![0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x7A, 0xF4];
            pdu.extend(std::iter::repeat_n(0, 244));
            pdu
        };
        // One byte longer than an ADU can carry: the PDU layer on its own.
        let mut pdu = request.clone();
        assert_eq!(
            avr_modbus::internal::pdu::extra::respond(&mut pdu, request.len(), &mut bank(), true),
            Err(avr_modbus::Exception::IllegalDataValue)
        );
    }

    #[test]
    fn fc23_read_range_past_65535_is_illegal_data_address() {
        let mut bank = bank();
        let request = [0x17, 0xFF, 0xFF, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x02, 0, 1];
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&request)), exception_reply(0x17, 0x02));
    }
}

#[cfg(feature = "diagnostics")]
mod diagnostics {
    use super::*;

    type Registers = Bank<1, 4, 1>;

    fn bank() -> Registers {
        let mut bank = Registers::new();
        bank.add_range(40001, 4).unwrap();
        bank
    }

    fn read_1() -> Vec<u8> {
        to_slave(&[0x03, 0x00, 0x00, 0x00, 0x01])
    }

    fn counter(slave: &mut avr_modbus::internal::Engine, bank: &mut Registers, sub: u8) -> u16 {
        let reply = ask(slave, bank, &to_slave(&[0x08, 0x00, sub, 0x00, 0x00]));
        assert_eq!(reply[..4], [ID, 0x08, 0x00, sub]);
        u16::from_be_bytes([reply[4], reply[5]])
    }

    #[test]
    fn fc8_sub0_echoes_the_query_data() {
        let request = [0x08, 0x00, 0x00, 0xA5, 0x37, 0x12, 0x34];
        assert_eq!(ask(&mut slave(), &mut bank(), &to_slave(&request)), to_slave(&request));
    }

    #[test]
    fn fc8_counters_follow_the_serial_line_definitions() {
        let (mut slave, mut bank) = (slave(), bank());
        ask(&mut slave, &mut bank, &read_1());
        ask(&mut slave, &mut bank, &to_slave(&[0x03, 0x00, 0x00, 0x00, 0x00])); // exception 03
        let mut bad = read_1();
        bad[7] ^= 0xFF;
        assert_eq!(slave.handle_frame(&bad, &mut bank), EndOfFrame::Dropped(avr_modbus::internal::FrameError::BadCrc));
        slave.handle_frame(&with_crc(&[0x00, 0x06, 0x00, 0x00, 0x00, 0x07]), &mut bank); // broadcast
        slave.handle_frame(&with_crc(&[0x22, 0x03, 0x00, 0x00, 0x00, 0x01]), &mut bank); // other slave
                                                                                         // Bus messages: the 5 frames so far, then each counter request itself.
        assert_eq!(counter(&mut slave, &mut bank, 0x0B), 6);
        assert_eq!(counter(&mut slave, &mut bank, 0x0C), 1, "bus communication errors");
        assert_eq!(counter(&mut slave, &mut bank, 0x0D), 1, "slave exception errors");
        assert_eq!(counter(&mut slave, &mut bank, 0x0E), 7, "slave messages: 2 + broadcast + 4 counter requests");
        assert_eq!(counter(&mut slave, &mut bank, 0x0F), 1, "no response: the broadcast");
        assert_eq!(counter(&mut slave, &mut bank, 0x10), 0);
        assert_eq!(counter(&mut slave, &mut bank, 0x11), 0);
        assert_eq!(counter(&mut slave, &mut bank, 0x12), 0);
    }

    #[test]
    fn fc8_sub0a_clears_the_counters() {
        let (mut slave, mut bank) = (slave(), bank());
        ask(&mut slave, &mut bank, &read_1());
        let clear = to_slave(&[0x08, 0x00, 0x0A, 0x00, 0x00]);
        assert_eq!(ask(&mut slave, &mut bank, &clear), clear);
        assert_eq!(counter(&mut slave, &mut bank, 0x0E), 1, "only the counter request itself");
    }

    #[test]
    fn fc8_sub4_silences_the_slave_until_sub1() {
        let (mut slave, mut bank) = (slave(), bank());
        let listen_only = to_slave(&[0x08, 0x00, 0x04, 0x00, 0x00]);
        assert_eq!(slave.handle_frame(&listen_only, &mut bank), EndOfFrame::Silent, "decided before any byte");
        assert!(slave.reply().is_empty(), "force listen only is never answered");
        assert!(slave.is_listen_only());
        assert_eq!(slave.handle_frame(&read_1(), &mut bank), EndOfFrame::Silent);
        // A write is not executed either.
        slave.handle_frame(&to_slave(&[0x06, 0x00, 0x00, 0x12, 0x34]), &mut bank);
        assert_eq!(bank.get(40001), Ok(0));
        let restart = to_slave(&[0x08, 0x00, 0x01, 0x00, 0x00]);
        assert_eq!(slave.handle_frame(&restart, &mut bank), EndOfFrame::Silent, "restart is not answered");
        assert!(!slave.is_listen_only());
        assert_eq!(slave.counters(), avr_modbus::SlaveCounters::new(), "restart clears the counters");
        assert_eq!(ask(&mut slave, &mut bank, &read_1()), to_slave(&[0x03, 0x02, 0x00, 0x00]));
    }

    #[test]
    fn broadcast_writes_are_not_executed_in_listen_only_mode() {
        let (mut slave, mut bank) = (slave(), bank());
        slave.handle_frame(&to_slave(&[0x08, 0x00, 0x04, 0x00, 0x00]), &mut bank);
        let broadcast = with_crc(&[
            0x00, // broadcast
            0x06, // write single register
            0x00, 0x00, // 40001
            0x12, 0x34, // value
        ]);
        assert_eq!(slave.handle_frame(&broadcast, &mut bank), EndOfFrame::Silent);
        assert_eq!(bank.get(40001), Ok(0), "nothing is executed until FC 8/01");
        // A broadcast restart is not one addressed to this slave: it stays silent.
        let broadcast_restart = with_crc(&[0x00, 0x08, 0x00, 0x01, 0x00, 0x00]);
        slave.handle_frame(&broadcast_restart, &mut bank);
        assert!(slave.is_listen_only());
    }

    /// `pdu` broadcast: address 0, the PDU, the CRC.
    fn broadcast(pdu: &[u8]) -> Vec<u8> {
        let mut frame = vec![0x00];
        frame.extend_from_slice(pdu);
        with_crc(&frame)
    }

    #[test]
    fn broadcast_diagnostics_are_valid_requests_not_exceptions() {
        let (mut slave, mut bank) = (slave(), bank());
        for pdu in [&[0x07][..], &[0x08, 0x00, 0x00, 0x12, 0x34], &[0x0B], &[0x11]] {
            assert_eq!(slave.handle_frame(&broadcast(pdu), &mut bank), EndOfFrame::Broadcast, "{pdu:02X?}");
        }
        assert_eq!(slave.counters().exceptions, 0, "FC 7, 8, 11 and 17 are supported");
        assert_eq!(slave.counters().events, 3, "FC 7, 8 and 17; FC 11 does not count itself");
    }

    #[test]
    fn broadcast_diagnostics_that_would_be_exceptions_count_as_exceptions() {
        let (mut slave, mut bank) = (slave(), bank());
        // Unknown sub-function (01), counter sub-function with data (03), FC 7 with data (03).
        for pdu in [&[0x08, 0x00, 0x02, 0x00, 0x00][..], &[0x08, 0x00, 0x0B, 0x00, 0x01], &[0x07, 0x00]] {
            slave.handle_frame(&broadcast(pdu), &mut bank);
        }
        assert_eq!(slave.counters().exceptions, 3);
        assert_eq!(slave.counters().events, 0);
    }

    #[test]
    fn broadcast_fc8_neither_clears_the_counters_nor_silences_the_slave() {
        let (mut slave, mut bank) = (slave(), bank());
        ask(&mut slave, &mut bank, &read_1());
        slave.handle_frame(&broadcast(&[0x08, 0x00, 0x0A, 0x00, 0x00]), &mut bank);
        slave.handle_frame(&broadcast(&[0x08, 0x00, 0x04, 0x00, 0x00]), &mut bank);
        assert!(!slave.is_listen_only(), "a broadcast does not enter listen-only mode");
        assert_eq!(slave.counters().messages, 3, "not cleared: FC 3 and the two broadcasts");
    }

    #[test]
    fn fc8_sub4_with_other_data_is_answered_with_exception_03() {
        let (mut slave, mut bank) = (slave(), bank());
        let request = to_slave(&[0x08, 0x00, 0x04, 0xFF, 0x00]);
        assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Reply);
        assert_eq!(slave.reply(), exception_reply(0x08, 0x03));
        assert!(!slave.is_listen_only());
    }

    #[test]
    fn fc8_pdu_shorter_than_its_fixed_part_is_exception_03_whatever_the_crc() {
        let (mut slave, mut bank) = (slave(), bank());
        for pdu in [&[0x08][..], &[0x08, 0x00], &[0x08, 0x0C], &[0x08, 0x00, 0x0B], &[0x08, 0x00, 0x0B, 0x00]] {
            assert_eq!(ask(&mut slave, &mut bank, &to_slave(pdu)), exception_reply(0x08, 0x03), "PDU {pdu:02X?}");
        }
    }

    #[test]
    fn fc8_sub1_is_echoed_and_clears_the_counters() {
        let (mut slave, mut bank) = (slave(), bank());
        ask(&mut slave, &mut bank, &read_1());
        for data in [0x00, 0xFF] {
            let restart = to_slave(&[0x08, 0x00, 0x01, data, 0x00]);
            assert_eq!(ask(&mut slave, &mut bank, &restart), restart);
            assert_eq!(slave.counters(), avr_modbus::SlaveCounters::new());
        }
    }

    #[test]
    fn fc8_with_a_bad_data_field_is_illegal_data_value() {
        let mut bank = bank();
        for request in [
            &[0x08, 0x00, 0x01, 0x12, 0x34][..],
            &[0x08, 0x00, 0x04, 0x00, 0x01],
            &[0x08, 0x00, 0x0B, 0x00, 0x01],
            &[0x08, 0x00, 0x0B, 0x00],
            &[0x08, 0x00, 0x00, 0x00],
        ] {
            assert_eq!(ask(&mut slave(), &mut bank, &to_slave(request)), exception_reply(0x08, 0x03), "{request:02X?}");
        }
    }

    #[test]
    fn fc8_unsupported_sub_functions_are_illegal_function() {
        for sub in [0x02u8, 0x03, 0x13, 0x14, 0x15, 0xFF] {
            let request = [0x08, 0x00, sub, 0x00, 0x00];
            assert_eq!(
                ask(&mut slave(), &mut bank(), &to_slave(&request)),
                exception_reply(0x08, 0x01),
                "sub {sub:#04X}"
            );
        }
    }

    #[test]
    fn fc7_reports_the_application_status_bits() {
        let mut bank = bank();
        bank.set_exception_status(0b1010_0101);
        assert_eq!(ask(&mut slave(), &mut bank, &to_slave(&[0x07])), to_slave(&[0x07, 0xA5]));
    }

    #[test]
    fn fc11_counts_successful_requests_but_not_itself_or_exceptions() {
        let (mut slave, mut bank) = (slave(), bank());
        ask(&mut slave, &mut bank, &read_1());
        ask(&mut slave, &mut bank, &read_1());
        ask(&mut slave, &mut bank, &to_slave(&[0x03, 0x00, 0x09, 0x00, 0x01])); // exception 02
        let get = to_slave(&[0x0B]);
        assert_eq!(ask(&mut slave, &mut bank, &get), to_slave(&[0x0B, 0x00, 0x00, 0x00, 0x02]));
        assert_eq!(ask(&mut slave, &mut bank, &get), to_slave(&[0x0B, 0x00, 0x00, 0x00, 0x02]));
    }

    #[test]
    fn fc17_reports_id_run_indicator_and_device_info() {
        let mut bank = bank();
        bank.set_device_info(b"UNO-1");
        let reply = ask(&mut slave(), &mut bank, &to_slave(&[0x11]));
        assert_eq!(reply, to_slave(&[0x11, 0x07, ID, 0xFF, b'U', b'N', b'O', b'-', b'1']));
    }

    #[test]
    fn fc7_11_17_with_data_are_illegal_data_value() {
        for function in [0x07, 0x0B, 0x11] {
            assert_eq!(ask(&mut slave(), &mut bank(), &to_slave(&[function, 0x00])), exception_reply(function, 0x03));
        }
    }
}
