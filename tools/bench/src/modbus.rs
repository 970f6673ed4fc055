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
        let bits: Vec<bool> = (0..qty).map(|i| i % 2 == 0).collect();
        Request::write_coil_values(id, start, &bits, expect)
    }

    /// FC 15: write `bits` to the coils from `start`.
    pub fn write_coil_values(id: u8, start: u16, bits: &[bool], expect: Expect) -> Request {
        let qty = bits.len() as u16;
        let mut pdu = vec![0x0F];
        pdu.extend_from_slice(&start.to_be_bytes());
        pdu.extend_from_slice(&qty.to_be_bytes());
        pdu.push(bits.len().div_ceil(8) as u8);
        pdu.extend(bits.chunks(8).map(|byte| byte.iter().rev().fold(0u8, |acc, &b| (acc << 1) | u8::from(b))));
        Request::new(format!("FC 15 × {qty}"), id, &pdu, expect)
    }

    /// FC 16: write `qty` registers from `start` with 0x1000, 0x1001, ...
    pub fn write_registers(id: u8, start: u16, qty: u16, expect: Expect) -> Request {
        let values: Vec<u16> = (0..qty).map(|i| 0x1000 + i).collect();
        Request::write_register_values(id, start, &values, expect)
    }

    /// FC 16: write `values` to the registers from `start`.
    pub fn write_register_values(id: u8, start: u16, values: &[u16], expect: Expect) -> Request {
        let qty = values.len() as u16;
        let mut pdu = vec![0x10];
        pdu.extend_from_slice(&start.to_be_bytes());
        pdu.extend_from_slice(&qty.to_be_bytes());
        pdu.push((2 * qty) as u8);
        pdu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        Request::new(format!("FC 16 × {qty}"), id, &pdu, expect)
    }

    /// Any PDU (e.g. an unsupported function code).
    pub fn raw(label: &str, id: u8, pdu: &[u8], expect: Expect) -> Request {
        Request::new(label.to_owned(), id, pdu, expect)
    }

    /// Function code, first address and quantity (1 for FC 5 and 6).
    fn fields(&self) -> (u8, u16, u16) {
        let word = |i: usize| u16::from_be_bytes([self.frame[i], self.frame[i + 1]]);
        let fc = self.frame[1];
        (fc, word(2), if matches!(fc, 5 | 6) { 1 } else { word(4) })
    }

    /// Whether `reply` is the answer a correct slave gives, byte for byte: CRC, address,
    /// function code, exception code, length, and every data byte `model` knows (a byte
    /// holding a value the firmware itself changes is only counted). A normal reply to a
    /// write is applied to `model`.
    pub fn check(&self, reply: &[u8], model: &mut Model) -> Result<(), String> {
        let n = reply.len();
        if n < 5 || crc16(reply) != 0 {
            return Err(format!("{}: bad reply {reply:02x?}", self.label));
        }
        let expected = match self.expect {
            Expect::Exception(code) => [self.frame[0], self.frame[1] | 0x80, code].map(Byte::known).to_vec(),
            Expect::Normal => model.reply(self),
        };
        let body = &reply[..n - 2];
        let same = body.len() == expected.len() && body.iter().zip(&expected).all(|(&b, e)| b & e.mask == e.value);
        if !same {
            let want: Vec<String> = expected.iter().map(Byte::shown).collect();
            return Err(format!("{}: expected [{}] + CRC, got {reply:02x?}", self.label, want.join(", ")));
        }
        if self.expect == Expect::Normal {
            model.apply(self);
        }
        Ok(())
    }
}

/// An expected reply byte: the bits under `mask` must equal `value`.
#[derive(Clone, Copy, Debug)]
struct Byte {
    value: u8,
    mask: u8,
}

impl Byte {
    fn known(value: u8) -> Byte {
        Byte { value, mask: 0xFF }
    }

    fn shown(&self) -> String {
        match self.mask {
            0xFF => format!("{:02x}", self.value),
            0 => "..".into(),
            mask => format!("{:02x}/{mask:02x}", self.value),
        }
    }
}

