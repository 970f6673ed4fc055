//! The master on the host: requests built as the Application Protocol's examples show them
//! (v1.1b3 §6.1–6.12, §6.17), replies checked and read, the master's states of Serial Line
//! v1.02 §2.4.1 (timeouts, retries, broadcast turnaround, T3.5 before a request), a round
//! trip through this crate's slave engine against the reference model, and the property
//! that no frame that does not answer the request is ever taken.
mod common;
mod model;

use avr_modbus::master::internal::{Action, Engine};
use avr_modbus::master::{Failure, MasterCounters, Request, Timeouts};
use avr_modbus::{Error, Exception, FunctionCode, Reference, Table};
use common::{with_crc, ID};
use proptest::prelude::*;

/// A master just after power-up that has seen T3.5 of silence.
fn master() -> Engine {
    let mut m = Engine::new();
    assert_eq!(m.on_end_deadline(), Action::None);
    m
}

/// `frame` arrives whole and the line goes quiet: T1.5, then T3.5.
fn deliver<const N: usize>(m: &mut Engine<N>, frame: &[u8]) -> Action {
    for &b in frame {
        m.on_byte(b);
    }
    m.on_gap_deadline();
    m.on_end_deadline()
}

/// Starts `request` to `slave` on a quiet line, checks it goes out at once as `expected`
/// (without the CRC, which is checked against the spec's), and ends its transmission.
fn send(m: &mut Engine, slave: u8, request: Request, expected: &[u8]) {
    assert_eq!(m.start(slave, &request), Ok(Action::Send));
    assert_eq!(m.request(), with_crc(expected).as_slice(), "{request:?}");
    sent(m, 0);
}

/// The request's last character left the wire at `now`, and T3.5 of silence followed.
fn sent<const N: usize>(m: &mut Engine<N>, now: u32) {
    m.on_sent(now);
    assert_eq!(m.on_end_deadline(), Action::None);
}

/// The outcome's reply data or failure, collected.
fn outcome(m: &mut Engine) -> Option<Result<Vec<u8>, Failure>> {
    let out = m.outcome().map(|r| r.map(|reply| reply.data().to_vec()));
    m.collect();
    out
}

fn counters(requests: u16, replies: u16) -> MasterCounters {
    MasterCounters { requests, replies, ..MasterCounters::default() }
}

// ---- requests, as the Application Protocol's examples -----------------------------------

#[test]
fn fc1_read_coils_20_to_38_is_the_spec_example() {
    let mut m = master();
    send(
        &mut m,
        ID,
        Request::ReadCoils { address: 19, quantity: 19 },
        &[
            ID, 0x01, // slave, function
            0x00, 0x13, // starting address 19 (coil 20)
            0x00, 0x13, // quantity 19
        ],
    );
    assert_eq!(deliver(&mut m, &with_crc(&[ID, 0x01, 0x03, 0xCD, 0x6B, 0x05])), Action::None);
    let reply = m.outcome().unwrap().unwrap();
    let bits: Vec<bool> = (0..19).map(|i| reply.bit(i).unwrap()).collect();
    // CD: coils 27–20 = 1100 1101; 6B: 35–28 = 0110 1011; 05: 38–36 = 101.
    let expected = [1, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 0, 1, 0, 1].map(|b| b == 1);
    assert_eq!(bits, expected);
    assert_eq!(reply.bit(19), None);
    assert_eq!((reply.function(), reply.len(), reply.is_empty()), (FunctionCode::ReadCoils, 19, false));
}

#[test]
fn fc2_read_discrete_inputs_197_to_218_is_the_spec_example() {
    let mut m = master();
    send(&mut m, ID, Request::ReadDiscreteInputs { address: 196, quantity: 22 }, &[ID, 0x02, 0x00, 0xC4, 0x00, 0x16]);
    deliver(&mut m, &with_crc(&[ID, 0x02, 0x03, 0xAC, 0xDB, 0x35]));
    let reply = m.outcome().unwrap().unwrap();
    assert_eq!(reply.bit(0), Some(false)); // AC = 1010 1100: input 197 off, 199 on
    assert_eq!(reply.bit(2), Some(true));
    assert_eq!(reply.bit(21), Some(true)); // 35 = 0011 0101: input 218 is its bit 5
}

#[test]
fn fc3_read_holding_registers_108_to_110_is_the_spec_example() {
    let mut m = master();
    send(&mut m, ID, Request::ReadHoldingRegisters { address: 107, quantity: 3 }, &[ID, 0x03, 0x00, 0x6B, 0x00, 0x03]);
    // The Serial Line spec's CRC example for this very frame: 76 87.
    assert_eq!(&m.request()[6..], &[0x76, 0x87]);
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64]));
    let reply = m.outcome().unwrap().unwrap();
    assert_eq!(reply.registers().collect::<Vec<_>>(), [0x022B, 0x0000, 0x0064]);
    assert_eq!((reply.register(0), reply.register(2), reply.register(3)), (Some(0x022B), Some(0x0064), None));
    assert_eq!(m.counters(), counters(1, 1));
}

