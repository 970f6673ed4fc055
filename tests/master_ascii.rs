//! The master in ASCII framing on the host, Modbus over Serial Line v1.02 §2.5.2: requests
//! written as `:`, hex pairs of address, PDU and LRC, CR LF (the spec's example
//! `:01030000000AF2` CR LF); replies received from `:` to CR LF and checked as RTU replies
//! are (§2.4.1: address, function or its exception form, byte count, echo, length); bad hex,
//! an odd count, a bad LRC or the inter-character timeout drop a frame in silence and count
//! it; a `:` starts a frame over; no T3.5, but no request while a frame is on the line.
//! Last, the property that the ASCII master takes exactly the replies the RTU master takes.

mod ascii_frames;
mod common;

use ascii_frames::ascii;
use avr_modbus::master::internal::{Action, Engine};
use avr_modbus::master::{Failure, MasterCounters, Request, Timeouts};
use avr_modbus::{Exception, FunctionCode};
use common::{with_crc, ID};
use proptest::prelude::*;

/// An ASCII master just after power-up (it needs no silence before its first request).
fn master() -> Engine {
    let mut m = Engine::new();
    m.set_ascii(true);
    m
}

/// The request's characters as they go on the wire.
fn wire<const N: usize>(m: &Engine<N>) -> Vec<u8> {
    (0..m.request_chars()).map(|i| m.request_char(i)).collect()
}

/// `chars` arrive; each frame's outcome is reported when its last character has left the
/// line, as the AVR layer does. Returns the last report's action.
fn deliver<const N: usize>(m: &mut Engine<N>, chars: &[u8]) -> Action {
    let mut action = Action::None;
    for &c in chars {
        if m.on_char(c) {
            action = m.on_end_deadline();
        }
    }
    action
}

/// Starts `request` to `slave`, checks it goes out at once as the characters `expected`,
/// and ends its transmission.
fn send(m: &mut Engine, slave: u8, request: Request, expected: &[u8]) {
    assert_eq!(m.start(slave, &request), Ok(Action::Send), "{request:?}");
    assert_eq!(String::from_utf8_lossy(&wire(m)), String::from_utf8_lossy(expected), "{request:?}");
    m.on_sent(0);
}

/// The outcome's reply data or failure, collected.
fn outcome(m: &mut Engine) -> Option<Result<Vec<u8>, Failure>> {
    let out = m.outcome().map(|r| r.map(|reply| reply.data().to_vec()));
    m.collect();
    out
}

/// FC 3, holding registers 0–1 of [`ID`], and its characters.
const READ_TWO: Request = Request::ReadHoldingRegisters { address: 0, quantity: 2 };

fn read_two() -> Vec<u8> {
    ascii(&[
        ID, 0x03, // slave, function
        0x00, 0x00, // starting address 0
        0x00, 0x02, // quantity 2
    ])
}

/// A good answer to [`READ_TWO`]: 0x1234, 0xABCD.
fn two_values() -> Vec<u8> {
    ascii(&[
        ID, 0x03, // slave, function
        0x04, // byte count
        0x12, 0x34, 0xAB, 0xCD, // two registers
    ])
}

// ---- requests as characters -----------------------------------------------------------

#[test]
fn fc3_request_is_the_spec_example_colon_01030000000af2_cr_lf() {
    let mut m = master();
    send(&mut m, 1, Request::ReadHoldingRegisters { address: 0, quantity: 10 }, b":01030000000AF2\r\n");
    // Address and PDU, then the LRC, before they are written out in hex.
    assert_eq!(m.request(), &[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xF2]);
    assert_eq!(m.request_chars(), 17);
}

