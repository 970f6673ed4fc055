//! Random frames and random event sequences against the reference model (`tests/model`,
//! written from the spec): the slave never panics, answers only with well-formed replies,
//! and every reply, every count and every change to the bank is what the model predicts.
//! It runs under every feature set `make test` builds; the model knows the optional
//! function codes when the build has them, and with feature `ascii` a fourth property
//! feeds an ASCII line to the slave and the model's ASCII receiver.

mod common;
mod model;

use avr_modbus::internal::UartError;
#[cfg(feature = "ascii")]
use model::ascii::{run_ascii_events, AsciiEvent};
use model::{exchange, fixture, run_events, slave, with_crc, Event, EDGES, ID};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::select;
use proptest::test_runner::{RngAlgorithm, RngSeed};

/// 2000 cases from a fixed seed in `make test`; `make fuzz` sets `FUZZ_CASES` (and
/// `FUZZ_SEED`) for a long run.
fn config() -> ProptestConfig {
    let env = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    ProptestConfig {
        cases: env("FUZZ_CASES").map_or(2000, |n| n as u32),
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(env("FUZZ_SEED").unwrap_or(0x04D0_DB05)),
        ..ProptestConfig::default()
    }
}

// ---- strategies --------------------------------------------------------------------------

fn address() -> impl Strategy<Value = u16> {
    prop_oneof![3 => select(EDGES.to_vec()), 4 => 0u16..16, 1 => 65528u16..=65535, 1 => any::<u16>()]
}

fn quantity() -> impl Strategy<Value = u16> {
    prop_oneof![
        4 => 1u16..=4,
        3 => 5u16..=12,
        2 => select(vec![0u16, 1, 2, 16, 123, 124, 125, 126, 1968, 1969, 2000, 2001, 0x8000, 0xFFFF]),
        1 => any::<u16>(),
    ]
}

fn function() -> impl Strategy<Value = u8> {
    prop_oneof![
        8 => select(vec![0x01u8, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F, 0x10]),
        // The optional ones: exception 01 in a build without their feature.
        3 => select(vec![0x07u8, 0x08, 0x0B, 0x11, 0x16, 0x17, 0x2B]),
        1 => any::<u8>(),
    ]
}

/// A request PDU as a master would build it (which may still be illegal: quantities and
/// addresses are random).
fn request_pdu() -> impl Strategy<Value = Vec<u8>> {
    (function(), address(), quantity(), any::<u16>(), any::<u64>()).prop_map(|(function, start, qty, raw, seed)| {
        let mut pdu = vec![function];
        match function {
            // No data: a longer PDU is exception 03.
            0x07 | 0x0B | 0x11 => {
                pdu.extend((0..u16::from(raw % 8 == 0)).map(|_| raw as u8));
                return pdu;
            }
            0x08 => {
                let subs = [0x00, 0x01, 0x04, 0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F, 0x10, 0x11, 0x12, 0x13, 0x02, raw];
                let sub: u16 = subs[usize::from(qty) % subs.len()];
                let data = match raw % 5 {
                    0 => 0xFF00,
                    1 => raw,
                    _ => 0x0000,
                };
                pdu.extend(sub.to_be_bytes());
                pdu.extend(data.to_be_bytes());
                return pdu;
            }
            // MEI type 14 mostly; read device id codes 01–04 and others; the ids of the
            // objects a device may have, and others.
            0x2B => {
                let mei = if raw % 8 == 0 { (raw >> 8) as u8 } else { 0x0E };
                let code = [0x01, 0x02, 0x03, 0x04, 0x01, 0x02, 0x04, 0x00, 0x05, raw as u8][usize::from(qty) % 10];
                let object = if start % 4 == 0 { start as u8 } else { (start % 9) as u8 };
                pdu.extend([mei, code, object]);
                return pdu;
            }
            _ => {}
        }
        pdu.extend(start.to_be_bytes());
        let mut noise = seed | 1;
        let mut next = move || {
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            noise as u8
        };
        match function {
            0x01..=0x04 => pdu.extend(qty.to_be_bytes()),
            0x05 => {
                let value = match raw % 4 {
                    0 => 0x0000,
                    1 | 2 => 0xFF00,
                    _ => raw,
                };
                pdu.extend(value.to_be_bytes());
            }
            0x06 => pdu.extend(raw.to_be_bytes()),
            0x16 => {
                pdu.extend(raw.to_be_bytes());
                pdu.extend((seed as u16).to_be_bytes());
            }
            0x17 => {
                let write_qty = 1 + raw % 6;
                let write_start = EDGES[usize::from(raw >> 8) % EDGES.len()];
                pdu.extend(qty.to_be_bytes());
                pdu.extend(write_start.to_be_bytes());
                pdu.extend(write_qty.to_be_bytes());
                pdu.push((2 * write_qty) as u8);
                pdu.extend((0..2 * write_qty).map(|_| next()));
            }
            0x0F | 0x10 => {
                let bytes = if function == 0x0F { usize::from(qty).div_ceil(8) } else { 2 * usize::from(qty) };
                let bytes = bytes.min(246 + usize::from(raw % 4));
                pdu.extend(qty.to_be_bytes());
                pdu.push(bytes as u8);
                pdu.extend((0..bytes).map(|_| next()));
            }
            _ => pdu.extend((0..raw % 8).map(|_| next())),
        }
        pdu
    })
}

