//! The serial-line ADU, Serial Line v1.02 §2.2–2.5: slave address (broadcast, other
//! slaves), CRC (low byte first), frame length limits and the counters of each outcome.

mod common;

use avr_modbus::internal::{EndOfFrame, FrameError};
use avr_modbus::{Reference, SlaveId, Table};
use common::{ask, exception_reply, reference_crc, slave, snapshot, spec_bank, to_slave, with_crc, ID};

// ---- the CRC used by these tests --------------------------------------------------------

#[test]
fn reference_crc_matches_the_spec_check_values() {
    assert_eq!(with_crc(&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03])[6..], [0x76, 0x87]);
    assert_eq!(with_crc(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x01])[6..], [0x31, 0xCA]);
    assert_eq!(with_crc(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02])[6..], [0x12, 0x98]);
}

#[test]
fn crate_crc_agrees_with_the_reference_crc() {
    let bytes: Vec<u8> = (0..=255u8).collect();
    for len in [0, 1, 2, 7, 100, 256] {
        assert_eq!(avr_modbus::internal::crc16(&bytes[..len]), reference_crc(&bytes[..len]), "{len} bytes");
    }
}

// ---- broadcast --------------------------------------------------------------------------

#[test]
fn broadcast_fc6_is_executed_without_a_reply() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let request = with_crc(&[
        0x00, // broadcast
        0x06, // function: write single register
        0x00, // register address hi
        0x01, // register address lo: 1
        0x12, // value hi
        0x34, // value lo
    ]);
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Broadcast);
    assert!(slave.reply().is_empty());
    assert_eq!(bank.get(40002), Ok(0x1234));
}

#[test]
fn broadcast_fc5_is_executed_without_a_reply() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let request = with_crc(&[
        0x00, // broadcast
        0x05, // function: write single coil
        0x00, // output address hi
        0xAC, // output address lo: 172
        0xFF, // value hi: ON
        0x00, // value lo
    ]);
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Broadcast);
    assert!(slave.reply().is_empty());
    assert_eq!(bank.get(Reference::coil(172)), Ok(1));
}

#[test]
fn broadcast_fc15_is_executed_without_a_reply() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let request = with_crc(&[
        0x00, // broadcast
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x28, // starting address lo: 40
        0x00, // quantity hi
        0x08, // quantity lo: 8
        0x01, // byte count
        0x5A, // coils 40..47
    ]);
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Broadcast);
    assert!(slave.reply().is_empty());
    let coils: Vec<u16> = (40..48).map(|a| bank.get(Reference::coil(a)).unwrap()).collect();
    assert_eq!(coils, [0, 1, 0, 1, 1, 0, 1, 0]);
}

#[test]
fn broadcast_fc16_is_executed_without_a_reply() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let request = with_crc(&[
        0x00, // broadcast
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x00, // starting address lo: 0
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0xAB, // register 0 hi
        0xCD, // register 0 lo
        0x00, // register 1 hi
        0x07, // register 1 lo
    ]);
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Broadcast);
    assert!(slave.reply().is_empty());
    assert_eq!((bank.get(40001), bank.get(40002)), (Ok(0xABCD), Ok(0x0007)));
    assert_eq!(bank.master_writes(), 1);
}

#[test]
fn broadcast_reads_are_ignored_without_a_reply() {
    for function in 1..=4u8 {
        let mut bank = spec_bank();
        let mut slave = slave();
        let request = with_crc(&[
            0x00,     // broadcast
            function, // a read
            0x00,     // starting address hi
            0x00,     // starting address lo
            0x00,     // quantity hi
            0x01,     // quantity lo
        ]);
        assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Broadcast, "FC {function}");
        assert!(slave.reply().is_empty(), "FC {function}");
        assert_eq!(slave.counters().replies, 0);
    }
}

#[test]
fn broadcast_with_an_exception_is_not_answered() {
    let mut bank = spec_bank();
    let mut slave = slave();
    for pdu in [&[0x2Bu8, 0x0E][..], &[0x06, 0x00, 0x03, 0x00, 0x01], &[0x03, 0x00, 0x00, 0x00, 0x00]] {
        let mut frame = vec![0x00];
        frame.extend_from_slice(pdu);
        assert_eq!(slave.handle_frame(&with_crc(&frame), &mut bank), EndOfFrame::Broadcast);
        assert!(slave.reply().is_empty());
    }
    assert_eq!(slave.counters().replies, 0);
}

