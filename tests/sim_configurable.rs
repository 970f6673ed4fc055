//! Line settings kept in EEPROM, on the release `configurable` firmware in simavr: the
//! master changes the slave id and the line through holding registers 40101–40104, gets
//! its reply at the old settings, and after a reset the slave starts with the new ones; a
//! record left by earlier firmware is still read; damaged records mean the default,
//! 19200 8E1, slave id 1, and so does the recovery jumper (pin 12 to GND). A reset during
//! a store: `sim_settings_reset`.

mod configurable;
mod sim;

use configurable::{
    ascii_frame, assert_usart_runs, legacy_record, record, slots, write_block, Board, B9600_8N2, BLOCK, JUMPER,
    SLOTS_AT, SLOT_LEN,
};
use sim::{cycles_to_us, read_request, us_to_cycles, with_crc, Exchange, Line, ID};
use uno_sim::Parity;

/// Every character of the reply lasted `char_cycles` (those of `line`), with no gap over
/// T1.5 between two of them (the write is checked between the address byte and the rest).
fn assert_reply_chars(exchange: &Exchange, line: Line, char_cycles: u64, what: &str) {
    assert!(!exchange.reply.is_empty(), "{what}: no reply");
    for byte in &exchange.reply {
        assert_eq!(byte.end_cycle - byte.start_cycle, char_cycles, "{what}: {byte:?}");
    }
    assert!(exchange.max_reply_gap() <= line.t15(), "{what}: gap of {} cycles", exchange.max_reply_gap());
}

#[test]
fn blank_eeprom_starts_at_the_default() {
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    assert_eq!(board.uno.eeprom(), vec![0xFF; 1024]);
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x04, 0, 3), Some(vec![0, 0, 0]), "30001: default; nothing saved");
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]), "40101-40104");
}

#[test]
fn new_id_and_line_take_effect_after_the_reply_and_survive_a_reset() {
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    let old_char = board.char_cycles();
    let exchange = board.exchange(&write_block(ID, [7, 96, 0, 2])); // id 7, 9600 8N2
                                                                    // The reply is the FC 16 echo from the old address, every character at the old rate.
    assert_eq!(exchange.bytes(), with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x04]));
    assert_reply_chars(&exchange, Line::B19200_8E1, old_char, "reply to the write");
    board.settle(B9600_8N2);
    assert_usart_runs(&board.uno, B9600_8N2);
    // The first store goes to slot B, as number 0.
    assert_eq!(board.slots(), slots(&[], &record(0, 7, B9600_8N2)));

    // At once, before any reset: the new id answers at the new rate, the old one is silent.
    assert!(board.exchange(&read_request(ID, 0x03, BLOCK, 4)).reply.is_empty(), "old id");
    let exchange = board.exchange(&read_request(7, 0x03, BLOCK, 4));
    assert_eq!(exchange.bytes(), with_crc(&[7, 0x03, 0x08, 0, 7, 0, 96, 0, 0, 0, 2]));
    assert_reply_chars(&exchange, B9600_8N2, board.char_cycles(), "new line");
    // 30002: all 11 bytes of the record written (none of them is 0xFF); 30003: one save.
    assert_eq!(board.read(7, 0x04, 1, 2), Some(vec![11, 1]));

    let mut board = board.reset(B9600_8N2);
    assert_usart_runs(&board.uno, B9600_8N2);
    assert_eq!(board.read(7, 0x04, 0, 3), Some(vec![1, 0, 0]), "30001: EEPROM; nothing saved yet");
    assert_eq!(board.read(7, 0x03, BLOCK, 4), Some(vec![7, 96, 0, 2]));
}