#[test]
fn requests_of_every_function_code_are_written_in_upper_case_hex_with_their_lrc() {
    let coils = [true, false, true, true, false, false, true, true, true, false];
    let cases: [(Request, Vec<u8>); 8] = [
        (Request::ReadCoils { address: 19, quantity: 19 }, vec![ID, 0x01, 0x00, 0x13, 0x00, 0x13]),
        (Request::ReadDiscreteInputs { address: 196, quantity: 22 }, vec![ID, 0x02, 0x00, 0xC4, 0x00, 0x16]),
        (Request::ReadInputRegisters { address: 8, quantity: 1 }, vec![ID, 0x04, 0x00, 0x08, 0x00, 0x01]),
        (Request::WriteSingleCoil { address: 172, value: true }, vec![ID, 0x05, 0x00, 0xAC, 0xFF, 0x00]),
        (Request::WriteSingleRegister { address: 1, value: 0xBEEF }, vec![ID, 0x06, 0x00, 0x01, 0xBE, 0xEF]),
        (
            Request::WriteMultipleCoils { address: 19, values: &coils },
            vec![ID, 0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01],
        ),
        (
            Request::WriteMultipleRegisters { address: 1, values: &[0x000A, 0x0102] },
            vec![ID, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02],
        ),
        (Request::Raw { function: FunctionCode::from_code(0x11), data: &[] }, vec![ID, 0x11]),
    ];
    for (request, bytes) in cases {
        let mut m = master();
        send(&mut m, ID, request, &ascii(&bytes));
        let text = wire(&m);
        assert!(text[1..text.len() - 2].iter().all(|c| c.is_ascii_digit() || (b'A'..=b'F').contains(c)));
    }
    // FC 6 spelled out: 11 06 00 01 BE EF sum to 0x1C5; the two's complement of C5 is 3B.
    let mut m = master();
    send(&mut m, ID, Request::WriteSingleRegister { address: 1, value: 0xBEEF }, b":11060001BEEF3B\r\n");
}

// ---- replies --------------------------------------------------------------------------

#[test]
fn a_good_reply_is_taken() {
    let mut m = master();
    send(&mut m, ID, READ_TWO, &read_two());
    assert_eq!(deliver(&mut m, &two_values()), Action::None);
    let reply = m.outcome().unwrap().unwrap();
    assert_eq!(reply.registers().collect::<Vec<_>>(), [0x1234, 0xABCD]);
    assert_eq!(reply.data(), &[0x04, 0x12, 0x34, 0xAB, 0xCD], "the LRC is no part of the PDU");
    m.collect();
    assert_eq!(m.counters(), MasterCounters { requests: 1, replies: 1, ..MasterCounters::default() });
}

#[test]
fn a_reply_in_lower_case_hex_is_taken() {
    let mut m = master();
    send(&mut m, ID, READ_TWO, &read_two());
    deliver(&mut m, &two_values().to_ascii_lowercase());
    assert_eq!(m.outcome().unwrap().unwrap().register(1), Some(0xABCD));
}

#[test]
fn a_write_is_answered_by_its_echo() {
    let mut m = master();
    let request = [ID, 0x06, 0x00, 0x01, 0xBE, 0xEF];
    send(&mut m, ID, Request::WriteSingleRegister { address: 1, value: 0xBEEF }, &ascii(&request));
    // An echo of another value is no answer.
    deliver(&mut m, &ascii(&[ID, 0x06, 0x00, 0x01, 0xBE, 0xEE]));
    assert_eq!(m.counters().unexpected, 1);
    m.on_sent(1);
    deliver(&mut m, &ascii(&request));
    assert_eq!(outcome(&mut m), Some(Ok(vec![0x00, 0x01, 0xBE, 0xEF])));
}

#[test]
fn an_exception_reply_is_the_answer_with_its_code() {
    for code in [0x01, 0x02, 0x03, 0x04] {
        let mut m = master();
        send(&mut m, ID, READ_TWO, &read_two());
        deliver(&mut m, &ascii(&[ID, 0x83, code]));
        assert_eq!(outcome(&mut m), Some(Err(Failure::Exception(Exception::from_code(code).unwrap()))));
        assert_eq!(
            m.counters(),
            MasterCounters { requests: 1, replies: 1, exceptions: 1, ..MasterCounters::default() }
        );
    }
}

#[test]
fn replies_that_do_not_answer_the_request_are_never_taken() {
    let wrong = [
        vec![ID, 0x04, 0x04, 0, 1, 0, 2],       // another function code
        vec![ID, 0x03, 0x02, 0, 1],             // one register, two asked
        vec![ID, 0x03, 0x04, 0, 1, 0, 2, 0],    // a byte more than the count says
        vec![ID, 0x03, 0x06, 0, 1, 0, 2, 0, 3], // byte count for three
        vec![ID, 0x83, 0x02, 0x00],             // an exception reply with a byte too many
        vec![ID, 0x84, 0x02],                   // the exception of another function
    ];
    for frame in wrong {
        let mut m = master();
        m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
        send(&mut m, ID, READ_TWO, &read_two());
        deliver(&mut m, &ascii(&frame));
        assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)), "{frame:02X?}");
        assert_eq!(m.counters().unexpected, 1, "{frame:02X?}");
    }
}

