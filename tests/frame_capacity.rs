//! A frame buffer sized for the register map (`DataModel::FRAME`) answers every frame as
//! the 256-byte buffer does: requests longer than the buffer (kept in part, CRC checked
//! over all of it) and reads whose reply would not fit get the same exception, the same
//! silence and the same counts (Serial Line v1.02 §2.5.1; Application Protocol v1.1b3 §7).

mod common;

use avr_modbus::internal::{EndOfFrame, Engine, FrameError, Framer};
use avr_modbus::{bit_bytes, Bank, DataModel, SlaveCounters, SlaveId};
use common::{exception_reply, with_crc, ID};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::select;
use proptest::test_runner::{RngAlgorithm, RngSeed};

avr_modbus::register_map! {
    /// `examples/sixteen_each.rs`'s map.
    #[derive(Clone, Debug)]
    struct Sixteen {
        1..=16,
        10001..=10016,
        30001..=30008,
        40001..=40016,
    }
}

avr_modbus::register_map! {
    /// Ranges that touch (runs of 8 coils and 8 holding registers) beside holes.
    #[derive(Clone, Debug)]
    struct Touching {
        40005..=40008,
        40001..=40004,
        40010,
        5..=8,
        1..=4,
        30002,
        30001,
    }
}

avr_modbus::register_map! {
    /// Runs longer than one request may cover: the spec's limits bound the buffer.
    #[derive(Clone, Debug)]
    struct Long {
        1..=2100,
        10001,
        40001..=40200,
    }
}

avr_modbus::register_map! {
    /// Three coils only.
    #[derive(Clone, Debug)]
    struct FewCoils {
        1..=3,
    }
}

const SIXTEEN: usize = <Sixteen as DataModel>::FRAME;
const TOUCHING: usize = <Touching as DataModel>::FRAME;

/// `examples/sixteen_each_bank.rs`'s bank: room for 4 runs, 24 registers and 32 bits.
type ContractBank = Bank<4, 24, { bit_bytes(32) }>;
const CONTRACT_BANK: usize = <ContractBank as DataModel>::FRAME;

/// The contract's map in a bank, added as the example adds it.
fn contract_bank() -> ContractBank {
    let mut bank = ContractBank::new();
    for (first, count) in [(1, 16), (10001, 16), (30001, 8), (40001, 16)] {
        bank.add_range(first, count).unwrap();
    }
    bank
}

/// `Touching`'s ranges in a bank with room for 8 more registers and bits, added in
/// reverse order: the runs join as they are added.
type TouchingBank = Bank<8, 19, { bit_bytes(16) }>;

fn touching_bank() -> TouchingBank {
    let mut bank = TouchingBank::new();
    for (first, count) in [(30001, 2), (1, 4), (5, 4), (40010, 1), (40001, 4), (40005, 4)] {
        bank.add_range(first, count).unwrap();
    }
    bank
}

/// Without the optional function codes (FC 7, 8, 11, 17, 22, 23, 43), which need 256 bytes.
const SIZED: bool = !cfg!(any(feature = "diagnostics", feature = "extra-fc", feature = "device-id"));

// ---- the buffer a map needs ----------------------------------------------------------------

#[test]
fn sixteen_each_needs_41_bytes_for_fc16_writing_16_registers() {
    // FC 16 × 16: address, function, start (2), quantity (2), byte count, 32 data bytes,
    // CRC (2) = 41; FC 3 × 16 replies with 37 bytes.
    assert_eq!(SIXTEEN, if SIZED { 41 } else { 256 });
}

#[test]
fn ranges_that_touch_count_as_one_run() {
    // 8 holding registers in a row: FC 16 × 8 is 9 + 16 bytes.
    assert_eq!(TOUCHING, if SIZED { 25 } else { 256 });
}

#[test]
fn runs_longer_than_one_request_are_bounded_by_the_spec_limits() {
    // FC 3 × 125 and FC 16 × 123 are 255 bytes, as are FC 1 × 2000 and FC 15 × 1968.
    assert_eq!(<Long as DataModel>::FRAME, if SIZED { 255 } else { 256 });
}

