//! Modbus ASCII framing, Modbus over Serial Line v1.02 §2.5.2 (feature `ascii`): the LRC,
//! the characters of a frame, every way a frame is dropped and how it is counted, and the
//! same answers as RTU for every request.

mod common;

use avr_modbus::internal::ascii::{encoded_char, encoded_len, hex_digit, hex_value, lrc, MAX_CHARS};
use avr_modbus::internal::{EndOfFrame, Engine, FrameError, UartError};
use avr_modbus::{Config, Mode, Parity, SlaveCounters, SlaveId, StopBits};
use common::{read_pdu, spec_bank, write_multiple_pdu, TestBank, ID};
use proptest::prelude::*;

/// The LRC as §2.5.2.2 defines it, written independently: the sum in a wide integer,
/// kept to 8 bits, negated.
fn reference_lrc(bytes: &[u8]) -> u8 {
    let sum: u32 = bytes.iter().map(|&b| u32::from(b)).sum();
    ((256 - (sum % 256)) % 256) as u8
}

/// The ASCII frame of `bytes` (address and PDU) with its LRC, upper-case hex, as a master
/// sends it.
fn ascii_frame(bytes: &[u8]) -> Vec<u8> {
    let mut text = String::from(":");
    for b in bytes.iter().copied().chain([reference_lrc(bytes)]) {
        text.push_str(&format!("{b:02X}"));
    }
    text.push_str("\r\n");
    text.into_bytes()
}

/// An ASCII request to [`ID`] carrying `pdu`.
fn to_slave(pdu: &[u8]) -> Vec<u8> {
    let mut bytes = vec![ID];
    bytes.extend_from_slice(pdu);
    ascii_frame(&bytes)
}

/// The slave under test in ASCII mode.
fn ascii_slave() -> Engine {
    let mut slave: Engine = Engine::new(SlaveId::new(ID));
    slave.set_ascii(true);
    slave
}

/// Feeds `chars` one by one, handling each frame where it ends; returns the end of the
/// last frame and the reply's characters (empty when there is none).
fn feed(slave: &mut Engine, bank: &mut TestBank, chars: &[u8]) -> (EndOfFrame, Vec<u8>) {
    let end = slave.handle_frame(chars, bank);
    let reply = slave.reply();
    let text = if end == EndOfFrame::Reply {
        (0..encoded_len(reply.len())).map(|i| encoded_char(reply, i)).collect()
    } else {
        Vec::new()
    };
    (end, text)
}

fn counters_of(slave: &Engine) -> SlaveCounters {
    slave.counters()
}

#[test]
fn lrc_of_the_specs_example_is_f2() {
    // §2.5.2.2 / the MODBUS.md example: 01 03 00 00 00 0A sums to 0x0E.
    assert_eq!(lrc(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]), 0xF2);
    assert_eq!(ascii_frame(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]), b":01030000000AF2\r\n");
}

#[test]
fn lrc_matches_the_definition_for_many_frames() {
    let mut seed = 0x1234_5678u32;
    for len in 0..300 {
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (seed >> 16) as u8
            })
            .collect();
        assert_eq!(lrc(&bytes), reference_lrc(&bytes), "{bytes:02X?}");
        // A frame with its LRC sums to 0.
        let mut sealed = bytes.clone();
        sealed.push(lrc(&bytes));
        assert_eq!(sealed.iter().fold(0u8, |s, &b| s.wrapping_add(b)), 0);
    }
    assert_eq!(lrc(&[]), 0);
    assert_eq!(lrc(&[0xFF, 0x01]), 0);
    assert_eq!(lrc(&[0x80]), 0x80);
}

#[test]
fn hex_digits_are_read_in_either_case_and_written_in_upper_case() {
    for n in 0..16u8 {
        let upper = hex_digit(n);
        assert_eq!(upper, format!("{n:X}").as_bytes()[0]);
        assert_eq!(hex_value(upper), Some(n));
        assert_eq!(hex_value(upper.to_ascii_lowercase()), Some(n));
    }
    for c in (0..=255u8).filter(|c| !c.is_ascii_hexdigit()) {
        assert_eq!(hex_value(c), None, "{c:#04x}");
    }
}

