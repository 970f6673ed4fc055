//! Line settings kept in EEPROM, on the release `configurable` firmware in simavr: the
//! master changes the slave id and the line through holding registers 40101–40104, gets
//! its reply at the old settings, and after a reset the slave starts with the new ones; a
//! damaged EEPROM record means the default, 19200 8E1, slave id 1, and so does the recovery
//! jumper (pin 12 to GND).
//!
//! The simulated master sends at whatever rate the firmware's USART runs (see `uno-sim`),
//! so the line settings are checked in USART0's registers and in the reply's character
//! times. Start-up with a stored record computes the configuration at run time (≈3 ms),
//! longer than `sim::Rtu` allows for booting, so these tests drive the board with a
//! small master of their own ([`Board`]).

#![cfg(feature = "eeprom-settings")]

mod sim;

use sim::{collect_reply, crc16, firmware, read_request, us_to_cycles, with_crc, Exchange, Line, ID};
use uno_sim::{Parity, Uno};

const FIRMWARE: &str = "configurable";
/// The recovery jumper's pin.
const JUMPER: u8 = 12;
/// The settings record's place in EEPROM.
const RECORD_AT: usize = 0;
/// The settings block: 40101, protocol address 100.
const BLOCK: u16 = 100;

/// 9600 bps, 8N2.
const B9600_8N2: Line = Line { baud: 9600, parity: Parity::None, stop_bits: 2 };

/// The EEPROM record for `id` and `line`, built from the layout documented in
/// `src/settings.rs`: magic, id, baud (u32 LE), parity code, stop bits, CRC.
fn record(id: u8, line: Line) -> Vec<u8> {
    let parity = match line.parity {
        Parity::None => 0,
        Parity::Odd => 1,
        Parity::Even => 2,
    };
    let mut bytes = vec![0x4D, id];
    bytes.extend_from_slice(&line.baud.to_le_bytes());
    bytes.extend_from_slice(&[parity, line.stop_bits]);
    let crc = crc16(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// FC 16 of the whole settings block to `id`.
fn write_block(id: u8, values: [u16; 4]) -> Vec<u8> {
    let mut frame = vec![
        id,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x64, // starting address lo: 40101
        0x00, // quantity hi
        0x04, // quantity lo: 4
        0x08, // byte count
    ];
    for value in values {
        frame.extend_from_slice(&value.to_be_bytes());
    }
    with_crc(&frame)
}

/// The simulated board with a master on its line.
struct Board {
    uno: Uno,
    /// The line the master uses (for its T3.5 waits).
    line: Line,
    /// The line has been idle since this cycle.
    quiet_since: u64,
}

/// Simulated time the firmware gets to start: the stored record's configuration takes
/// ≈3 ms to compute.
const BOOT_US: u64 = 10_000;

impl Board {
    /// Loads the firmware, lets `setup` prepare the board (EEPROM, pins), and starts it.
    fn boot(line: Line, setup: impl FnOnce(&mut Uno)) -> Board {
        let mut uno = Uno::load(firmware(FIRMWARE)).expect("firmware loads");
        setup(&mut uno);
        Board::start(uno, line)
    }

    fn start(mut uno: Uno, line: Line) -> Board {
        uno.run_until(us_to_cycles(BOOT_US)).expect("firmware runs");
        let quiet_since = uno.now();
        Board { uno, line, quiet_since }
    }

    /// Resets the board, keeping its EEPROM (and nothing else: the jumper is off), and
    /// starts it with the master on `line`.
    fn reset(mut self, line: Line) -> Board {
        self.uno.reset().expect("reset");
        Board::start(self.uno, line)
    }

    fn char_cycles(&self) -> u64 {
        self.uno.wire_char_cycles().expect("USART0 enabled")
    }

    /// Schedules `request` after T3.5 (and a little) of silence; returns its last
    /// character's end.
    fn send(&mut self, request: &[u8]) -> u64 {
        let start = (self.quiet_since + self.line.t35() + us_to_cycles(100)).max(self.uno.now());
        let end = self.uno.send_frame(request, start + self.char_cycles(), 0).expect("bytes scheduled");
        self.quiet_since = end;
        end
    }

    /// Sends `request` and collects the reply (empty: none within T3.5 + 10 characters).
    fn exchange(&mut self, request: &[u8]) -> Exchange {
        let request_end = self.send(request);
        let char_cycles = self.char_cycles();
        let reply = collect_reply(&mut self.uno, request_end, char_cycles, self.line.t35());
        if let Some(last) = reply.last() {
            self.quiet_since = self.quiet_since.max(last.end_cycle);
        }
        Exchange { request_end, reply }
    }

    fn ask(&mut self, request: &[u8]) -> Vec<u8> {
        self.exchange(request).bytes()
    }

    /// Reads `qty` registers of `function` from `start` at slave `id`; the values, or
    /// `None` when there was no normal reply.
    fn read(&mut self, id: u8, function: u8, start: u16, qty: u16) -> Option<Vec<u16>> {
        let reply = self.ask(&read_request(id, function, start, qty));
        let data = reply.get(3..reply.len().checked_sub(2)?)?;
        (reply.get(..3)? == [id, function, 2 * qty as u8] && reply == with_crc(&reply[..reply.len() - 2]))
            .then(|| data.chunks_exact(2).map(|pair| u16::from_be_bytes([pair[0], pair[1]])).collect())
    }

    /// Lets the main loop switch and store the settings: ≈3 ms to compute them, ≈3.4 ms
    /// per EEPROM byte on the chip (simavr finishes a write at once, but a test should not
    /// depend on that). The master then uses `line`.
    fn settle(&mut self, line: Line) {
        self.uno.run_for(us_to_cycles(50_000)).expect("firmware runs");
        self.quiet_since = self.uno.now();
        self.line = line;
    }
}

/// USART0 runs `line`.
fn assert_usart_runs(uno: &Uno, line: Line) {
    let cfg = uno.serial_config().expect("USART0 enabled");
    assert!(cfg.rx_enabled && cfg.tx_enabled, "{cfg:?}");
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, line.parity, line.stop_bits), "{cfg:?}");
    assert!(cfg.baud_error(line.baud).abs() <= 0.025, "{} bps for {}", cfg.baud(), line.name());
}

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
    assert_eq!(board.uno.read_eeprom(RECORD_AT, 10).unwrap(), record(7, B9600_8N2));

    // At once, before any reset: the new id answers at the new rate, the old one is silent.
    assert!(board.exchange(&read_request(ID, 0x03, BLOCK, 4)).reply.is_empty(), "old id");
    let exchange = board.exchange(&read_request(7, 0x03, BLOCK, 4));
    assert_eq!(exchange.bytes(), with_crc(&[7, 0x03, 0x08, 0, 7, 0, 96, 0, 0, 0, 2]));
    assert_reply_chars(&exchange, B9600_8N2, board.char_cycles(), "new line");
    // 30002: all 10 bytes of the record written; 30003: one save.
    assert_eq!(board.read(7, 0x04, 1, 2), Some(vec![10, 1]));

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
    let stored = record(ID, Line::B115200_8E1);
    let mut board = Board::boot(Line::B115200_8E1, |uno| uno.write_eeprom(RECORD_AT, &stored).unwrap());
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
        uno.write_eeprom(RECORD_AT, &record(ID, Line::B19200_8E1)).unwrap();
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
    assert_eq!(board.uno.read_eeprom(RECORD_AT, 10).unwrap(), record(ID, Line::B115200_8E1));
    // 19200 → 115200: baud bytes 0x4B 0x00 → 0xC2 0x01, and the two CRC bytes.
    assert_eq!(board.read(ID, 0x04, 1, 1), Some(vec![4]));

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
fn damaged_record_falls_back_to_the_default() {
    let mut damaged = record(7, B9600_8N2);
    damaged[4] ^= 0x10; // one bit of the baud rate
    let ramp: Vec<u8> = (0..10u8).map(|i| i.wrapping_mul(37)).collect();
    for garbage in [damaged, vec![0x4D; 10], vec![0x00; 10], ramp] {
        let mut board = Board::boot(Line::B19200_8E1, |uno| uno.write_eeprom(RECORD_AT, &garbage).unwrap());
        assert_usart_runs(&board.uno, Line::B19200_8E1);
        assert_eq!(board.read(ID, 0x04, 0, 1), Some(vec![0]), "30001 with {garbage:02X?}");
        assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
    }
}

