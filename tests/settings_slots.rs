//! The two settings slots in EEPROM (feature `eeprom-settings`): load takes the newest
//! valid record, a store writes the other slot, and a reset at any instant of a store,
//! even one that tears the byte being written, leaves the complete old settings or the
//! complete new ones, never neither.

mod common;

use avr_modbus::internal::settings::{
    decode, encode, is_newer, Newest, Record, Slot, Slots, Write, LEGACY_MAGIC, MAGIC, MAX_WRITES, RECORD_LEN,
    SLOTS_LEN,
};
use avr_modbus::{Config, Parity, StopBits};
use common::reference_crc;

const DEFAULT: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const OLD: Config = Config::new(5, 9600, Parity::None, StopBits::Two);
const NEW: Config = Config::new(7, 38_400, Parity::Odd, StopBits::One);
const OLDER: Config = Config::new(9, 57_600, Parity::Even, StopBits::One);

const BLANK: [u8; RECORD_LEN] = [0xFF; RECORD_LEN];

/// Slot A's and slot B's bytes side by side.
fn slots(a: [u8; RECORD_LEN], b: [u8; RECORD_LEN]) -> [u8; SLOTS_LEN] {
    let mut bytes = [0; SLOTS_LEN];
    bytes[..RECORD_LEN].copy_from_slice(&a);
    bytes[RECORD_LEN..].copy_from_slice(&b);
    bytes
}

/// A format-1 record, as earlier firmware wrote it at the start of slot A (the 11th byte
/// stays blank): 'M', id, baud (u32 LE), parity, stop bits, CRC of bytes 0–7.
fn legacy(config: &Config) -> [u8; RECORD_LEN] {
    let parity = match config.parity() {
        Parity::None => 0,
        Parity::Odd => 1,
        Parity::Even => 2,
    };
    let stop_bits = if config.stop_bits() == StopBits::Two { 2 } else { 1 };
    let mut record = BLANK;
    record[0] = 0x4D;
    record[1] = config.slave_id().get();
    record[2..6].copy_from_slice(&config.baud().to_le_bytes());
    record[6] = parity;
    record[7] = stop_bits;
    let crc = reference_crc(&record[..8]);
    record[8..10].copy_from_slice(&crc.to_le_bytes());
    record
}

fn damaged(mut record: [u8; RECORD_LEN]) -> [u8; RECORD_LEN] {
    record[4] ^= 0x10;
    record
}

fn load(bytes: [u8; SLOTS_LEN]) -> Option<Config> {
    Slots::new(bytes).load()
}

fn apply(bytes: &mut [u8; SLOTS_LEN], writes: &[Write]) {
    for write in writes {
        bytes[usize::from(write.offset)] = write.byte;
    }
}

/// The bytes after storing `config` over `before`, completely.
fn stored(before: [u8; SLOTS_LEN], config: &Config) -> [u8; SLOTS_LEN] {
    let mut bytes = before;
    apply(&mut bytes, &Slots::new(before).store(config).collect::<Vec<_>>());
    bytes
}

/// What a reset can leave of a store: the first `complete` writes done, and maybe the next
/// one torn, its byte reading `torn`.
struct ResetPoint {
    complete: usize,
    torn: Option<u8>,
    bytes: [u8; SLOTS_LEN],
}

/// Every state a reset can leave while `config` is stored over `before`: after each of the
/// writes (and before the first), and during each, with the byte it writes reading each
/// of `torn_values`.
fn reset_points(before: [u8; SLOTS_LEN], config: &Config, torn_values: &[u8]) -> Vec<ResetPoint> {
    let writes: Vec<Write> = Slots::new(before).store(config).collect();
    let mut points = Vec::new();
    for complete in 0..=writes.len() {
        let mut bytes = before;
        apply(&mut bytes, &writes[..complete]);
        points.push(ResetPoint { complete, torn: None, bytes });
        if let Some(next) = writes.get(complete) {
            for &value in torn_values {
                let mut torn = bytes;
                torn[usize::from(next.offset)] = value;
                points.push(ResetPoint { complete, torn: Some(value), bytes: torn });
            }
        }
    }
    points
}

