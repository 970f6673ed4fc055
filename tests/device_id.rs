//! FC 43 (0x2B) / MEI type 14, Read Device Identification, Application Protocol v1.1b3
//! §6.21 (feature `device-id`), through the whole RTU engine; without the feature FC 43
//! is exception 01.

mod common;

use common::{exception_reply, exchange};

avr_modbus::register_map! {
    struct Registers { 40001..=40004 }
}

avr_modbus::identification! {
    /// The objects of the spec's example (§6.21): the basic ones.
    static SPEC = {
        vendor_name: "Company identification",
        product_code: "Product code XX",
        major_minor_revision: "V2.11",
    };
}

/// The map with `identification`'s objects; without the feature a map has no setter for
/// them, and so no objects.
fn map(identification: &'static avr_modbus::Identification) -> Registers {
    #[allow(unused_mut)]
    let mut map = Registers::new();
    #[cfg(feature = "device-id")]
    map.set_identification(identification);
    let _ = identification;
    map
}

/// The request PDU for read device id `code` from `object`.
fn request(code: u8, object: u8) -> [u8; 4] {
    [0x2B, 0x0E, code, object]
}

#[cfg(feature = "device-id")]
mod answered {
    use super::*;
    use avr_modbus::internal::EndOfFrame;
    use common::{ask, slave, with_crc};

    avr_modbus::identification! {
        /// Basic and regular objects, ProductName (04) left out.
        static REGULAR = {
            vendor_name: "Acme",
            product_code: "AC-16",
            major_minor_revision: "1.2",
            vendor_url: "https://acme.example",
            model_name: "Sixteen",
            user_application_name: "pump station",
        };
    }

    /// Seven objects of 60 bytes: 434 bytes of objects, more than one reply holds.
    const SIXTY: &str = "abcdefghijklmnopqrstuvwxyzabcdefghijklmnopqrstuvwxyzabcdefgh";

    avr_modbus::identification! {
        static LONG = {
            vendor_name: SIXTY,
            product_code: SIXTY,
            major_minor_revision: SIXTY,
            vendor_url: SIXTY,
            product_name: SIXTY,
            model_name: SIXTY,
            user_application_name: SIXTY,
        };
    }

    /// The reply ADU to slave [`common::ID`]: the PDU header, then each object as id, length,
    /// value.
    fn reply(code: u8, conformity: u8, more: u8, next: u8, objects: &[(u8, &str)]) -> Vec<u8> {
        let mut pdu = vec![common::ID, 0x2B, 0x0E, code, conformity, more, next, objects.len() as u8];
        for (id, value) in objects {
            pdu.push(*id);
            pdu.push(value.len() as u8);
            pdu.extend_from_slice(value.as_bytes());
        }
        with_crc(&pdu)
    }

    #[test]
    fn the_basic_stream_is_the_specs_example() {
        let expected = reply(
            0x01,
            0x81,
            0x00,
            0x00,
            &[(0x00, "Company identification"), (0x01, "Product code XX"), (0x02, "V2.11")],
        );
        assert_eq!(exchange(&mut map(&SPEC), &request(0x01, 0x00)), expected);
        // Byte for byte: 2B 0E 01 81 00 00 03, then 00 16 "Company identification" …
        assert_eq!(expected[1..9], [0x2B, 0x0E, 0x01, 0x81, 0x00, 0x00, 0x03, 0x00]);
        assert_eq!(expected[9], 0x16);
    }

