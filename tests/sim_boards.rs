//! The slave on every chip the crate runs on and every USART they have: `examples/boards.rs`
//! built for the ATmega168, ATmega32U4 (USART1), ATmega1280 and ATmega2560 (USART0–USART3)
//! by `make chips`, and for the ATmega328P by `make firmware`, run in simavr on its chip
//! with the master on that USART at 19200 8E1.
//!
//! Each board gets the same representative run, since the protocol core is the same code on
//! every chip and is tested in full on the Uno and the host: what differs per chip is the
//! USART's registers, the vectors the slave binds, Timer0's interrupts and the board's LED.
//! So each run crosses every function code (Application Protocol v1.1b3 §6.1–6.6, §6.11,
//! §6.12), the exceptions 01–03 (§7), the frames dropped in silence (Serial Line v1.02
//! §2.4.1, §2.5.1.1, §2.5.1.2: bad CRC, another slave, a character with a framing or parity
//! error, a gap over T1.5), broadcast, the reply's place after T3.5, the LED, and the clock
//! behind 30001 (feature `millis`).

mod sim;

use sim::{
    crc16, exception_reply, read_request, registers_reply, us_to_cycles, with_crc, write_register_request, Line, Rtu,
    ID,
};
use uno_sim::{Chip, LineError};

/// `examples/boards.rs` on `chip`, the master on USART `usart`.
fn boot(chip: Chip, usart: u8) -> Rtu {
    Rtu::boot_chip(chip, usart, "boards", Line::B19200_8E1)
}

/// The board's LED "L" (pin 13): PB5 on the Uno and Nano, PB7 on the Mega, PC7 on the
/// Leonardo.
fn led(chip: Chip) -> (char, u8) {
    match chip {
        Chip::Atmega328p | Chip::Atmega168 => ('B', 5),
        Chip::Atmega1280 | Chip::Atmega2560 => ('B', 7),
        Chip::Atmega32u4 => ('C', 7),
        other => panic!("no LED known for the {other}"),
    }
}

/// A bit-table reply (FC 1 or 2) carrying `bytes`.
fn bits_reply(function: u8, bytes: &[u8]) -> Vec<u8> {
    let mut frame = vec![ID, function, bytes.len() as u8];
    frame.extend_from_slice(bytes);
    with_crc(&frame)
}

/// Every function code, read back where it writes: FC 5, 15 and 1 on the coils, FC 2 on the
/// discrete inputs, FC 6, 16 and 3 on the holding registers, FC 4 on the input registers.
fn every_function_code(rtu: &mut Rtu, what: &str) {
    // FC 05: coil 00003 on; FC 15: coils 00009–00016 = 0xA5; FC 01 reads 00001–00016.
    let fc5 = with_crc(&[ID, 0x05, 0x00, 0x02, 0xFF, 0x00]);
    assert_eq!(rtu.ask(&fc5), fc5, "{what}: FC 5 echoes");
    let fc15 = with_crc(&[ID, 0x0F, 0x00, 0x08, 0x00, 0x08, 0x01, 0xA5]);
    assert_eq!(rtu.ask(&fc15), with_crc(&[ID, 0x0F, 0x00, 0x08, 0x00, 0x08]), "{what}: FC 15");
    assert_eq!(rtu.ask(&read_request(ID, 0x01, 0, 16)), bits_reply(0x01, &[0x04, 0xA5]), "{what}: FC 1");
    // FC 02: the discrete inputs, 0 until the firmware sets them.
    assert_eq!(rtu.ask(&read_request(ID, 0x02, 0, 16)), bits_reply(0x02, &[0, 0]), "{what}: FC 2");
    // FC 06 and FC 16 on 40001 and 40015–40016; FC 03 reads 40001–40016.
    let fc6 = write_register_request(ID, 0, 0xBEEF);
    assert_eq!(rtu.ask(&fc6), fc6, "{what}: FC 6 echoes");
    let fc16 = with_crc(&[ID, 0x10, 0x00, 0x0E, 0x00, 0x02, 0x04, 0x12, 0x34, 0x56, 0x78]);
    assert_eq!(rtu.ask(&fc16), with_crc(&[ID, 0x10, 0x00, 0x0E, 0x00, 0x02]), "{what}: FC 16");
    let mut holding = [0u16; 16];
    holding[0] = 0xBEEF;
    holding[14] = 0x1234;
    holding[15] = 0x5678;
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 16)), registers_reply(ID, 0x03, &holding), "{what}: FC 3");
    // FC 04: 30002–30008, zero (30001 counts seconds: see `the_clock_counts_seconds`).
    assert_eq!(rtu.ask(&read_request(ID, 0x04, 1, 7)), registers_reply(ID, 0x04, &[0; 7]), "{what}: FC 4");
}