/// After a reset anywhere in the store of `new` over `before`, the slots load the old
/// settings until the store's last write is complete (or torn into the very value it
/// writes), and `new` from then on. Returns the number of writes.
fn assert_old_or_new(before: [u8; SLOTS_LEN], new: &Config, torn_values: &[u8]) -> usize {
    let old = load(before);
    let writes: Vec<Write> = Slots::new(before).store(new).collect();
    for point in reset_points(before, new, torn_values) {
        let last_done = point.complete == writes.len()
            || (point.complete + 1 == writes.len() && point.torn == Some(writes[point.complete].byte));
        let expected = if last_done { Some(*new) } else { old };
        assert_eq!(
            load(point.bytes),
            expected,
            "reset after {} of {} writes, torn {:02X?}: {:02X?} (before {before:02X?})",
            point.complete,
            writes.len(),
            point.torn,
            point.bytes
        );
    }
    writes.len()
}

/// Every value a torn byte can read.
fn every_byte() -> Vec<u8> {
    (0..=255).collect()
}

// ---- load ------------------------------------------------------------------------------------

#[test]
fn both_slots_blank_load_nothing() {
    assert_eq!(load([0xFF; SLOTS_LEN]), None);
    assert_eq!(load([0x00; SLOTS_LEN]), None);
}

#[test]
fn both_slots_damaged_load_nothing() {
    assert_eq!(load(slots(damaged(encode(&OLD, 1)), damaged(encode(&NEW, 2)))), None);
    assert_eq!(load(slots(damaged(legacy(&OLD)), damaged(encode(&NEW, 2)))), None);
}

#[test]
fn one_valid_slot_is_loaded_whichever_it_is() {
    assert_eq!(load(slots(encode(&OLD, 1), BLANK)), Some(OLD));
    assert_eq!(load(slots(BLANK, encode(&OLD, 1))), Some(OLD));
    assert_eq!(load(slots(encode(&OLD, 1), damaged(encode(&NEW, 2)))), Some(OLD));
    assert_eq!(load(slots(damaged(encode(&NEW, 2)), encode(&OLD, 1))), Some(OLD));
}

#[test]
fn the_newer_sequence_number_wins_in_either_slot() {
    assert_eq!(load(slots(encode(&OLD, 1), encode(&NEW, 2))), Some(NEW));
    assert_eq!(load(slots(encode(&NEW, 2), encode(&OLD, 1))), Some(NEW));
}

#[test]
fn sequence_comparison_wraps() {
    assert!(is_newer(0, 255));
    assert!(is_newer(127, 0));
    assert!(!is_newer(128, 0), "128 ahead is as far behind: neither is newer");
    assert!(!is_newer(0, 128));
    assert!(!is_newer(5, 5));
    assert_eq!(load(slots(encode(&OLD, 255), encode(&NEW, 0))), Some(NEW));
    assert_eq!(load(slots(encode(&NEW, 0), encode(&OLD, 255))), Some(NEW));
    // Neither is newer (equal, or 128 apart): slot A.
    assert_eq!(load(slots(encode(&NEW, 7), encode(&OLD, 7))), Some(NEW));
    assert_eq!(load(slots(encode(&NEW, 200), encode(&OLD, 72))), Some(NEW));
}

#[test]
fn a_format_1_record_is_loaded_as_the_oldest() {
    assert_eq!(
        Slots::new(slots(legacy(&OLD), BLANK)).newest(),
        Some(Newest { slot: Slot::A, sequence: None, config: OLD })
    );
    assert_eq!(load(slots(legacy(&OLD), encode(&NEW, 0))), Some(NEW));
    assert_eq!(load(slots(legacy(&OLD), encode(&NEW, 200))), Some(NEW));
    assert_eq!(load(slots(legacy(&OLD), damaged(encode(&NEW, 0)))), Some(OLD));
}

// ---- store -----------------------------------------------------------------------------------

#[test]
fn first_store_goes_to_slot_b_numbered_0() {
    let after = stored([0xFF; SLOTS_LEN], &NEW);
    assert_eq!(after, slots(BLANK, encode(&NEW, 0)));
}

