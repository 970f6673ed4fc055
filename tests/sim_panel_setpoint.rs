//! A serial slave that may only read while a local panel holds its setpoint
//! (`examples/panel_setpoint.rs`, feature `write-protect`), on the simulated Uno: with the
//! HOLD switch on pin 7 closed, the master's writes get exception 01 and change nothing, a
//! broadcast write changes nothing and is not answered, reads go on; open, writes work again.

mod sim;

use sim::{exception_reply, read_request, registers_reply, with_crc, write_register_request, Line, Rtu};

const ID: u8 = 1;
/// The HOLD switch's pin.
const HOLD: u8 = 7;
/// Long enough for the main loop to see the switch.
const MAIN_LOOP_US: u64 = 200;

#[test]
fn while_the_panel_holds_the_setpoint_the_masters_writes_get_01_and_change_nothing() {
    let mut rtu = Rtu::boot("panel_setpoint", Line::B19200_8E1);
    // Open: the master writes 40001 = 0x0150.
    let write = write_register_request(ID, 0, 0x0150);
    assert_eq!(rtu.ask(&write), write);
    // Closed: FC 6 and FC 16 (quantity 0, 03 from a writing slave) get 01.
    rtu.uno.drive_pin(HOLD, Some(false)).unwrap();
    rtu.run_us(MAIN_LOOP_US);
    assert_eq!(rtu.ask(&write_register_request(ID, 0, 0x0999)), exception_reply(ID, 0x06, 0x01));
    let fc16 = with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(rtu.ask(&fc16), exception_reply(ID, 0x10, 0x01));
    // A broadcast FC 6: no answer, nothing changed.
    let end = rtu.send(&write_register_request(0, 0, 0x0777));
    let heard = rtu.receive(end);
    assert!(heard.bytes().is_empty(), "a broadcast answered: {:02X?}", heard.bytes());
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 1)), registers_reply(ID, 0x03, &[0x0150]));
    // Open again: the master's write is done.
    rtu.uno.drive_pin(HOLD, None).unwrap();
    rtu.run_us(MAIN_LOOP_US);
    let write = write_register_request(ID, 0, 0x0160);
    assert_eq!(rtu.ask(&write), write);
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 1)), registers_reply(ID, 0x03, &[0x0160]));
}