#[test]
fn a_request_of_one_value_always_fits_the_buffer() {
    // FC 15 × 3 is 10 bytes, FC 1–6 requests 8; FC 16 writing one register, 11, sets the
    // floor, though the map has no register.
    assert_eq!(<FewCoils as DataModel>::FRAME, if SIZED { 11 } else { 256 });
}

#[test]
fn a_bank_sizes_its_buffer_from_its_capacity() {
    // No run is longer than the bank's registers or bits: FC 16 × 24 is 9 + 48 bytes.
    assert_eq!(CONTRACT_BANK, if SIZED { 57 } else { 256 });
    // FC 16 × 64 registers: 9 + 128.
    assert_eq!(<common::TestBank as DataModel>::FRAME, if SIZED { 137 } else { 256 });
    // Four coils at most: FC 15 × 4, 10 bytes; every request of one value fits in 11.
    assert_eq!(<Bank<1, 0, { bit_bytes(4) }> as DataModel>::FRAME, if SIZED { 11 } else { 256 });
    // Past the spec's limits the capacity no longer matters.
    assert_eq!(<common::FullBank as DataModel>::FRAME, if SIZED { 255 } else { 256 });
    assert_eq!(<Bank<1, 4000, { bit_bytes(60000) }> as DataModel>::FRAME, if SIZED { 255 } else { 256 });
}

#[test]
fn the_engine_is_smaller_by_what_the_buffer_is() {
    // Up to the host's alignment padding (the AVR has none).
    let saved = size_of::<Engine>() - size_of::<Engine<SIXTEEN>>();
    assert!(saved.abs_diff(256 - SIXTEEN) < align_of::<Engine>(), "saved {saved}");
}

// ---- one frame through both buffers ------------------------------------------------------

/// What one frame led to: the end of frame, the reply (empty for silence), the counters.
type Outcome = (EndOfFrame, Vec<u8>, SlaveCounters);

/// Ends whatever `slave` was doing (T3.5), then feeds `frame` as the interrupts would,
/// with the gap deadline before T3.5 when `gap`, and processes it.
fn deliver<const N: usize, M: DataModel>(slave: &mut Engine<N>, model: &mut M, frame: &[u8], gap: bool) -> Outcome {
    slave.handle_frame(&[], model);
    for &byte in frame {
        slave.on_byte(byte);
    }
    if gap {
        slave.on_gap_deadline();
    }
    let end = slave.on_end_deadline();
    if matches!(end, EndOfFrame::Reply | EndOfFrame::Broadcast | EndOfFrame::Silent) {
        slave.process(model);
    }
    let reply = slave.reply().to_vec();
    slave.on_reply_sent();
    (end, reply, slave.counters())
}

fn slave<const N: usize>() -> Engine<N> {
    Engine::new(SlaveId::new(ID))
}

/// `frame` sent to a fresh `Sixteen` slave with the sized buffer and to one with 256
/// bytes, with and without a gap deadline: the outcomes must be the same. Returns it.
fn both(frame: &[u8]) -> Outcome {
    let mut outcome = None;
    for gap in [false, true] {
        let (mut small_map, mut full_map) = (Sixteen::new(), Sixteen::new());
        let small = deliver(&mut slave::<SIXTEEN>(), &mut small_map, frame, gap);
        let full = deliver(&mut slave::<256>(), &mut full_map, frame, gap);
        assert_eq!(small, full, "{}-byte frame, gap deadline {gap}", frame.len());
        assert_eq!(format!("{small_map:?}"), format!("{full_map:?}"));
        outcome = Some(small);
    }
    outcome.unwrap()
}

/// `frame` sent to the contract's bank with its sized buffer and with 256 bytes: the
/// outcomes must be the same, and the same as `Sixteen`'s. Returns it.
fn both_banks(frame: &[u8]) -> Outcome {
    let map = both(frame);
    for gap in [false, true] {
        let (mut small_bank, mut full_bank) = (contract_bank(), contract_bank());
        let small = deliver(&mut slave::<CONTRACT_BANK>(), &mut small_bank, frame, gap);
        let full = deliver(&mut slave::<256>(), &mut full_bank, frame, gap);
        assert_eq!(small, full, "{}-byte frame, gap deadline {gap}", frame.len());
        assert_eq!(small, map, "{}-byte frame, gap deadline {gap}: the bank and the map", frame.len());
        assert_eq!(format!("{small_bank:?}"), format!("{full_bank:?}"));
    }
    map
}

