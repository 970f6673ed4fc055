//! A serial line on a timer's input capture (RX) and compare output (TX) pins, end to end:
//! characters sent with `send_pin_uart` reach the capture unit, the firmware
//! (tests/fw/timer_uart.c, ECHO) replays every captured edge on the compare output 200 ticks
//! later, and `take_pin_uart` reads them back from TX's logged edges.

mod common;

use std::ops::RangeInclusive;

use common::timer_uart::*;
use uno_sim::{Chip, Error, Parity, PinUart, Uno};

const EVEN_19200: PinUart = PinUart::new(19200).parity(Parity::Even);
const TWO_STOP_38400: PinUart = PinUart::new(38400).stop_bits(2);

/// Cycles from an edge on RX to its replay on TX: the capture stamps the tick of edge + 7
/// (synchronizer and noise canceller), the replay comes when the count moves on from that
/// tick + ECHO_TICKS; so 201 ticks, less the edge's phase within its tick.
const ECHO_LAG: RangeInclusive<u64> = (ECHO_TICKS + 1) * TICK..=(ECHO_TICKS + 1) * TICK + 7;

/// The firmware on `chip` replaying RX on TX, its timer at clk/8 with the noise canceller, TX
/// logged: the board, its pins, the counter's start cycle.
fn echo_board(chip: Chip) -> (Uno, Board, u64) {
    let mut uno = boot(chip);
    let base = start(&mut uno, CLK_8 | ICNC);
    command(&mut uno, ECHO, 0);
    let board = board(chip);
    uno.watch_pin(board.tx).unwrap();
    (uno, board, base)
}

/// Sends `bytes` on RX from a little after now, `gap` cycles between characters, and reads
/// TX back once the last one has been replayed: the characters' sent start cycles and what
/// came back.
fn round_trip(
    uno: &mut Uno,
    board: &Board,
    uart: PinUart,
    bytes: &[u8],
    gap: u64,
) -> (Vec<u64>, Vec<uno_sim::DecodedByte>) {
    let first = uno.now() + 1000;
    let end = uno.send_pin_uart(board.rx, bytes, uart, first, gap).unwrap();
    let starts =
        (0..bytes.len() as u32).map(|k| first + u64::from(k) * gap + uart.bit_start(k * uart.char_bits())).collect();
    uno.run_until(end + 2 * *ECHO_LAG.end()).unwrap();
    (starts, uno.take_pin_uart(board.tx, uart).unwrap())
}

fn check_echo(uart: PinUart, bytes: &[u8], starts: &[u64], back: &[uno_sim::DecodedByte]) {
    assert_eq!(back.iter().map(|b| b.byte).collect::<Vec<_>>(), bytes);
    for (b, &sent) in back.iter().zip(starts) {
        assert!(b.parity_ok && b.stop_ok, "{b:?}");
        assert!(ECHO_LAG.contains(&(b.start_cycle - sent)), "{b:?} sent at {sent}");
        assert_eq!(b.end_cycle - b.start_cycle, uart.bit_start(uart.char_bits()));
    }
}

#[test]
fn round_trip_at_19200_8e1_back_to_back() {
    let (mut uno, board, _) = echo_board(Chip::Atmega328p);
    let bytes = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD, 0x55, 0xFF, 0x80];
    let (starts, back) = round_trip(&mut uno, &board, EVEN_19200, &bytes, 0);
    check_echo(EVEN_19200, &bytes, &starts, &back);
    assert_eq!(uno.take_pin_uart(9, EVEN_19200).unwrap(), [], "read once");
}

#[test]
fn round_trip_at_38400_8n2_with_gaps() {
    let (mut uno, board, _) = echo_board(Chip::Atmega328p);
    let bytes = [0xA5, 0x5A, 0x00, 0xFF, 0x01, 0x80];
    let (starts, back) = round_trip(&mut uno, &board, TWO_STOP_38400, &bytes, 777);
    check_echo(TWO_STOP_38400, &bytes, &starts, &back);
    // back to back too: the second stop bit runs into the next start bit
    let (starts, back) = round_trip(&mut uno, &board, TWO_STOP_38400, &bytes, 0);
    check_echo(TWO_STOP_38400, &bytes, &starts, &back);
}

