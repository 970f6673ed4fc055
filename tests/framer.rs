//! RTU framing by silence, driven through the slave's event methods the way the USART and
//! Timer0 interrupts drive it (Serial Line v1.02 §2.5.1.1, figure 14): power-up wait,
//! inter-character gaps, UART errors, and the busy time while a reply is pending.

mod common;

use avr_modbus::internal::{EndOfFrame, Engine, FrameError, Framer, UartError};
use common::{spec_bank, to_slave, with_crc, TestBank, ID};

/// A read of holding registers 40001–40002: answered `ID 03 04 00 00 00 00 CRC`.
fn read_request() -> Vec<u8> {
    with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo: 0
        0x00, // quantity hi
        0x02, // quantity lo: 2
    ])
}

fn read_reply() -> Vec<u8> {
    with_crc(&[
        ID,   // slave address
        0x03, // function
        0x04, // byte count
        0x00, // register 40001 hi
        0x00, // register 40001 lo
        0x00, // register 40002 hi
        0x00, // register 40002 lo
    ])
}

fn feed(slave: &mut Engine, bytes: &[u8]) {
    for &byte in bytes {
        slave.on_byte(byte);
    }
}

/// A slave past its power-up wait.
fn listening_slave() -> Engine {
    let mut slave = common::slave();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    slave
}

/// Processes a frame the slave accepted and returns the reply, then releases the buffer.
fn answer(slave: &mut Engine, bank: &mut TestBank) -> Vec<u8> {
    let len = slave.process(bank);
    let reply = slave.reply().to_vec();
    assert_eq!(len, reply.len());
    slave.on_reply_sent();
    reply
}

/// The next good frame is answered normally.
fn next_frame_is_answered(slave: &mut Engine) {
    let mut bank = spec_bank();
    feed(slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    assert_eq!(answer(slave, &mut bank), read_reply());
}

// ---- power-up -------------------------------------------------------------------------

#[test]
fn a_frame_received_before_the_power_up_silence_is_ignored() {
    let mut slave = common::slave();
    feed(&mut slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    assert_eq!(slave.counters().frames, 0);
    assert!(slave.reply().is_empty());
}

#[test]
fn the_first_frame_after_the_power_up_silence_is_answered() {
    let mut slave = common::slave();
    feed(&mut slave, &[0x55, 0xAA]);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    next_frame_is_answered(&mut slave);
}

#[test]
fn uart_errors_before_the_power_up_silence_are_not_counted() {
    let mut slave = common::slave();
    slave.on_error(UartError::Framing);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    assert_eq!(slave.counters().uart_errors, 0);
    next_frame_is_answered(&mut slave);
}

#[test]
fn a_slave_that_never_saw_silence_never_answers() {
    let mut slave = common::slave();
    for _ in 0..3 {
        feed(&mut slave, &read_request());
        slave.on_gap_deadline();
    }
    assert!(slave.reply().is_empty());
    assert_eq!(slave.counters().frames, 0);
}

// ---- silence ends the frame, gaps break it ------------------------------------------------

#[test]
fn end_deadline_without_bytes_is_nothing() {
    let mut slave = listening_slave();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    assert_eq!(slave.counters().frames, 0);
}

#[test]
fn gap_deadline_after_the_last_byte_does_not_harm_the_frame() {
    let mut slave = listening_slave();
    feed(&mut slave, &read_request());
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    assert_eq!(answer(&mut slave, &mut spec_bank()), read_reply());
}

#[test]
fn a_byte_after_the_gap_deadline_breaks_the_frame() {
    let mut slave = listening_slave();
    let request = read_request();
    feed(&mut slave, &request[..3]);
    slave.on_gap_deadline();
    feed(&mut slave, &request[3..]);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Gap));
    assert!(slave.reply().is_empty());
}

#[test]
fn a_gap_is_counted_as_malformed() {
    let mut slave = listening_slave();
    let request = read_request();
    feed(&mut slave, &request[..7]);
    slave.on_gap_deadline();
    feed(&mut slave, &request[7..]);
    slave.on_end_deadline();
    let counters = slave.counters();
    assert_eq!((counters.frames, counters.malformed, counters.messages), (1, 1, 0));
}

#[test]
fn the_frame_after_a_gap_is_answered() {
    let mut slave = listening_slave();
    feed(&mut slave, &[ID, 0x03]);
    slave.on_gap_deadline();
    feed(&mut slave, &[0x00]);
    slave.on_end_deadline();
    next_frame_is_answered(&mut slave);
}

#[test]
fn two_frames_without_silence_between_them_are_one_bad_frame() {
    let mut slave = listening_slave();
    feed(&mut slave, &read_request());
    feed(&mut slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::BadCrc));
}

#[test]
fn a_frame_split_by_an_end_deadline_is_two_short_frames() {
    let mut slave = listening_slave();
    let request = read_request();
    feed(&mut slave, &request[..2]);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::TooShort));
    feed(&mut slave, &request[2..]);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::BadCrc));
}