/// FC 16 at `start` for `qty` registers with byte count `count` and `data` data bytes.
fn fc16(address: u8, start: u16, qty: u16, count: u8, data: usize) -> Vec<u8> {
    let mut frame = vec![address, 0x10];
    frame.extend(start.to_be_bytes());
    frame.extend(qty.to_be_bytes());
    frame.push(count);
    frame.extend((0..data).map(|i| i as u8));
    with_crc(&frame)
}

#[test]
fn fc16_of_100_registers_outside_the_map_is_illegal_data_address() {
    let frame = fc16(ID, 0x0100, 100, 200, 200);
    assert!(frame.len() > SIXTEEN || !SIZED);
    let (end, reply, counters) = both(&frame);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, exception_reply(0x10, 0x02));
    assert_eq!((counters.messages, counters.exceptions), (1, 1));
}

#[test]
fn fc16_of_100_registers_from_the_first_is_illegal_data_address() {
    // Starts inside the map but runs past its 16 registers.
    assert_eq!(both(&fc16(ID, 0, 100, 200, 200)).1, exception_reply(0x10, 0x02));
}

#[test]
fn fc16_with_a_byte_count_unlike_its_quantity_is_illegal_data_value() {
    assert_eq!(both(&fc16(ID, 0x0100, 100, 199, 199)).1, exception_reply(0x10, 0x03));
}

#[test]
fn fc16_with_fewer_data_bytes_than_its_byte_count_is_illegal_data_value() {
    assert_eq!(both(&fc16(ID, 0x0100, 100, 200, 199)).1, exception_reply(0x10, 0x03));
}

#[test]
fn fc16_of_124_registers_is_illegal_data_value() {
    // With 248 data bytes it would be 257 bytes long: 200 make it long enough.
    assert_eq!(both(&fc16(ID, 0, 124, 200, 200)).1, exception_reply(0x10, 0x03));
}

#[test]
fn fc16_ending_past_65535_is_illegal_data_address() {
    assert_eq!(both(&fc16(ID, 0xFFD0, 100, 200, 200)).1, exception_reply(0x10, 0x02));
}

#[test]
fn fc15_of_1000_coils_is_illegal_data_address() {
    let mut frame = vec![
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x00, // starting address lo
        0x03, // quantity hi
        0xE8, // quantity lo: 1000
        0x7D, // byte count: 125
    ];
    frame.extend([0xFF; 125]);
    assert_eq!(both(&with_crc(&frame)).1, exception_reply(0x0F, 0x02));
}

#[test]
fn a_long_frame_with_a_bad_crc_is_dropped_and_counted() {
    let mut frame = fc16(ID, 0x0100, 100, 200, 200);
    *frame.last_mut().unwrap() ^= 0x01;
    let (end, reply, counters) = both(&frame);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::BadCrc));
    assert!(reply.is_empty());
    assert_eq!((counters.frames, counters.crc_errors, counters.messages), (1, 1, 0));
}

#[test]
fn a_bad_byte_past_the_buffer_breaks_the_crc() {
    let mut frame = fc16(ID, 0x0100, 100, 200, 200);
    frame[SIXTEEN.min(200) + 3] ^= 0x40;
    assert_eq!(both(&frame).0, EndOfFrame::Dropped(FrameError::BadCrc));
}

#[test]
fn a_long_frame_for_another_slave_gets_silence() {
    let (end, reply, counters) = both(&fc16(ID + 1, 0x0100, 100, 200, 200));
    assert_eq!(end, EndOfFrame::OtherSlave);
    assert!(reply.is_empty());
    assert_eq!((counters.frames, counters.messages), (1, 0));
}

#[test]
fn a_long_broadcast_is_refused_in_silence_and_counted() {
    let (end, reply, counters) = both(&fc16(0, 0x0100, 100, 200, 200));
    assert_eq!(end, EndOfFrame::Broadcast);
    assert!(reply.is_empty());
    assert_eq!((counters.broadcasts, counters.exceptions, counters.replies), (1, 1, 0));
}

#[test]
fn an_unknown_function_with_long_data_is_illegal_function() {
    let mut frame = vec![ID, 0x41];
    frame.extend([0x55; 150]);
    assert_eq!(both(&with_crc(&frame)).1, exception_reply(0x41, 0x01));
}