    #[test]
    fn the_regular_stream_sends_every_object_given_in_id_order() {
        let all = [
            (0x00, "Acme"),
            (0x01, "AC-16"),
            (0x02, "1.2"),
            (0x03, "https://acme.example"),
            (0x05, "Sixteen"),
            (0x06, "pump station"),
        ];
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x02, 0x00)), reply(0x02, 0x82, 0, 0, &all));
        // The basic stream stops at 02; a stream can start at any object there is.
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x01, 0x00)), reply(0x01, 0x82, 0, 0, &all[..3]));
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x02, 0x05)), reply(0x02, 0x82, 0, 0, &all[4..]));
    }

    #[test]
    fn the_extended_stream_is_answered_at_the_regular_level() {
        let all = exchange(&mut map(&REGULAR), &request(0x02, 0x00));
        let mut expected = all.clone();
        expected[3] = 0x03;
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x03, 0x00)), with_crc(&expected[..expected.len() - 2]));
    }

    #[test]
    fn a_stream_from_an_object_not_there_starts_over_at_zero() {
        let from_zero = exchange(&mut map(&REGULAR), &request(0x02, 0x00));
        // 04 is a regular object this device lacks; 07 and 0x80 are none it could have;
        // 03 is not a basic object.
        for object in [0x04, 0x07, 0x80, 0xFF] {
            assert_eq!(exchange(&mut map(&REGULAR), &request(0x02, object)), from_zero, "object {object:02X}");
        }
        let basic = exchange(&mut map(&REGULAR), &request(0x01, 0x00));
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x01, 0x03)), basic);
    }

    #[test]
    fn one_object_is_sent_alone_and_a_missing_one_is_illegal_data_address() {
        assert_eq!(exchange(&mut map(&REGULAR), &request(0x04, 0x05)), reply(0x04, 0x82, 0, 0, &[(0x05, "Sixteen")]));
        assert_eq!(
            exchange(&mut map(&SPEC), &request(0x04, 0x01)),
            reply(0x04, 0x81, 0, 0, &[(0x01, "Product code XX")])
        );
        for object in [0x04, 0x07, 0x80] {
            assert_eq!(exchange(&mut map(&REGULAR), &request(0x04, object)), exception_reply(0x2B, 0x02));
        }
    }

    #[test]
    fn objects_that_do_not_fit_one_reply_follow_in_the_next() {
        let object = |id| (id, SIXTY);
        // 7 header bytes and 3 objects of 62 bytes: a fourth would pass 253.
        let first = reply(0x02, 0x82, 0xFF, 0x03, &[object(0), object(1), object(2)]);
        assert_eq!(exchange(&mut map(&LONG), &request(0x02, 0x00)), first);
        let second = reply(0x02, 0x82, 0xFF, 0x06, &[object(3), object(4), object(5)]);
        assert_eq!(exchange(&mut map(&LONG), &request(0x02, 0x03)), second);
        let last = reply(0x02, 0x82, 0x00, 0x00, &[object(6)]);
        assert_eq!(exchange(&mut map(&LONG), &request(0x02, 0x06)), last);
        assert!(first.len() - 3 <= 253);
    }

    #[test]
    fn checks_come_in_the_specs_order() {
        let mut regular = map(&REGULAR);
        // Another MEI type (13 is CANopen): the function is not supported.
        assert_eq!(exchange(&mut regular, &[0x2B, 0x0D, 0x01, 0x00]), exception_reply(0x2B, 0x01));
        assert_eq!(exchange(&mut regular, &[0x2B]), exception_reply(0x2B, 0x01));
        // A code outside 01–04, or a PDU that is not 4 bytes: illegal data value, even for
        // code 04 with an object not there.
        for code in [0x00, 0x05, 0xFF] {
            assert_eq!(exchange(&mut regular, &request(code, 0x00)), exception_reply(0x2B, 0x03), "code {code}");
        }
        assert_eq!(exchange(&mut regular, &[0x2B, 0x0E, 0x01]), exception_reply(0x2B, 0x03));
        assert_eq!(exchange(&mut regular, &[0x2B, 0x0E, 0x04, 0x04, 0x00]), exception_reply(0x2B, 0x03));
        // A map not given an identification does not offer FC 43.
        assert_eq!(exchange(&mut Registers::new(), &request(0x01, 0x00)), exception_reply(0x2B, 0x01));
    }

    #[test]
    fn a_broadcast_is_not_answered_and_counts_as_a_good_request() {
        let mut engine = slave();
        let mut regular = map(&REGULAR);
        let frame = with_crc(&[0x00, 0x2B, 0x0E, 0x01, 0x00]);
        assert_eq!(engine.handle_frame(&frame, &mut regular), EndOfFrame::Broadcast);
        assert_eq!(engine.reply(), &[] as &[u8]);
        let counters = engine.counters();
        assert_eq!((counters.broadcasts, counters.events, counters.exceptions), (1, 1, 0));
        // The next request is answered.
        let answer = ask(&mut engine, &mut regular, &with_crc(&[common::ID, 0x2B, 0x0E, 0x04, 0x00]));
        assert_eq!(answer, reply(0x04, 0x82, 0, 0, &[(0x00, "Acme")]));
    }

    #[test]
    fn the_objects_print_as_text() {
        let text = format!("{:?}", REGULAR);
        assert_eq!(
            text,
            r#"{0: "Acme", 1: "AC-16", 2: "1.2", 3: "https://acme.example", 5: "Sixteen", 6: "pump station"}"#
        );
    }
}

#[cfg(not(feature = "device-id"))]
#[test]
fn without_the_feature_fc43_is_illegal_function() {
    assert_eq!(exchange(&mut map(&SPEC), &request(0x01, 0x00)), exception_reply(0x2B, 0x01));
    assert_eq!(exchange(&mut map(&SPEC), &[0x2B, 0x0D]), exception_reply(0x2B, 0x01));
}
