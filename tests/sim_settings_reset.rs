//! A reset at any instant of a settings store, on the release `configurable` firmware in
//! simavr. The master writes a new slave id and line; the harness watches the EEPROM byte
//! by byte and resets the Uno while the reply is on the wire, once the slave has switched
//! (just before the store's first byte), right after each byte of the store, and during
//! each byte (modelled as that byte erased, or half-written). After every reset the next
//! start-up must answer at the complete old settings or the complete new ones, the new
//! ones exactly when the store's last byte is written, and never at the default (19200
//! 8E1, slave id 1), which neither of them is.

mod configurable;
mod sim;

use configurable::{block, legacy_record, record, slots, write_block, Board, B9600_8N2, BLOCK, SLOTS_AT, SLOT_LEN};
use sim::{read_request, us_to_cycles, with_crc, Line};
use uno_sim::{Parity, Uno};

/// A slave id and line.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    id: u8,
    line: Line,
}

impl Settings {
    fn name(&self) -> String {
        format!("id {} at {}", self.id, self.line.name())
    }
}

/// Settings stored before the old ones, left in the slot the store overwrites.
const OLDER: Settings = Settings { id: 3, line: B9600_8N2 };
/// The settings the slave starts with.
const OLD: Settings = Settings { id: 5, line: Line::B19200_8N2 };
/// The settings the master writes.
const NEW: Settings = Settings { id: 9, line: Line { baud: 115_200, parity: Parity::Odd, stop_bits: 1, data_bits: 8 } };

/// Simulated cycles between two looks at the board: far fewer than one EEPROM byte takes
/// the firmware (a read of the old value, the write sequence), so every byte is seen
/// alone.
const STEP: u64 = 8;

/// Where in the handling of the write the harness resets the Uno.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Moment {
    /// The reply to the write is on the wire; the slave still runs the old settings.
    Answering,
    /// The slave runs the new settings; no EEPROM byte of the store is written yet.
    Switched,
    /// Right after the store's `n`th EEPROM byte (from 1) was written.
    Written(usize),
}

/// One EEPROM byte of the store.
#[derive(Clone, Copy, Debug)]
struct ByteWrite {
    address: usize,
    before: u8,
    after: u8,
}

/// What the harness saw up to the moment it stopped.
struct Run {
    board: Board,
    reply: Vec<u8>,
    moments: Vec<Moment>,
    writes: Vec<ByteWrite>,
}

/// Boots with `eeprom` in the slots, has the master write `NEW` to the slave at `OLD`, and
/// watches until `until` (`None`: until the store is long over).
fn run_to(eeprom: &[u8], until: Option<Moment>) -> Run {
    let mut board = Board::boot(OLD.line, |uno| uno.write_eeprom(SLOTS_AT, eeprom).unwrap());
    let old_usart = board.uno.serial_config();
    let request_end = board.send(&write_block(OLD.id, block(NEW.id, NEW.line)));
    board.uno.run_until(request_end).expect("firmware runs");
    let mut run = Run { board, reply: Vec::new(), moments: Vec::new(), writes: Vec::new() };
    let mut seen = run.board.slots();
    let deadline = request_end + us_to_cycles(100_000);
    while run.board.uno.now() < deadline {
        run.board.uno.run_for(STEP).expect("firmware runs");
        let mut moment = None;
        let sent = run.board.uno.take_tx();
        if !sent.is_empty() && run.reply.is_empty() {
            moment = Some(Moment::Answering);
        }
        run.reply.extend(sent.iter().map(|t| t.byte));
        if run.board.uno.serial_config() != old_usart && !run.moments.contains(&Moment::Switched) {
            assert_eq!(moment, None, "switched while the reply started");
            moment = Some(Moment::Switched);
        }
        let now = run.board.slots();
        let changed: Vec<usize> = (0..now.len()).filter(|&i| now[i] != seen[i]).collect();
        if let Some(&address) = changed.first() {
            assert_eq!(changed.len(), 1, "several bytes in {STEP} cycles: {seen:02X?} → {now:02X?}");
            assert_eq!(moment, None, "a byte written at {moment:?}");
            run.writes.push(ByteWrite { address: SLOTS_AT + address, before: seen[address], after: now[address] });
            moment = Some(Moment::Written(run.writes.len()));
            seen = now;
        }
        if let Some(moment) = moment {
            run.moments.push(moment);
            if Some(moment) == until {
                return run;
            }
        }
    }
    assert_eq!(until, None, "{until:?} never came; saw {:?}", run.moments);
    run
}

/// A reset point: the moment, and for a reset during a byte's write, the address and what
/// the byte reads afterwards.
#[derive(Clone, Copy, Debug)]
struct ResetPoint {
    moment: Moment,
    torn: Option<(usize, u8)>,
}

/// A byte write cut short. Erase and write: an erase cut short leaves some of the old
/// value's bits set, a write cut short some of the new value's 0 bits still 1. Returns
/// one such value.
fn half_written(write: ByteWrite) -> u8 {
    let unwritten = !write.after;
    if unwritten & 0x0F != 0 {
        write.after | (unwritten & 0x0F)
    } else if unwritten & 0xF0 != 0 {
        write.after | (unwritten & 0xF0)
    } else {
        write.before | 0x0F
    }
}