#[test]
fn fc3_with_long_data_is_illegal_data_value() {
    let mut frame = vec![ID, 0x03, 0x00, 0x00, 0x00, 0x02];
    frame.extend([0x00; 100]);
    assert_eq!(both(&with_crc(&frame)).1, exception_reply(0x03, 0x03));
}

#[test]
fn fc3_of_125_registers_whose_reply_would_not_fit_is_illegal_data_address() {
    let frame = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo
        0x00, // quantity hi
        0x7D, // quantity lo: 125 (the map has 16)
    ]);
    assert_eq!(both(&frame).1, exception_reply(0x03, 0x02));
}

#[test]
fn fc1_of_2000_coils_whose_reply_would_not_fit_is_illegal_data_address() {
    let frame = with_crc(&[ID, 0x01, 0x00, 0x00, 0x07, 0xD0]);
    assert_eq!(both(&frame).1, exception_reply(0x01, 0x02));
}

#[test]
fn the_longest_write_the_map_accepts_fits_and_is_answered() {
    let (end, reply, _) = both(&fc16(ID, 0, 16, 32, 32));
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x10]));
}

#[test]
fn frames_of_256_bytes_are_answered_and_of_257_are_overruns() {
    let mut frame = vec![ID, 0x0F, 0x00, 0x00, 0x07, 0xB1, 0xF7];
    frame.extend([0xFF; 247]);
    let frame = with_crc(&frame);
    assert_eq!(frame.len(), 256);
    assert_eq!(both(&frame).1, exception_reply(0x0F, 0x03));

    let mut frame = vec![ID, 0x41];
    frame.extend([0x00; 253]);
    let frame = with_crc(&frame);
    assert_eq!(frame.len(), 257);
    let (end, reply, counters) = both(&frame);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::TooLong));
    assert!(reply.is_empty());
    assert_eq!(counters.overruns, 1);
}

// ---- a bank's buffer, sized from its capacity ---------------------------------------------

#[test]
fn a_bank_answers_fc16_of_100_registers_with_illegal_data_address() {
    let frame = fc16(ID, 0, 100, 200, 200);
    assert!(frame.len() > CONTRACT_BANK || !SIZED);
    let (end, reply, counters) = both_banks(&frame);
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, exception_reply(0x10, 0x02));
    assert_eq!((counters.messages, counters.exceptions), (1, 1));
}

#[test]
fn a_bank_answers_long_requests_as_the_spec_says() {
    // Byte count unlike the quantity, fewer data bytes than it says: 03.
    assert_eq!(both_banks(&fc16(ID, 0x0100, 100, 199, 199)).1, exception_reply(0x10, 0x03));
    assert_eq!(both_banks(&fc16(ID, 0x0100, 100, 200, 199)).1, exception_reply(0x10, 0x03));
    // Past 65535: 02.
    assert_eq!(both_banks(&fc16(ID, 0xFFD0, 100, 200, 200)).1, exception_reply(0x10, 0x02));
    // Reads whose reply would not fit: 02.
    assert_eq!(both_banks(&with_crc(&[ID, 0x03, 0x00, 0x00, 0x00, 0x7D])).1, exception_reply(0x03, 0x02));
    assert_eq!(both_banks(&with_crc(&[ID, 0x01, 0x00, 0x00, 0x07, 0xD0])).1, exception_reply(0x01, 0x02));
    // Unknown function with long data: 01.
    let mut frame = vec![ID, 0x41];
    frame.extend([0x55; 150]);
    assert_eq!(both_banks(&with_crc(&frame)).1, exception_reply(0x41, 0x01));
}

#[test]
fn a_long_frame_with_a_bad_crc_to_a_bank_is_dropped_and_counted() {
    let mut frame = fc16(ID, 0x0100, 100, 200, 200);
    *frame.last_mut().unwrap() ^= 0x01;
    let (end, reply, counters) = both_banks(&frame);
    assert_eq!(end, EndOfFrame::Dropped(FrameError::BadCrc));
    assert!(reply.is_empty());
    assert_eq!((counters.frames, counters.crc_errors, counters.messages), (1, 1, 0));
}