#[test]
fn a_bad_lrc_is_a_crc_error_and_the_request_is_sent_again() {
    let mut m = master();
    send(&mut m, ID, READ_TWO, &read_two());
    let mut bad = two_values();
    let lrc_at = bad.len() - 3;
    bad[lrc_at] = if bad[lrc_at] == b'0' { b'1' } else { b'0' };
    // The retry goes out once the bad frame's LF has left the line.
    assert_eq!(deliver(&mut m, &bad), Action::Send);
    assert_eq!(wire(&m), read_two());
    m.on_sent(5);
    deliver(&mut m, &two_values());
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x1234));
    m.collect();
    assert_eq!(
        m.counters(),
        MasterCounters { requests: 2, replies: 1, retries: 1, crc_errors: 1, ..MasterCounters::default() }
    );
}

#[test]
fn bad_hex_and_an_odd_count_are_malformed_and_the_last_try_fails() {
    let good = two_values();
    let mut not_hex = good.clone();
    not_hex[5] = b'G';
    let mut odd = good.clone();
    odd.remove(5);
    let mut cr_alone = good.clone();
    let lf_at = cr_alone.len() - 1;
    cr_alone[lf_at] = b'0';
    cr_alone.extend_from_slice(b"\r\n");
    for bad in [not_hex, odd, cr_alone] {
        let mut m = master();
        m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
        send(&mut m, ID, READ_TWO, &read_two());
        deliver(&mut m, &bad);
        assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)), "{}", String::from_utf8_lossy(&bad));
        assert_eq!(m.counters(), MasterCounters { requests: 1, malformed: 1, ..MasterCounters::default() });
    }
}

#[test]
fn a_frame_from_another_slave_is_ignored_and_the_timeout_keeps_running() {
    let mut m = master();
    m.set_timeouts(Timeouts { response_ms: 50, turnaround_ms: 100, retries: 0 });
    send(&mut m, ID, READ_TWO, &read_two());
    m.on_tick(30);
    assert_eq!(deliver(&mut m, &ascii(&[ID + 1, 0x03, 0x04, 0x12, 0x34, 0xAB, 0xCD])), Action::None);
    assert!(m.is_under_way());
    assert_eq!(m.on_tick(50), Action::None);
    m.on_tick(51);
    assert_eq!(outcome(&mut m), Some(Err(Failure::Timeout)));
    assert_eq!(m.counters(), MasterCounters { requests: 1, timeouts: 1, unexpected: 1, ..MasterCounters::default() });
    // Another slave's frame, then the answer: taken.
    send(&mut m, ID, READ_TWO, &read_two());
    deliver(&mut m, &ascii(&[ID + 1, 0x83, 0x02]));
    deliver(&mut m, &two_values());
    assert_eq!(m.outcome().unwrap().unwrap().register(1), Some(0xABCD));
}

#[test]
fn a_colon_starts_the_frame_over_and_the_reply_after_it_is_taken() {
    let mut m = master();
    send(&mut m, ID, READ_TWO, &read_two());
    // A frame cut short by a `:`: counted, and the try goes on.
    let mut chars = b":110304".to_vec();
    chars.extend(two_values());
    assert_eq!(deliver(&mut m, &chars), Action::None);
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x1234));
    m.collect();
    assert_eq!(m.counters(), MasterCounters { requests: 1, replies: 1, malformed: 1, ..MasterCounters::default() });
}

#[test]
fn the_inter_character_timeout_inside_a_reply_drops_it_and_the_request_goes_again() {
    let mut m = master();
    send(&mut m, ID, READ_TWO, &read_two());
    let good = two_values();
    deliver(&mut m, &good[..7]);
    // Nothing goes out while a frame is on the line.
    assert_eq!(m.on_tick(2000), Action::None);
    assert_eq!(m.on_char_timeout(), Action::Send);
    assert_eq!(
        m.counters(),
        MasterCounters { requests: 2, timeouts: 1, retries: 1, malformed: 1, ..MasterCounters::default() }
    );
}

#[test]
fn damaged_characters_break_a_reply_but_not_the_line_outside_one() {
    use avr_modbus::internal::UartError;
    let mut m = master();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    send(&mut m, ID, READ_TWO, &read_two());
    // Outside a frame: noise.
    m.on_error(UartError::Framing);
    let good = two_values();
    deliver(&mut m, &good[..5]);
    m.on_error(UartError::Parity);
    deliver(&mut m, &good[5..]);
    assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)));
    assert_eq!(m.counters(), MasterCounters { requests: 1, uart_errors: 1, ..MasterCounters::default() });
}

// ---- when a request goes out ----------------------------------------------------------