/// Runs the exchange of `request` in small steps and returns the reply and the cycle at
/// which USART0's rate register first changed (`None`: not within 20 ms).
fn switch_time(board: &mut Board, request: &[u8]) -> (Exchange, Option<u64>) {
    let before = board.uno.serial_config();
    let request_end = board.send(request);
    let mut reply = Vec::new();
    let mut switched = None;
    while board.uno.now() < request_end + us_to_cycles(20_000) {
        board.uno.run_for(16).expect("firmware runs");
        reply.extend(board.uno.take_tx());
        if switched.is_none() && board.uno.serial_config() != before {
            switched = Some(board.uno.now());
        }
    }
    board.quiet_since = board.uno.now();
    (Exchange { request_end, reply }, switched)
}

#[test]
fn switch_waits_for_the_reply_when_the_config_is_ready_first() {
    // At 19200 the 8-byte reply lasts ≈4.6 ms, longer than computing the new
    // configuration: the transmit-complete interrupt switches.
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    let old_char = board.char_cycles();
    let (exchange, switched) = switch_time(&mut board, &write_block(ID, [1, 96, 2, 1]));
    assert_reply_chars(&exchange, Line::B19200_8E1, old_char, "reply");
    let reply_end = exchange.reply.last().unwrap().end_cycle;
    let switched = switched.expect("switched");
    assert!(switched >= reply_end, "switched at {switched}, reply ended at {reply_end}");
    assert!(switched - reply_end < us_to_cycles(50), "switched {} cycles after the reply", switched - reply_end);
}

#[test]
fn switch_waits_for_the_config_when_the_reply_ends_first() {
    // At 115200 the reply lasts ≈0.8 ms: the main loop switches when it has the
    // configuration, ≈3 ms after the request.
    let stored = slots(&record(0, ID, Line::B115200_8E1), &[]);
    let mut board = Board::boot(Line::B115200_8E1, |uno| uno.write_eeprom(SLOTS_AT, &stored).unwrap());
    assert_usart_runs(&board.uno, Line::B115200_8E1);
    let old_char = board.char_cycles();
    let (exchange, switched) = switch_time(&mut board, &write_block(ID, [1, 192, 2, 1]));
    assert_eq!(exchange.bytes(), with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x04]));
    assert_reply_chars(&exchange, Line::B115200_8E1, old_char, "reply");
    let reply_end = exchange.reply.last().unwrap().end_cycle;
    let switched = switched.expect("switched");
    assert!(switched > reply_end, "switched at {switched}, reply ended at {reply_end}");
    eprintln!(
        "115200: reply ended {} µs and the switch came {} µs after the request",
        (reply_end - exchange.request_end) / 16,
        (switched - exchange.request_end) / 16
    );
    assert!(switched - exchange.request_end < us_to_cycles(10_000), "switch took too long");
    board.settle(Line::B19200_8E1);
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
}

#[test]
fn fc6_of_the_baud_rate_rewrites_only_the_bytes_that_changed() {
    let mut board = Board::boot(Line::B19200_8E1, |uno| {
        // Slot A newest (number 1), slot B an older record of the same settings (number 0).
        let stored = slots(&record(1, ID, Line::B19200_8E1), &record(0, ID, Line::B19200_8E1));
        uno.write_eeprom(SLOTS_AT, &stored).unwrap();
    });
    assert_eq!(board.read(ID, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x65, // register address lo: 40102
        0x04, // value hi
        0x80, // value lo: 1152 = 115200 bps
    ]);
    let old_char = board.char_cycles();
    let exchange = board.exchange(&write);
    assert_eq!(exchange.bytes(), write);
    assert_reply_chars(&exchange, Line::B19200_8E1, old_char, "reply to the write");
    board.settle(Line::B115200_8E1);
    assert_usart_runs(&board.uno, Line::B115200_8E1);
    let new = record(2, ID, Line::B115200_8E1);
    assert_eq!(board.slots(), slots(&record(1, ID, Line::B19200_8E1), &new));
    // Into slot B as number 2: its magic invalidated, then the sequence number, baud
    // bytes 0x4B 0x00 → 0xC2 0x01 (19200 → 115200), the two CRC bytes, the magic again.
    assert_eq!(board.read(ID, 0x04, 1, 1), Some(vec![7]));

    let mut board = board.reset(Line::B115200_8E1);
    assert_usart_runs(&board.uno, Line::B115200_8E1);
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 1152, 2, 1]));
}

