//! Helpers shared by the integration tests: a CRC written from the spec (not the crate's),
//! frame builders, the fixture banks and a data model that fails on purpose.
//!
//! Each test crate uses a different subset of these helpers.
#![allow(dead_code)]

use avr_modbus::internal::{EndOfFrame, Engine};
use avr_modbus::{Bank, DataModel, Exception, Reference, SlaveId, Table};

/// The address of the slave under test (the spec's examples use 0x11).
pub const ID: u8 = 0x11;

/// CRC-16/MODBUS as Serial Line v1.02 §6.2.2 describes it: start at 0xFFFF, xor each
/// byte into the low byte, then eight rounds of "shift right, xor 0xA001 if a 1 fell out".
pub fn reference_crc(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            let carry = crc & 1;
            crc >>= 1;
            if carry == 1 {
                crc ^= 0xA001;
            }
        }
    }
    crc
}

/// The frame with its CRC appended, low byte first.
pub fn with_crc(frame: &[u8]) -> Vec<u8> {
    let crc = reference_crc(frame);
    let mut out = frame.to_vec();
    out.push((crc & 0xFF) as u8);
    out.push((crc >> 8) as u8);
    out
}

/// A request ADU to [`ID`] carrying `pdu`.
pub fn to_slave(pdu: &[u8]) -> Vec<u8> {
    let mut frame = vec![ID];
    frame.extend_from_slice(pdu);
    with_crc(&frame)
}

/// The exception reply ADU from [`ID`]: function code with bit 7 set, exception code.
pub fn exception_reply(function: u8, code: u8) -> Vec<u8> {
    with_crc(&[ID, function | 0x80, code])
}

/// A read request PDU (FC 01–04): function, start, quantity.
pub fn read_pdu(function: u8, start: u16, qty: u16) -> Vec<u8> {
    let [s_hi, s_lo] = start.to_be_bytes();
    let [q_hi, q_lo] = qty.to_be_bytes();
    vec![function, s_hi, s_lo, q_hi, q_lo]
}

/// A write-multiple request PDU (FC 0F / 10): function, start, quantity, byte count, data.
pub fn write_multiple_pdu(function: u8, start: u16, qty: u16, data: &[u8]) -> Vec<u8> {
    let mut pdu = read_pdu(function, start, qty);
    pdu.push(data.len() as u8);
    pdu.extend_from_slice(data);
    pdu
}

/// The slave under test, just after power-up.
pub fn slave() -> Engine {
    Engine::new(SlaveId::new(ID))
}

/// Sends `frame` as one whole frame and returns the reply, which must exist.
pub fn ask<M: DataModel>(slave: &mut Engine, model: &mut M, frame: &[u8]) -> Vec<u8> {
    assert_eq!(slave.handle_frame(frame, model), EndOfFrame::Reply, "frame {frame:02X?}");
    slave.reply().to_vec()
}

/// Sends `pdu` to [`ID`] on a fresh slave and returns the reply ADU.
pub fn exchange<M: DataModel>(model: &mut M, pdu: &[u8]) -> Vec<u8> {
    ask(&mut slave(), model, &to_slave(pdu))
}

/// The bank used by most tests.
pub type TestBank = Bank<16, 64, 16>;