/// Exceptions 01, 02 and 03, each changing nothing.
fn exceptions(rtu: &mut Rtu, what: &str) {
    let fc7 = with_crc(&[ID, 0x07]);
    assert_eq!(rtu.ask(&fc7), exception_reply(ID, 0x07, 0x01), "{what}: FC 7 is not supported");
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 15, 2)), exception_reply(ID, 0x03, 0x02), "{what}: 40017");
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 0, 126)), exception_reply(ID, 0x03, 0x03), "{what}: 126 registers");
    let bad_coil = with_crc(&[ID, 0x05, 0x00, 0x00, 0x12, 0x34]);
    assert_eq!(rtu.ask(&bad_coil), exception_reply(ID, 0x05, 0x03), "{what}: FC 5 with 0x1234");
    assert_eq!(rtu.ask(&read_request(ID, 0x01, 0, 1)), bits_reply(0x01, &[0]), "{what}: coil 00001 unchanged");
}

/// `frame` gets no reply, and FC 3 for 40002 right after it gets the right one.
fn dropped_then_recovers(rtu: &mut Rtu, end: u64, what: &str) {
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "{what}: the slave answered {:02X?}", exchange.bytes());
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 1, 1)), registers_reply(ID, 0x03, &[0]), "{what}: the next request");
}

/// Bad CRC, another slave, a character with a framing or a parity error, a gap over T1.5
/// inside a frame: silence, and the next good request is answered. A broadcast write is
/// executed and not answered.
fn bad_input(rtu: &mut Rtu, what: &str) {
    let good = read_request(ID, 0x03, 1, 1);
    let mut bad_crc = good.clone();
    bad_crc[6] ^= 0x01;
    let end = rtu.send(&bad_crc);
    dropped_then_recovers(rtu, end, &format!("{what}, bad CRC"));
    let end = rtu.send(&read_request(2, 0x03, 1, 1));
    dropped_then_recovers(rtu, end, &format!("{what}, slave 2"));
    for error in [LineError::Framing, LineError::Parity] {
        let first_end = rtu.first_end_after_silence(0);
        let step = rtu.char_cycles;
        rtu.send_at(&good[..3], first_end, 0);
        rtu.uno.send_byte_with_error(good[3], first_end + 3 * step, error).unwrap();
        let end = rtu.send_at(&good[4..], first_end + 4 * step, 0);
        dropped_then_recovers(rtu, end, &format!("{what}, {error:?} error"));
    }
    // The last two characters after a gap of T1.5 + 1.5 characters, still short of T3.5.
    let first_end = rtu.first_end_after_silence(0);
    rtu.send_at(&good[..6], first_end, 0);
    let late = first_end + 5 * rtu.char_cycles + rtu.line.t15() + 3 * rtu.char_cycles / 2;
    let end = rtu.send_at(&good[6..], late, 0);
    dropped_then_recovers(rtu, end, &format!("{what}, gap over T1.5"));
    // Broadcast FC 6 to 40002: executed, not answered.
    let end = rtu.send(&write_register_request(0, 1, 0x0B0B));
    let exchange = rtu.receive(end);
    assert!(exchange.reply.is_empty(), "{what}: a broadcast was answered");
    assert_eq!(rtu.ask(&good), registers_reply(ID, 0x03, &[0x0B0B]), "{what}: the broadcast was executed");
}

/// The reply starts T3.5 after the request at the earliest, and within 25 µs of it (Timer0's
/// two ticks of resolution and the compare interrupt's cycles, docs/serial-line.md), for
/// requests that end at every phase of Timer0's tick while the main loop runs; the LED is
/// lit from the reply's start and dark once it has left.
fn reply_timing_and_led(rtu: &mut Rtu, chip: Chip, what: &str) {
    let request = read_request(ID, 0x03, 0, 2);
    let reply = registers_reply(ID, 0x03, &[0xBEEF, 0x0B0B]);
    let t35 = rtu.line.t35();
    for offset in 0..16 {
        // Each request ends at another phase of Timer0's 64-cycle tick.
        let first_end = rtu.first_end_after_silence(offset * 7 + offset * offset * 131);
        let end = rtu.send_at(&request, first_end, 0);
        let exchange = rtu.receive(end);
        assert_eq!(exchange.bytes(), reply, "{what}: FC 3");
        let turnaround = exchange.turnaround().expect("a reply");
        assert!(turnaround >= t35, "{what}: the reply started {turnaround} cycles after the request, T3.5 is {t35}");
        assert!(
            turnaround <= t35 + us_to_cycles(25),
            "{what}: the reply started {turnaround} cycles after the request, T3.5 is {t35}"
        );
    }
    let end = rtu.send(&request);
    let watched = rtu.watch_ports(end, &[led(chip)], t35 + 12 * rtu.char_cycles);
    assert_eq!(watched.exchange.bytes(), reply, "{what}: FC 3, LED watched");
    let edges = watched.pin(led(chip));
    let first = watched.exchange.reply[0].start_cycle;
    let last = watched.exchange.reply.last().unwrap().end_cycle;
    assert!(edges.rose.is_some_and(|t| t <= first), "{what}: LED {edges:?}, reply from {first}");
    assert!(edges.fell.is_some_and(|t| t >= last), "{what}: LED {edges:?}, reply until {last}");
}