#[test]
fn jumper_forces_the_default_over_a_good_record() {
    let stored = record(7, B9600_8N2);
    let mut board = Board::boot(Line::B19200_8E1, |uno| {
        uno.write_eeprom(RECORD_AT, &stored).unwrap();
        uno.drive_pin(JUMPER, Some(false)).unwrap();
    });
    assert_usart_runs(&board.uno, Line::B19200_8E1);
    assert_eq!(board.read(ID, 0x04, 0, 1), Some(vec![2]), "30001: jumper");
    assert_eq!(board.read(ID, 0x03, BLOCK, 4), Some(vec![1, 192, 2, 1]));
    assert_eq!(board.uno.read_eeprom(RECORD_AT, 10).unwrap(), stored, "record kept");

    // Jumper removed, reset: the stored settings again.
    let mut board = board.reset(B9600_8N2);
    assert_usart_runs(&board.uno, B9600_8N2);
    assert_eq!(board.read(7, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
}

#[test]
fn settings_written_with_the_jumper_on_are_stored() {
    let mut board = Board::boot(Line::B19200_8E1, |uno| {
        uno.write_eeprom(RECORD_AT, &[0x12; 10]).unwrap();
        uno.drive_pin(JUMPER, Some(false)).unwrap();
    });
    let reply = board.ask(&write_block(ID, [3, 192, 1, 1])); // id 3, 19200 8O1
    assert_eq!(reply, with_crc(&[ID, 0x10, 0x00, 0x64, 0x00, 0x04]));
    board.settle(Line::B19200_8O1);
    assert_eq!(board.uno.read_eeprom(RECORD_AT, 10).unwrap(), record(3, Line::B19200_8O1));
    let mut board = board.reset(Line::B19200_8O1);
    assert_usart_runs(&board.uno, Line::B19200_8O1);
    assert_eq!(board.read(3, 0x04, 0, 1), Some(vec![1]), "30001: EEPROM");
}