#[test]
fn fc4_read_input_register_9_is_the_spec_example() {
    let mut m = master();
    send(&mut m, ID, Request::ReadInputRegisters { address: 8, quantity: 1 }, &[ID, 0x04, 0x00, 0x08, 0x00, 0x01]);
    deliver(&mut m, &with_crc(&[ID, 0x04, 0x02, 0x00, 0x0A]));
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x000A));
}

#[test]
fn fc5_write_coil_173_on_is_the_spec_example_and_its_echo_is_the_answer() {
    let mut m = master();
    let request = [ID, 0x05, 0x00, 0xAC, 0xFF, 0x00];
    send(&mut m, ID, Request::WriteSingleCoil { address: 172, value: true }, &request);
    deliver(&mut m, &with_crc(&request));
    let reply = m.outcome().unwrap().unwrap();
    // The echo is the reply's data; a write reads no registers nor bits.
    assert_eq!(reply.data(), &[0x00, 0xAC, 0xFF, 0x00]);
    assert_eq!((reply.registers().count(), reply.register(0), reply.bit(0)), (0, None, None));
    assert_eq!((reply.function(), reply.len(), reply.is_empty()), (FunctionCode::WriteSingleCoil, 0, true));
    m.collect();
    send(&mut m, ID, Request::WriteSingleCoil { address: 172, value: false }, &[ID, 0x05, 0x00, 0xAC, 0x00, 0x00]);
}

#[test]
fn fc6_write_register_2_is_the_spec_example() {
    let mut m = master();
    let request = [ID, 0x06, 0x00, 0x01, 0x00, 0x03];
    send(&mut m, ID, Request::WriteSingleRegister { address: 1, value: 3 }, &request);
    deliver(&mut m, &with_crc(&request));
    assert!(matches!(outcome(&mut m), Some(Ok(_))));
}

#[test]
fn fc15_write_coils_20_to_29_is_the_spec_example() {
    let mut m = master();
    // CD 01: coils 27–20 = 1100 1101, 29–28 = 01.
    let values = [1, 0, 1, 1, 0, 0, 1, 1, 1, 0].map(|b| b == 1);
    send(
        &mut m,
        ID,
        Request::WriteMultipleCoils { address: 19, values: &values },
        &[
            ID, 0x0F, 0x00, 0x13, // start 19
            0x00, 0x0A, // quantity 10
            0x02, 0xCD, 0x01, // byte count, coils
        ],
    );
    deliver(&mut m, &with_crc(&[ID, 0x0F, 0x00, 0x13, 0x00, 0x0A]));
    assert!(matches!(outcome(&mut m), Some(Ok(_))));
}

#[test]
fn fc16_write_registers_2_and_3_is_the_spec_example() {
    let mut m = master();
    send(
        &mut m,
        ID,
        Request::WriteMultipleRegisters { address: 1, values: &[0x000A, 0x0102] },
        &[
            ID, 0x10, 0x00, 0x01, 0x00, 0x02, // start 1, quantity 2
            0x04, 0x00, 0x0A, 0x01, 0x02, // byte count, values
        ],
    );
    deliver(&mut m, &with_crc(&[ID, 0x10, 0x00, 0x01, 0x00, 0x02]));
    assert!(matches!(outcome(&mut m), Some(Ok(_))));
}

#[test]
fn fc23_read_write_registers_is_the_spec_example() {
    let mut m = master();
    send(
        &mut m,
        ID,
        Request::ReadWriteMultipleRegisters {
            read_address: 3,
            read_quantity: 6,
            write_address: 14,
            values: &[0xFF; 3],
        },
        &[
            ID, 0x17, 0x00, 0x03, 0x00, 0x06, // read 6 from 3
            0x00, 0x0E, 0x00, 0x03, // write 3 at 14
            0x06, 0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF, // byte count, values
        ],
    );
    let reply = [ID, 0x17, 0x0C, 0x00, 0xFE, 0x0A, 0xCD, 0x00, 0x01, 0x00, 0x03, 0x00, 0x0D, 0x00, 0xFF];
    deliver(&mut m, &with_crc(&reply));
    let got = m.outcome().unwrap().unwrap();
    assert_eq!(got.registers().collect::<Vec<_>>(), [0x00FE, 0x0ACD, 0x0001, 0x0003, 0x000D, 0x00FF]);
}