#[test]
fn a_long_broadcast_to_a_bank_is_refused_in_silence() {
    let (end, reply, counters) = both_banks(&fc16(0, 0x0100, 100, 200, 200));
    assert_eq!(end, EndOfFrame::Broadcast);
    assert!(reply.is_empty());
    assert_eq!((counters.broadcasts, counters.exceptions, counters.replies), (1, 1, 0));
}

#[test]
fn the_longest_write_a_bank_accepts_fits_and_is_answered() {
    let (end, reply, _) = both_banks(&fc16(ID, 0, 16, 32, 32));
    assert_eq!(end, EndOfFrame::Reply);
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x10]));
}

#[test]
fn a_bank_full_to_capacity_answers_its_longest_requests() {
    // 24 holding registers in one run: FC 16 × 24 is the whole buffer, FC 3 × 24 nearly.
    type Full = Bank<1, 24, { bit_bytes(0) }>;
    let mut bank = Full::new();
    bank.add_range(40001, 24).unwrap();
    let mut slave = slave::<{ <Full as DataModel>::FRAME }>();
    let write = fc16(ID, 0, 24, 48, 48);
    assert!(write.len() == <Full as DataModel>::FRAME || !SIZED);
    let (end, reply, _) = deliver(&mut slave, &mut bank, &write, false);
    assert_eq!((end, reply), (EndOfFrame::Reply, with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x18])));
    let (_, reply, _) = deliver(&mut slave, &mut bank, &with_crc(&[ID, 0x03, 0x00, 0x00, 0x00, 0x18]), false);
    let mut expected = vec![ID, 0x03, 48];
    expected.extend((0..48).map(|i| i as u8));
    assert_eq!(reply, with_crc(&expected));
    // One more register is a missing address, and its request one byte too long: 02.
    let (_, reply, _) = deliver(&mut slave, &mut bank, &fc16(ID, 0, 25, 50, 50), false);
    assert_eq!(reply, exception_reply(0x10, 0x02));
}

// ---- the framer on its own ---------------------------------------------------------------

fn framer_after(frame: &[u8], gap: bool) -> (Framer<8>, Option<Result<usize, FrameError>>) {
    let mut framer = Framer::<8>::new();
    framer.on_end_deadline();
    for &byte in frame {
        framer.on_byte(byte);
    }
    if gap {
        framer.on_gap_deadline();
    }
    let end = framer.on_end_deadline();
    (framer, end)
}

#[test]
fn an_8_byte_framer_receives_256_bytes_and_keeps_the_first_8() {
    let data: Vec<u8> = (0..254).map(|i| (i * 7) as u8).collect();
    let frame = with_crc(&data);
    for gap in [false, true] {
        let (framer, end) = framer_after(&frame, gap);
        assert_eq!(end, Some(Ok(256)));
        assert_eq!(framer.buffer(), &frame[..8]);
    }
}

#[test]
fn an_8_byte_framer_refuses_257_bytes() {
    let frame = with_crc(&[0x11; 255]);
    assert_eq!(framer_after(&frame, false).1, Some(Err(FrameError::TooLong)));
}

#[test]
fn an_8_byte_framer_checks_the_crc_of_every_byte() {
    let data: Vec<u8> = (0..100).map(|i| (i * 13) as u8).collect();
    let mut frame = with_crc(&data);
    frame[50] ^= 0x80;
    for gap in [false, true] {
        assert_eq!(framer_after(&frame, gap).1, Some(Err(FrameError::BadCrc)), "gap deadline {gap}");
    }
}

#[test]
fn after_a_long_frame_a_short_one_is_checked_alone() {
    let (mut framer, end) = framer_after(&with_crc(&[0x22; 60]), true);
    assert_eq!(end, Some(Ok(62)));
    framer.release();
    let short = with_crc(&[ID, 0x03, 0x00, 0x00, 0x00, 0x01]);
    for &byte in &short {
        framer.on_byte(byte);
    }
    framer.on_gap_deadline();
    assert_eq!(framer.on_end_deadline(), Some(Ok(8)));
    assert_eq!(framer.buffer(), &short[..]);
}

// ---- random frames -------------------------------------------------------------------------