#[test]
fn every_edge_comes_back_on_its_tick() {
    // 0x55 changes the line at every bit: at 38400 baud (416.67 cycles) the edges fall on
    // every phase of the 8-cycle tick
    let (mut uno, board, base) = echo_board(Chip::Atmega328p);
    let uart = TWO_STOP_38400;
    let first = uno.now() + 1001;
    let bytes = [0x55; 16];
    let end = uno.send_pin_uart(board.rx, &bytes, uart, first, 0).unwrap();
    uno.run_until(end + 2 * *ECHO_LAG.end()).unwrap();
    let bits: Vec<bool> = bytes.iter().flat_map(|&b| uart.frame(b)).collect();
    let mut level = true;
    let mut expected = Vec::new();
    for (k, &bit) in (0u32..).zip(&bits) {
        if bit != level {
            let edge = first + uart.bit_start(k);
            let stamp = count_at(base, edge + 3 + 4);
            expected.push((match_after(base, stamp.wrapping_add(ECHO_TICKS as u16), edge), bit));
            level = bit;
        }
    }
    assert_eq!(expected.len(), 16 * 10);
    assert_eq!(uno.take_pin_edges(board.tx).unwrap(), expected);
}

#[test]
fn malformed_characters_come_back_flagged() {
    let (mut uno, board, _) = echo_board(Chip::Atmega328p);
    let uart = EVEN_19200;
    let bit = uart.bit_start(1);
    let char_time = uart.bit_start(uart.char_bits());
    let mut at = uno.now() + 1000;

    // a glitch: low for a quarter of a bit, no start bit
    uno.schedule_pin(board.rx, at, false).unwrap();
    uno.schedule_pin(board.rx, at + bit / 4, true).unwrap();
    at += 2 * char_time;
    // a wrong parity bit
    let mut frame = uart.frame(0x31);
    frame[9] = !frame[9];
    at = uno.send_pin_bits(board.rx, uart, at, &frame).unwrap() + char_time;
    // no stop bit: the line stays low one bit more
    let mut frame = uart.frame(0x31);
    frame[10] = false;
    frame.push(true);
    at = uno.send_pin_bits(board.rx, uart, at, &frame).unwrap() + char_time;
    // a break: low for three characters
    uno.schedule_pin(board.rx, at, false).unwrap();
    uno.schedule_pin(board.rx, at + 3 * char_time, true).unwrap();
    at += 5 * char_time;
    // and a good character after it
    let end = uno.send_pin_uart(board.rx, &[0x42], uart, at, 0).unwrap();
    uno.run_until(end + 2 * *ECHO_LAG.end()).unwrap();

    let back: Vec<(u8, bool, bool)> =
        uno.take_pin_uart(board.tx, uart).unwrap().iter().map(|b| (b.byte, b.parity_ok, b.stop_ok)).collect();
    assert_eq!(back, [(0x31, false, true), (0x31, true, false), (0x00, true, false), (0x42, true, true)]);
}

#[test]
fn timer3_on_the_32u4_and_timer5_on_the_megas() {
    // simavr's 32U4 core links Timer3 to ICP3 (PC7) and OC3A (PC6), the Megas' Timer5 to
    // ICP5 (PL1) and OC5A (PL3), as the chips have them
    for chip in [Chip::Atmega32u4, Chip::Atmega2560, Chip::Atmega1280] {
        let (mut uno, board, _) = echo_board(chip);
        let bytes = b"OK\r\n";
        let (starts, back) = round_trip(&mut uno, &board, EVEN_19200, bytes, 0);
        check_echo(EVEN_19200, bytes, &starts, &back);
    }
}

#[test]
fn pins_formats_and_times_are_checked() {
    let (mut uno, board, _) = echo_board(Chip::Atmega328p);
    let now = uno.now();
    assert!(matches!(uno.schedule_pin(8, now - 1, false), Err(Error::PinInPast { .. })));
    assert!(matches!(uno.take_pin_uart(8, EVEN_19200), Err(Error::PinNotWatched { port: 'B', bit: 0 })));
    assert!(matches!(uno.take_pin_uart(9, PinUart::new(9600).data_bits(9)), Err(Error::BadPinUart(_))));
    assert!(matches!(uno.schedule_pin(20, now, false), Err(Error::BadPin(20))));
    assert!(matches!(uno.watch_pin(('H', 0)), Err(Error::NoSuchPortPin { port: 'H', .. })));
    assert_eq!(board.rx, ('B', 0), "pin 8");
    uno.schedule_pin(('B', 0), now + 10, false).unwrap();
    assert_eq!(uno.pending_pin_levels(), 1);
    uno.run_for(20).unwrap();
    assert!(!uno.pin(8).unwrap().level);
    assert_eq!(uno.pending_pin_levels(), 0);

    let (mut mega, _, _) = echo_board(Chip::Atmega2560);
    assert!(matches!(mega.schedule_pin(48, mega.now() + 10, false), Err(Error::NoArduinoPins(Chip::Atmega2560))));
    mega.schedule_pin(('L', 1), mega.now() + 10, false).unwrap();
}
