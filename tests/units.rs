//! Several slave ids on one line (Serial Line v1.02 §2.2): [`Units`] (a model for each id)
//! and [`Windows`] (a window of one model for each id), through the whole RTU engine and
//! the TCP server's handling: which ids are answered, what each sees, a broadcast made
//! once per unit, the line's counters, FC 17's id.

mod common;

use avr_modbus::internal::{EndOfFrame, Engine};
use avr_modbus::{DataModel, Reference, SlaveId, Units, Windows};
use common::{exception_reply, read_pdu, with_crc};

avr_modbus::register_map! {
    /// One sensor: a reading and a setpoint.
    struct Sensor { 30001..=30002, 40001..=40002 }
}

avr_modbus::register_map! {
    /// Four sensors' registers side by side, ten addresses apart.
    struct Sensors { 30001..=30032, 40001..=40032 }
}

/// Four sensors at slave ids 5–8, sensor `k`'s reading 100 + `k`.
fn units() -> Units<Sensor, 4> {
    let mut units = Units::new(5, [Sensor::new(), Sensor::new(), Sensor::new(), Sensor::new()]);
    for id in 5..=8 {
        units.set(id, 30001, 100 + u16::from(id)).unwrap();
    }
    units
}

/// Four windows at slave ids 5–8, ten addresses apart; window `k`'s first reading 100 + `k`.
fn windows() -> Windows<Sensors, 4> {
    let mut windows = Windows::new(5, 10, Sensors::new());
    for k in 0..4 {
        windows.set_value(Reference::classic(30001 + 10 * k).unwrap(), 105 + k as u16).unwrap();
    }
    windows
}

/// A slave whose own id (unused by a units model) is none of the units'.
fn line() -> Engine {
    Engine::new(SlaveId::new(1))
}

/// `pdu` sent to slave `id`, as a frame.
fn to(id: u8, pdu: &[u8]) -> Vec<u8> {
    let mut frame = vec![id];
    frame.extend_from_slice(pdu);
    with_crc(&frame)
}

/// FC 4 reading one input register from `address` at slave `id`: the reply, if any.
fn read_input<M: DataModel>(line: &mut Engine, model: &mut M, id: u8, address: u16) -> Option<Vec<u8>> {
    let end = line.handle_frame(&to(id, &read_pdu(0x04, address, 1)), model);
    (end == EndOfFrame::Reply).then(|| line.reply().to_vec())
}

/// The reply to FC 4 from slave `id`: one register holding `value`.
fn one_register(id: u8, value: u16) -> Vec<u8> {
    let [hi, lo] = value.to_be_bytes();
    with_crc(&[id, 0x04, 0x02, hi, lo])
}

/// FC 6 writing `value` to holding register `address`.
fn write_pdu(address: u16, value: u16) -> Vec<u8> {
    let [a, b] = address.to_be_bytes();
    let [c, d] = value.to_be_bytes();
    vec![0x06, a, b, c, d]
}

#[test]
fn each_id_of_units_is_answered_from_its_own_model_with_its_own_address() {
    let (mut line, mut units) = (line(), units());
    for id in 5..=8 {
        assert_eq!(read_input(&mut line, &mut units, id, 0), Some(one_register(id, 100 + u16::from(id))));
    }
}

#[test]
fn ids_outside_the_units_are_another_slaves_and_get_silence() {
    let (mut line, mut units) = (line(), units());
    for id in [1, 4, 9, 247] {
        let end = line.handle_frame(&to(id, &read_pdu(0x04, 0, 1)), &mut units);
        assert_eq!(end, EndOfFrame::OtherSlave, "id {id}");
    }
    // Counted as today: frames on the line, no message for this slave.
    let counters = line.counters();
    assert_eq!((counters.frames, counters.messages), (4, 0));
}

#[test]
fn units_past_247_are_never_answered() {
    let mut units: Units<Sensor, 4> = Units::new(246, [Sensor::new(), Sensor::new(), Sensor::new(), Sensor::new()]);
    let mut line = line();
    assert!(read_input(&mut line, &mut units, 246, 0).is_some());
    assert!(read_input(&mut line, &mut units, 247, 0).is_some());
    assert_eq!(line.handle_frame(&to(248, &read_pdu(0x04, 0, 1)), &mut units), EndOfFrame::OtherSlave);
    assert!(units.unit(248).is_none());
}

#[test]
fn a_write_to_one_unit_changes_only_its_model() {
    let (mut line, mut units) = (line(), units());
    let end = line.handle_frame(&to(6, &write_pdu(1, 0x1234)), &mut units);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(line.reply(), to(6, &write_pdu(1, 0x1234)));
    for id in 5..=8 {
        assert_eq!(units.get(id, 40002), Ok(if id == 6 { 0x1234 } else { 0 }), "id {id}");
    }
}

