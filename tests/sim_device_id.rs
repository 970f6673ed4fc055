//! FC 43 (0x2B) / MEI type 14 (0x0E), Read Device Identification, Application Protocol
//! v1.1b3 §6.21, end to end: the release `configurable` firmware in simavr at 19200 8E1,
//! whose objects `identification!` placed in flash (`.progmem.data`) and the reply reads
//! with `lpm`. Requests are sent on the wire, replies compared byte for byte with frames
//! whose CRC the test computes itself.
//!
//! The firmware's objects (its header): 00 "avr-modbus", 01 "configurable",
//! 02 the crate's version, 04 "Uno Modbus slave with stored settings",
//! 05 "Arduino Uno (ATmega328P)"; no 03 and no 06.

// `make firmware` builds `configurable` with the feature; the test needs it too
// (`required-features` in Cargo.toml).

mod sim;

use sim::{exception_reply, read_request, registers_reply, with_crc, Line, Rtu, ID};

const VENDOR_NAME: &[u8] = b"avr-modbus";
const PRODUCT_CODE: &[u8] = b"configurable";
const REVISION: &[u8] = env!("CARGO_PKG_VERSION").as_bytes();
const PRODUCT_NAME: &[u8] = b"Uno Modbus slave with stored settings";
const MODEL_NAME: &[u8] = b"Arduino Uno (ATmega328P)";

fn configurable() -> Rtu {
    Rtu::boot("configurable", Line::B19200_8E1)
}

/// FC 43 / MEI 14 to `id` with read device id code `code`, starting at `object`.
fn read_device_id(id: u8, code: u8, object: u8) -> Vec<u8> {
    with_crc(&[
        id,     // slave address
        0x2B,   // function: encapsulated interface transport
        0x0E,   // MEI type: read device identification
        code,   // read device id code
        object, // object id
    ])
}

/// The reply: header, then each object as id, length, value.
fn device_id_reply(code: u8, conformity: u8, objects: &[(u8, &[u8])]) -> Vec<u8> {
    let mut frame = vec![
        ID,                  // slave address
        0x2B,                // function
        0x0E,                // MEI type
        code,                // read device id code, echoed
        conformity,          // conformity level
        0x00,                // more follows: no
        0x00,                // next object id: 0 when nothing follows
        objects.len() as u8, // number of objects
    ];
    for (id, value) in objects {
        frame.push(*id);
        frame.push(value.len() as u8);
        frame.extend_from_slice(value);
    }
    with_crc(&frame)
}

const BASIC: [(u8, &[u8]); 3] = [(0x00, VENDOR_NAME), (0x01, PRODUCT_CODE), (0x02, REVISION)];

const REGULAR: [(u8, &[u8]); 5] =
    [(0x00, VENDOR_NAME), (0x01, PRODUCT_CODE), (0x02, REVISION), (0x04, PRODUCT_NAME), (0x05, MODEL_NAME)];

/// Stream and single access, regular objects given: 0x82.
const CONFORMITY: u8 = 0x82;

#[test]
fn code_01_streams_the_three_basic_objects_from_flash() {
    let mut rtu = configurable();
    assert_eq!(rtu.ask(&read_device_id(ID, 0x01, 0x00)), device_id_reply(0x01, CONFORMITY, &BASIC));
}

#[test]
fn code_02_streams_basic_then_the_regular_objects_given() {
    let mut rtu = configurable();
    assert_eq!(rtu.ask(&read_device_id(ID, 0x02, 0x00)), device_id_reply(0x02, CONFORMITY, &REGULAR));
}

#[test]
fn code_02_from_a_given_object_starts_there() {
    let mut rtu = configurable();
    assert_eq!(rtu.ask(&read_device_id(ID, 0x02, 0x04)), device_id_reply(0x02, CONFORMITY, &REGULAR[3..]));
}

#[test]
fn code_02_from_a_missing_object_starts_over_at_00() {
    let mut rtu = configurable();
    // 0x03 VendorUrl is not given: the stream restarts at 0x00 (§6.21).
    assert_eq!(rtu.ask(&read_device_id(ID, 0x02, 0x03)), device_id_reply(0x02, CONFORMITY, &REGULAR));
}

#[test]
fn code_04_reads_one_object() {
    let mut rtu = configurable();
    for (id, value) in REGULAR {
        assert_eq!(
            rtu.ask(&read_device_id(ID, 0x04, id)),
            device_id_reply(0x04, CONFORMITY, &[(id, value)]),
            "object {id:02X}"
        );
    }
}

#[test]
fn code_04_of_a_missing_object_is_exception_02() {
    let mut rtu = configurable();
    for object in [0x03, 0x06, 0x07, 0x80, 0xFF] {
        assert_eq!(rtu.ask(&read_device_id(ID, 0x04, object)), exception_reply(ID, 0x2B, 0x02), "object {object:02X}");
    }
}

#[test]
fn a_bad_code_is_exception_03() {
    let mut rtu = configurable();
    for code in [0x00, 0x05, 0xFF] {
        assert_eq!(rtu.ask(&read_device_id(ID, code, 0x00)), exception_reply(ID, 0x2B, 0x03), "code {code:02X}");
    }
}

#[test]
fn another_mei_type_is_exception_01() {
    let mut rtu = configurable();
    // MEI type 13 (0x0D), CANopen General Reference: not served.
    let request = with_crc(&[ID, 0x2B, 0x0D, 0x01, 0x00]);
    assert_eq!(rtu.ask(&request), exception_reply(ID, 0x2B, 0x01));
}

#[test]
fn a_broadcast_is_not_answered_and_the_next_request_is() {
    let mut rtu = configurable();
    assert!(rtu.ask(&read_device_id(0, 0x01, 0x00)).is_empty(), "broadcast FC 43 answered");
    rtu.assert_silent("after the broadcast");
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 1)), registers_reply(ID, 0x03, &[0]));
}
