//! Timer1's input capture and output compare units against the ATmega328P datasheet (§16,
//! 16-bit Timer/Counter1), in normal mode at clk/8 as a serial line built on the timer uses
//! them: the firmware is tests/fw/timer_uart.c, RX on ICP1 (PB0, pin 8), TX on OC1A (PB1,
//! pin 9). Times are exact: the counter runs from the cycle TCCR1B is written (`start`).

mod common;

use common::timer_uart::*;
use uno_sim::{Chip, Options, Uno};

/// Pin 8 (ICP1) and pin 9 (OC1A).
const RX: u8 = 8;
const TX: u8 = 9;

/// The 328P's firmware, its timer started with TCCR1B = `tccrb`: (the board, the counter's
/// start cycle).
fn started(tccrb: u32) -> (Uno, u64) {
    let mut uno = boot(Chip::Atmega328p);
    let base = start(&mut uno, tccrb);
    (uno, base)
}

/// Falling edges on RX at `base` + 80000 + 1000·k + k (every phase against the clk/8 tick),
/// each followed by a rising one 300 cycles later; the falling edges' cycles.
fn falling_edges(uno: &mut Uno, base: u64, count: u64) -> Vec<u64> {
    let edges: Vec<u64> = (0..count).map(|k| base + 80_000 + 1000 * k + k).collect();
    for &at in &edges {
        uno.schedule_pin(RX, at, false).unwrap();
        uno.schedule_pin(RX, at + 300, true).unwrap();
    }
    uno.run_until(edges[edges.len() - 1] + 1000).unwrap();
    edges
}

#[test]
fn capture_stamps_the_count_three_cycles_after_the_edge() {
    // the synchronizer: 2.5-3.5 system clocks from the pin to the edge detector ("Input
    // Capture Trigger Source", sampled as the T1 pin is in §17); the stamp is the count in
    // the cycle edge + 3
    let (mut uno, base) = started(CLK_8);
    let edges = falling_edges(&mut uno, base, 16);
    let expected: Vec<(u16, bool)> = edges.iter().map(|&at| (count_at(base, at + 3), false)).collect();
    assert_eq!(captures(&uno), expected);
}

#[test]
fn the_noise_canceller_adds_four_cycles() {
    let (mut uno, base) = started(CLK_8 | ICNC);
    let edges = falling_edges(&mut uno, base, 16);
    let expected: Vec<(u16, bool)> = edges.iter().map(|&at| (count_at(base, at + 3 + 4), false)).collect();
    assert_eq!(captures(&uno), expected);
}

#[test]
fn edge_select_picks_the_edge_and_the_firmware_turns_it() {
    // ICES1 set: only the rising edges are stamped
    let (mut uno, base) = started(CLK_8 | ICES);
    let edges = falling_edges(&mut uno, base, 4);
    let rising: Vec<(u16, bool)> = edges.iter().map(|&at| (count_at(base, at + 300 + 3), true)).collect();
    assert_eq!(captures(&uno), rising);

    // turned after each capture, as a receiver does: every edge, alternately
    let (mut uno, base) = started(CLK_8);
    uno.write_symbol("toggle_edge", &[1]).unwrap();
    let edges = falling_edges(&mut uno, base, 4);
    let both: Vec<(u16, bool)> =
        edges.iter().flat_map(|&at| [(count_at(base, at + 3), false), (count_at(base, at + 300 + 3), true)]).collect();
    assert_eq!(captures(&uno), both);
}

#[test]
fn the_noise_canceller_drops_pulses_shorter_than_four_cycles() {
    // "monitored over four samples, and all four must be equal for changing the output"
    let (mut uno, base) = started(CLK_8 | ICNC);
    let at = base + 80_000;
    for (k, width) in [1u64, 2, 3, 4].into_iter().enumerate() {
        let fall = at + 1000 * k as u64;
        uno.schedule_pin(RX, fall, false).unwrap();
        uno.schedule_pin(RX, fall + width, true).unwrap();
    }
    uno.run_until(at + 5000).unwrap();
    assert_eq!(captures(&uno), [(count_at(base, at + 3000 + 7), false)], "only the 4-cycle pulse");

    // without it one cycle is enough
    let (mut uno, base) = started(CLK_8);
    let at = base + 80_000;
    uno.schedule_pin(RX, at, false).unwrap();
    uno.schedule_pin(RX, at + 1, true).unwrap();
    uno.run_until(at + 1000).unwrap();
    assert_eq!(captures(&uno), [(count_at(base, at + 3), false)]);
}

/// The counter's value `ticks` after now.
fn soon(uno: &Uno, base: u64, ticks: u16) -> u16 {
    count_at(base, uno.now()).wrapping_add(ticks)
}