#[test]
fn raw_fc17_report_server_id_hands_back_the_reply_pdu() {
    let mut m = master();
    send(&mut m, ID, Request::Raw { function: FunctionCode::from_code(0x11), data: &[] }, &[ID, 0x11]);
    deliver(&mut m, &with_crc(&[ID, 0x11, 0x03, 0x2A, 0xFF, 0x07]));
    assert_eq!(outcome(&mut m), Some(Ok(vec![0x03, 0x2A, 0xFF, 0x07])));
}

// ---- limits checked before a byte is built ----------------------------------------------

#[test]
fn quantities_outside_the_spec_are_refused_before_sending() {
    let mut m = master();
    let too_many_coils = [false; 1969];
    let too_many_registers = [0; 124];
    let refused = [
        Request::ReadCoils { address: 0, quantity: 0 },
        Request::ReadCoils { address: 0, quantity: 2001 },
        Request::ReadDiscreteInputs { address: 0, quantity: 2001 },
        Request::ReadHoldingRegisters { address: 0, quantity: 126 },
        Request::ReadInputRegisters { address: 0, quantity: 0 },
        Request::WriteMultipleCoils { address: 0, values: &too_many_coils },
        Request::WriteMultipleCoils { address: 0, values: &[] },
        Request::WriteMultipleRegisters { address: 0, values: &too_many_registers },
        Request::WriteMultipleRegisters { address: 0, values: &[] },
        Request::ReadWriteMultipleRegisters { read_address: 0, read_quantity: 126, write_address: 0, values: &[1] },
        Request::ReadWriteMultipleRegisters { read_address: 0, read_quantity: 1, write_address: 0, values: &[0; 122] },
    ];
    for request in refused {
        assert_eq!(m.start(ID, &request), Err(Error::Quantity), "{request:?}");
    }
    // The limits themselves are accepted.
    for request in [
        Request::ReadCoils { address: 0, quantity: 2000 },
        Request::ReadHoldingRegisters { address: 0, quantity: 125 },
        Request::WriteMultipleCoils { address: 0, values: &[true; 1968] },
        Request::WriteMultipleRegisters { address: 0, values: &[7; 123] },
        Request::ReadWriteMultipleRegisters {
            read_address: 0,
            read_quantity: 125,
            write_address: 0,
            values: &[1; 121],
        },
    ] {
        let mut m = master();
        assert_eq!(m.start(ID, &request), Ok(Action::Send), "{request:?}");
    }
    assert_eq!(m.counters(), MasterCounters::default());
}

#[test]
fn reads_are_never_broadcast_and_reserved_addresses_are_refused() {
    let mut m = master();
    assert_eq!(m.start(0, &Request::ReadHoldingRegisters { address: 0, quantity: 1 }), Err(Error::Broadcast));
    let fc23 =
        Request::ReadWriteMultipleRegisters { read_address: 0, read_quantity: 1, write_address: 0, values: &[1] };
    assert_eq!(m.start(0, &fc23), Err(Error::Broadcast));
    assert_eq!(m.start(248, &Request::WriteSingleRegister { address: 0, value: 1 }), Err(Error::SlaveId));
    assert_eq!(m.start(ID, &Request::Raw { function: FunctionCode::from_code(0), data: &[] }), Err(Error::Function));
    assert_eq!(m.start(ID, &Request::Raw { function: FunctionCode::from_code(0x80), data: &[] }), Err(Error::Function));
    // The highest unicast address is a slave's.
    assert_eq!(m.start(247, &Request::WriteSingleRegister { address: 0, value: 1 }), Ok(Action::Send));
}

#[test]
fn a_request_or_reply_longer_than_the_buffer_is_refused() {
    let mut small: Engine<16> = Engine::new();
    small.on_end_deadline();
    // 10 registers answer in 25 bytes: more than 16.
    assert_eq!(small.start(1, &Request::ReadHoldingRegisters { address: 0, quantity: 10 }), Err(Error::TooLong));
    // 4 registers written take 17 bytes.
    assert_eq!(small.start(1, &Request::WriteMultipleRegisters { address: 0, values: &[1; 4] }), Err(Error::TooLong));
    assert_eq!(small.start(1, &Request::ReadHoldingRegisters { address: 0, quantity: 5 }), Ok(Action::Send));
    // 88 coils answer in 16 bytes (11 data bytes): the buffer's size is room enough; 89 take 17.
    let mut small: Engine<16> = Engine::new();
    small.on_end_deadline();
    assert_eq!(small.start(1, &Request::ReadCoils { address: 0, quantity: 89 }), Err(Error::TooLong));
    assert_eq!(small.start(1, &Request::ReadCoils { address: 0, quantity: 88 }), Ok(Action::Send));
    // A raw request of more than 253 bytes of PDU does not fit a frame.
    let mut m = master();
    assert_eq!(
        m.start(1, &Request::Raw { function: FunctionCode::from_code(0x41), data: &[0; 253] }),
        Err(Error::TooLong)
    );
    assert_eq!(
        m.start(1, &Request::Raw { function: FunctionCode::from_code(0x41), data: &[0; 252] }),
        Ok(Action::Send)
    );
}