/// The spec's examples (Application Protocol §6.1–6.12) laid out in a bank with holes:
///
/// | table | present (protocol addresses) | values | holes |
/// |---|---|---|---|
/// | coils | 19–37, 40–47, 172 | 19–37 = bits of `CD 6B 05` (LSB first), 40–47 on | 38, 39, 48… |
/// | discrete inputs | 196–217 | bits of `AC DB 35` | 218… |
/// | input registers | 8, 10 | 0x000A, 0x1234 | 9 |
/// | holding registers | 0–2, 107–109, 112 | 107–109 = 0x022B, 0, 0x0064 | 3–106, 110, 111 |
pub fn spec_bank() -> TestBank {
    let mut bank = TestBank::new();
    bank.add_range(Reference::coil(19), 19).unwrap();
    bank.add_range(Reference::coil(40), 8).unwrap();
    bank.add(Reference::coil(172)).unwrap();
    bank.add_range(Reference::discrete_input(196), 22).unwrap();
    bank.add(Reference::input_register(8)).unwrap();
    bank.add(Reference::input_register(10)).unwrap();
    bank.add_range(Reference::holding_register(0), 3).unwrap();
    bank.add_range(Reference::holding_register(107), 3).unwrap();
    bank.add(Reference::holding_register(112)).unwrap();
    for k in 0..19 {
        bank.set(Reference::coil(19 + k), bit_of(&[0xCD, 0x6B, 0x05], k)).unwrap();
    }
    for a in 40..48 {
        bank.set(Reference::coil(a), 1).unwrap();
    }
    for k in 0..22 {
        bank.set(Reference::discrete_input(196 + k), bit_of(&[0xAC, 0xDB, 0x35], k)).unwrap();
    }
    bank.set(Reference::input_register(8), 0x000A).unwrap();
    bank.set(Reference::input_register(10), 0x1234).unwrap();
    bank.set(Reference::holding_register(107), 0x022B).unwrap();
    bank.set(Reference::holding_register(108), 0x0000).unwrap();
    bank.set(Reference::holding_register(109), 0x0064).unwrap();
    bank
}

/// Bit `k` of `bytes`, LSB first: 0 or 1.
pub fn bit_of(bytes: &[u8], k: u16) -> u16 {
    u16::from(bytes[usize::from(k / 8)] >> (k % 8) & 1)
}

/// A bank as large as the largest requests: coils and discrete inputs 0–1999, input and
/// holding registers 0–124; coil `a` is on when `a % 3 == 0`, register `a` holds
/// `0x0100 * a + 1`.
pub type FullBank = Bank<4, 250, 500>;

/// See [`FullBank`].
pub fn full_bank() -> FullBank {
    let mut bank = FullBank::new();
    bank.add_range(Reference::coil(0), 2000).unwrap();
    bank.add_range(Reference::discrete_input(0), 2000).unwrap();
    bank.add_range(Reference::input_register(0), 125).unwrap();
    bank.add_range(Reference::holding_register(0), 125).unwrap();
    for a in 0..2000 {
        bank.set(Reference::coil(a), u16::from(a % 3 == 0)).unwrap();
        bank.set(Reference::discrete_input(a), u16::from(a % 3 == 0)).unwrap();
    }
    for a in 0..125 {
        bank.set(Reference::input_register(a), 0x0100 * a + 1).unwrap();
        bank.set(Reference::holding_register(a), 0x0100 * a + 1).unwrap();
    }
    bank
}

/// Every value of `table` from `first` to `last` in the bank (missing ones as `None`).
pub fn snapshot<const R: usize, const G: usize, const B: usize>(
    bank: &Bank<R, G, B>,
    table: Table,
    first: u16,
    last: u16,
) -> Vec<Option<u16>> {
    (first..=last).map(|address| bank.get(Reference { table, address }).ok()).collect()
}

/// A data model that answers 02 where the wrapped model would, and 04 for everything
/// else, changing nothing: a device whose hardware has failed.
#[derive(Clone, Debug)]
pub struct Failing<M>(pub M);

impl<M: DataModel + Clone> DataModel for Failing<M> {
    fn has_range(&self, table: Table, start: u16, qty: u16) -> bool {
        self.0.has_range(table, start, qty)
    }

    fn read_bits(&self, table: Table, start: u16, qty: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.0.read_bits(table, start, qty, out)?;
        Err(Exception::ServerDeviceFailure)
    }

    fn read_registers(&self, table: Table, start: u16, out: &mut [u8]) -> Result<(), Exception> {
        self.0.read_registers(table, start, out)?;
        Err(Exception::ServerDeviceFailure)
    }

    fn write_coils(&mut self, start: u16, qty: u16, packed: &[u8]) -> Result<(), Exception> {
        self.0.clone().write_coils(start, qty, packed)?;
        Err(Exception::ServerDeviceFailure)
    }

    fn write_registers(&mut self, start: u16, values: &[u8]) -> Result<(), Exception> {
        self.0.clone().write_registers(start, values)?;
        Err(Exception::ServerDeviceFailure)
    }
}
