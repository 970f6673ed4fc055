//! The line settings (feature `eeprom-settings`): the two EEPROM record slots and the
//! settings block of holding registers the master writes.
//!
//! Records: any 22 bytes of slots load without panicking; a store of settings, carried
//! out completely, loads as those settings; cut short after any write with the byte being
//! written torn to any value, it loads as the settings before the store or the new ones,
//! never as nothing when there were settings before.
//!
//! Block: FC 6 and FC 16 requests in and around the block (40101–40104, and 40105, the
//! transmission mode, with feature `ascii`) through the slave: a well-formed reply; an
//! exception changes neither the block nor the bank; a write the slave accepted holds
//! settings it can run.
#![no_main]

use avr_modbus::internal::settings::{LineSettings, Slots, SLOTS_LEN};
use avr_modbus::internal::{EndOfFrame, Engine};
use avr_modbus::{bit_bytes, Bank, Config, Configurable, Parity, SlaveId, StopBits};
use libfuzzer_sys::fuzz_target;

#[cfg(feature = "ascii")]
use avr_modbus::Mode;

/// Settings from four input bytes: any id, a rate from a list the USART can make or not,
/// any parity, stop-bit and (feature `ascii`) mode choice.
fn settings(bytes: [u8; 4]) -> LineSettings {
    const RATES: [u32; 8] = [1200, 9600, 19_200, 57_600, 115_200, 250_000, 36_000, 4700];
    LineSettings {
        slave_id: bytes[0],
        baud: RATES[usize::from(bytes[1]) % RATES.len()] + u32::from(bytes[2] >> 6) * 100,
        parity: [Parity::None, Parity::Even, Parity::Odd][usize::from(bytes[2] & 3) % 3],
        stop_bits: if bytes[3] & 1 == 0 { StopBits::One } else { StopBits::Two },
        #[cfg(feature = "ascii")]
        mode: [Mode::Rtu, Mode::Ascii, Mode::Ascii8][usize::from(bytes[3] >> 1) % 3],
    }
}

fn records(slots: [u8; SLOTS_LEN], new: Config, cut: usize, torn: u8) {
    let before = Slots::new(slots).load();
    let writes: Vec<_> = Slots::new(slots).store(&new).collect();
    let mut bytes = slots;
    for write in &writes {
        bytes[usize::from(write.offset)] = write.byte;
    }
    assert_eq!(Slots::new(bytes).load(), Some(new), "a complete store");
    for (k, write) in writes.iter().enumerate().take(cut % (writes.len() + 1)) {
        let mut bytes = slots;
        for earlier in &writes[..k] {
            bytes[usize::from(earlier.offset)] = earlier.byte;
        }
        bytes[usize::from(write.offset)] = torn;
        let loaded = Slots::new(bytes).load();
        assert!(loaded == before || loaded == Some(new), "cut at write {k}, torn {torn:#04X}: {loaded:?}");
        assert!(before.is_none() || loaded.is_some(), "settings lost at write {k}");
    }
}

type Registers = Configurable<Bank<2, 4, { bit_bytes(0) }>>;

fn with_crc(frame: &[u8]) -> Vec<u8> {
    let mut crc: u16 = 0xFFFF;
    for &byte in frame {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
        }
    }
    let mut out = frame.to_vec();
    out.extend(crc.to_le_bytes());
    out
}

fn block(writes: &[u8]) {
    let default = Config::new(1, 19_200, Parity::Even, StopBits::One);
    let mut bank = Bank::new();
    bank.add_range(40001, 4).unwrap();
    let mut model: Registers = Configurable::new(bank, 40101, default).unwrap();
    let mut slave: Engine = Engine::new(SlaveId::new(1));
    for chunk in writes.chunks(8) {
        let [op, address, a, b, c, d, e, f] = <[u8; 8]>::try_from(chunk).unwrap_or([0; 8]);
        // Addresses 96–107: around the block at 100–103.
        let start = 96 + u16::from(address % 12);
        let mut pdu = vec![];
        if op & 1 == 0 {
            pdu.extend([0x06]);
            pdu.extend(start.to_be_bytes());
            pdu.extend([a, b]);
        } else {
            let qty = 1 + u16::from(op >> 1) % 4;
            pdu.extend([0x10]);
            pdu.extend(start.to_be_bytes());
            pdu.extend(qty.to_be_bytes());
            pdu.push((2 * qty) as u8);
            pdu.extend([a, b, c, d, e, f, a, c].iter().take(usize::from(2 * qty)));
        }
        let mut frame = vec![1];
        frame.extend(&pdu);
        let (settings, values) = (model.settings(), model.inner().clone());
        let end = slave.handle_frame(&with_crc(&frame), &mut model);
        assert_eq!(end, EndOfFrame::Reply);
        let reply = slave.reply();
        assert_eq!(reply[..], with_crc(&reply[..reply.len() - 2])[..], "reply CRC");
        if reply[1] & 0x80 != 0 {
            assert_eq!(reply.len(), 5);
            assert!(reply[2] == 2 || reply[2] == 3, "exception {}", reply[2]);
            assert_eq!(model.settings(), settings, "an exception changes no setting");
            for register in 40001..=40004 {
                assert_eq!(model.inner().get(register), values.get(register), "nor the bank");
            }
        } else {
            assert_eq!(reply[1..6], pdu[..5], "the echo");
            assert!(model.settings().is_runnable() && model.settings().to_config().is_some());
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((head, rest)) = data.split_first_chunk::<{ SLOTS_LEN + 6 }>() else { return };
    let mut slots = [0; SLOTS_LEN];
    slots.copy_from_slice(&head[..SLOTS_LEN]);
    let [s0, s1, s2, s3, cut, torn] = [0, 1, 2, 3, 4, 5].map(|k| head[SLOTS_LEN + k]);
    if let Some(new) = settings([s0, s1, s2, s3]).to_config() {
        records(slots, new, usize::from(cut), torn);
    } else {
        let _ = Slots::new(slots).load();
    }
    block(rest);
});