#[test]
fn a_broadcast_write_is_made_once_in_every_unit_and_not_answered() {
    let (mut line, mut units) = (line(), units());
    let end = line.handle_frame(&to(0, &write_pdu(0, 77)), &mut units);
    assert_eq!(end, EndOfFrame::Broadcast);
    assert!(line.reply().is_empty());
    for id in 5..=8 {
        assert_eq!(units.get(id, 40001), Ok(77), "id {id}");
        assert_eq!(units.unit(id).unwrap().master_writes(), 1, "id {id}: written once");
    }
    // One broadcast on the line: one message, one broadcast, one event.
    let counters = line.counters();
    assert_eq!((counters.messages, counters.broadcasts, counters.events, counters.exceptions), (1, 1, 1, 0));
}

#[test]
fn a_broadcast_write_is_made_once_in_every_window() {
    let (mut line, mut windows) = (line(), windows());
    // FC 16: holding registers 0 and 1 of each window.
    let pdu = [0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0x00, 0x07, 0x00, 0x08];
    assert_eq!(line.handle_frame(&to(0, &pdu), &mut windows), EndOfFrame::Broadcast);
    for k in 0..4u32 {
        assert_eq!(windows.value(Reference::classic(40001 + 10 * k).unwrap()), Ok(7), "window {k}");
        assert_eq!(windows.value(Reference::classic(40002 + 10 * k).unwrap()), Ok(8), "window {k}");
    }
    // Four windows, four writes; the registers between the windows untouched.
    assert_eq!(windows.master_writes(), 4);
    assert_eq!(windows.value(Reference::classic(40003).unwrap()), Ok(0));
}

#[test]
fn a_broadcast_read_is_ignored() {
    let (mut line, mut units) = (line(), units());
    assert_eq!(line.handle_frame(&to(0, &read_pdu(0x04, 0, 1)), &mut units), EndOfFrame::Broadcast);
    assert!(line.reply().is_empty());
    assert_eq!(units.master_writes(), 0);
}

#[test]
fn each_window_sees_its_own_addresses_of_the_one_model() {
    let (mut line, mut windows) = (line(), windows());
    for id in 5..=8 {
        assert_eq!(read_input(&mut line, &mut windows, id, 0), Some(one_register(id, 100 + u16::from(id))));
    }
    // Window 3 (id 8) writes its register 1: the model's 40032.
    assert_eq!(line.handle_frame(&to(8, &write_pdu(1, 9)), &mut windows), EndOfFrame::Reply);
    assert_eq!(windows.value(Reference::classic(40032).unwrap()), Ok(9));
    assert_eq!(windows.model().value(Reference::classic(40002).unwrap()), Ok(0));
}

#[test]
fn a_window_past_the_model_or_past_65535_is_exception_02() {
    let mut line = line();
    let mut windows: Windows<Sensors, 4> = Windows::new(5, 10, Sensors::new());
    // Id 8 (window 3): address 3 is the model's 33, which it lacks.
    let reply = line.handle_frame(&to(8, &read_pdu(0x04, 2, 1)), &mut windows);
    assert_eq!(reply, EndOfFrame::Reply);
    assert_eq!(line.reply(), &exception_reply_from(8, 0x04, 0x02)[..]);
    // A stride that takes window 1 past 65535.
    let mut far: Windows<Sensors, 2> = Windows::new(5, 0xFFF0, Sensors::new());
    line.handle_frame(&to(6, &read_pdu(0x04, 0x0010, 1)), &mut far);
    assert_eq!(line.reply(), &exception_reply_from(6, 0x04, 0x02)[..]);
    // Window 0 of the same model still reads.
    assert_eq!(read_input(&mut line, &mut far, 5, 0), Some(one_register(5, 0)));
}

/// An exception reply from slave `id`.
fn exception_reply_from(id: u8, function: u8, code: u8) -> Vec<u8> {
    let mut reply = exception_reply(function, code);
    reply[0] = id;
    let len = reply.len();
    with_crc(&reply[..len - 2])
}

#[cfg(feature = "diagnostics")]
mod diagnostics {
    use super::*;

    /// FC 17 (Report Server ID) to slave `id`: the reply.
    fn report_id<M: DataModel>(line: &mut Engine, model: &mut M, id: u8) -> Vec<u8> {
        assert_eq!(line.handle_frame(&to(id, &[0x11]), model), EndOfFrame::Reply);
        line.reply().to_vec()
    }