// ---- the master's states ------------------------------------------------------------------

#[test]
fn a_request_waits_for_t35_of_silence_after_anything_on_the_line() {
    let mut m: Engine = Engine::new();
    // Power-up: no T3.5 seen yet.
    let read = Request::ReadHoldingRegisters { address: 0, quantity: 1 };
    assert_eq!(m.start(ID, &read), Ok(Action::None));
    assert_eq!(m.counters().requests, 0);
    assert_eq!(m.on_end_deadline(), Action::Send);
    sent(&mut m, 0);
    // A late character on the line after a reply: the next request waits for its T3.5.
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0x00, 0x01]));
    m.collect();
    m.on_byte(0x55);
    assert_eq!(m.start(ID, &read), Ok(Action::None));
    assert_eq!(m.on_tick(5), Action::None);
    m.on_gap_deadline();
    assert_eq!(m.on_end_deadline(), Action::Send);
}

#[test]
fn a_request_while_one_is_under_way_is_refused_and_the_first_goes_on() {
    let mut m = master();
    let read = Request::ReadHoldingRegisters { address: 0, quantity: 1 };
    send(&mut m, ID, read, &[ID, 0x03, 0, 0, 0, 1]);
    assert_eq!(m.start(2, &Request::WriteSingleCoil { address: 0, value: true }), Err(Error::Busy));
    assert_eq!(m.request(), with_crc(&[ID, 0x03, 0, 0, 0, 1]).as_slice());
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0x12, 0x34]));
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x1234));
}

#[test]
fn a_silent_slave_times_out_after_each_retry_and_the_failure_is_a_timeout() {
    let mut m = master();
    m.set_timeouts(Timeouts { response_ms: 200, turnaround_ms: 100, retries: 2 });
    send(&mut m, ID, Request::ReadInputRegisters { address: 0, quantity: 5 }, &[ID, 0x04, 0, 0, 0, 5]);
    // The clock's readings are rounded down: 200 ms have surely passed only at 201.
    assert_eq!(m.on_tick(200), Action::None);
    assert!(m.is_busy());
    // The first timeout: sent again at once (the line is quiet).
    assert_eq!(m.on_tick(201), Action::Send);
    sent(&mut m, 210);
    assert_eq!(m.on_tick(410), Action::None);
    assert_eq!(m.on_tick(411), Action::Send);
    sent(&mut m, 420);
    assert_eq!(m.on_tick(621), Action::None);
    assert_eq!(outcome(&mut m), Some(Err(Failure::Timeout)));
    assert_eq!(m.counters(), MasterCounters { requests: 3, timeouts: 3, retries: 2, ..MasterCounters::default() });
    assert!(!m.is_busy());
}

#[test]
fn a_reply_just_inside_the_timeout_is_taken_and_one_just_outside_is_not() {
    let mut m = master();
    m.set_timeouts(Timeouts { response_ms: 100, turnaround_ms: 100, retries: 0 });
    let read = Request::ReadHoldingRegisters { address: 0, quantity: 1 };
    let reply = with_crc(&[ID, 0x03, 0x02, 0xBE, 0xEF]);
    send(&mut m, ID, read, &[ID, 0x03, 0, 0, 0, 1]);
    assert_eq!(m.on_tick(100), Action::None);
    deliver(&mut m, &reply);
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0xBEEF));
    m.collect();
    send(&mut m, ID, read, &[ID, 0x03, 0, 0, 0, 1]);
    m.on_tick(101);
    deliver(&mut m, &reply);
    assert_eq!(outcome(&mut m), Some(Err(Failure::Timeout)));
    assert_eq!(m.counters().unexpected, 1);
}

#[test]
fn an_exception_reply_of_five_bytes_is_the_answer_with_its_code() {
    for code in [0x01, 0x02, 0x03, 0x04, 0x0B] {
        let mut m = master();
        send(&mut m, ID, Request::ReadHoldingRegisters { address: 0, quantity: 1 }, &[ID, 0x03, 0, 0, 0, 1]);
        deliver(&mut m, &with_crc(&[ID, 0x83, code]));
        assert_eq!(outcome(&mut m), Some(Err(Failure::Exception(Exception::from_code(code).unwrap()))));
        assert_eq!(
            m.counters(),
            MasterCounters { requests: 1, replies: 1, exceptions: 1, ..MasterCounters::default() }
        );
    }
}