/// What the master knows of the slave's data: one entry per address of each table, `None`
/// where the firmware changes the value itself (inputs, measurements, copies).
#[derive(Clone, Debug)]
pub struct Model {
    /// Coils, discrete inputs, input registers, holding registers (bits as 0 and 1).
    tables: [Vec<Option<u16>>; 4],
}

impl Model {
    /// Tables of these sizes holding 0, the ranges in `changing` (first reference, Modbus
    /// 1-based: 00001, 10001, 30001, 40001; count) unknown, then the `initial` values.
    pub fn new(sizes: [u16; 4], changing: &[(u32, u16)], initial: &[(u32, u16)]) -> Model {
        let mut model = Model { tables: sizes.map(|n| vec![Some(0); usize::from(n)]) };
        for &(first, count) in changing {
            for r in first..first + u32::from(count) {
                if let Some(slot) = model.slot(r) {
                    *slot = None;
                }
            }
        }
        for &(r, value) in initial {
            if let Some(slot) = model.slot(r) {
                *slot = Some(value);
            }
        }
        model
    }

    fn slot(&mut self, reference: u32) -> Option<&mut Option<u16>> {
        let table = match reference / 10_000 {
            0 => 0,
            1 => 1,
            3 => 2,
            4 => 3,
            _ => return None,
        };
        let addr = (reference % 10_000).checked_sub(1)?;
        self.tables[table].get_mut(addr as usize)
    }

    fn table(fc: u8) -> usize {
        match fc {
            1 | 5 | 15 => 0,
            2 => 1,
            4 => 2,
            _ => 3,
        }
    }

