//! A slave that may only read (feature `write-protect`, `Engine::set_read_only`): every
//! write function code gets exception 01 (Application Protocol v1.1b3 §7, "not an
//! allowable action for the server") before its quantity or addresses are checked, changes
//! nothing, and is counted; reads and FC 8 go on.

mod common;

use avr_modbus::internal::EndOfFrame;
use avr_modbus::{bit_bytes, Bank};
use common::{ask, exception_reply, slave, to_slave, with_crc};

type Small = Bank<4, 8, { bit_bytes(16) }>;

/// Coils 00001–00008, holding registers 40001–40004.
fn bank() -> Small {
    let mut bank: Small = Bank::new();
    bank.add_range(1, 8).unwrap();
    bank.add_range(40001, 4).unwrap();
    bank
}

/// Each write code with a request a writing slave refuses for its data (03) or its
/// addresses (02), and that exception.
const FLAWED_WRITES: [(&[u8], u8); 6] = [
    (&[0x05, 0x00, 0x00, 0x12, 0x34], 0x03),       // FC 5, value neither ON nor OFF
    (&[0x06, 0x00, 0x63, 0x00, 0x01], 0x02),       // FC 6 to 40100, missing
    (&[0x0F, 0x00, 0x00, 0x00, 0x00, 0x00], 0x03), // FC 15, quantity 0
    (&[0x10, 0x00, 0x00, 0x00, 0x00, 0x00], 0x03), // FC 16, quantity 0
    (&[0x16, 0x00, 0x63, 0xFF, 0xFF, 0x00, 0x00], 0x02), // FC 22 to 40100, missing
    (&[0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x02, 0x00, 0x01], 0x03), // FC 23, read quantity 0
];

#[test]
fn every_write_code_is_illegal_function_before_its_quantity_and_addresses() {
    for (pdu, exception) in FLAWED_WRITES {
        let code = pdu[0];
        // FC 22 and 23 are 01 anyway without feature `extra-fc`.
        let writing = if code >= 0x16 && !cfg!(feature = "extra-fc") { 0x01 } else { exception };
        assert_eq!(ask(&mut slave(), &mut bank(), &to_slave(pdu)), exception_reply(code, writing), "FC {code}");
        let mut reading = slave();
        reading.set_read_only(true);
        assert_eq!(ask(&mut reading, &mut bank(), &to_slave(pdu)), exception_reply(code, 0x01), "FC {code}");
        let counters = reading.counters();
        assert_eq!((counters.refused_writes, counters.exceptions, counters.events), (1, 1, 0), "FC {code}");
    }
}

#[test]
fn a_refused_write_changes_nothing_and_writes_work_again_once_allowed() {
    let mut bank = bank();
    let mut slave = slave();
    slave.set_read_only(true);
    assert!(slave.is_read_only());
    let fc6 = [0x06, 0x00, 0x01, 0x12, 0x34]; // 40002
    let fc15 = [0x0F, 0x00, 0x00, 0x00, 0x08, 0x01, 0xFF]; // 00001–00008
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc6)), exception_reply(0x06, 0x01));
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc15)), exception_reply(0x0F, 0x01));
    assert_eq!((bank.get(40002), bank.get(1), bank.master_writes()), (Ok(0), Ok(0), 0));
    slave.set_read_only(false);
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc6)), to_slave(&fc6));
    assert_eq!((bank.get(40002), bank.master_writes()), (Ok(0x1234), 1));
    assert_eq!(slave.counters().refused_writes, 2);
}

#[test]
fn reads_go_on_while_read_only() {
    let mut bank = bank();
    bank.set(40001, 0xABCD).unwrap();
    let mut slave = slave();
    slave.set_read_only(true);
    let fc3 = [0x03, 0x00, 0x00, 0x00, 0x01];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc3)), to_slave(&[0x03, 0x02, 0xAB, 0xCD]));
    let fc1 = [0x01, 0x00, 0x00, 0x00, 0x08];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc1)), to_slave(&[0x01, 0x01, 0x00]));
    // A read of a missing address is still 02: only writes are refused.
    let missing = [0x03, 0x00, 0x63, 0x00, 0x01];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&missing)), exception_reply(0x03, 0x02));
    assert_eq!(slave.counters().refused_writes, 0);
}

#[cfg(feature = "diagnostics")]
#[test]
fn fc8_reads_the_counters_while_read_only_and_its_restart_keeps_it_so() {
    let mut bank = bank();
    let mut slave = slave();
    slave.set_read_only(true);
    let fc6 = [0x06, 0x00, 0x01, 0x12, 0x34];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc6)), exception_reply(0x06, 0x01));
    // Sub-function 0D: the exception count, the refused write in it.
    let fc8 = [0x08, 0x00, 0x0D, 0x00, 0x00];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc8)), to_slave(&[0x08, 0x00, 0x0D, 0x00, 0x01]));
    // Sub-function 01, restart communications: the counters cleared, writes still refused.
    let restart = [0x08, 0x00, 0x01, 0x00, 0x00];
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&restart)), to_slave(&restart));
    assert_eq!(slave.counters().refused_writes, 0);
    assert_eq!(ask(&mut slave, &mut bank, &to_slave(&fc6)), exception_reply(0x06, 0x01));
    assert_eq!(bank.get(40002), Ok(0));
}

#[test]
fn a_broadcast_write_changes_nothing_gets_no_reply_and_is_counted() {
    let mut bank = bank();
    let mut slave = slave();
    slave.set_read_only(true);
    let fc16 = with_crc(&[0x00, 0x10, 0x00, 0x00, 0x00, 0x01, 0x02, 0x12, 0x34]);
    assert_eq!(slave.handle_frame(&fc16, &mut bank), EndOfFrame::Broadcast);
    assert_eq!((bank.get(40001), bank.master_writes()), (Ok(0), 0));
    assert!(slave.reply().is_empty());
    let counters = slave.counters();
    assert_eq!((counters.broadcasts, counters.refused_writes, counters.replies), (1, 1, 0));
}