#[test]
fn settings_the_slave_cant_run_are_exception_03_and_change_nothing() {
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    for (values, what) in [
        ([0, 192, 2, 1], "slave id 0"),
        ([248, 192, 2, 1], "slave id 248"),
        ([1, 2304, 2, 1], "230400 bps"),
        ([1, 11, 2, 1], "1100 bps"),
        ([1, 192, 3, 1], "parity 3"),
        ([1, 192, 2, 3], "3 stop bits"),
    ] {
        let reply = board.ask(&write_block(ID, values));
        assert_eq!(reply, with_crc(&[ID, 0x90, 0x03]), "{what}");
    }
    board.settle(Line::B19200_8E1);
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
    assert_eq!(board.uno.eeprom(), vec![0xFF; 1024], "EEPROM untouched");
}

#[test]
fn damaged_records_fall_back_to_the_default() {
    let damaged = |mut bytes: Vec<u8>| {
        bytes[4] ^= 0x10; // one bit of the baud rate
        bytes
    };
    let ramp: Vec<u8> = (0..2 * SLOT_LEN as u8).map(|i| i.wrapping_mul(37)).collect();
    for garbage in [
        slots(&damaged(record(3, 7, B9600_8N2)), &damaged(record(4, 7, B9600_8N2))),
        slots(&damaged(legacy_record(7, B9600_8N2)), &damaged(record(0, 7, B9600_8N2))),
        vec![0x4E; 2 * SLOT_LEN],
        vec![0x4D; 2 * SLOT_LEN],
        vec![0x00; 2 * SLOT_LEN],
        ramp,
    ] {
        let mut board = Board::boot(Line::B19200_8E1, |uno| uno.write_eeprom(SLOTS_AT, &garbage).unwrap());
        assert_usart_runs(&board.uno, Line::B19200_8E1);
        assert_eq!(board.read(ID, 0x04, 0, 1), Some(vec![0]), "30001 with {garbage:02X?}");
        assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
    }
}