#[test]
fn a_frame_from_another_slave_is_ignored_and_the_timeout_keeps_running() {
    let mut m = master();
    m.set_timeouts(Timeouts { response_ms: 50, turnaround_ms: 100, retries: 0 });
    send(&mut m, ID, Request::ReadHoldingRegisters { address: 0, quantity: 1 }, &[ID, 0x03, 0, 0, 0, 1]);
    m.on_tick(30);
    deliver(&mut m, &with_crc(&[ID + 1, 0x03, 0x02, 0x00, 0x01]));
    assert!(m.is_busy());
    assert_eq!(m.on_tick(50), Action::None);
    m.on_tick(51);
    assert_eq!(outcome(&mut m), Some(Err(Failure::Timeout)));
    assert_eq!(m.counters().unexpected, 1);
}

#[test]
fn a_damaged_reply_is_counted_and_the_request_is_sent_again() {
    let mut m = master();
    send(&mut m, ID, Request::ReadHoldingRegisters { address: 0, quantity: 1 }, &[ID, 0x03, 0, 0, 0, 1]);
    let mut damaged = with_crc(&[ID, 0x03, 0x02, 0x00, 0x01]);
    damaged[4] ^= 0x10;
    assert_eq!(deliver(&mut m, &damaged), Action::Send);
    sent(&mut m, 10);
    // A gap over T1.5 inside the second reply: malformed, and no retries left.
    for &b in &with_crc(&[ID, 0x03, 0x02, 0x00, 0x01])[..3] {
        m.on_byte(b);
    }
    m.on_gap_deadline();
    m.on_byte(0x00);
    m.on_end_deadline();
    assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)));
    assert_eq!(
        m.counters(),
        MasterCounters { requests: 2, retries: 1, crc_errors: 1, malformed: 1, ..MasterCounters::default() }
    );
}

#[test]
fn replies_that_do_not_answer_the_request_are_never_taken() {
    let read = Request::ReadHoldingRegisters { address: 0, quantity: 2 };
    let wrong = [
        vec![ID, 0x04, 0x04, 0, 1, 0, 2],       // another function code
        vec![ID, 0x03, 0x02, 0, 1],             // one register, two asked
        vec![ID, 0x03, 0x04, 0, 1, 0, 2, 0],    // a byte more than the count says
        vec![ID, 0x03, 0x06, 0, 1, 0, 2, 0, 3], // byte count for three
        vec![ID, 0x83, 0x02, 0x00],             // an exception reply of six bytes
        vec![ID, 0x84, 0x02],                   // the exception of another function
    ];
    for frame in wrong {
        let mut m = master();
        m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
        send(&mut m, ID, read, &[ID, 0x03, 0, 0, 0, 2]);
        deliver(&mut m, &with_crc(&frame));
        assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)), "{frame:02X?}");
        assert_eq!(m.counters().unexpected, 1);
    }
    // A write's echo must repeat the address and the value or quantity.
    let mut m = master();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    send(&mut m, ID, Request::WriteSingleRegister { address: 5, value: 9 }, &[ID, 0x06, 0, 5, 0, 9]);
    deliver(&mut m, &with_crc(&[ID, 0x06, 0, 5, 0, 8]));
    assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)));
    send(
        &mut m,
        ID,
        Request::WriteMultipleRegisters { address: 5, values: &[1, 2] },
        &[ID, 0x10, 0, 5, 0, 2, 4, 0, 1, 0, 2],
    );
    deliver(&mut m, &with_crc(&[ID, 0x10, 0, 5, 0, 3]));
    assert_eq!(outcome(&mut m), Some(Err(Failure::BadReply)));
}

#[test]
fn a_flood_longer_than_the_buffer_never_overruns_it_is_not_taken_and_counts_as_the_slaves_does() {
    let mut m: Engine<16> = Engine::new();
    m.on_end_deadline();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    assert_eq!(m.start(1, &Request::ReadHoldingRegisters { address: 0, quantity: 2 }), Ok(Action::Send));
    sent(&mut m, 0);
    // A good frame of 200 bytes whose byte count claims them all: dropped as too long once
    // it overflows the buffer (no answer is longer), its CRC never checked.
    let mut frame = vec![1, 0x03, 196];
    frame.extend((0..196).map(|i| i as u8));
    deliver(&mut m, &with_crc(&frame));
    assert_eq!(m.outcome(), Some(Err(Failure::BadReply)));
    let counters = m.counters();
    assert_eq!(
        (counters.overruns, counters.malformed, counters.crc_errors, counters.unexpected),
        (1, 0, 0, 0),
        "{counters:?}"
    );
    // 300 bytes without a pause: too long for any frame.
    let mut m: Engine<16> = Engine::new();
    m.on_end_deadline();
    m.start(1, &Request::ReadHoldingRegisters { address: 0, quantity: 2 }).unwrap();
    sent(&mut m, 0);
    deliver(&mut m, &[0x01; 300]);
    assert_eq!(m.counters().overruns, 1);
}