fn config() -> ProptestConfig {
    let env = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    ProptestConfig {
        cases: env("FUZZ_CASES").map_or(1000, |n| n as u32),
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(env("FUZZ_SEED").unwrap_or(0x0029_0100)),
        ..ProptestConfig::default()
    }
}

/// A write of coils or registers or another request, with a header near the maps' edges,
/// a byte count right or not (or none, for the other codes), and as many data bytes as it
/// says or a few more or fewer; or random bytes. The CRC is right in most of them.
fn frame() -> impl Strategy<Value = Vec<u8>> {
    let address = prop_oneof![8 => Just(ID), 1 => Just(0u8), 1 => any::<u8>()];
    let function = prop_oneof![
        6 => select(vec![0x0Fu8, 0x10]),
        3 => select(vec![0x01u8, 0x02, 0x03, 0x04, 0x05, 0x06]),
        1 => any::<u8>(),
    ];
    let start = prop_oneof![3 => 0u16..24, 1 => 0xFF80u16..=0xFFFF, 1 => any::<u16>()];
    let qty = prop_oneof![3 => 1u16..=20, 2 => 0u16..=2100, 1 => any::<u16>()];
    let header = (address, function, start, qty, any::<bool>(), any::<u8>(), -3i16..=3, any::<bool>(), any::<u8>());
    let request = header.prop_map(|(address, function, start, qty, right_count, count, slack, good_crc, byte)| {
        let mut frame = vec![address, function];
        frame.extend(start.to_be_bytes());
        frame.extend(qty.to_be_bytes());
        // Other codes have no byte count: as a master sends them with `right_count`.
        let writes = function == 0x0F || function == 0x10;
        if writes || !right_count {
            let needed = if function == 0x0F { qty.div_ceil(8) } else { qty.saturating_mul(2) };
            let count = if right_count { needed as u8 } else { count };
            frame.push(count);
            let data = (i16::from(count) + slack).max(0) as usize;
            frame.extend((0..data).map(|i| byte.wrapping_add(i as u8)));
        }
        let mut frame = with_crc(&frame);
        if !good_crc {
            let at = usize::from(byte) % frame.len();
            frame[at] ^= 0x10;
        }
        frame
    });
    let random = (vec(any::<u8>(), 0..=300), any::<bool>()).prop_map(|(mut bytes, crc)| {
        if let Some(first) = bytes.first_mut() {
            *first = ID;
        }
        if crc && bytes.len() <= 298 {
            with_crc(&bytes)
        } else {
            bytes
        }
    });
    prop_oneof![4 => request, 1 => random]
}

/// `frames` through a slave with `N` bytes of buffer and one with 256, each on its own
/// copy of `model`: every outcome and the models after it must be the same.
fn same_outcomes<const N: usize, M: DataModel + Clone + std::fmt::Debug>(
    model: &M,
    frames: &[(Vec<u8>, bool)],
) -> Result<(), TestCaseError> {
    assert_eq!(N, M::FRAME);
    let (mut small, mut full) = (slave::<N>(), slave::<256>());
    let (mut small_model, mut full_model) = (model.clone(), model.clone());
    for (frame, gap) in frames {
        let a = deliver(&mut small, &mut small_model, frame, *gap);
        let b = deliver(&mut full, &mut full_model, frame, *gap);
        prop_assert_eq!(&a, &b, "frame {:02X?}", frame);
        prop_assert_eq!(format!("{small_model:?}"), format!("{full_model:?}"));
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn a_sized_buffer_answers_random_frames_as_256_bytes_do(
        frames in vec((frame(), any::<bool>()), 1..6),
    ) {
        same_outcomes::<SIXTEEN, _>(&Sixteen::new(), &frames)?;
        same_outcomes::<TOUCHING, _>(&Touching::new(), &frames)?;
        same_outcomes::<{ <FewCoils as DataModel>::FRAME }, _>(&FewCoils::new(), &frames)?;
    }

    #[test]
    fn a_bank_sized_buffer_answers_random_frames_as_256_bytes_do(
        frames in vec((frame(), any::<bool>()), 1..6),
    ) {
        same_outcomes::<CONTRACT_BANK, _>(&contract_bank(), &frames)?;
        same_outcomes::<{ <TouchingBank as DataModel>::FRAME }, _>(&touching_bank(), &frames)?;
    }
}