#[test]
fn one_damaged_slot_leaves_the_other() {
    let mut damaged = record(5, 3, Line::B19200_8O1);
    damaged[4] ^= 0x10;
    let stored = slots(&damaged, &record(4, 7, B9600_8N2));
    let mut board = Board::boot(B9600_8N2, |uno| uno.write_eeprom(SLOTS_AT, &stored).unwrap());
    assert_usart_runs(&board.uno, B9600_8N2);
    assert_eq!(board.read(7, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
    assert_eq!(board.read(7, 0x03, BLOCK, 4), Some(vec![7, 96, 0, 2]));
}

#[test]
fn record_of_earlier_firmware_is_used_and_kept_until_the_second_store() {
    let legacy = legacy_record(7, B9600_8N2);
    let mut board = Board::boot(B9600_8N2, |uno| uno.write_eeprom(SLOTS_AT, &legacy).unwrap());
    assert_usart_runs(&board.uno, B9600_8N2);
    assert_eq!(board.read(7, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
    assert_eq!(board.read(7, 0x03, BLOCK, 4), Some(vec![7, 96, 0, 2]));

    let reply = board.ask(&write_block(7, [3, 192, 1, 1])); // id 3, 19200 8O1
    assert_eq!(reply, with_crc(&[7, 0x10, 0x00, 0x64, 0x00, 0x04]));
    board.settle(Line::B19200_8O1);
    assert_eq!(board.slots(), slots(&legacy, &record(0, 3, Line::B19200_8O1)), "format-1 record kept");
    let mut board = board.reset(Line::B19200_8O1);
    assert_usart_runs(&board.uno, Line::B19200_8O1);
    assert_eq!(board.read(3, 0x03, BLOCK, 4), Some(vec![3, 192, 1, 1]));

    let reply = board.ask(&write_block(3, [4, 192, 1, 1])); // id 4
    assert_eq!(reply, with_crc(&[3, 0x10, 0x00, 0x64, 0x00, 0x04]));
    board.settle(Line::B19200_8O1);
    assert_eq!(board.slots(), slots(&record(1, 4, Line::B19200_8O1), &record(0, 3, Line::B19200_8O1)));
    let mut board = board.reset(Line::B19200_8O1);
    assert_eq!(board.read(4, 0x03, BLOCK, 4), Some(vec![4, 192, 1, 1]));
}

#[test]
fn jumper_forces_the_default_over_a_good_record() {
    let stored = slots(&record(0, 7, B9600_8N2), &[]);
    let mut board = Board::boot(Line::B19200_8E1, |uno| {
        uno.write_eeprom(SLOTS_AT, &stored).unwrap();
        uno.drive_pin(JUMPER, Some(false)).unwrap();
    });
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x04, 0, 1), Some(vec![2]), "30001: jumper");
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
    assert_eq!(board.slots(), stored, "record kept");

    // Jumper removed, reset: the stored settings again.
    let mut board = board.reset(B9600_8N2);
    assert_usart_runs(&board.uno, B9600_8N2);
    assert_eq!(board.read(7, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
}

#[test]
fn settings_written_with_the_jumper_on_are_stored() {
    let mut board = Board::boot(Line::B19200_8E1, |uno| {
        uno.write_eeprom(SLOTS_AT, &[0x12; 10]).unwrap();
        uno.drive_pin(JUMPER, Some(false)).unwrap();
    });
    let reply = board.ask(&write_block(ID, [3, 192, 1, 1])); // id 3, 19200 8O1
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x04]));
    board.settle(Line::B19200_8O1);
    assert_eq!(board.slots(), slots(&[0x12; 10], &record(0, 3, Line::B19200_8O1)));
    let mut board = board.reset(Line::B19200_8O1);
    assert_usart_runs(&board.uno, Line::B19200_8O1);
    assert_eq!(board.read(3, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
}

/// 19200 bps 7E1: the default line in ASCII.
const B19200_7E1: Line = Line { data_bits: 7, ..Line::B19200_8E1 };

#[test]
fn writing_1_to_40105_switches_to_ascii_on_the_same_line_and_a_reset_keeps_it() {
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // address hi
        0x68, // address lo: 40105, the mode
        0x00, // value hi
        0x01, // value lo: ASCII
    ]);
    // Answered in RTU: the switch comes once the reply has left the wire.
    assert_eq!(board.ask(&write), write);
    board.settle(B19200_7E1);
    let cfg = board.uno.serial_config().expect("USART0 enabled");
    assert!(cfg.matches(19_200, 7, Parity::Even, 1), "{cfg:?}");
    let read_block = ascii_frame(&[ID, 0x03, 0x00, 0x64, 0x00, 0x05]);
    let block_reply = ascii_frame(&[ID, 0x03, 0x0A, 0, ID, 0, 192, 0, 2, 0, 1, 0, 1]);
    assert_eq!(board.ask(&read_block), block_reply);
    // An RTU frame is no longer understood.
    assert!(board.ask(&read_request(ID, 0x03, BLOCK, 5)).is_empty());
    // The record keeps the mode in the high nibble of its stop-bits byte.
    assert_eq!(board.slots()[SLOT_LEN + 8], 0x11, "{:02X?}", board.slots());

    let mut board = board.reset(B19200_7E1);
    assert_eq!(board.ask(&read_block), block_reply, "ASCII after the reset");
    // Back to RTU with a write in ASCII.
    let back = ascii_frame(&[ID, 0x06, 0x00, 0x68, 0x00, 0x00]);
    assert_eq!(board.ask(&back), back);
    board.settle(Line::B19200_8E1);
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x03, BLOCK, 5), Some(vec![1, 192, 2, 1, 0]));
}