#[test]
fn encoded_frame_is_colon_hex_pairs_cr_lf() {
    let frame = [0x11, 0x03, 0x06, 0xAE, 0x41, 0x56, 0x52, 0x43, 0x40, 0x49];
    let text: Vec<u8> = (0..encoded_len(frame.len())).map(|i| encoded_char(&frame, i)).collect();
    assert_eq!(text, b":110306AE415652434049\r\n");
    assert_eq!(encoded_len(255), MAX_CHARS as usize);
}

#[test]
fn ascii_config_has_seven_data_bits_and_a_one_second_timeout() {
    const C: Config = Config::ascii(1, 9600, Parity::Even, StopBits::One);
    assert_eq!((C.mode(), C.line().data_bits(), C.line().bits_per_char()), (Mode::Ascii, 7, 10));
    assert_eq!(C.line().char_timeout_ms(), 1000);
    assert_eq!(C.with_mode(Mode::Ascii8).line().bits_per_char(), 11);
    // 7N2, the spec's format without parity.
    let run_time = Config::try_new(1, 9600, Parity::None, StopBits::Two).unwrap().with_mode(Mode::Ascii);
    assert_eq!(run_time.line().bits_per_char(), 10);
    assert_eq!(C.with_char_timeout(250).line().char_timeout_ms(), 250);
    assert_eq!(Config::new(1, 9600, Parity::Even, StopBits::One).mode(), Mode::Rtu);
}

#[test]
fn a_read_is_answered_in_ascii() {
    // §6.3's example: read holding registers 108–110 (40108–40110): 022B 0000 0064.
    let (end, reply) = feed(&mut ascii_slave(), &mut spec_bank(), &to_slave(&read_pdu(0x03, 107, 3)));
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, ascii_frame(&[ID, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64]));
}

#[test]
fn lower_case_hex_is_accepted() {
    let frame = String::from_utf8(to_slave(&read_pdu(0x03, 107, 3))).unwrap().to_ascii_lowercase();
    let (end, reply) = feed(&mut ascii_slave(), &mut spec_bank(), frame.as_bytes());
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, ascii_frame(&[ID, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64]));
}

#[test]
fn characters_before_the_colon_are_ignored() {
    let mut chars = b"\r\n garbage 0123 \n".to_vec();
    chars.extend(to_slave(&read_pdu(0x03, 107, 1)));
    let mut slave = ascii_slave();
    let (end, _) = feed(&mut slave, &mut spec_bank(), &chars);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(counters_of(&slave).frames, 1);
}

#[test]
fn a_colon_inside_a_frame_drops_it_and_starts_the_next() {
    let mut chars = b":1103006B".to_vec();
    chars.extend(to_slave(&read_pdu(0x03, 107, 1)));
    let mut slave = ascii_slave();
    let (end, reply) = feed(&mut slave, &mut spec_bank(), &chars);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, ascii_frame(&[ID, 0x03, 0x02, 0x02, 0x2B]));
    let c = counters_of(&slave);
    assert_eq!((c.frames, c.malformed, c.messages), (2, 1, 1));
}

/// Feeds `chars` and checks that the frame is dropped for `error`, counted in the
/// counter `counted` picks, and that the next good frame is answered.
fn dropped(chars: &[u8], error: FrameError, counted: fn(&SlaveCounters) -> u16) {
    let mut slave = ascii_slave();
    let mut bank = spec_bank();
    let (end, reply) = feed(&mut slave, &mut bank, chars);
    assert_eq!(end, EndOfFrame::Dropped(error), "{:?}", String::from_utf8_lossy(chars));
    assert!(reply.is_empty());
    let c = counters_of(&slave);
    assert_eq!((c.frames, counted(&c), c.messages, c.replies), (1, 1, 0, 0), "{c:?}");
    let (end, _) = feed(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 107, 1)));
    assert_eq!(end, EndOfFrame::Reply, "the next frame is answered");
}

#[test]
fn a_bad_lrc_is_dropped_as_a_crc_error() {
    let mut chars = to_slave(&read_pdu(0x03, 107, 1));
    let n = chars.len();
    chars[n - 3] = if chars[n - 3] == b'0' { b'1' } else { b'0' };
    dropped(&chars, FrameError::BadCrc, |c| c.crc_errors);
}

#[test]
fn a_character_that_is_not_hex_drops_the_frame_as_encoding() {
    dropped(b":1103006G0001\r\n", FrameError::Encoding, |c| c.malformed);
}