    /// Values `start..start + qty` of the table `fc` addresses (`None`: unknown).
    fn values(&self, fc: u8, start: u16, qty: u16) -> impl Iterator<Item = Option<u16>> + '_ {
        let table = &self.tables[Model::table(fc)];
        (start..start.saturating_add(qty)).map(|a| table.get(usize::from(a)).copied().flatten())
    }

    /// The normal reply to `req` without its CRC.
    fn reply(&self, req: &Request) -> Vec<Byte> {
        let (fc, start, qty) = req.fields();
        let mut out = vec![Byte::known(req.frame[0]), Byte::known(fc)];
        match fc {
            1 | 2 => {
                let bits: Vec<Option<u16>> = self.values(fc, start, qty).collect();
                out.push(Byte::known(usize::from(qty).div_ceil(8) as u8));
                // Unused high bits of the last byte are 0 (§6.1).
                out.extend(bits.chunks(8).map(|byte| {
                    byte.iter().enumerate().fold(Byte::known(0), |acc, (i, bit)| match bit {
                        Some(b) => Byte { value: acc.value | (u8::from(*b != 0) << i), ..acc },
                        None => Byte { mask: acc.mask & !(1 << i), ..acc },
                    })
                }));
            }
            3 | 4 => {
                out.push(Byte::known((2 * qty) as u8));
                for value in self.values(fc, start, qty) {
                    let unknown = Byte { value: 0, mask: 0 };
                    out.extend(value.map_or([unknown; 2], |v| v.to_be_bytes().map(Byte::known)));
                }
            }
            // Writes echo address and value or quantity.
            _ => out.extend(req.frame[2..6].iter().copied().map(Byte::known)),
        }
        out
    }

    /// Applies a write the slave acknowledged; unknown values stay unknown.
    fn apply(&mut self, req: &Request) {
        let (fc, start, qty) = req.fields();
        let values: Vec<u16> = match fc {
            5 => vec![u16::from(req.frame[4] == 0xFF)],
            6 => vec![u16::from_be_bytes([req.frame[4], req.frame[5]])],
            15 => (0..usize::from(qty)).map(|i| u16::from((req.frame[7 + i / 8] >> (i % 8)) & 1)).collect(),
            16 => req.frame[7..7 + 2 * usize::from(qty)].chunks(2).map(|w| u16::from_be_bytes([w[0], w[1]])).collect(),
            _ => return,
        };
        let table = &mut self.tables[Model::table(fc)];
        for (addr, value) in (usize::from(start)..).zip(values) {
            if let Some(Some(slot)) = table.get_mut(addr) {
                *slot = value;
            }
        }
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
        let mut model = Model::new([0, 0, 0, 2], &[], &[(40001, 0x1234)]);
        let req = Request::read(1, 3, 0, 1, Expect::Normal);
        assert_eq!(req.frame, [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A]);
        let mut reply = vec![1, 3, 2, 0x12, 0x34];
        reply.extend_from_slice(&crc16(&reply).to_le_bytes());
        assert!(req.check(&reply, &mut model).is_ok());
        assert!(req.check(&reply[..6], &mut model).is_err());
        let coils = Request::write_coils(1, 0, 5, Expect::Normal);
        assert_eq!(coils.frame[6..8], [1, 0x15]);
    }

    fn with_crc(bytes: &[u8]) -> Vec<u8> {
        let mut frame = bytes.to_vec();
        frame.extend_from_slice(&crc16(bytes).to_le_bytes());
        frame
    }

    #[test]
    fn a_wrong_value_is_caught_and_writes_update_the_model() {
        let mut model = Model::new([10, 0, 0, 2], &[], &[]);
        let read = Request::read(1, 3, 0, 2, Expect::Normal);
        assert!(read.check(&with_crc(&[1, 3, 4, 0, 0, 0, 0]), &mut model).is_ok());
        assert!(read.check(&with_crc(&[1, 3, 4, 0, 0, 0, 1]), &mut model).is_err());
        let write = Request::write_register_values(1, 1, &[0xBEEF], Expect::Normal);
        assert!(write.check(&with_crc(&write.frame[..6]), &mut model).is_ok());
        assert!(read.check(&with_crc(&[1, 3, 4, 0, 0, 0xBE, 0xEF]), &mut model).is_ok());

        let bits = [true, false, true, true, false, false, false, false, true];
        let coils = Request::write_coil_values(1, 0, &bits, Expect::Normal);
        assert!(coils.check(&with_crc(&coils.frame[..6]), &mut model).is_ok());
        let read = Request::read(1, 1, 0, 10, Expect::Normal);
        assert!(read.check(&with_crc(&[1, 1, 2, 0b0000_1101, 0b01]), &mut model).is_ok());
        let single = Request::write_single(1, 5, 9, 0xFF00, Expect::Normal);
        assert!(single.check(&with_crc(&single.frame[..6]), &mut model).is_ok());
        assert!(read.check(&with_crc(&[1, 1, 2, 0b0000_1101, 0b11]), &mut model).is_ok());
    }

    #[test]
    fn values_the_firmware_changes_are_not_compared() {
        let mut model = Model::new([0, 3, 2, 0], &[(10002, 1), (30002, 1)], &[]);
        let inputs = Request::read(1, 2, 0, 3, Expect::Normal);
        assert!(inputs.check(&with_crc(&[1, 2, 1, 0b010]), &mut model).is_ok());
        assert!(inputs.check(&with_crc(&[1, 2, 1, 0b000]), &mut model).is_ok());
        assert!(inputs.check(&with_crc(&[1, 2, 1, 0b011]), &mut model).is_err());
        assert!(inputs.check(&with_crc(&[1, 2, 1, 0b1010]), &mut model).is_err());
        let regs = Request::read(1, 4, 0, 2, Expect::Normal);
        assert!(regs.check(&with_crc(&[1, 4, 4, 0, 0, 0x12, 0x34]), &mut model).is_ok());
        assert!(regs.check(&with_crc(&[1, 4, 4, 0, 1, 0x12, 0x34]), &mut model).is_err());
        let exception = Request::read(1, 4, 0, 3, Expect::Exception(2));
        assert!(exception.check(&with_crc(&[1, 0x84, 2]), &mut model).is_ok());
        assert!(exception.check(&with_crc(&[1, 0x84, 3]), &mut model).is_err());
    }
}