/// ASCII with two stop bits (9600 7N2, started from a record whose stop-bits byte carries
/// the mode): the USART flags each character a bit and a half before its last stop bit
/// ends, and the reply's `:` still waits for the LF to leave the line, then comes within a
/// character.
#[test]
fn in_ascii_with_two_stop_bits_the_reply_waits_for_the_lfs_last_stop_bit() {
    let line = Line { data_bits: 7, ..B9600_8N2 };
    let mut fields = vec![0x4E, 0, ID]; // magic, sequence, id
    fields.extend_from_slice(&9600u32.to_le_bytes());
    fields.extend_from_slice(&[0, 0x12]); // parity none; ASCII (high nibble), 2 stop bits
    let stored = slots(&with_crc(&fields), &[]);
    let mut board = Board::boot(line, |uno| uno.write_eeprom(SLOTS_AT, &stored).unwrap());
    let cfg = board.uno.serial_config().expect("USART0 enabled");
    assert!(cfg.matches(9600, 7, Parity::None, 2), "{cfg:?}");
    let lead = board.uno.rx_flag_lead().expect("USART0 enabled");
    assert_eq!(lead, 3 * cfg.bit_cycles / 2);
    let request = ascii_frame(&[ID, 0x03, 0x00, 0x00, 0x00, 0x04]);
    let (mut least, mut most) = (u64::MAX, 0);
    for i in 0..20 {
        // Each request a few cycles later against Timer0's ticks.
        board.uno.run_for(37 * i).unwrap();
        let exchange = board.exchange(&request);
        assert_eq!(exchange.bytes(), ascii_frame(&[ID, 0x03, 0x08, 0, 0, 0, 0, 0, 0, 0, 0]), "request {i}");
        let turnaround = exchange.turnaround().expect("a reply");
        assert!(turnaround < board.char_cycles(), "request {i}: reply {turnaround} cycles after the LF");
        least = least.min(turnaround);
        most = most.max(turnaround);
    }
    eprintln!(
        "ascii 9600 7N2: the reply's `:` starts {:.1}..{:.1} us after the LF's last stop bit ends, RXC0 {:.1} us \
         before it",
        cycles_to_us(least),
        cycles_to_us(most),
        cycles_to_us(lead)
    );
}

#[test]
fn writing_3_to_40106_delays_every_reply_3_ms_after_t35_and_a_reset_keeps_it() {
    let mut board = Board::boot(Line::B19200_8E1, |_| {});
    let line = Line::B19200_8E1;
    let turnaround = |board: &mut Board| {
        let exchange = board.exchange(&read_request(ID, 0x03, BLOCK, 6));
        assert_eq!(exchange.bytes().len(), 5 + 12, "a reply to the block's read");
        exchange.turnaround().unwrap()
    };
    let before = turnaround(&mut board);
    assert!(before < line.t35() + us_to_cycles(40), "no delay yet: {} µs", cycles_to_us(before));
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // address hi
        0x69, // address lo: 40106, the reply delay
        0x00, // value hi
        0x03, // value lo: 3 ms
    ]);
    // Answered at once: the new settings apply once the reply has left the wire.
    assert_eq!(board.ask(&write), write);
    board.settle(line);
    let after = turnaround(&mut board);
    let past = cycles_to_us(after) - cycles_to_us(line.t35());
    println!("reply delay 3 ms: the reply starts {past:.1} µs after T3.5");
    assert!((3000.0..3040.0).contains(&past), "{past:.1} µs after T3.5");
    assert_eq!(board.read(ID, 0x03, BLOCK, 6), Some(vec![1, 192, 2, 1, 0, 3]));
    // Kept in EEPROM: a reset starts with the delay.
    let mut board = board.reset(line);
    let past = cycles_to_us(turnaround(&mut board)) - cycles_to_us(line.t35());
    assert!((3000.0..3040.0).contains(&past), "after the reset: {past:.1} µs after T3.5");
}