#[derive(Clone, Debug)]
enum Mutation {
    None,
    Flip(usize, u8),
    Set(usize, u8),
    Truncate(usize),
    Append(Vec<u8>),
}

impl Mutation {
    fn apply(&self, pdu: &mut Vec<u8>) {
        let len = pdu.len();
        match self {
            Mutation::None => {}
            Mutation::Flip(i, mask) => pdu[i % len] ^= mask,
            Mutation::Set(i, byte) => pdu[i % len] = *byte,
            Mutation::Truncate(i) => pdu.truncate(i % len),
            Mutation::Append(bytes) => pdu.extend(bytes),
        }
    }
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        6 => Just(Mutation::None),
        1 => (any::<usize>(), 1u8..=255).prop_map(|(i, m)| Mutation::Flip(i, m)),
        1 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        1 => vec(any::<u8>(), 1..4).prop_map(Mutation::Append),
    ]
}

fn slave_address() -> impl Strategy<Value = u8> {
    prop_oneof![6 => Just(ID), 1 => Just(0u8), 1 => any::<u8>()]
}

/// A request with a correct CRC, possibly mutated before the CRC was computed.
fn mutated_request() -> impl Strategy<Value = Vec<u8>> {
    (slave_address(), request_pdu(), mutation()).prop_map(|(address, mut pdu, mutation)| {
        mutation.apply(&mut pdu);
        let mut frame = vec![address];
        frame.extend(pdu);
        with_crc(&frame)
    })
}

/// Random bytes, then sometimes the first byte set to this slave and a correct CRC.
fn random_frame() -> impl Strategy<Value = Vec<u8>> {
    (vec(any::<u8>(), 0..=300), any::<bool>(), any::<bool>()).prop_map(|(mut bytes, mine, crc)| {
        if mine && !bytes.is_empty() {
            bytes[0] = ID;
        }
        if crc && bytes.len() <= 298 {
            with_crc(&bytes)
        } else {
            bytes
        }
    })
}

// ---- events --------------------------------------------------------------------------------

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        6 => any::<u8>().prop_map(Event::Byte),
        2 => Just(Event::Byte(ID)),
        2 => Just(Event::Gap),
        3 => Just(Event::End),
        1 => select(vec![UartError::Parity, UartError::Framing, UartError::Overrun]).prop_map(Event::Error),
        2 => Just(Event::ReplySent),
        3 => mutated_request().prop_map(Event::Request),
    ]
}

/// An ASCII line (feature `ascii`): characters, most of them ones a frame is made of,
/// requests written out in either case (some with a wrong LRC, some without their CR LF),
/// timeouts, damaged characters and the end of a reply.
#[cfg(feature = "ascii")]
fn ascii_event() -> impl Strategy<Value = AsciiEvent> {
    let requests = (mutated_request(), any::<bool>(), 0u8..8, 1u8..=255).prop_map(|(frame, lower, damage, flip)| {
        let frame = &frame[..frame.len() - 2];
        let mut text = model::ascii::request(frame, lower);
        let n = text.len();
        match damage {
            // The LRC's digits of another value.
            0 => text[n - 4..n - 2].copy_from_slice(format!("{:02X}", model::ascii::lrc(frame) ^ flip).as_bytes()),
            1 => text.truncate(n - 2),
            _ => {}
        }
        AsciiEvent::Text(text)
    });
    prop_oneof![
        6 => select(b"0123456789ABCDEFabcdef:\r\n".to_vec()).prop_map(AsciiEvent::Char),
        1 => any::<u8>().prop_map(AsciiEvent::Char),
        1 => Just(AsciiEvent::Timeout),
        1 => select(vec![UartError::Parity, UartError::Framing, UartError::Overrun]).prop_map(AsciiEvent::Error),
        2 => Just(AsciiEvent::ReplySent),
        4 => requests,
    ]
}

// ---- properties --------------------------------------------------------------------------

/// A model check's failure as a failing test case.
fn fail(message: String) -> TestCaseError {
    TestCaseError::fail(message)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_bytes_yield_silence_or_the_reply_the_model_predicts(
        salt in any::<u16>(),
        frame in random_frame(),
    ) {
        let (mut bank, mut model) = fixture(salt);
        exchange(&mut slave(), &mut bank, &mut model, &frame).map_err(fail)?;
    }

    #[test]
    fn mutated_requests_with_a_correct_crc_get_the_reply_the_model_predicts(
        salt in any::<u16>(),
        frames in vec(mutated_request(), 1..8),
    ) {
        let (mut bank, mut model) = fixture(salt);
        let mut slave = slave();
        for frame in &frames {
            exchange(&mut slave, &mut bank, &mut model, frame).map_err(fail)?;
        }
    }

    #[test]
    fn random_event_sequences_follow_the_reference_receiver(
        salt in any::<u16>(),
        events in vec(event(), 0..40),
    ) {
        let (mut bank, mut model) = fixture(salt);
        run_events(&mut slave(), &mut bank, &mut model, &events).map_err(fail)?;
    }
}

#[cfg(feature = "ascii")]
proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_ascii_lines_follow_the_reference_receiver_and_the_rtu_twin(
        salt in any::<u16>(),
        events in vec(ascii_event(), 0..40),
    ) {
        let (mut bank, mut model) = fixture(salt);
        let mut slave = slave();
        slave.set_ascii(true);
        run_ascii_events(&mut slave, &mut bank, &mut model, &events).map_err(fail)?;
    }
}