    #[test]
    fn fc17_reports_the_id_addressed() {
        let mut line = line();
        let (mut units, mut windows) = (units(), windows());
        for id in 5..=8 {
            // Byte count 2, the slave id, run indicator ON.
            assert_eq!(report_id(&mut line, &mut units, id), with_crc(&[id, 0x11, 0x02, id, 0xFF]));
            assert_eq!(report_id(&mut line, &mut windows, id), with_crc(&[id, 0x11, 0x02, id, 0xFF]));
        }
    }

    #[test]
    fn the_counters_are_the_lines_whichever_unit_asks() {
        let (mut line, mut units) = (line(), units());
        for id in 5..=8 {
            read_input(&mut line, &mut units, id, 0).unwrap();
        }
        line.handle_frame(&to(2, &read_pdu(0x04, 0, 1)), &mut units);
        // FC 8 sub-function 0E (slave message count) to id 7: the four reads and itself.
        assert_eq!(line.handle_frame(&to(7, &[0x08, 0x00, 0x0E, 0x00, 0x00]), &mut units), EndOfFrame::Reply);
        assert_eq!(line.reply(), with_crc(&[7, 0x08, 0x00, 0x0E, 0x00, 0x05]));
        // FC 8 sub-function 0B (bus message count) to id 5: every frame on the line.
        line.handle_frame(&to(5, &[0x08, 0x00, 0x0B, 0x00, 0x00]), &mut units);
        assert_eq!(line.reply(), with_crc(&[5, 0x08, 0x00, 0x0B, 0x00, 0x07]));
        // FC 11 (comm event counter) to id 6: the line's events.
        line.handle_frame(&to(6, &[0x0B]), &mut units);
        assert_eq!(line.reply(), with_crc(&[6, 0x0B, 0x00, 0x00, 0x00, 0x06]));
    }

    #[test]
    fn listen_only_entered_through_one_unit_silences_them_all() {
        let (mut line, mut units) = (line(), units());
        assert_eq!(line.handle_frame(&to(5, &[0x08, 0x00, 0x04, 0x00, 0x00]), &mut units), EndOfFrame::Silent);
        for id in 5..=8 {
            assert_eq!(line.handle_frame(&to(id, &read_pdu(0x04, 0, 1)), &mut units), EndOfFrame::Silent);
        }
        // Restart communications through another unit: all answer again.
        line.handle_frame(&to(8, &[0x08, 0x00, 0x01, 0x00, 0x00]), &mut units);
        assert!(!line.is_listen_only());
        assert!(read_input(&mut line, &mut units, 6, 0).is_some());
    }
}

#[cfg(feature = "tcp")]
mod tcp {
    use super::*;
    use avr_modbus::internal::tcp::respond;

    /// The MBAP header for unit `unit` and `pdu`, then the PDU: the reply ADU's PDU and
    /// whether it is an exception.
    fn over_tcp<M: DataModel>(model: &mut M, unit: u8, pdu: &[u8]) -> (Vec<u8>, bool) {
        let mut adu = vec![0x00, 0x01, 0x00, 0x00, 0x00, pdu.len() as u8 + 1, unit];
        adu.extend_from_slice(pdu);
        adu.resize(260, 0);
        let (len, exception) = respond(&mut adu, pdu.len(), model).unwrap();
        (adu[7..7 + len].to_vec(), exception)
    }

    #[test]
    fn the_unit_id_selects_the_unit() {
        let (mut units, mut windows) = (units(), windows());
        for id in 5..=8 {
            let value = 100 + u16::from(id);
            let expected = vec![0x04, 0x02, (value >> 8) as u8, value as u8];
            assert_eq!(over_tcp(&mut units, id, &read_pdu(0x04, 0, 1)), (expected.clone(), false));
            assert_eq!(over_tcp(&mut windows, id, &read_pdu(0x04, 0, 1)), (expected, false));
        }
    }

    #[test]
    fn unit_0_writes_every_unit_and_reads_none() {
        let mut units = units();
        assert_eq!(over_tcp(&mut units, 0, &write_pdu(1, 5)), (write_pdu(1, 5), false));
        for id in 5..=8 {
            assert_eq!(units.get(id, 40002), Ok(5), "id {id}");
            assert_eq!(units.unit(id).unwrap().master_writes(), 1, "id {id}");
        }
        assert_eq!(over_tcp(&mut units, 0, &read_pdu(0x04, 0, 1)), (vec![0x84, 0x0B], true));
    }

    #[test]
    fn a_unit_id_the_model_does_not_answer_is_exception_0b() {
        let mut units = units();
        for unit in [1, 4, 9, 0xFF] {
            assert_eq!(over_tcp(&mut units, unit, &read_pdu(0x04, 0, 1)), (vec![0x84, 0x0B], true), "unit {unit}");
        }
    }
}
