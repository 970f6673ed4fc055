//! Each function code's frame length, from the frames pymodbus's RTU framer sends.

use super::*;
use crate::link::crc::crc16;

/// `body` (address and PDU) with its CRC, low byte first.
fn frame(body: &[u8]) -> Vec<u8> {
    let mut frame = body.to_vec();
    frame.extend_from_slice(&crc16(body).to_le_bytes());
    frame
}

/// The length `frame_len` finds for `frame` received whole (and with more behind it).
fn found(frame: &[u8]) -> Option<u16> {
    frame_len(frame, frame.len() as u16)
}

#[test]
fn fc_1_to_6_and_8_are_8_bytes() {
    for code in [1, 2, 3, 4, 5, 6, 8] {
        let request = frame(&[
            0x11, code, // address 17, the function code
            0x00, 0x13, // start (FC 8: sub-function)
            0x00, 0x25, // quantity (value, data)
        ]);
        assert_eq!(found(&request), Some(8), "FC {code}");
    }
}

#[test]
fn fc_7_11_12_17_are_address_code_and_crc() {
    for code in [0x07, 0x0B, 0x0C, 0x11] {
        assert_eq!(found(&frame(&[0x11, code])), Some(4), "FC {code}");
    }
}

#[test]
fn fc_15_and_16_count_their_byte_count_at_6() {
    // Application Protocol §6.12's FC 16: two registers from 2, 4 data bytes.
    let request = frame(&[
        0x11, 0x10, // address 17, FC 16
        0x00, 0x01, // start 2
        0x00, 0x02, // quantity 2
        0x04, // byte count
        0x00, 0x0A, 0x01, 0x02, // values
    ]);
    assert_eq!(found(&request), Some(13));
    // §6.11's FC 15: ten coils, 2 data bytes.
    let request = frame(&[0x11, 0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01]);
    assert_eq!(found(&request), Some(11));
}

#[test]
fn fc_22_is_10_bytes_and_fc_23_counts_its_byte_count_at_10() {
    assert_eq!(found(&frame(&[0x11, 0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25])), Some(10));
    let request = frame(&[
        0x11, 0x17, // address 17, FC 23
        0x00, 0x03, 0x00, 0x06, // read 6 from 3
        0x00, 0x0E, 0x00, 0x03, // write 3 at 14
        0x06, // byte count
        0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF,
    ]);
    assert_eq!(found(&request), Some(19));
}

#[test]
fn fc_20_21_count_at_2_fc_24_is_6_fc_43_is_7() {
    // §6.14's FC 20: one sub-request of 7 bytes.
    let request = frame(&[0x11, 0x14, 0x07, 0x06, 0x00, 0x04, 0x00, 0x01, 0x00, 0x02]);
    assert_eq!(found(&request), Some(12));
    assert_eq!(found(&frame(&[0x11, 0x15, 0x00])), Some(5));
    assert_eq!(found(&frame(&[0x11, 0x18, 0x04, 0xDE])), Some(6));
    assert_eq!(found(&frame(&[0x11, 0x2B, 0x0E, 0x01, 0x00])), Some(7));
}

#[test]
fn an_unknown_code_is_every_byte_received() {
    for code in [0x00, 0x09, 0x0A, 0x0D, 0x0E, 0x12, 0x13, 0x19, 0x2A, 0x41, 0x64, 0x7F, 0x83, 0xFF] {
        let bytes = frame(&[0x11, code, 1, 2, 3]);
        assert_eq!(found(&bytes), Some(7), "FC {code}");
        assert_eq!(frame_len(&bytes[..2], 300), Some(300), "FC {code}: received");
    }
}

#[test]
fn the_length_waits_for_its_byte_count() {
    let fc16 = frame(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0, 0, 0, 0]);
    for cut in 0..7 {
        assert_eq!(frame_len(&fc16[..cut], cut as u16), None, "FC 16 cut at {cut}");
    }
    let fc23 = frame(&[0x11, 0x17, 0, 3, 0, 6, 0, 14, 0, 3, 6, 0, 1, 0, 2, 0, 3]);
    for cut in 0..11 {
        assert_eq!(frame_len(&fc23[..cut], cut as u16), None, "FC 23 cut at {cut}");
    }
    assert_eq!(frame_len(&fc23[..11], 11), Some(19));
    assert_eq!(frame_len(&[0x11, 0x14], 2), None);
    assert_eq!(frame_len(&[0x11], 1), None);
}

#[test]
fn the_longest_byte_counts_pass_256() {
    // 9 + 255 and 13 + 255: past Serial Line §2.5.1.1's 256 bytes, which the server refuses.
    assert_eq!(frame_len(&[0x11, 0x10, 0, 0, 0, 0x7B, 0xFF], 300), Some(264));
    assert_eq!(frame_len(&[0x11, 0x17, 0, 0, 0, 1, 0, 0, 0, 0x79, 0xFF], 300), Some(268));
    const { assert!(MAX_FRAME < 264) };
}
