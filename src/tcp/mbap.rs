//! The MBAP header, Modbus Messaging on TCP/IP Implementation Guide v1.0b §3.1.3: seven
//! bytes in front of every PDU, no CRC (TCP checks the bytes).
//!
//! | bytes | field | rule |
//! |---|---|---|
//! | 0–1 | transaction id | copied into the response |
//! | 2–3 | protocol id | 0 for Modbus; anything else is discarded (§4.4.2.2) |
//! | 4–5 | length | the bytes that follow: unit id and PDU, 2–254 |
//! | 6 | unit id | 0xFF (and 0) the device itself (§4.4.1.2) |
//!
//! All big-endian. [`Header::parse`] checks a header before any of the body is read, so a
//! length that cannot be a Modbus request never decides how many bytes are taken.

/// The header's bytes.
pub const HEADER: usize = 7;
/// The shortest length field: the unit id and a function code.
pub const MIN_LENGTH: u16 = 2;
/// The longest length field: the unit id and a PDU of 253 bytes.
pub const MAX_LENGTH: u16 = 254;
/// The longest ADU: header and the longest PDU.
pub const MAX_ADU: usize = HEADER - 1 + MAX_LENGTH as usize;
/// The unit id of a device addressed by its IP address (§4.4.1.2).
pub const DEVICE_UNIT: u8 = 0xFF;

/// A checked MBAP header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// The transaction id, echoed.
    pub transaction: u16,
    /// The length field: unit id and PDU, 2–254.
    pub length: u16,
    /// The unit id.
    pub unit: u8,
}

/// Why a header is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// A protocol id other than 0: the ADU (whose length is valid) is skipped in silence.
    Protocol,
    /// A length outside 2–254: the stream cannot be followed any further.
    Length,
}

impl Header {
    /// Checks the first seven bytes of an ADU: the length first (it alone says whether
    /// the stream can be followed), then the protocol id.
    pub fn parse(bytes: &[u8; HEADER]) -> Result<Header, Refused> {
        let length = u16::from_be_bytes([bytes[4], bytes[5]]);
        if !(MIN_LENGTH..=MAX_LENGTH).contains(&length) {
            return Err(Refused::Length);
        }
        if bytes[2] | bytes[3] != 0 {
            return Err(Refused::Protocol);
        }
        Ok(Header { transaction: u16::from_be_bytes([bytes[0], bytes[1]]), length, unit: bytes[6] })
    }

    /// The ADU's bytes in the stream: header up to the length field, and what the length
    /// says follows (a refused header's too: see [`Header::skip`]).
    pub fn adu_len(&self) -> u16 {
        6 + self.length
    }

    /// The ADU a header of a refused protocol id belongs to, to skip: `None` when its
    /// length cannot be trusted.
    pub fn skip(bytes: &[u8; HEADER]) -> Option<u16> {
        let length = u16::from_be_bytes([bytes[4], bytes[5]]);
        (MIN_LENGTH..=MAX_LENGTH).contains(&length).then_some(6 + length)
    }
}

/// Writes a response's length field into the header in `adu`'s first bytes (the
/// transaction id, protocol id and unit id stay the request's): unit id and a PDU of
/// `pdu_len` bytes.
pub fn seal(adu: &mut [u8], pdu_len: usize) {
    let [hi, lo] = (pdu_len as u16 + 1).to_be_bytes();
    if let Some(field) = adu.get_mut(4..6) {
        field[0] = hi;
        field[1] = lo;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Implementation Guide §3.1.3's fields, with the Application Protocol's FC 3 example
    // (§6.3: read 3 registers from 40108) as the PDU.
    const READ_REQUEST: [u8; 12] = [
        0x00, 0x01, // transaction id
        0x00, 0x00, // protocol id: Modbus
        0x00, 0x06, // length: unit id and 5 bytes of PDU
        0xFF, // unit id: the device
        0x03, // FC 3
        0x00, 0x6B, // starting address 107
        0x00, 0x03, // quantity 3
    ];

    fn head(adu: &[u8]) -> [u8; HEADER] {
        adu[..HEADER].try_into().unwrap()
    }

    #[test]
    fn the_guides_read_request_parses() {
        let header = Header::parse(&head(&READ_REQUEST)).unwrap();
        assert_eq!(header, Header { transaction: 1, length: 6, unit: 0xFF });
        assert_eq!(header.adu_len() as usize, READ_REQUEST.len());
    }

    #[test]
    fn length_1_is_refused_before_the_body() {
        let mut adu = READ_REQUEST;
        adu[5] = 1;
        assert_eq!(Header::parse(&head(&adu)), Err(Refused::Length));
        assert_eq!(Header::skip(&head(&adu)), None);
    }

    #[test]
    fn length_2_and_254_are_the_bounds() {
        for (length, ok) in [(0u16, false), (2, true), (254, true), (255, false), (0x0106, false), (0xFFFF, false)] {
            let mut adu = head(&READ_REQUEST);
            adu[4..6].copy_from_slice(&length.to_be_bytes());
            assert_eq!(Header::parse(&adu).is_ok(), ok, "length {length}");
        }
    }

    #[test]
    fn protocol_id_other_than_0_is_skipped_whole() {
        for protocol in [0x0001u16, 0x0100, 0xFFFF] {
            let mut adu = head(&READ_REQUEST);
            adu[2..4].copy_from_slice(&protocol.to_be_bytes());
            assert_eq!(Header::parse(&adu), Err(Refused::Protocol));
            assert_eq!(Header::skip(&adu), Some(12));
        }
    }

    #[test]
    fn the_response_length_counts_the_unit_id() {
        // §6.3's response: FC 3, byte count 6, three registers: 8 bytes of PDU.
        let mut adu = READ_REQUEST;
        seal(&mut adu, 8);
        assert_eq!(&adu[..7], &[0x00, 0x01, 0x00, 0x00, 0x00, 0x09, 0xFF]);
    }
}