#[test]
fn broadcast_multi_write_touching_a_hole_changes_nothing() {
    let mut bank = spec_bank();
    let before = snapshot(&bank, Table::HoldingRegisters, 0, 120);
    let request = with_crc(&[
        0x00, // broadcast
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x02, // starting address lo: 2 (3 is a hole)
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0x11, // register 2 hi
        0x11, // register 2 lo
        0x22, // register 3 hi
        0x22, // register 3 lo
    ]);
    assert_eq!(slave().handle_frame(&request, &mut bank), EndOfFrame::Broadcast);
    assert_eq!(snapshot(&bank, Table::HoldingRegisters, 0, 120), before);
}

#[test]
fn broadcasts_are_counted_as_messages_and_broadcasts() {
    let mut bank = spec_bank();
    let mut slave = slave();
    slave.handle_frame(&with_crc(&[0x00, 0x06, 0x00, 0x01, 0x00, 0x01]), &mut bank);
    slave.handle_frame(&with_crc(&[0x00, 0x03, 0x00, 0x01, 0x00, 0x01]), &mut bank);
    let c = slave.counters();
    assert_eq!((c.frames, c.messages, c.broadcasts, c.replies), (2, 2, 2, 0));
}

// ---- other slaves -------------------------------------------------------------------------

#[test]
fn a_frame_for_another_slave_is_not_answered_or_executed() {
    for address in [0x01u8, 0x10, 0x12, 0xF7, 0xF8, 0xFF] {
        let mut bank = spec_bank();
        let mut slave = slave();
        let request = with_crc(&[
            address, // another slave (or a reserved address)
            0x06,    // function: write single register
            0x00,    // register address hi
            0x01,    // register address lo
            0x12,    // value hi
            0x34,    // value lo
        ]);
        assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::OtherSlave, "address {address:#04X}");
        assert!(slave.reply().is_empty());
        assert_eq!(bank.get(40002), Ok(0));
        let c = slave.counters();
        assert_eq!((c.frames, c.messages, c.replies), (1, 0, 0));
    }
}

#[test]
fn every_valid_slave_id_answers_only_its_own_address() {
    for id in [1u8, 2, 100, 246, 247] {
        let mut slave: avr_modbus::internal::Engine = avr_modbus::internal::Engine::new(SlaveId::new(id));
        let mut bank = spec_bank();
        let mine = with_crc(&[id, 0x03, 0x00, 0x00, 0x00, 0x01]);
        let theirs = with_crc(&[id % 247 + 1, 0x03, 0x00, 0x00, 0x00, 0x01]);
        assert_eq!(slave.handle_frame(&theirs, &mut bank), EndOfFrame::OtherSlave, "id {id}");
        assert_eq!(slave.handle_frame(&mine, &mut bank), EndOfFrame::Reply, "id {id}");
        assert_eq!(slave.reply(), with_crc(&[id, 0x03, 0x02, 0x00, 0x00]));
    }
}

// ---- CRC -----------------------------------------------------------------------------

#[test]
fn a_frame_with_a_wrong_crc_is_dropped_and_counted() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let mut request = to_slave(&[0x06, 0x00, 0x01, 0x12, 0x34]);
    request[7] ^= 0x01;
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Dropped(FrameError::BadCrc));
    assert!(slave.reply().is_empty());
    assert_eq!(bank.get(40002), Ok(0));
    let c = slave.counters();
    assert_eq!((c.frames, c.crc_errors, c.messages), (1, 1, 0));
}

#[test]
fn a_crc_sent_high_byte_first_is_wrong() {
    let mut request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x6B, // starting address lo
        0x00, // quantity hi
        0x03, // quantity lo
    ]);
    request.swap(6, 7); // 87 76 instead of 76 87
    assert_eq!(slave().handle_frame(&request, &mut spec_bank()), EndOfFrame::Dropped(FrameError::BadCrc));
}

#[test]
fn a_single_flipped_bit_anywhere_in_the_frame_is_a_crc_error() {
    let request = to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x03]);
    for bit in 0..request.len() * 8 {
        let mut damaged = request.clone();
        damaged[bit / 8] ^= 1 << (bit % 8);
        assert_eq!(
            slave().handle_frame(&damaged, &mut spec_bank()),
            EndOfFrame::Dropped(FrameError::BadCrc),
            "bit {bit}"
        );
    }
}