#[test]
fn a_broadcast_waits_the_turnaround_delay_and_no_reply() {
    let mut m = master();
    m.set_timeouts(Timeouts { response_ms: 1000, turnaround_ms: 100, retries: 3 });
    send(&mut m, 0, Request::WriteSingleRegister { address: 0, value: 1 }, &[0, 0x06, 0, 0, 0, 1]);
    assert_eq!(m.on_tick(100), Action::None);
    assert_eq!(m.start(1, &Request::ReadCoils { address: 0, quantity: 1 }), Err(Error::Busy));
    m.on_tick(101);
    let reply = m.outcome().unwrap().unwrap();
    assert!(reply.is_empty() && reply.data().is_empty());
    m.collect();
    assert_eq!(m.counters(), counters(1, 0));
}

#[test]
fn frames_with_no_request_waiting_are_counted_as_unexpected() {
    let mut m = master();
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0, 1]));
    assert_eq!(m.counters().unexpected, 1);
    assert!(m.outcome().is_none());
}

// ---- a round trip through this crate's slave, against the reference model ----------------

/// Every request the master can build, run through the slave engine with the model's bank;
/// what the master reads is what the model holds, and what it writes lands in the model.
#[test]
fn round_trip_through_the_slave_engine_matches_the_reference_model() {
    let (mut bank, mut model) = model::fixture(0x5A5A);
    let mut slave = model::slave();
    let mut m = master();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    for (table, first, count) in model::LAYOUT {
        let requests: Vec<Request> = match table {
            Table::Coils => vec![Request::ReadCoils { address: first, quantity: count }],
            Table::DiscreteInputs => vec![Request::ReadDiscreteInputs { address: first, quantity: count }],
            Table::InputRegisters => vec![Request::ReadInputRegisters { address: first, quantity: count }],
            Table::HoldingRegisters => vec![Request::ReadHoldingRegisters { address: first, quantity: count }],
        };
        for request in requests {
            m.start(ID, &request).unwrap();
            let frame = m.request().to_vec();
            let reply = model.frame(&frame).1;
            sent(&mut m, 0);
            deliver(&mut m, &reply);
            let got = m.outcome().unwrap().expect("an answer");
            for i in 0..count {
                let want = model.value(table, u32::from(first + i));
                let value = if model::is_bits(table) {
                    u16::from(got.bit(usize::from(i)).unwrap())
                } else {
                    got.register(usize::from(i)).unwrap()
                };
                assert_eq!(value, want, "{table:?} {}", first + i);
            }
            m.collect();
            // The slave engine gives the same reply bytes.
            assert_eq!(common::ask(&mut slave, &mut bank, &frame), reply);
        }
    }
    // Writes, then read back through both.
    let writes = [
        Request::WriteSingleCoil { address: 3, value: true },
        Request::WriteSingleRegister { address: 12, value: 0xA5A5 },
        Request::WriteMultipleCoils { address: 12, values: &[true, false, true, true, false, false, true, true, true] },
        Request::WriteMultipleRegisters { address: 65532, values: &[1, 2, 3, 4] },
        Request::WriteMultipleRegisters { address: 9, values: &[1, 2] }, // 10 is a hole: exception 02
    ];
    for request in writes {
        m.start(ID, &request).unwrap();
        let frame = m.request().to_vec();
        let reply = model.frame(&frame).1;
        assert_eq!(common::ask(&mut slave, &mut bank, &frame), reply);
        sent(&mut m, 0);
        deliver(&mut m, &reply);
        match m.outcome().unwrap() {
            Ok(_) => assert_eq!(reply.len(), 8),
            Err(Failure::Exception(code)) => assert_eq!(reply[2], code.code()),
            Err(other) => panic!("{other:?}"),
        }
        m.collect();
    }
    model::check_bank(&bank, &model).unwrap();
    assert_eq!(bank.get(Reference::holding_register(12)), Ok(0xA5A5));
}

// ---- the property ---------------------------------------------------------------------

/// What a reply to `request` from `slave` must be to be its answer, written out from the
/// spec apart from the crate: `None` when `frame` (with a good CRC) is no answer.
fn answers(slave: u8, request: &[u8], frame: &[u8]) -> Option<Result<(), u8>> {
    let body = &frame[..frame.len() - 2];
    if body.len() < 2 || body[0] != slave {
        return None;
    }
    let function = request[1];
    if body[1] == function | 0x80 {
        // Code 0 is no exception (Application Protocol §7 numbers them from 01): no answer.
        return (body.len() == 3 && body[2] != 0).then(|| Err(body[2]));
    }
    if body[1] != function {
        return None;
    }
    let word = |at: usize| u16::from_be_bytes([request[at], request[at + 1]]);
    let ok = match function {
        1 | 2 => {
            body.len() >= 3
                && usize::from(body[2]) == usize::from(word(4)).div_ceil(8)
                && body.len() == 3 + usize::from(body[2])
        }
        3 | 4 | 0x17 => {
            body.len() >= 3
                && usize::from(body[2]) == 2 * usize::from(word(4))
                && body.len() == 3 + usize::from(body[2])
        }
        5 | 6 | 0x0F | 0x10 => body.len() == 6 && body[2..6] == request[2..6],
        _ => true,
    };
    ok.then_some(Ok(()))
}