#[test]
fn an_odd_hex_count_drops_the_frame_as_encoding() {
    let mut chars = to_slave(&read_pdu(0x03, 107, 1));
    chars.remove(3);
    dropped(&chars, FrameError::Encoding, |c| c.malformed);
}

#[test]
fn anything_but_lf_after_cr_drops_the_frame_as_encoding() {
    let mut chars = to_slave(&read_pdu(0x03, 107, 1));
    let n = chars.len();
    chars[n - 1] = b'\r';
    chars.extend(b"\n");
    dropped(&chars, FrameError::Encoding, |c| c.malformed);
}

#[test]
fn fewer_than_three_bytes_is_too_short() {
    // Address and function code, no LRC.
    dropped(b":1103\r\n", FrameError::TooShort, |c| c.malformed);
    dropped(b":\r\n", FrameError::TooShort, |c| c.malformed);
}

#[test]
fn frame_of_513_characters_is_received_and_514_is_too_long() {
    // 513 characters: 255 bytes. FC 16 with 123 registers is 252 bytes of PDU: address,
    // PDU and LRC make 254, so one more data byte (a wrong byte count: exception 03).
    let values = vec![0u8; 247];
    let mut pdu = write_multiple_pdu(0x10, 0, 123, &values[..246]);
    pdu.push(0);
    let chars = to_slave(&pdu);
    assert_eq!(chars.len(), 513);
    let mut slave = ascii_slave();
    let (end, reply) = feed(&mut slave, &mut spec_bank(), &chars);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, ascii_frame(&[ID, 0x90, 0x03]));
    // One more hex pair: 515 characters, dropped before it ends.
    let mut long = chars[..chars.len() - 4].to_vec();
    long.extend(b"00");
    long.extend(&chars[chars.len() - 4..]);
    dropped(&long, FrameError::TooLong, |c| c.overruns);
    // Its 256th byte (the 513th character) breaks it; the LF after reports it at once.
    let mut framer = avr_modbus::internal::Framer::<256>::new();
    framer.set_ascii(true);
    let due: Vec<usize> = (0..long.len()).filter(|&i| framer.on_char(long[i])).collect();
    assert_eq!(due, [514]);
    assert_eq!(framer.on_end_deadline(), Some(Err(FrameError::TooLong)));
}

#[test]
fn bytes_past_a_small_buffer_are_counted_in_the_frame_s_length() {
    // 40 bytes and the LRC into a 16-byte buffer: the first 16 kept, the frame's length
    // (counted as an RTU frame's: the bytes and one) all 41 and one.
    let mut sealed: Vec<u8> = (1..=40).collect();
    sealed.push(lrc(&sealed));
    let mut framer = avr_modbus::internal::Framer::<16>::new();
    framer.set_ascii(true);
    let due = (0..encoded_len(sealed.len())).filter(|&i| framer.on_char(encoded_char(&sealed, i))).count();
    assert_eq!(due, 1);
    assert_eq!(framer.on_end_deadline(), Some(Ok(sealed.len() + 1)));
    assert_eq!(&framer.buffer()[..16], &sealed[..16]);
}

#[test]
fn the_inter_character_timeout_drops_a_frame_in_progress() {
    let mut slave = ascii_slave();
    let mut bank = spec_bank();
    for &c in b":1103006B" {
        assert!(!slave.on_char(c));
    }
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Gap));
    assert_eq!(counters_of(&slave).malformed, 1);
    // Outside a frame, silence is nothing.
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing);
    let (end, _) = feed(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 107, 1)));
    assert_eq!(end, EndOfFrame::Reply);
}

#[test]
fn a_frame_broken_before_the_timeout_is_counted_for_its_first_fault() {
    // As in RTU: a damaged character, then silence, is a UART error, not a gap.
    let mut slave = ascii_slave();
    for &c in b":1103" {
        slave.on_char(c);
    }
    slave.on_error(UartError::Parity);
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Uart));
    let c = counters_of(&slave);
    assert_eq!((c.frames, c.uart_errors, c.malformed), (1, 1, 0));
    // A frame that ran past 255 bytes, then silence: too long, an overrun.
    let mut chars = vec![b':'];
    chars.extend([b'0'; 2 * 256]);
    for &c in &chars {
        slave.on_char(c);
    }
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::TooLong));
    let c = counters_of(&slave);
    assert_eq!((c.frames, c.overruns, c.malformed), (2, 1, 0));
    // A character that is not a hex digit, then silence: encoding.
    for &c in b":11G" {
        slave.on_char(c);
    }
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Encoding));
    assert_eq!(counters_of(&slave).malformed, 1);
}