// ---- UART errors ------------------------------------------------------------------------

fn damaged_at(position: usize, error: UartError) -> (EndOfFrame, Engine) {
    let mut slave = listening_slave();
    let request = read_request();
    feed(&mut slave, &request[..position]);
    slave.on_error(error);
    feed(&mut slave, &request[position..]);
    (slave.on_end_deadline(), slave)
}

#[test]
fn a_parity_error_drops_the_frame_and_counts_a_uart_error() {
    let (end, slave) = damaged_at(3, UartError::Parity);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::Uart));
    assert_eq!((slave.counters().uart_errors, slave.counters().overruns), (1, 0));
    assert!(slave.reply().is_empty());
}

#[test]
fn a_framing_error_drops_the_frame_and_counts_a_uart_error() {
    let (end, slave) = damaged_at(5, UartError::Framing);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::Uart));
    assert_eq!((slave.counters().uart_errors, slave.counters().overruns), (1, 0));
}

#[test]
fn an_overrun_drops_the_frame_and_counts_an_overrun() {
    let (end, slave) = damaged_at(4, UartError::Overrun);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::Overrun));
    assert_eq!((slave.counters().uart_errors, slave.counters().overruns), (0, 1));
}

#[test]
fn a_damaged_first_character_drops_the_frame() {
    let (end, _) = damaged_at(0, UartError::Parity);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::Uart));
}

#[test]
fn a_damaged_last_character_drops_the_frame() {
    let (end, _) = damaged_at(8, UartError::Framing);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::Uart));
}

#[test]
fn the_frame_after_a_uart_error_is_answered() {
    for error in [UartError::Parity, UartError::Framing, UartError::Overrun] {
        let (_, mut slave) = damaged_at(2, error);
        next_frame_is_answered(&mut slave);
    }
}

#[test]
fn a_uart_error_after_a_gap_still_counts_as_a_uart_error() {
    let mut slave = listening_slave();
    feed(&mut slave, &[ID, 0x03, 0x00]);
    slave.on_gap_deadline();
    slave.on_error(UartError::Parity);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Uart));
}

// ---- frame length -----------------------------------------------------------------------

#[test]
fn a_frame_of_257_bytes_is_dropped_as_too_long_and_counted_as_overrun() {
    let mut slave = listening_slave();
    feed(&mut slave, &[0x11; 257]);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::TooLong));
    assert_eq!(slave.counters().overruns, 1);
    next_frame_is_answered(&mut slave);
}

#[test]
fn a_frame_of_3_bytes_is_dropped_as_too_short_and_counted_as_malformed() {
    let mut slave = listening_slave();
    feed(&mut slave, &with_crc(&[ID]));
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::TooShort));
    assert_eq!(slave.counters().malformed, 1);
}

// ---- busy while a reply is pending --------------------------------------------------------