#[test]
fn a_frame_for_another_slave_with_a_wrong_crc_counts_as_a_crc_error() {
    let mut slave = slave();
    let mut request = with_crc(&[0x05, 0x03, 0x00, 0x00, 0x00, 0x01]);
    request[6] ^= 0xFF;
    assert_eq!(slave.handle_frame(&request, &mut spec_bank()), EndOfFrame::Dropped(FrameError::BadCrc));
    assert_eq!(slave.counters().crc_errors, 1);
}

// ---- length ------------------------------------------------------------------------------

#[test]
fn an_empty_frame_is_nothing() {
    let mut slave = slave();
    assert_eq!(slave.handle_frame(&[], &mut spec_bank()), EndOfFrame::Nothing);
    assert_eq!(slave.counters().frames, 0);
}

#[test]
fn frames_of_1_to_3_bytes_are_too_short_even_with_a_matching_crc() {
    let frames = [vec![ID], vec![ID, 0x03], with_crc(&[ID]), with_crc(&[0x00])];
    for frame in frames {
        let mut slave = slave();
        assert_eq!(
            slave.handle_frame(&frame, &mut spec_bank()),
            EndOfFrame::Dropped(FrameError::TooShort),
            "{frame:02X?}"
        );
        assert_eq!(slave.counters().malformed, 1);
    }
}

#[test]
fn a_4_byte_frame_with_an_unknown_function_is_answered_with_illegal_function() {
    let request = with_crc(&[
        ID,   // slave address
        0x41, // function: not supported
    ]);
    assert_eq!(ask(&mut slave(), &mut spec_bank(), &request), exception_reply(0x41, 0x01));
}

#[test]
fn a_frame_of_exactly_256_bytes_is_answered() {
    // FC 0F for 1969 coils: 247 data bytes, a 253-byte PDU, the longest the ADU allows.
    let mut frame = vec![
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x00, // starting address lo
        0x07, // quantity hi
        0xB1, // quantity lo: 1969 (one too many)
        0xF7, // byte count: 247
    ];
    frame.extend([0xFF; 247]);
    let frame = with_crc(&frame);
    assert_eq!(frame.len(), 256);
    assert_eq!(ask(&mut slave(), &mut spec_bank(), &frame), exception_reply(0x0F, 0x03));
}

#[test]
fn a_frame_of_257_bytes_is_too_long_even_with_a_matching_crc() {
    let mut frame = vec![ID, 0x2B];
    frame.extend([0x00; 253]);
    let frame = with_crc(&frame);
    assert_eq!(frame.len(), 257);
    let mut slave = slave();
    assert_eq!(slave.handle_frame(&frame, &mut spec_bank()), EndOfFrame::Dropped(FrameError::TooLong));
    assert!(slave.reply().is_empty());
    assert_eq!(slave.counters().overruns, 1);
}

#[test]
fn frames_of_300_and_1000_bytes_are_too_long() {
    for len in [300, 1000] {
        let frame = vec![ID; len];
        assert_eq!(slave().handle_frame(&frame, &mut spec_bank()), EndOfFrame::Dropped(FrameError::TooLong), "{len}");
    }
}

#[test]
fn the_longest_read_reply_is_255_bytes() {
    let mut bank = common::full_bank();
    let reply = ask(&mut slave(), &mut bank, &to_slave(&[0x03, 0x00, 0x00, 0x00, 0x7D]));
    assert_eq!(reply.len(), 255);
    assert_eq!(reply, with_crc(&reply[..253]));
}

// ---- counters and recovery ----------------------------------------------------------------