#[test]
fn a_damaged_character_drops_its_frame_and_noise_between_frames_is_ignored() {
    let mut slave = ascii_slave();
    let mut bank = spec_bank();
    slave.on_error(UartError::Framing);
    slave.on_gap_deadline();
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Nothing, "no frame: nothing counted");
    for &c in b":110300" {
        slave.on_char(c);
    }
    slave.on_error(UartError::Parity);
    let mut ended = false;
    for &c in b"6B0001\r\n" {
        ended |= slave.on_char(c);
    }
    assert!(ended, "the broken frame ends at its LF");
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Dropped(FrameError::Uart));
    assert_eq!(counters_of(&slave).uart_errors, 1);
    let (end, _) = feed(&mut slave, &mut bank, &to_slave(&read_pdu(0x03, 107, 1)));
    assert_eq!(end, EndOfFrame::Reply);
}

#[test]
fn a_frame_for_another_slave_and_a_broadcast_get_no_reply() {
    let mut slave = ascii_slave();
    let mut bank = spec_bank();
    let (end, reply) = feed(&mut slave, &mut bank, &ascii_frame(&[0x12, 0x03, 0x00, 0x6B, 0x00, 0x01]));
    assert_eq!((end, reply.len()), (EndOfFrame::OtherSlave, 0));
    // Broadcast FC 6: executed, not answered.
    let (end, reply) = feed(&mut slave, &mut bank, &ascii_frame(&[0x00, 0x06, 0x00, 0x6B, 0x12, 0x34]));
    assert_eq!((end, reply.len()), (EndOfFrame::Broadcast, 0));
    assert_eq!(bank.get(40108), Ok(0x1234));
}

#[test]
fn characters_while_a_frame_waits_for_processing_are_ignored() {
    let mut slave = ascii_slave();
    let mut bank = spec_bank();
    let chars = to_slave(&read_pdu(0x03, 107, 1));
    let mut due = false;
    for &c in &chars {
        due |= slave.on_char(c);
    }
    assert!(due);
    // The next frame starts before this one was processed: ignored, the master waits.
    for &c in &to_slave(&read_pdu(0x03, 108, 1)) {
        assert!(!slave.on_char(c));
    }
    assert_eq!(slave.on_end_deadline(), EndOfFrame::Reply);
    assert!(slave.process(&mut bank) > 0);
    assert_eq!(slave.reply(), &[ID, 0x03, 0x02, 0x02, 0x2B, lrc(&[ID, 0x03, 0x02, 0x02, 0x2B])]);
}

/// How a slave ended a frame, its reply without the check, and its counters.
type Outcome = (EndOfFrame, Vec<u8>, SlaveCounters);

/// The RTU slave's reply to `pdu` without its CRC, and the ASCII slave's without its LRC,
/// and their counters: ASCII answers every request as RTU does.
fn both_modes(pdu: &[u8], address: u8) -> (Outcome, Outcome) {
    let mut frame = vec![address];
    frame.extend_from_slice(pdu);
    let mut rtu: Engine = Engine::new(SlaveId::new(ID));
    let mut rtu_bank = spec_bank();
    let rtu_end = rtu.handle_frame(&common::with_crc(&frame), &mut rtu_bank);
    let rtu_reply = rtu.reply().get(..rtu.reply().len().saturating_sub(2)).unwrap_or(&[]).to_vec();
    let mut ascii = ascii_slave();
    let mut ascii_bank = spec_bank();
    let ascii_end = ascii.handle_frame(&ascii_frame(&frame), &mut ascii_bank);
    let ascii_reply = ascii.reply().get(..ascii.reply().len().saturating_sub(1)).unwrap_or(&[]).to_vec();
    assert_eq!(
        common::snapshot(&rtu_bank, avr_modbus::Table::HoldingRegisters, 0, 120),
        common::snapshot(&ascii_bank, avr_modbus::Table::HoldingRegisters, 0, 120)
    );
    assert_eq!(
        common::snapshot(&rtu_bank, avr_modbus::Table::Coils, 0, 200),
        common::snapshot(&ascii_bank, avr_modbus::Table::Coils, 0, 200)
    );
    ((rtu_end, rtu_reply, rtu.counters()), (ascii_end, ascii_reply, ascii.counters()))
}

