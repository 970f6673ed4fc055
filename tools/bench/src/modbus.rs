//! The master's side of Modbus RTU: request frames and a check of the replies
//! (Application Protocol v1.1b3 §6, Serial Line v1.02 §2.5.1.2 for the CRC).

/// CRC-16/MODBUS (0xA001 reflected, initial 0xFFFF), bit by bit: independent of the
/// firmware's table-free byte step.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for &byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
        }
    }
    crc
}

/// What the master expects back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// A normal response.
    Normal,
    /// An exception response with this code.
    Exception(u8),
}

/// One request frame (address, PDU, CRC) with a label for the tables.
#[derive(Clone, Debug)]
pub struct Request {
    /// E.g. "FC 3 × 10".
    pub label: String,
    /// The ADU as it goes on the wire.
    pub frame: Vec<u8>,
    /// The answer a correct slave gives.
    pub expect: Expect,
}

impl Request {
    fn new(label: String, id: u8, pdu: &[u8], expect: Expect) -> Request {
        let mut frame = Vec::with_capacity(pdu.len() + 3);
        frame.push(id);
        frame.extend_from_slice(pdu);
        frame.extend_from_slice(&crc16(&frame).to_le_bytes());
        Request { label, frame, expect }
    }

    /// FC 1-4: read `qty` items from address `start`.
    pub fn read(id: u8, fc: u8, start: u16, qty: u16, expect: Expect) -> Request {
        let [sh, sl] = start.to_be_bytes();
        let [qh, ql] = qty.to_be_bytes();
        Request::new(format!("FC {fc} × {qty}"), id, &[fc, sh, sl, qh, ql], expect)
    }

    /// FC 5 or 6: write one coil (`value` 0xFF00 or 0) or register.
    pub fn write_single(id: u8, fc: u8, addr: u16, value: u16, expect: Expect) -> Request {
        let [ah, al] = addr.to_be_bytes();
        let [vh, vl] = value.to_be_bytes();
        Request::new(format!("FC {fc} × 1"), id, &[fc, ah, al, vh, vl], expect)
    }

    /// FC 15: write `qty` coils from `start`, alternating on and off.
    pub fn write_coils(id: u8, start: u16, qty: u16, expect: Expect) -> Request {
        let bytes = usize::from(qty).div_ceil(8);
        let mut pdu = vec![0x0F];
        pdu.extend_from_slice(&start.to_be_bytes());
        pdu.extend_from_slice(&qty.to_be_bytes());
        pdu.push(bytes as u8);
        pdu.extend((0..bytes).map(|i| if (i + 1) * 8 <= usize::from(qty) { 0x55 } else { 0x55 >> (8 - qty % 8) }));
        Request::new(format!("FC 15 × {qty}"), id, &pdu, expect)
    }

    /// FC 16: write `qty` registers from `start` with 0x1000, 0x1001, ...
    pub fn write_registers(id: u8, start: u16, qty: u16, expect: Expect) -> Request {
        let mut pdu = vec![0x10];
        pdu.extend_from_slice(&start.to_be_bytes());
        pdu.extend_from_slice(&qty.to_be_bytes());
        pdu.push((2 * qty) as u8);
        pdu.extend((0..qty).flat_map(|i| (0x1000 + i).to_be_bytes()));
        Request::new(format!("FC 16 × {qty}"), id, &pdu, expect)
    }

    /// Any PDU (e.g. an unsupported function code).
    pub fn raw(label: &str, id: u8, pdu: &[u8], expect: Expect) -> Request {
        Request::new(label.to_owned(), id, pdu, expect)
    }

    /// Whether `reply` is the answer a correct slave gives: CRC, address, function code,
    /// length, and the exception code if one is expected.
    pub fn check(&self, reply: &[u8]) -> Result<(), String> {
        let n = reply.len();
        if n < 5 || crc16(reply) != 0 {
            return Err(format!("bad reply {reply:02x?}"));
        }
        let (id, fc) = (self.frame[0], self.frame[1]);
        let quantity = || u16::from_be_bytes([self.frame[4], self.frame[5]]);
        let ok = match self.expect {
            Expect::Exception(code) => reply[..3] == [id, fc | 0x80, code] && n == 5,
            Expect::Normal => {
                let len = match fc {
                    1 | 2 => 5 + usize::from(quantity()).div_ceil(8),
                    3 | 4 => 5 + 2 * usize::from(quantity()),
                    _ => 8,
                };
                reply[..2] == [id, fc] && n == len
            }
        };
        ok.then_some(()).ok_or_else(|| format!("{}: expected {:?}, got {reply:02x?}", self.label, self.expect))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_check_values_from_the_spec() {
        assert_eq!(crc16(&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03]).to_le_bytes(), [0x76, 0x87]);
        assert_eq!(crc16(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x01]).to_le_bytes(), [0x31, 0xCA]);
        assert_eq!(crc16(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02]).to_le_bytes(), [0x12, 0x98]);
    }

    #[test]
    fn frames_carry_their_crc_and_replies_are_checked() {
        let req = Request::read(1, 3, 0, 1, Expect::Normal);
        assert_eq!(req.frame, [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A]);
        let mut reply = vec![1, 3, 2, 0x12, 0x34];
        reply.extend_from_slice(&crc16(&reply).to_le_bytes());
        assert!(req.check(&reply).is_ok());
        assert!(req.check(&reply[..6]).is_err());
        let coils = Request::write_coils(1, 0, 5, Expect::Normal);
        assert_eq!(coils.frame[6..8], [1, 0x0A]);
    }
}