/// A request: function code, slave, address, quantity, values written.
type Asked = (u8, u8, u16, u16, Vec<u16>);

fn any_request() -> impl Strategy<Value = Asked> {
    (
        prop::sample::select(vec![1u8, 2, 3, 4, 5, 6, 0x0F, 0x10, 0x17]),
        1u8..=3,
        0u16..4,
        1u16..5,
        prop::collection::vec(any::<u16>(), 1..4),
    )
}

fn build<'a>(asked: &'a Asked, bools: &'a [bool]) -> Request<'a> {
    let (function, _, address, quantity, values) = asked;
    let (address, quantity) = (*address, *quantity);
    match function {
        1 => Request::ReadCoils { address, quantity },
        2 => Request::ReadDiscreteInputs { address, quantity },
        3 => Request::ReadHoldingRegisters { address, quantity },
        4 => Request::ReadInputRegisters { address, quantity },
        5 => Request::WriteSingleCoil { address, value: bools[0] },
        6 => Request::WriteSingleRegister { address, value: values[0] },
        0x0F => Request::WriteMultipleCoils { address, values: &bools[..values.len()] },
        0x10 => Request::WriteMultipleRegisters { address, values },
        _ => Request::ReadWriteMultipleRegisters {
            read_address: address,
            read_quantity: quantity,
            write_address: 1,
            values,
        },
    }
}

/// The request's frame as the spec builds it (without the crate), and its true reply.
fn spec_frames(asked: &Asked) -> (Vec<u8>, Vec<u8>) {
    let (function, slave, address, quantity, values) = asked;
    let (function, slave) = (*function, *slave);
    let mut request = vec![slave, function];
    request.extend(address.to_be_bytes());
    match function {
        1..=4 => request.extend(quantity.to_be_bytes()),
        5 => request.extend(if values[0] & 1 == 1 { [0xFF, 0x00] } else { [0, 0] }),
        6 => request.extend(values[0].to_be_bytes()),
        0x0F => {
            request.extend((values.len() as u16).to_be_bytes());
            request.push(1);
            request.push(values.iter().enumerate().fold(0, |b, (i, v)| b | ((v & 1) as u8) << i));
        }
        0x10 => {
            request.extend((values.len() as u16).to_be_bytes());
            request.push(2 * values.len() as u8);
            request.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        }
        _ => {
            request.extend(quantity.to_be_bytes());
            request.extend([0, 1]);
            request.extend((values.len() as u16).to_be_bytes());
            request.push(2 * values.len() as u8);
            request.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        }
    }
    let mut reply = vec![slave, function];
    match function {
        1 | 2 => {
            reply.push(quantity.div_ceil(8) as u8);
            reply.extend((0..quantity.div_ceil(8)).map(|i| 0xA5 ^ i as u8));
        }
        3 | 4 | 0x17 => {
            reply.push(2 * *quantity as u8);
            reply.extend((0..2 * quantity).map(|i| 0x3C ^ i as u8));
        }
        _ => reply.extend_from_slice(&request[2..6]),
    }
    (with_crc(&request), reply)
}