/// 30001 counts whole seconds since the slave started (`millis() / 1000`), a few
/// milliseconds after reset.
fn the_clock_counts_seconds(rtu: &mut Rtu, what: &str) {
    rtu.run_us(2_100_000);
    let read_at = rtu.uno.now();
    let reply = rtu.ask(&read_request(ID, 0x04, 0, 1));
    let since_reset = read_at / 16_000_000;
    let since_start = read_at.saturating_sub(us_to_cycles(100_000)) / 16_000_000;
    assert!(since_reset >= 2, "{what}: ran {read_at} cycles");
    assert!(
        [since_start, since_reset].iter().any(|&s| reply == registers_reply(ID, 0x04, &[s as u16])),
        "{what}: 30001 {since_start}–{since_reset} s after reset: {reply:02X?}"
    );
}

/// The whole run on one board.
fn serves(chip: Chip, usart: u8) {
    let what = format!("{chip} USART{usart}");
    let mut rtu = boot(chip, usart);
    assert_eq!(rtu.uno.usart(), usart);
    every_function_code(&mut rtu, &what);
    exceptions(&mut rtu, &what);
    bad_input(&mut rtu, &what);
    reply_timing_and_led(&mut rtu, chip, &what);
    the_clock_counts_seconds(&mut rtu, &what);
    assert_eq!(crc16(&with_crc(&[ID, 0x03])), 0, "the test's own CRC");
}

#[test]
fn atmega328p_uno_serves_on_usart0() {
    serves(Chip::Atmega328p, 0);
}

#[test]
fn atmega168_nano168_serves_on_usart0() {
    serves(Chip::Atmega168, 0);
}

#[test]
fn atmega32u4_leonardo_serves_on_usart1_pins_0_and_1() {
    serves(Chip::Atmega32u4, 1);
}

#[test]
fn atmega1280_mega_serves_on_usart0() {
    serves(Chip::Atmega1280, 0);
}

#[test]
fn atmega1280_mega_serves_on_usart1() {
    serves(Chip::Atmega1280, 1);
}

#[test]
fn atmega1280_mega_serves_on_usart2() {
    serves(Chip::Atmega1280, 2);
}

#[test]
fn atmega1280_mega_serves_on_usart3() {
    serves(Chip::Atmega1280, 3);
}

#[test]
fn atmega2560_mega_serves_on_usart0() {
    serves(Chip::Atmega2560, 0);
}

#[test]
fn atmega2560_mega_serves_on_usart1_serial1() {
    serves(Chip::Atmega2560, 1);
}

#[test]
fn atmega2560_mega_serves_on_usart2_serial2() {
    serves(Chip::Atmega2560, 2);
}

#[test]
fn atmega2560_mega_serves_on_usart3_serial3() {
    serves(Chip::Atmega2560, 3);
}

/// A slave on a Mega's USART1 leaves USART0 to the application: `boards` prints `writes N`
/// there (polled, 9600 8N1) after each master write, while the slave keeps answering.
#[test]
fn atmega2560_slave_on_usart1_leaves_usart0_to_the_application() {
    let mut rtu = boot(Chip::Atmega2560, 1);
    let fc6 = write_register_request(ID, 3, 7);
    assert_eq!(rtu.ask(&fc6), fc6);
    rtu.run_us(20_000); // "writes 1\r\n" at 9600: 10.4 ms
    assert_eq!(rtu.uno.take_usart_output(0).unwrap(), b"writes 1\r\n");
    assert_eq!(rtu.ask(&fc6), fc6);
    rtu.run_us(20_000);
    assert_eq!(rtu.uno.take_usart_output(0).unwrap(), b"writes 2\r\n");
    assert_eq!(rtu.ask(&read_request(ID, 0x03, 3, 1)), registers_reply(ID, 0x03, &[7]));
}