#[test]
fn a_request_goes_out_at_power_up_and_waits_only_for_a_frame_on_the_line() {
    let mut m = master();
    // No T3.5 in ASCII: at once.
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    m.on_sent(0);
    deliver(&mut m, &two_values());
    m.collect();
    // Noise outside a frame delays nothing.
    deliver(&mut m, b"\r\n\x00zz?");
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    m.on_sent(0);
    deliver(&mut m, &two_values());
    m.collect();
    // A frame on the line (someone's late reply) holds the request until its LF.
    let other = ascii(&[ID + 1, 0x03, 0x02, 0x00, 0x01]);
    deliver(&mut m, &other[..9]);
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::None));
    assert_eq!(m.on_tick(5), Action::None);
    assert_eq!(deliver(&mut m, &other[9..]), Action::Send);
    assert_eq!(m.counters(), MasterCounters { requests: 3, replies: 2, unexpected: 1, ..MasterCounters::default() });
}

#[test]
fn the_echo_of_the_request_is_no_reply() {
    let mut m = master();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    for c in wire(&m) {
        assert!(!m.on_char(c));
    }
    m.on_sent(0);
    assert!(m.is_under_way());
    deliver(&mut m, &two_values());
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x1234));
}

#[test]
fn a_broadcast_waits_the_turnaround_delay_and_no_reply() {
    let mut m = master();
    send(&mut m, 0, Request::WriteSingleRegister { address: 0, value: 1 }, &ascii(&[0, 0x06, 0, 0, 0, 1]));
    assert_eq!(m.on_tick(100), Action::None);
    m.on_tick(101);
    assert!(m.outcome().unwrap().unwrap().is_empty());
}

#[test]
fn a_flood_never_overruns_the_buffer_and_is_not_taken() {
    let mut m: Engine<25> = Engine::new();
    m.set_ascii(true);
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    m.on_sent(0);
    // A frame with a good LRC, from the slave asked, of 200 bytes: past the 25-byte buffer.
    let mut long = vec![ID, 0x03, 4];
    long.extend((0..197).map(|i| i as u8));
    deliver(&mut m, &ascii(&long));
    assert_eq!(m.outcome().map(|o| o.is_err()), Some(true));
    m.collect();
    // 5000 hex digits without an end: too long for any frame (513 characters).
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    m.on_sent(0);
    let mut flood = vec![b':'];
    flood.extend(std::iter::repeat_n(b'1', 5000));
    flood.extend_from_slice(b"\r\n");
    deliver(&mut m, &flood);
    assert_eq!(m.outcome().map(|o| o.err()), Some(Some(Failure::BadReply)));
    m.collect();
    // 10000 characters of noise without a `:`: nothing at all.
    deliver(&mut m, &vec![b'7'; 10_000]);
    assert_eq!(m.counters(), MasterCounters { requests: 2, overruns: 1, unexpected: 1, ..MasterCounters::default() });
    // And the next reply is taken.
    m.start(ID, &READ_TWO).unwrap();
    m.on_sent(0);
    deliver(&mut m, &two_values());
    assert_eq!(m.outcome().unwrap().unwrap().register(1), Some(0xABCD));
}

// ---- ASCII and RTU take the same replies ------------------------------------------------

/// What a master makes of `reply` (address and PDU) to FC 3 of two registers from [`ID`]:
/// the outcome and the counters.
fn judged(ascii_mode: bool, reply: &[u8]) -> (Option<Result<Vec<u8>, Failure>>, MasterCounters) {
    let mut m = if ascii_mode { master() } else { Engine::new() };
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    if !ascii_mode {
        m.on_end_deadline();
    }
    assert_eq!(m.start(ID, &READ_TWO), Ok(Action::Send));
    m.on_sent(0);
    if ascii_mode {
        deliver(&mut m, &ascii(reply));
    } else {
        for b in with_crc(reply) {
            m.on_byte(b);
        }
        m.on_gap_deadline();
        m.on_end_deadline();
    }
    m.on_tick(5000);
    (outcome(&mut m), m.counters())
}

/// Replies near the right one: the slave asked or another, the function code or its
/// exception form or another, a byte count, and 0 to 6 bytes.
fn near_reply() -> impl Strategy<Value = Vec<u8>> {
    (
        prop::sample::select(vec![ID, ID + 1, 0]),
        prop::sample::select(vec![0x03, 0x83, 0x04, 0x10]),
        prop::sample::select(vec![0x04, 0x02, 0x01, 0x06]),
        prop::collection::vec(any::<u8>(), 0..=6),
    )
        .prop_map(|(slave, function, count, data)| [vec![slave, function, count], data].concat())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn the_ascii_master_takes_exactly_the_replies_the_rtu_master_takes(reply in near_reply()) {
        prop_assert_eq!(judged(true, &reply), judged(false, &reply));
    }
}