#[test]
fn bytes_while_a_reply_is_pending_are_ignored() {
    let mut slave = listening_slave();
    let mut bank = spec_bank();
    feed(&mut slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    slave.process(&mut bank);
    feed(&mut slave, &to_slave(&[0x06, 0x00, 0x00, 0x12, 0x34]));
    slave.on_error(UartError::Overrun);
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    assert_eq!(slave.reply(), read_reply(), "the reply being sent is untouched");
    assert_eq!(bank.get(40001), Ok(0));
    assert_eq!(slave.counters().overruns, 0);
}

#[test]
fn bytes_between_the_end_of_a_frame_and_processing_are_ignored() {
    let mut slave = listening_slave();
    feed(&mut slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    feed(&mut slave, &[0xFF; 300]);
    assert_eq!(answer(&mut slave, &mut spec_bank()), read_reply());
}

#[test]
fn reply_sent_returns_to_idle_and_the_next_frame_is_answered() {
    let mut slave = listening_slave();
    next_frame_is_answered(&mut slave);
    assert!(slave.reply().is_empty());
    next_frame_is_answered(&mut slave);
    assert_eq!(slave.counters().replies, 2);
}

#[test]
fn process_without_an_accepted_frame_does_nothing() {
    let mut slave = listening_slave();
    let mut bank = spec_bank();
    assert_eq!(slave.process(&mut bank), 0);
    feed(&mut slave, &read_request());
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    assert_eq!(slave.process(&mut bank), read_reply().len());
    assert_eq!(slave.process(&mut bank), 0, "a frame is processed once");
    assert_eq!(slave.counters().replies, 1);
}

#[test]
fn a_broadcast_releases_the_buffer_when_processed() {
    let mut slave = listening_slave();
    let mut bank = spec_bank();
    feed(&mut slave, &with_crc(&[0x00, 0x06, 0x00, 0x00, 0x12, 0x34]));
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Broadcast);
    assert_eq!(slave.process(&mut bank), 0);
    assert_eq!(bank.get(40001), Ok(0x1234));
    next_frame_is_answered(&mut slave);
}

#[test]
fn a_frame_for_another_slave_releases_the_buffer_at_once() {
    let mut slave = listening_slave();
    feed(&mut slave, &with_crc(&[ID + 1, 0x03, 0x00, 0x00, 0x00, 0x01]));
    assert_eq!(slave.on_end_deadline(), EndOfFrame::OtherSlave);
    next_frame_is_answered(&mut slave);
}

// ---- the framer on its own ----------------------------------------------------------------

#[test]
fn framer_hands_out_a_good_frame_with_its_length_and_bytes() {
    let mut framer: Framer = Framer::new();
    assert_eq!(framer.on_end_deadline(), None);
    let request = read_request();
    for &byte in &request {
        framer.on_byte(byte);
    }
    assert_eq!(framer.on_end_deadline(), Some(Ok(8)));
    assert!(framer.is_busy());
    assert_eq!(&framer.buffer()[..8], &request[..]);
    framer.release();
    assert!(!framer.is_busy());
}

#[test]
fn framer_accepts_exactly_256_bytes() {
    let mut framer: Framer = Framer::new();
    framer.on_end_deadline();
    let mut frame = vec![0x2Bu8; 254];
    frame[0] = ID;
    let frame = with_crc(&frame);
    assert_eq!(frame.len(), 256);
    for &byte in &frame {
        framer.on_byte(byte);
    }
    assert_eq!(framer.on_end_deadline(), Some(Ok(256)));
}

#[test]
fn framer_refuses_257_bytes_even_with_a_correct_crc() {
    let mut framer: Framer = Framer::new();
    framer.on_end_deadline();
    let mut frame = vec![0x2Bu8; 255];
    frame[0] = ID;
    for &byte in &with_crc(&frame) {
        framer.on_byte(byte);
    }
    assert_eq!(framer.on_end_deadline(), Some(Err(FrameError::TooLong)));
}

#[test]
fn a_frame_released_before_processing_is_never_processed_later() {
    let mut slave = listening_slave();
    let mut bank = spec_bank();
    feed(&mut slave, &to_slave(&[0x06, 0x00, 0x00, 0x12, 0x34]));
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    slave.on_reply_sent(); // the application gave up on this frame
    feed(&mut slave, &[ID, 0x06, 0x00]); // the next frame is arriving
    assert_eq!(slave.process(&mut bank), 0);
    assert_eq!(bank.get(40001), Ok(0));
    assert!(slave.reply().is_empty());
}

// ---- the CRC, checked once the frame has ended --------------------------------------------

#[test]
fn a_bad_crc_found_at_the_gap_deadline_drops_the_frame_at_t35() {
    let mut slave = listening_slave();
    let mut request = read_request();
    request[7] ^= 0x01; // CRC hi, one bit off
    feed(&mut slave, &request);
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::BadCrc));
    assert_eq!(slave.counters().crc_errors, 1);
    next_frame_is_answered(&mut slave);
}

#[test]
fn a_bad_crc_is_found_at_t35_when_no_gap_deadline_came() {
    let mut slave = listening_slave();
    let mut request = read_request();
    request[6] ^= 0x80; // CRC lo, one bit off
    feed(&mut slave, &request);
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::BadCrc));
    next_frame_is_answered(&mut slave);
}

#[test]
fn a_second_gap_deadline_keeps_the_crc_found_at_the_first() {
    let mut framer: Framer = Framer::new();
    framer.on_end_deadline();
    for &byte in &read_request() {
        framer.on_byte(byte);
    }
    framer.on_gap_deadline();
    framer.on_gap_deadline();
    assert_eq!(framer.on_end_deadline(), Some(Ok(8)));
}

#[test]
fn framer_accepts_exactly_256_bytes_checked_at_the_gap_deadline() {
    let mut framer: Framer = Framer::new();
    framer.on_end_deadline();
    let mut frame = vec![0x2Bu8; 254];
    frame[0] = ID;
    let frame = with_crc(&frame);
    for &byte in &frame {
        framer.on_byte(byte);
    }
    framer.on_gap_deadline();
    assert_eq!(framer.on_end_deadline(), Some(Ok(256)));
    assert_eq!(&framer.buffer()[..], &frame[..]);
}

#[test]
fn a_256_byte_frame_with_a_bad_crc_is_dropped_for_its_crc() {
    let mut framer: Framer = Framer::new();
    framer.on_end_deadline();
    let mut frame = with_crc(&[0x2Bu8; 254]);
    frame[255] ^= 0x10;
    for &byte in &frame {
        framer.on_byte(byte);
    }
    framer.on_gap_deadline();
    assert_eq!(framer.on_end_deadline(), Some(Err(FrameError::BadCrc)));
}