#[test]
fn store_goes_to_the_slot_without_the_newest_record_numbered_one_past_it() {
    let a_newest = slots(encode(&OLD, 4), encode(&OLDER, 3));
    assert_eq!(stored(a_newest, &NEW), slots(encode(&OLD, 4), encode(&NEW, 5)));
    let b_newest = slots(encode(&OLDER, 3), encode(&OLD, 4));
    assert_eq!(stored(b_newest, &NEW), slots(encode(&NEW, 5), encode(&OLD, 4)));
    let wrap = slots(encode(&OLDER, 254), encode(&OLD, 255));
    assert_eq!(stored(wrap, &NEW), slots(encode(&NEW, 0), encode(&OLD, 255)));
}

#[test]
fn first_store_over_a_format_1_record_keeps_it_until_the_next() {
    let before = slots(legacy(&OLD), BLANK);
    let after = stored(before, &NEW);
    assert_eq!(after, slots(legacy(&OLD), encode(&NEW, 0)));
    assert_eq!(load(after), Some(NEW));
    assert_eq!(stored(after, &DEFAULT), slots(encode(&DEFAULT, 1), encode(&NEW, 0)));
}

#[test]
fn store_invalidates_the_magic_first_and_writes_it_last() {
    let before = slots(encode(&OLDER, 3), encode(&OLD, 4));
    let writes: Vec<Write> = Slots::new(before).store(&NEW).collect();
    assert_eq!(writes.first(), Some(&Write { offset: 0, byte: 0xFF }));
    assert_eq!(writes.last(), Some(&Write { offset: 0, byte: MAGIC }));
    assert!(writes[1..writes.len() - 1].iter().all(|w| (1..RECORD_LEN as u16).contains(&w.offset)));
    // Over a blank slot there is no magic to invalidate.
    let writes: Vec<Write> = Slots::new(slots(encode(&OLD, 4), BLANK)).store(&NEW).collect();
    let b = RECORD_LEN as u16;
    assert_eq!(writes.first(), Some(&Write { offset: b + 1, byte: 5 }), "the sequence number");
    assert_eq!(writes.last(), Some(&Write { offset: b, byte: MAGIC }));
    assert_eq!(writes.iter().filter(|w| w.offset == b).count(), 1);
}

#[test]
fn store_over_a_format_1_record_invalidates_its_magic_too() {
    let before = slots(legacy(&OLDER), encode(&OLD, 9));
    assert_eq!(before[0], LEGACY_MAGIC);
    assert_eq!(Slots::new(before).store(&NEW).next(), Some(Write { offset: 0, byte: 0xFF }));
}

#[test]
fn store_skips_bytes_already_right() {
    // Slot A holds OLD as number 3, slot B OLD as number 4: storing NEW, which differs
    // from OLD only in its id, rewrites the magic (twice), the sequence number, the id
    // and the CRC.
    let new = Config::new(6, 9600, Parity::None, StopBits::Two);
    let before = slots(encode(&OLD, 3), encode(&OLD, 4));
    let offsets: Vec<u16> = Slots::new(before).store(&new).map(|w| w.offset).collect();
    assert_eq!(offsets, [0, 1, 2, 9, 10, 0]);
}

#[test]
fn the_settings_of_the_newest_record_are_not_stored_again() {
    for before in [slots(encode(&OLDER, 3), encode(&OLD, 4)), slots(legacy(&OLD), BLANK)] {
        assert_eq!(Slots::new(before).store(&OLD).count(), 0);
    }
    // Equal to the older record only: stored.
    assert_ne!(Slots::new(slots(encode(&OLDER, 3), encode(&OLD, 4))).store(&OLDER).count(), 0);
}

#[test]
fn a_store_takes_at_most_twelve_writes() {
    assert_eq!(MAX_WRITES, 12);
    let before = slots(encode(&OLD, 4), [MAGIC; RECORD_LEN]);
    assert_eq!(Slots::new(before).store(&NEW).count(), 12);
}

// ---- a reset during a store ------------------------------------------------------------------

#[test]
fn reset_during_a_store_over_a_blank_slot_leaves_old_or_new() {
    let writes = assert_old_or_new(slots(encode(&OLD, 4), BLANK), &NEW, &every_byte());
    assert_eq!(writes, 11);
}