/// Every reset point of a store made of `writes`: while answering, once switched, after
/// each byte and during each (erased, half-written; values equal to the byte before or
/// after the write leave a state already covered, and are left out).
fn reset_points(writes: &[ByteWrite]) -> Vec<ResetPoint> {
    let mut points =
        vec![ResetPoint { moment: Moment::Answering, torn: None }, ResetPoint { moment: Moment::Switched, torn: None }];
    for (k, write) in writes.iter().enumerate() {
        let mut torn_values = vec![0xFF, half_written(*write)];
        torn_values.dedup();
        for value in torn_values {
            if value != write.before && value != write.after {
                points.push(ResetPoint { moment: Moment::Written(k + 1), torn: Some((write.address, value)) });
            }
        }
        points.push(ResetPoint { moment: Moment::Written(k + 1), torn: None });
    }
    points
}

/// Resets the Uno at `point` of the store over `eeprom` and checks that the next start-up
/// runs `expected`, and not `other`.
fn assert_starts_with(eeprom: &[u8], point: ResetPoint, expected: Settings, other: Settings) {
    let what = format!("reset at {point:?}: expected {}", expected.name());
    let run = run_to(eeprom, Some(point.moment));
    let mut uno: Uno = run.board.uno;
    uno.reset().expect("reset");
    if let Some((address, value)) = point.torn {
        uno.write_eeprom(address, &[value]).unwrap();
    }
    let eeprom_after = uno.read_eeprom(SLOTS_AT, 2 * SLOT_LEN).unwrap();
    let mut board = Board::start(uno, expected.line);
    let what = format!("{what}; EEPROM {eeprom_after:02X?}");
    let cfg = board.uno.serial_config().expect("USART0 enabled");
    let line = expected.line;
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, line.parity, line.stop_bits), "{what}: {cfg:?}");
    assert!(cfg.rx_enabled && cfg.tx_enabled && cfg.baud_error(line.baud).abs() <= 0.025, "{what}: {cfg:?}");
    assert_eq!(board.read(expected.id, 0x04, 0, 1), Some(vec![1]), "{what}: 30001 (EEPROM)");
    assert_eq!(board.read(expected.id, 0x03, BLOCK, 4), Some(block(expected.id, expected.line).to_vec()), "{what}");
    assert!(board.exchange(&read_request(other.id, 0x03, BLOCK, 4)).reply.is_empty(), "{what}: {} answers", other.id);
}

/// Records the store over `eeprom`, checks it leaves `expected_slots` in `expected_writes`
/// byte writes, then resets the Uno at every reset point; returns how many.
fn reset_everywhere(eeprom: &[u8], expected_slots: &[u8], expected_writes: usize) -> usize {
    let run = run_to(eeprom, None);
    assert_eq!(run.reply, with_crc(&[OLD.id, 0x10, 0x00, 0x64, 0x00, 0x04]), "reply at the old settings");
    assert_eq!(run.board.slots(), expected_slots, "slots after the store");
    assert_eq!(run.writes.len(), expected_writes, "{:?}", run.writes);
    let order: Vec<Moment> =
        [Moment::Answering, Moment::Switched].into_iter().chain((1..=expected_writes).map(Moment::Written)).collect();
    assert_eq!(run.moments, order, "answer, switch, then the store");

    let points = reset_points(&run.writes);
    for point in &points {
        let complete = point.moment == Moment::Written(expected_writes) && point.torn.is_none();
        let (expected, other) = if complete { (NEW, OLD) } else { (OLD, NEW) };
        assert_starts_with(eeprom, *point, expected, other);
    }
    let torn = points.iter().filter(|p| p.torn.is_some()).count();
    eprintln!(
        "{} reset points: while answering, once switched, after each of {} bytes, {torn} during a byte",
        points.len(),
        run.writes.len()
    );
    points.len()
}

/// Bytes of `new` that differ from `old`.
fn changed(old: &[u8], new: &[u8]) -> usize {
    old.iter().zip(new).filter(|(a, b)| a != b).count()
}

#[test]
fn reset_during_a_store_over_an_older_record_leaves_old_or_new() {
    // Slot B holds OLD (number 3), slot A OLDER (number 2): the store goes to slot A as
    // number 4, its magic invalidated first and written last. Had the magic stayed, slot A
    // with bytes 1-5 new and 6-10 old would pass its CRC (id 9, 115200 8N2: see
    // `settings_slots`), settings nobody wrote.
    let older = record(2, OLDER.id, OLDER.line);
    let old = record(3, OLD.id, OLD.line);
    let new = record(4, NEW.id, NEW.line);
    let writes = 1 + changed(&older[1..], &new[1..]) + 1;
    let points = reset_everywhere(&slots(&older, &old), &slots(&new, &old), writes);
    eprintln!("over an older record: {writes} bytes written, {points} reset points");
}

#[test]
fn reset_during_the_first_store_after_earlier_firmware_leaves_old_or_new() {
    // A format-1 record in slot A, slot B blank: the store goes to slot B as number 0 and
    // leaves the format-1 record as it is.
    let legacy = legacy_record(OLD.id, OLD.line);
    let new = record(0, NEW.id, NEW.line);
    let writes = changed(&[0xFF; SLOT_LEN], &new);
    let points = reset_everywhere(&slots(&legacy, &[]), &slots(&legacy, &new), writes);
    eprintln!("after a format-1 record: {writes} bytes written, {points} reset points");
}