/// A request and a frame near its true reply: the reply itself, or changed in one byte,
/// cut short or one byte longer, an exception form, another slave's, or noise; each with
/// a good CRC.
fn request_and_frame() -> impl Strategy<Value = (Asked, Vec<u8>)> {
    any_request().prop_flat_map(|asked| {
        let body = spec_frames(&asked).1;
        let len = body.len();
        let near = prop_oneof![
            Just(body.clone()),
            (0..len, any::<u8>()).prop_map({
                let body = body.clone();
                move |(at, value)| {
                    let mut b = body.clone();
                    b[at] = value;
                    b
                }
            }),
            (1..len).prop_map({
                let body = body.clone();
                move |cut| body[..cut].to_vec()
            }),
            any::<u8>().prop_map({
                let body = body.clone();
                move |extra| {
                    let mut b = body.clone();
                    b.push(extra);
                    b
                }
            }),
            (prop::sample::select(vec![asked.0 | 0x80, 0x83, 0x81]), any::<u8>(), 2usize..5).prop_map({
                let slave = asked.1;
                move |(f, code, len)| [slave, f, code, 0][..len.min(4)].to_vec()
            }),
            prop::collection::vec(any::<u8>(), 1..12),
        ];
        (Just(asked), near.prop_map(|b| with_crc(&b)))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Whatever good frame ends while the master waits, it is taken as the answer (or as
    /// an exception) only when it answers the request as the spec says; the request itself
    /// is the spec's.
    #[test]
    fn no_reply_that_does_not_match_its_request_is_ever_taken((asked, frame) in request_and_frame()) {
        let bools: Vec<bool> = asked.4.iter().map(|v| v & 1 == 1).collect();
        let request = build(&asked, &bools);
        let slave = asked.1;
        let mut m = master();
        m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
        prop_assert_eq!(m.start(slave, &request), Ok(Action::Send));
        let sent = m.request().to_vec();
        prop_assert_eq!(&sent, &spec_frames(&asked).0);
        crate::sent(&mut m, 0);
        deliver(&mut m, &frame);
        let expected = answers(slave, &sent, &frame);
        match m.outcome() {
            Some(Ok(reply)) => {
                prop_assert_eq!(expected, Some(Ok(())), "taken: {:02X?} for {:02X?}", frame, sent);
                prop_assert_eq!(reply.data(), &frame[2..frame.len() - 2]);
            }
            Some(Err(Failure::Exception(code))) => prop_assert_eq!(expected, Some(Err(code.code()))),
            Some(Err(failure)) => {
                prop_assert_eq!(failure, Failure::BadReply);
                // From the slave asked, or too short to say whose.
                prop_assert!(expected.is_none() && (frame[0] == slave || frame.len() < 4), "{:02X?}", frame);
            }
            None => prop_assert!(expected.is_none() && frame[0] != slave && frame.len() >= 4, "{:02X?}", frame),
        }
    }
}

/// Found by the `master` fuzz target: a request refused for its length wrote its bytes over
/// the last one's before it was refused.
#[test]
fn a_refused_request_changes_nothing() {
    let mut small: Engine<16> = Engine::new();
    small.on_end_deadline();
    let write = Request::WriteSingleRegister { address: 7, value: 1 };
    assert_eq!(small.start(0, &write), Ok(Action::Send));
    let sent = small.request().to_vec();
    crate::sent(&mut small, 0);
    small.on_tick(101);
    assert!(small.outcome().is_some());
    small.collect();
    assert_eq!(small.start(3, &Request::ReadHoldingRegisters { address: 0, quantity: 39 }), Err(Error::TooLong));
    assert_eq!(small.request(), sent.as_slice());
    assert!(!small.is_busy());
}

#[test]
fn an_outcome_not_collected_keeps_the_next_request_out() {
    let mut m = master();
    send(&mut m, ID, Request::ReadHoldingRegisters { address: 0, quantity: 1 }, &[ID, 0x03, 0, 0, 0, 1]);
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0x12, 0x34]));
    assert!(m.is_busy() && !m.is_under_way());
    assert_eq!(m.start(ID, &Request::WriteSingleCoil { address: 0, value: true }), Err(Error::Busy));
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(0x1234));
    m.collect();
    assert_eq!(m.start(ID, &Request::WriteSingleCoil { address: 0, value: true }), Ok(Action::Send));
}

/// A slave should wait T3.5 after the request before it answers, but many answer sooner
/// (pymodbus's serial server, for one): their replies are taken.
#[test]
fn a_reply_right_after_the_request_from_a_slave_that_does_not_wait_t35_is_taken() {
    let mut m = master();
    assert_eq!(m.start(ID, &Request::ReadHoldingRegisters { address: 0, quantity: 1 }), Ok(Action::Send));
    m.on_sent(0);
    // No T1.5, no T3.5 after the request: the reply follows at once.
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0x00, 0x07]));
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(7));
}

#[test]
fn the_echo_of_the_request_from_a_transceiver_that_hears_itself_is_no_reply() {
    let mut m = master();
    m.set_timeouts(Timeouts { retries: 0, ..Timeouts::DEFAULT });
    assert_eq!(m.start(ID, &Request::ReadHoldingRegisters { address: 0, quantity: 1 }), Ok(Action::Send));
    // The request's own characters come back while it goes out.
    let request = m.request().to_vec();
    for &b in &request {
        m.on_byte(b);
    }
    m.on_sent(0);
    m.on_gap_deadline();
    assert_eq!(m.on_end_deadline(), Action::None);
    assert!(m.is_under_way(), "the echo ended the try");
    assert_eq!(m.counters().unexpected + m.counters().malformed, 0);
    deliver(&mut m, &with_crc(&[ID, 0x03, 0x02, 0x00, 0x05]));
    assert_eq!(m.outcome().unwrap().unwrap().register(0), Some(5));
}