#[test]
fn reset_during_a_store_over_an_older_record_leaves_old_or_new() {
    assert_old_or_new(slots(encode(&OLD, 4), encode(&OLDER, 3)), &NEW, &every_byte());
    assert_old_or_new(slots(encode(&OLDER, 3), encode(&OLD, 4)), &NEW, &every_byte());
}

#[test]
fn a_half_rewritten_record_can_pass_its_crc_so_its_magic_goes_first() {
    // Found by search: rewriting the older record of slot A as number 4 of `new`, bytes 1-5
    // new and 6-10 old make a record whose CRC is right, of settings nobody wrote. With
    // its magic still there, a reset at that point would start the device with them.
    let older = encode(&Config::new(3, 9600, Parity::None, StopBits::Two), 2);
    let new = Config::new(9, 115_200, Parity::Odd, StopBits::One);
    let mut mixed = older;
    mixed[1..6].copy_from_slice(&encode(&new, 4)[1..6]);
    let nobodys = Config::new(9, 115_200, Parity::None, StopBits::Two);
    assert_eq!(decode(&mixed), Some(Record { sequence: 4, config: nobodys }));
    // The store invalidates the magic first: old or new after a reset anywhere.
    let before = slots(older, encode(&OLD, 3));
    assert_eq!(Slots::new(before).store(&new).next(), Some(Write { offset: 0, byte: 0xFF }));
    assert_old_or_new(before, &new, &every_byte());
}

#[test]
fn reset_during_a_store_across_the_sequence_wrap_leaves_old_or_new() {
    assert_old_or_new(slots(encode(&OLDER, 254), encode(&OLD, 255)), &NEW, &every_byte());
    assert_old_or_new(slots(encode(&OLD, 255), encode(&OLDER, 254)), &NEW, &every_byte());
    assert_old_or_new(slots(encode(&OLDER, 255), encode(&OLD, 0)), &NEW, &every_byte());
}

#[test]
fn reset_during_a_store_over_a_damaged_record_leaves_old_or_new() {
    // A damaged record that still starts with the magic: invalidated first.
    assert_old_or_new(slots(encode(&OLD, 4), damaged(encode(&OLDER, 3))), &NEW, &every_byte());
    assert_old_or_new(slots(damaged(encode(&OLDER, 5)), encode(&OLD, 4)), &NEW, &every_byte());
    let garbage: [u8; RECORD_LEN] = core::array::from_fn(|i| (i as u8).wrapping_mul(37));
    assert_old_or_new(slots(garbage, encode(&OLD, 4)), &NEW, &every_byte());
}

#[test]
fn reset_during_a_store_after_a_format_1_record_leaves_old_or_new() {
    // First store: slot B, the format-1 record untouched.
    assert_old_or_new(slots(legacy(&OLD), BLANK), &NEW, &every_byte());
    // Second: over the format-1 record, slot B holding the newest.
    assert_old_or_new(slots(legacy(&OLDER), encode(&OLD, 0)), &NEW, &every_byte());
}

#[test]
fn reset_during_the_first_store_leaves_nothing_or_new() {
    // Nothing valid before: the default, or the new settings once complete.
    assert_old_or_new([0xFF; SLOTS_LEN], &NEW, &every_byte());
    assert_old_or_new(slots(damaged(encode(&OLD, 1)), damaged(encode(&OLDER, 2))), &NEW, &every_byte());
}

#[test]
fn three_hundred_stores_wrap_the_sequence_and_each_survives_a_reset_anywhere() {
    let configs = [OLD, NEW, OLDER, DEFAULT, Config::new(247, 1200, Parity::Odd, StopBits::Two)];
    let mut bytes = [0xFF; SLOTS_LEN];
    for n in 0..300usize {
        let config = configs[n % configs.len()];
        let writes = assert_old_or_new(bytes, &config, &[0xFF, 0x00, MAGIC, LEGACY_MAGIC, 0xA5]);
        assert!(writes <= MAX_WRITES, "store {n}: {writes} writes");
        bytes = stored(bytes, &config);
        let newest = Slots::new(bytes).newest().unwrap();
        assert_eq!(newest.config, config, "store {n}");
        assert_eq!(newest.sequence, Some(n as u8), "store {n}");
        assert_eq!(newest.slot, if n % 2 == 0 { Slot::B } else { Slot::A }, "store {n}");
    }
}