/// OC1A connected for "set" with its latch forced high (its match far away), as a serial
/// transmitter starts: the line idle high.
fn idle_high(uno: &mut Uno, base: u64) {
    let far = soon(uno, base, 30_000);
    command(uno, COMPARE, COM_SET | u32::from(far));
    command(uno, FORCE, 0);
    assert!(uno.pin(TX).unwrap().level);
}

/// TIFR1 and its OCF1A flag.
const TIFR1: u16 = 0x36;
const OCF1A: u8 = 0x02;

#[test]
fn oc1a_changes_at_the_compare_match() {
    let (mut uno, base) = started(CLK_8);
    idle_high(&mut uno, base);
    uno.watch_pin(TX).unwrap();
    let now = uno.now();
    let at = soon(&uno, base, 100);
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(at));
    uno.run_for(150 * TICK).unwrap();
    let back = at.wrapping_add(104);
    command(&mut uno, COMPARE, COM_SET | u32::from(back));
    uno.run_for(150 * TICK).unwrap();
    assert_eq!(
        uno.take_pin_edges(TX).unwrap(),
        [(match_after(base, at, now), false), (match_after(base, back, now), true)]
    );
}

#[test]
fn the_compare_output_latch_starts_low_until_forced() {
    // "If a system reset occur, the OC1x Register is reset to 0": connecting COM1A shows it
    let (mut uno, base) = started(CLK_8);
    uno.watch_pin(TX).unwrap();
    assert!(uno.pin(TX).unwrap().level, "PORTB1 high");
    let far = soon(&uno, base, 30_000);
    command(&mut uno, COMPARE, COM_SET | u32::from(far));
    assert!(!uno.pin(TX).unwrap().level, "OC1A's latch, low");
    uno.write_ram(TIFR1, &[0]).unwrap(); // OCR1A = 0 matched as the counter started
    command(&mut uno, FORCE, 0);
    assert!(uno.pin(TX).unwrap().level, "forced: the match's action (set) without a match");
    let edges = uno.take_pin_edges(TX).unwrap();
    assert_eq!(edges.iter().map(|e| e.1).collect::<Vec<_>>(), [false, true]);
    assert_eq!(uno.read_ram(TIFR1, 1).unwrap()[0] & OCF1A, 0, "FOC1A sets no flag");
}

#[test]
fn oc1a_shows_only_while_an_output() {
    let (mut uno, base) = started(CLK_8);
    uno.watch_pin(TX).unwrap();
    command(&mut uno, TX_OUTPUT, 0);
    let at = soon(&uno, base, 100);
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(at));
    uno.run_for(200 * TICK).unwrap();
    let pin = uno.pin(TX).unwrap();
    assert!(!pin.output && pin.pull_up && pin.level, "an input with its pull-up reads high");
    assert!(uno.take_pin_edges(TX).unwrap().is_empty());
    // an output again: the latch (low since the match) shows from the DDRB write on
    command(&mut uno, TX_OUTPUT, 1);
    assert!(!uno.pin(TX).unwrap().level);
    assert_eq!(uno.take_pin_edges(TX).unwrap().iter().map(|e| e.1).collect::<Vec<_>>(), [false]);
}

#[test]
fn port_writes_leave_a_connected_oc1a_alone() {
    let (mut uno, base) = started(CLK_8);
    let at = soon(&uno, base, 100);
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(at));
    uno.run_for(200 * TICK).unwrap();
    uno.watch_pin(TX).unwrap();
    assert!(!uno.pin(TX).unwrap().level);
    command(&mut uno, PORT, 0xFF); // PORTB1 high, and pin 10 (a chip select) too
    command(&mut uno, PORT, 0xFD);
    command(&mut uno, PORT, 0xFF);
    assert!(!uno.pin(TX).unwrap().level, "OC1A, not PORTB1");
    assert!(uno.pin(10).unwrap().level, "pin 10 is a port pin");
    command(&mut uno, READ, 0);
    assert_eq!(uno.read_symbol("tx_pins").unwrap()[0] & 0x06, 0x04, "PINB reads OC1A low, PB2 high");
    assert!(uno.take_pin_edges(TX).unwrap().is_empty());
}

#[test]
fn normal_mode_leaves_oc1a_alone_at_the_overflow_and_at_an_ocr1a_write() {
    // simavr 1.6 drives the compare output the PWM way at every overflow and on every OCR1A
    // write (set for COM1A "clear", clear for "set"); in normal mode the pin only changes at
    // a match
    let (mut uno, base) = started(CLK_8);
    idle_high(&mut uno, base);
    uno.watch_pin(TX).unwrap();
    let far = soon(&uno, base, 60_000);
    command(&mut uno, COMPARE, COM_SET | u32::from(far));
    uno.run_for(TURN / 2).unwrap(); // an overflow, no match
    assert!(uno.take_pin_edges(TX).unwrap().is_empty(), "high all along");

    // the same for "clear" with the line low
    let at = soon(&uno, base, 100);
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(at));
    uno.run_for(200 * TICK).unwrap();
    assert_eq!(uno.take_pin_edges(TX).unwrap().len(), 1);
    let far = soon(&uno, base, 60_000);
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(far));
    uno.run_for(TURN / 2).unwrap();
    assert!(uno.take_pin_edges(TX).unwrap().is_empty(), "low all along");
}