#[test]
fn each_outcome_is_counted_in_its_own_counter() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let good = to_slave(&[0x03, 0x00, 0x00, 0x00, 0x01]);
    let mut bad_crc = good.clone();
    bad_crc[2] ^= 0x40;
    slave.handle_frame(&good, &mut bank); // reply
    slave.handle_frame(&bad_crc, &mut bank); // crc error
    slave.handle_frame(&[ID, 0x03], &mut bank); // too short
    slave.handle_frame(&[0u8; 400], &mut bank); // too long
    slave.handle_frame(&with_crc(&[0x22, 0x03, 0x00, 0x00, 0x00, 0x01]), &mut bank); // other slave
    slave.handle_frame(&with_crc(&[0x00, 0x06, 0x00, 0x00, 0x00, 0x01]), &mut bank); // broadcast
    slave.handle_frame(&to_slave(&[0x41]), &mut bank); // exception reply
    let c = slave.counters();
    assert_eq!(c.frames, 7);
    assert_eq!(c.replies, 2);
    assert_eq!(c.crc_errors, 1);
    assert_eq!(c.malformed, 1);
    assert_eq!(c.overruns, 1);
    assert_eq!(c.uart_errors, 0);
    assert_eq!(c.messages, 3);
    assert_eq!(c.broadcasts, 1);
    assert_eq!(c.exceptions, 1);
}

#[test]
fn after_any_bad_frame_the_next_good_frame_is_answered() {
    let good = to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x03]);
    let expected = to_slave(&[0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64]);
    let mut bad_crc = good.clone();
    bad_crc[3] ^= 0x80;
    let bad_frames = [
        bad_crc,
        vec![ID],
        vec![0xFF; 257],
        with_crc(&[0x33, 0x03, 0x00, 0x6B, 0x00, 0x03]),
        with_crc(&[0x00, 0x03, 0x00, 0x6B, 0x00, 0x03]),
        to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x00]),
        to_slave(&[0x2B]),
    ];
    for bad in bad_frames {
        let mut bank = spec_bank();
        let mut slave = slave();
        slave.handle_frame(&bad, &mut bank);
        assert_eq!(ask(&mut slave, &mut bank, &good), expected, "after {bad:02X?}");
    }
}

#[test]
fn a_reply_is_cleared_by_the_next_frame() {
    let mut bank = spec_bank();
    let mut slave = slave();
    ask(&mut slave, &mut bank, &to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x03]));
    assert_eq!(slave.handle_frame(&[ID, 0x00, 0x00], &mut bank), EndOfFrame::Dropped(FrameError::TooShort));
    assert!(slave.reply().is_empty());
}

#[test]
fn prepare_leaves_the_crc_to_the_sender() {
    let request = to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x03]);
    let (mut full, mut bank_a) = (slave(), spec_bank());
    let (mut lazy, mut bank_b) = (slave(), spec_bank());
    full.handle_frame(&request, &mut bank_a);
    let expected = full.reply().to_vec();
    lazy.on_end_deadline(); // the power-up silence
    for &byte in &request {
        lazy.on_byte(byte);
    }
    assert_eq!(lazy.on_end_deadline(), EndOfFrame::Reply);
    let body = lazy.prepare(&mut bank_b);
    assert_eq!(body, expected.len() - 2);
    assert_eq!(lazy.reply(), &expected[..body]);
    assert_eq!(reference_crc(lazy.reply()).to_le_bytes(), expected[body..]);
}

#[test]
fn bytes_fed_one_by_one_end_at_the_silence_before_a_whole_frame() {
    let mut bank = spec_bank();
    let mut slave = slave();
    let request = to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x03]);
    slave.on_end_deadline(); // the power-up silence
                             // Half a frame on the byte path, then the whole frame in one call: the silence before
                             // it ends the half frame (too short: dropped and counted), and the frame is answered.
    for &byte in &request[..3] {
        slave.on_byte(byte);
    }
    assert_eq!(slave.handle_frame(&request, &mut bank), EndOfFrame::Reply);
    assert_eq!(slave.reply(), with_crc(&[ID, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64]));
    assert_eq!(slave.counters().malformed, 1);
}

#[test]
fn a_whole_frame_fed_byte_by_byte_is_executed_before_the_next_whole_frame() {
    let mut bank = spec_bank();
    let mut slave = slave();
    slave.on_end_deadline(); // the power-up silence
    let write = to_slave(&[0x06, 0x00, 0x6B, 0x12, 0x34]);
    for &byte in &write {
        slave.on_byte(byte);
    }
    let read = to_slave(&[0x03, 0x00, 0x6B, 0x00, 0x01]);
    assert_eq!(slave.handle_frame(&read, &mut bank), EndOfFrame::Reply, "not swallowed");
    assert_eq!(slave.reply(), with_crc(&[ID, 0x03, 0x02, 0x12, 0x34]), "the write came first");
}