#[test]
fn every_function_code_and_exception_is_answered_as_in_rtu() {
    let requests: Vec<Vec<u8>> = vec![
        read_pdu(0x01, 19, 19),
        read_pdu(0x02, 196, 22),
        read_pdu(0x03, 107, 3),
        read_pdu(0x04, 8, 1),
        vec![0x05, 0x00, 0xAC, 0xFF, 0x00],
        vec![0x06, 0x00, 0x01, 0x00, 0x03],
        write_multiple_pdu(0x0F, 19, 10, &[0xCD, 0x01]),
        write_multiple_pdu(0x10, 0, 2, &[0x00, 0x0A, 0x01, 0x02]),
        read_pdu(0x03, 3, 1),               // 02
        read_pdu(0x03, 0, 126),             // 03
        vec![0x41],                         // 01
        vec![0x05, 0x00, 0xAC, 0x12, 0x34], // 03
    ];
    for pdu in &requests {
        for address in [ID, 0] {
            let (rtu, ascii) = both_modes(pdu, address);
            assert_eq!(rtu, ascii, "PDU {pdu:02X?} to {address}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Any request, well formed or not, gets the same answer and the same counts in ASCII
    /// as in RTU.
    #[test]
    fn any_request_is_answered_as_in_rtu(
        code in prop::sample::select(vec![1u8, 2, 3, 4, 5, 6, 15, 16, 7, 8, 0x2B, 0x41]),
        body in prop::collection::vec(any::<u8>(), 0..24),
        address in prop::sample::select(vec![ID, 0, 0x12]),
    ) {
        let mut pdu = vec![code];
        pdu.extend(body);
        let (rtu, ascii) = both_modes(&pdu, address);
        prop_assert_eq!(rtu, ascii);
    }

    /// A frame of any bytes, given its LRC and written out, is received as it was: and a
    /// character changed anywhere drops it, or makes another frame that is itself whole.
    #[test]
    fn frames_survive_the_round_trip_and_a_changed_character_is_caught(
        bytes in prop::collection::vec(any::<u8>(), 2..=254),
        at in any::<prop::sample::Index>(),
        to in any::<u8>(),
    ) {
        let mut sealed = bytes.clone();
        sealed.push(lrc(&bytes));
        let text: Vec<u8> = (0..encoded_len(sealed.len())).map(|i| encoded_char(&sealed, i)).collect();
        prop_assert_eq!(&text, &ascii_frame(&bytes));
        let mut framer = avr_modbus::internal::Framer::<256>::new();
        framer.set_ascii(true);
        let due = text.iter().map(|&c| framer.on_char(c)).filter(|&d| d).count();
        prop_assert_eq!(due, 1);
        prop_assert_eq!(framer.on_end_deadline(), Some(Ok(sealed.len() + 1)));
        prop_assert_eq!(&framer.buffer()[..sealed.len()], &sealed[..]);

        let i = 1 + at.index(text.len() - 3);
        let mut changed = text.clone();
        prop_assume!(changed[i] != to && !(changed[i].is_ascii_hexdigit() && to.is_ascii_hexdigit() && changed[i].eq_ignore_ascii_case(&to)));
        changed[i] = to;
        let mut framer = avr_modbus::internal::Framer::<256>::new();
        framer.set_ascii(true);
        let mut outcome = None;
        for &c in &changed {
            if framer.on_char(c) {
                outcome = framer.on_end_deadline();
                if let Some(Ok(_)) = outcome {
                    framer.release();
                }
            }
        }
        match outcome {
            Some(Err(_)) => {}
            // A `:` put in starts a new frame from there, whose LRC rarely checks; one that
            // does is a whole frame of its own, never the old one changed.
            Some(Ok(len)) => prop_assert!(to == b':' && len - 1 < sealed.len()),
            None => prop_assert!(false, "no outcome for {:?}", String::from_utf8_lossy(&changed)),
        }
    }
}