#[test]
fn a_compare_already_passed_waits_a_whole_turn() {
    let (mut uno, base) = started(CLK_8);
    command(&mut uno, READ, 0);
    let tcnt = u16::from_le_bytes(uno.read_symbol("tcnt").unwrap().try_into().unwrap());
    uno.watch_pin(TX).unwrap();
    let written = uno.now();
    let passed = tcnt.wrapping_sub(10);
    command(&mut uno, COMPARE, COM_SET | u32::from(passed));
    uno.run_for(TURN + 100 * TICK).unwrap();
    let edges = uno.take_pin_edges(TX).unwrap();
    // connected: low (the latch), then set a whole turn later
    assert_eq!(edges.len(), 2, "{edges:?}");
    assert_eq!(edges[1], (match_after(base, passed, written), true));
    assert!(edges[1].0 - written > TURN - 20 * TICK);
}

#[test]
fn ocr1a_takes_its_high_byte_through_temp() {
    // "the high byte must be written before the low byte": the low byte's write copies TEMP
    // (the last high byte written, or read with a low byte) into OCR1AH
    let (mut uno, base) = started(CLK_8);
    uno.run_for(300 * TICK).unwrap(); // TCNT1H = 0x01 from here on, for a while
    command(&mut uno, READ, 0); // TCNT1 read: TEMP = TCNT1H
    let tcnt = u16::from_le_bytes(uno.read_symbol("tcnt").unwrap().try_into().unwrap());
    command(&mut uno, COMPARE_LOW_FIRST, COM_SET | 0x7FCD);
    command(&mut uno, READ, 0);
    let ocr = u16::from_le_bytes(uno.read_symbol("ocr").unwrap().try_into().unwrap());
    assert_eq!(ocr, (tcnt & 0xFF00) | 0xCD, "TEMP's old high byte, not 0x7F");

    // in the right order the value is the one written, and the match comes there
    idle_high(&mut uno, base);
    uno.watch_pin(TX).unwrap();
    let at = soon(&uno, base, 100);
    let written = uno.now();
    command(&mut uno, COMPARE, COM_CLEAR | u32::from(at));
    command(&mut uno, READ, 0);
    let ocr = u16::from_le_bytes(uno.read_symbol("ocr").unwrap().try_into().unwrap());
    assert_eq!(ocr, at);
    uno.run_for(200 * TICK).unwrap();
    assert_eq!(uno.take_pin_edges(TX).unwrap(), [(match_after(base, at, written), false)]);
}

/// TIFR1's OCF1B flag.
const OCF1B: u8 = 0x04;

#[test]
fn writing_one_to_icf1_leaves_the_compare_flags_up() {
    // "OCF1B can be cleared by writing a logic one to its bit location" (§16.11.9): a zero
    // written leaves a flag as it is. A capture handler clears ICF1 alone after turning the
    // edge select, while a compare match B may wait behind its interrupt.
    let program: [u16; 14] = [
        0xE002, // ldi r16, 0x02
        0x9300, 0x0081, // sts TCCR1B, r16: clk/8, the capture on a falling edge
        0xE000, // ldi r16, 0
        0x9300, 0x008B, // sts OCR1BH, r16
        0xE100, // ldi r16, 16
        0x9300, 0x008A, // sts OCR1BL, r16: compare B matches 16 ticks on (OCR1A = 0 at once)
        0x9BB5, // wait: sbis TIFR1, ICF1
        0xCFFE, // rjmp wait
        0xE220, // ldi r18, 0x20: ICF1
        0xBB26, // out TIFR1, r18
        0xCFFF, // rjmp .
    ];
    let mut uno = Uno::erased(Options::new()).unwrap();
    uno.write_flash(0, &program.iter().flat_map(|w| w.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    uno.drive_pin(RX, Some(true)).unwrap();
    uno.run_until(3_000).unwrap();
    let flags = uno.read_ram(TIFR1, 1).unwrap()[0];
    assert_eq!(flags, OCF1A | OCF1B, "both compare units matched, no edge yet");
    uno.schedule_pin(RX, 4_000, false).unwrap();
    uno.run_until(4_100).unwrap();
    assert_eq!(uno.pc(), 13 * 2, "ICF1 seen and written");
    assert_eq!(uno.read_ram(TIFR1, 1).unwrap()[0], OCF1A | OCF1B, "ICF1 cleared, the compare flags kept");
}
