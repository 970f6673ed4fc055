//! Four slave ids on one line from one firmware (`examples/units.rs`, [`avr_modbus::Units`])
//! end to end in simavr at 19200 8E1 (Serial Line v1.02 §2.2): each id answers from its own
//! register map with its own address, a broadcast write reaches all four and is not
//! answered, and the ids around them are other slaves' (silence).

mod sim;

use sim::{read_request, registers_reply, with_crc, write_register_request, Line, Rtu};

fn units() -> Rtu {
    Rtu::boot("units", Line::B19200_8E1)
}

#[test]
fn each_id_answers_its_own_reading_with_its_own_address() {
    let mut rtu = units();
    for id in 1..=4u8 {
        let reply = rtu.ask(&read_request(id, 0x04, 0, 1));
        assert_eq!(reply, registers_reply(id, 0x04, &[100 * u16::from(id)]), "slave {id}");
    }
}

#[test]
fn ids_around_the_units_get_silence() {
    let mut rtu = units();
    for id in [5, 6, 247] {
        let exchange = rtu.exchange(&read_request(id, 0x04, 0, 1));
        assert!(exchange.reply.is_empty(), "slave {id} answered {:02X?}", exchange.bytes());
    }
    // The line is heard still: id 4 answers after them.
    assert_eq!(rtu.ask(&read_request(4, 0x04, 0, 1)), registers_reply(4, 0x04, &[400]));
}

#[test]
fn a_broadcast_write_reaches_every_unit_and_one_write_reaches_one() {
    let mut rtu = units();
    // Broadcast: 40001 = 7 at all four, no answer.
    let exchange = rtu.exchange(&write_register_request(0, 0, 7));
    assert!(exchange.reply.is_empty(), "broadcast answered {:02X?}", exchange.bytes());
    // Then 40002 = 9 at slave 3 only.
    let write = write_register_request(3, 1, 9);
    assert_eq!(rtu.ask(&write), write);
    for id in 1..=4u8 {
        let holding = rtu.ask(&read_request(id, 0x03, 0, 2));
        assert_eq!(holding, registers_reply(id, 0x03, &[7, if id == 3 { 9 } else { 0 }]), "slave {id}");
        // The main loop copied each one's 40001 into its 30002.
        let copy = rtu.ask(&read_request(id, 0x04, 1, 1));
        assert_eq!(copy, registers_reply(id, 0x04, &[7]), "slave {id}");
    }
}

#[test]
fn an_exception_carries_the_address_asked() {
    let mut rtu = units();
    // 40003 is missing from each sensor's map: exception 02, from slave 2.
    assert_eq!(rtu.ask(&read_request(2, 0x03, 2, 1)), with_crc(&[2, 0x83, 0x02]));
}
