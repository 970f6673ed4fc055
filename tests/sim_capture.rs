//! The serial line on a timer's input capture (feature `capture-line`): the slave and the
//! master on the Uno's pins 8 (RX, ICP1) and 9 (TX, OC1A), the Leonardo's 13/5 and the Mega's
//! 48/46, on the simulated chips with every edge scheduled at its exact cycle and every level
//! TX shows logged at its cycle (`uno_sim::PinUart`): requests answered after T3.5 and never
//! before, the silences, damaged characters and frames dropped, bad input (glitches, a break,
//! a line held low, frames run together), the master's poll, and a gateway on one Uno.
//!
//! Built by `make chips`: `boards` and `master_boards` with AVR_MODBUS_EXAMPLE_USART=capture
//! for each chip (target/chips/CHIP-capture/), the contract on pins 8/9
//! (target/chips/atmega328p-capture-uno/) and the gateway (atmega328p-capture-gateway/).

mod configurable;
mod sim;

use configurable::ascii_frame;
use sim::{built, target_dir};
use sim::{read_request, registers_reply, write_register_request, Line, ID};
use uno_sim::{us_to_cycles, Chip, DecodedByte, Options, Parity, PinUart, Uno};

/// Quiet after a reply at the slowest rate the line takes: T3.5 and a character at 1200 bps.
const SLOW_QUIET_US: u64 = 80_000;

/// The contract's and `boards`' line: 19200 8E1.
const LINE: Line = Line::B19200_8E1;
const UART: PinUart = PinUart::new(19200).parity(Parity::Even);

/// The firmware `name` of build `dir` (`make chips`).
fn elf(dir: &str, name: &str) -> std::path::PathBuf {
    built(
        target_dir().join("chips").join(dir).join("avr-none/release/examples").join(format!("{name}.elf")),
        "make chips",
    )
}

/// A firmware with a line on two pins, and a master (or slave) on them.
struct PinLine {
    uno: Uno,
    rx: (char, u8),
    tx: (char, u8),
    /// The line has been quiet since this cycle.
    quiet_since: u64,
}

/// One request and what came back.
struct Reply {
    request_end: u64,
    bytes: Vec<DecodedByte>,
}

impl Reply {
    fn data(&self) -> Vec<u8> {
        self.bytes.iter().map(|b| b.byte).collect()
    }

    /// Cycles from the request's last stop bit to the reply's first start bit.
    fn turnaround(&self) -> u64 {
        let start = self.bytes.first().expect("a reply").start_cycle;
        start
            .checked_sub(self.request_end)
            .unwrap_or_else(|| panic!("the reply started {} cycles before the request ended", self.request_end - start))
    }
}

impl PinLine {
    /// Boots `elf` with its line's RX on `rx` and TX on `tx`.
    fn boot(elf: &std::path::Path, rx: (char, u8), tx: (char, u8)) -> PinLine {
        let mut uno = Uno::load_with(elf, Options::new()).expect("firmware loads");
        uno.watch_pin(tx).expect("TX logged");
        // Start-up and the power-up T3.5.
        uno.run_for(us_to_cycles(5_000)).expect("firmware runs");
        let quiet_since = uno.now();
        PinLine { uno, rx, tx, quiet_since }
    }

    /// The Uno's pins 8 and 9.
    fn uno(elf: &std::path::Path) -> PinLine {
        PinLine::boot(elf, ('B', 0), ('B', 1))
    }

    /// Sends `frame` from at least T3.5 after the line went quiet plus `delay` cycles, waits
    /// for the reply until the line has been quiet for `quiet` cycles (at most 200 ms).
    fn ask_after(&mut self, frame: &[u8], delay: u64) -> Reply {
        let start = self.quiet_since.max(self.uno.now()) + LINE.t35() + delay;
        let end = self.uno.send_pin_uart(self.rx, frame, UART, start, 0).expect("frame scheduled");
        let bytes = self.collect(end);
        self.quiet_since = bytes.last().map_or(end, |b| b.end_cycle);
        Reply { request_end: end, bytes }
    }

    fn ask(&mut self, frame: &[u8]) -> Reply {
        self.ask_after(frame, 0)
    }

    /// Runs until TX has been quiet for 5 ms after `from`, and reads what it sent.
    fn collect(&mut self, from: u64) -> Vec<DecodedByte> {
        self.collect_in(from, UART, 5_000)
    }

    /// Runs until TX has been quiet for `quiet_us` after `from` (at most a second), reads
    /// what it sent in `uart`'s format, and notes when the line went quiet.
    fn collect_in(&mut self, from: u64, uart: PinUart, quiet_us: u64) -> Vec<DecodedByte> {
        let mut bytes = Vec::new();
        let mut last = from;
        while self.uno.now() < from + us_to_cycles(1_000_000) {
            self.uno.run_for(us_to_cycles(1_000)).expect("firmware runs");
            let more = self.uno.take_pin_uart(self.tx, uart).expect("TX decoded");
            if let Some(b) = more.last() {
                last = b.end_cycle;
            }
            bytes.extend(more);
            if self.uno.now() > last + us_to_cycles(quiet_us) {
                break;
            }
        }
        self.quiet_since = last;
        bytes
    }

    /// Sends `bits` (one level per bit time) at T3.5 after the line went quiet, and lets the
    /// line rest high for `rest` cycles after.
    fn send_bits(&mut self, bits: &[bool], rest: u64) -> u64 {
        let start = self.quiet_since.max(self.uno.now()) + LINE.t35();
        let end = self.uno.send_pin_bits(self.rx, UART, start, bits).expect("bits scheduled");
        self.uno.schedule_pin(self.rx, end, true).expect("line released");
        self.uno.run_until(end + rest).expect("firmware runs");
        self.quiet_since = end;
        end
    }
}

/// FC 3 of the contract's 16 holding registers.
fn read16() -> Vec<u8> {
    read_request(ID, 0x03, 0, 16)
}

fn assert_clean(reply: &Reply) {
    for b in &reply.bytes {
        assert!(b.parity_ok && b.stop_ok, "reply character {b:?} malformed");
    }
}

#[test]
fn the_contract_on_pins_8_9_answers_reads_and_writes_after_t35() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    let write = write_register_request(ID, 40003 - 40001, 0xBEEF);
    let echo = line.ask(&write);
    assert_eq!(echo.data(), write, "FC 6 echoed");
    assert_clean(&echo);
    let reply = line.ask(&read16());
    let mut values = [0u16; 16];
    values[2] = 0xBEEF;
    assert_eq!(reply.data(), registers_reply(ID, 0x03, &values));
    assert_clean(&reply);
    let turnaround = reply.turnaround();
    assert!(turnaround >= LINE.t35(), "reply {turnaround} cycles after the request, before T3.5 {}", LINE.t35());
    // A reply's characters follow each other closely (the next starts from the last one's
    // end interrupt): far inside T1.5.
    for pair in reply.bytes.windows(2) {
        let gap = pair[1].start_cycle - pair[0].end_cycle;
        assert!(gap < us_to_cycles(50), "{gap} cycles between reply characters");
    }
}

#[test]
fn the_reply_starts_within_50_us_of_t35_at_every_phase() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    let mut late = Vec::new();
    for phase in 0..40u64 {
        // Spread the request's start over a Timer0 turn (1024 µs) and Timer1's ticks.
        let reply = line.ask_after(&read16(), phase * 26 * 16 + phase % 8);
        assert_eq!(reply.bytes.len(), 37, "phase {phase}: whole reply");
        late.push(reply.turnaround() - LINE.t35());
    }
    late.sort_unstable();
    let worst = *late.last().unwrap();
    assert!(worst <= us_to_cycles(50), "reply {worst} cycles past T3.5 at worst: {late:?}");
}

#[test]
fn a_frame_with_a_bad_crc_or_a_damaged_character_gets_no_reply() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    let mut bad = read16();
    let last = bad.len() - 1;
    bad[last] ^= 0x01;
    assert!(line.ask(&bad).bytes.is_empty(), "bad CRC answered");
    // Wrong parity on the function code: the frame is dropped though its CRC is right.
    let request = read16();
    let mut bits: Vec<bool> = Vec::new();
    for (i, &byte) in request.iter().enumerate() {
        let mut frame = UART.frame(byte);
        if i == 1 {
            frame[9] = !frame[9];
        }
        bits.extend(frame);
    }
    line.send_bits(&bits, us_to_cycles(20_000));
    assert!(line.uno.take_pin_uart(line.tx, UART).unwrap().is_empty(), "a parity error answered");
    // A missing stop bit (low) on the last character, its bits and the CRC right: a
    // framing error, dropped.
    let mut bits: Vec<bool> = Vec::new();
    for (i, &byte) in request.iter().enumerate() {
        let mut frame = UART.frame(byte);
        if i == request.len() - 1 {
            frame[10] = false;
        }
        bits.extend(frame);
    }
    line.send_bits(&bits, us_to_cycles(20_000));
    assert!(line.uno.take_pin_uart(line.tx, UART).unwrap().is_empty(), "a framing error answered");
    // And the next good request is answered.
    assert_eq!(line.ask(&read16()).bytes.len(), 37);
}

#[test]
fn a_gap_longer_than_t15_inside_a_frame_drops_it() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    let request = read16();
    let start = line.quiet_since.max(line.uno.now()) + LINE.t35();
    let mid = line.uno.send_pin_uart(line.rx, &request[..3], UART, start, 0).unwrap();
    // 2 character times of silence: past T1.5, short of T3.5.
    let gap = LINE.t15() + LINE.t15() / 3;
    assert!(gap < LINE.t35());
    let end = line.uno.send_pin_uart(line.rx, &request[3..], UART, mid + gap, 0).unwrap();
    line.quiet_since = end;
    assert!(line.collect(end).is_empty(), "a frame broken by a gap past T1.5 answered");
    assert_eq!(line.ask(&read16()).bytes.len(), 37);
}

#[test]
fn glitches_a_break_and_a_line_held_low_are_never_taken_for_a_frame() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    let bit = us_to_cycles(1_000_000) / 19_200;
    // Glitches shorter than half a bit on the idle line, then at once a request: the glitches
    // are not characters (as on the USART), so the request stands.
    let start = line.quiet_since.max(line.uno.now()) + LINE.t35();
    for k in 0..5u64 {
        let at = start + k * 3 * bit;
        line.uno.schedule_pin(line.rx, at, false).unwrap();
        line.uno.schedule_pin(line.rx, at + bit / 3, true).unwrap();
    }
    line.quiet_since = start;
    let reply = line.ask_after(&read16(), 0);
    assert_eq!(reply.bytes.len(), 37, "the request after short glitches");
    // A break: the line low for 20 character times; no reply, then a request answered.
    line.send_bits(&vec![false; 20 * 11], us_to_cycles(10_000));
    assert!(line.uno.take_pin_uart(line.tx, UART).unwrap().is_empty(), "a break answered");
    assert_eq!(line.ask(&read16()).bytes.len(), 37, "the request after a break");
    // Glitches inside a request's characters, across a bit's middle: the frame is dropped.
    let request = read16();
    let start = line.quiet_since.max(line.uno.now()) + LINE.t35();
    let end = line.uno.send_pin_uart(line.rx, &request, UART, start, 0).unwrap();
    let char_cycles = UART.bit_start(UART.char_bits());
    // A short low pulse over the middle of the fourth character's last data bit (high: 0x00's
    // data bits are low; the quantity's low byte 0x10 has bit 4 high).
    let fourth = start + 5 * char_cycles;
    let middle = fourth + UART.bit_start(5) + bit / 2;
    line.uno.schedule_pin(line.rx, middle - bit / 4, false).unwrap();
    line.uno.schedule_pin(line.rx, middle + bit / 4, true).unwrap();
    line.quiet_since = end;
    assert!(line.collect(end).is_empty(), "a request with a flipped bit answered");
    // The line held low for 300 ms (a cut cable), then released: nothing answered, nothing
    // stuck.
    let low = line.uno.now() + LINE.t35();
    line.uno.schedule_pin(line.rx, low, false).unwrap();
    line.uno.schedule_pin(line.rx, low + us_to_cycles(300_000), true).unwrap();
    line.uno.run_until(low + us_to_cycles(300_000) + 10).unwrap();
    line.quiet_since = line.uno.now();
    assert!(line.uno.take_pin_uart(line.tx, UART).unwrap().is_empty(), "a line held low answered");
    assert_eq!(line.ask(&read16()).bytes.len(), 37, "the request after the line came back");
}

#[test]
fn noise_on_rx_while_the_reply_goes_out_leaves_the_reply_whole() {
    // RS-232 is full duplex: edges on RX while the slave sends (a master's echo, noise) are
    // captured beside the transmitter's matches. The reply still goes out whole and on time,
    // and the next request is answered.
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    for round in 0..20u64 {
        let request = read16();
        let start = line.quiet_since.max(line.uno.now()) + LINE.t35();
        let end = line.uno.send_pin_uart(line.rx, &request, UART, start, 0).unwrap();
        // Short low pulses every 0.37 character through the reply (37 characters).
        let char_cycles = UART.bit_start(UART.char_bits());
        for k in 0..100u64 {
            let at = end + LINE.t35() + k * char_cycles * 37 / 100 + round * 7;
            line.uno.schedule_pin(line.rx, at, false).unwrap();
            line.uno.schedule_pin(line.rx, at + 80, true).unwrap();
        }
        let reply = line.collect(end);
        assert_eq!(reply.len(), 37, "round {round}: the reply's characters");
        let data: Vec<u8> = reply.iter().map(|b| b.byte).collect();
        assert_eq!(data, registers_reply(ID, 0x03, &[0; 16]), "round {round}");
        line.quiet_since = reply.last().unwrap().end_cycle.max(end + LINE.t35() + 40 * char_cycles);
    }
    assert_eq!(line.ask(&read16()).bytes.len(), 37, "the request after the noise");
}

#[test]
fn frames_back_to_back_each_get_their_reply() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-uno", "sixteen_each_capture"));
    // Characters with no idle between them (start bit right after the stop bit), twenty
    // frames: each answered.
    for n in 0..20u16 {
        let write = write_register_request(ID, n % 16, n);
        assert_eq!(line.ask(&write).data(), write, "write {n}");
    }
    let reply = line.ask(&read16());
    let values: Vec<u16> = (0..16).map(|i| if i < 4 { 16 + i } else { i }).collect();
    assert_eq!(reply.data(), registers_reply(ID, 0x03, &values));
}

#[test]
fn characters_held_up_by_a_critical_section_are_not_lost() {
    // The capture unit stamps each edge as it comes; an interrupt held off for less than a
    // bit loses nothing. `boards` reads millis() and sets 30001 in its loop, interrupts off
    // for a few µs each time, while the requests come in.
    let mut line = PinLine::uno(&elf("atmega328p-capture", "boards"));
    for _ in 0..30 {
        let reply = line.ask(&read_request(ID, 0x03, 0, 16));
        assert_eq!(reply.bytes.len(), 37);
        assert_clean(&reply);
    }
}

/// The Leonardo's (13 = PC7 RX, 5 = PC6 TX) and the Mega's (48 = PL1 RX, 46 = PL3 TX) lines.
#[test]
fn the_leonardo_and_the_mega_answer_on_their_capture_pins() {
    for (chip, rx, tx) in [(Chip::Atmega32u4, ('C', 7), ('C', 6)), (Chip::Atmega2560, ('L', 1), ('L', 3))] {
        let mut line = PinLine::boot(&elf(&format!("{chip}-capture"), "boards"), rx, tx);
        let write = write_register_request(ID, 4, 0x1234);
        assert_eq!(line.ask(&write).data(), write, "{chip}: FC 6");
        let reply = line.ask(&read_request(ID, 0x03, 4, 1));
        assert_eq!(reply.data(), registers_reply(ID, 0x03, &[0x1234]), "{chip}: FC 3");
        assert!(reply.turnaround() >= LINE.t35(), "{chip}: early");
    }
}

/// The master on pins 8/9 (master_boards: FC 3 of 10 registers from slave 1, over and over),
/// answered by the test as a slave would: each request whole, T3.5 after the reply before it
/// (after a reply with a bad CRC, the retry). What the master takes from the replies, the
/// gateway's test reads back.
#[test]
fn the_master_on_pins_8_9_polls_and_takes_only_good_replies() {
    let mut line = PinLine::uno(&elf("atmega328p-capture", "master_boards"));
    let expected = read_request(ID, 0x03, 0, 10);
    let mut reply_end = line.uno.now();
    for round in 0..5u16 {
        // The next request, up to 1.5 s on.
        let mut request = Vec::new();
        while request.len() < expected.len() && line.uno.now() < reply_end + us_to_cycles(1_500_000) {
            line.uno.run_for(us_to_cycles(1_000)).unwrap();
            request.extend(line.uno.take_pin_uart(line.tx, UART).unwrap());
        }
        let data: Vec<u8> = request.iter().map(|b| b.byte).collect();
        assert_eq!(data, expected, "round {round}: the request");
        assert!(request.iter().all(|b| b.parity_ok && b.stop_ok), "round {round}: request characters");
        let waited = request[0].start_cycle.saturating_sub(reply_end);
        if round > 0 {
            assert!(waited >= LINE.t35(), "round {round}: the request {waited} cycles after the reply, before T3.5");
            assert!(waited < us_to_cycles(10_000), "round {round}: the request {waited} cycles after the reply");
        }
        let end = request.last().unwrap().end_cycle;
        let values: Vec<u16> = (0..10).map(|i| round * 100 + i).collect();
        let mut reply = registers_reply(ID, 0x03, &values);
        if round == 2 {
            let n = reply.len();
            reply[n - 1] ^= 0xFF;
        }
        reply_end = line.uno.send_pin_uart(line.rx, &reply, UART, end + LINE.t35(), 0).unwrap();
    }
}

/// A gateway on one Uno: the SCADA's slave on pins 0/1 (USART0, the test's wire), the master
/// on pins 8/9 polling the field device (the test, answering on pin 8). The master takes the
/// field device's good replies, and the SCADA reads them; a reply with a bad CRC is not taken.
#[test]
fn the_uno_gateway_polls_the_field_device_on_pins_8_9() {
    let path = elf("atmega328p-capture-gateway", "gateway");
    let mut line = PinLine::uno(&path);
    // The field line's RS-485 driver enable: pin 13.
    line.uno.watch_pin(13u8).unwrap();
    let watched_from = line.uno.now();
    let field = read_request(1, 0x03, 0, 10);
    let answer = |line: &mut PinLine, values: &[u16], damaged: bool, rounds: u32| {
        // Answer the gateway's requests for `rounds` polls: its write of the SCADA's coils
        // (FC 15, echoed), then its reads of the registers.
        let (mut polls, until) = (0, line.uno.now() + us_to_cycles(3_000_000));
        while polls < rounds {
            assert!(line.uno.now() < until, "{polls} polls of {rounds} in 3 s");
            let request = line.collect(line.uno.now());
            let bytes: Vec<u8> = request.iter().map(|b| b.byte).collect();
            if bytes.is_empty() {
                continue;
            }
            // The driver enabled before the first start bit, released after the last stop
            // bit (and within 20 µs of it).
            let de = line.uno.take_pin_edges(13u8).unwrap();
            let (first, last) = (request[0].start_cycle, request.last().unwrap().end_cycle);
            if first >= watched_from {
                assert!(de.iter().any(|&(at, high)| high && at <= first), "DE high before {first}: {de:?}");
                assert!(
                    de.iter().any(|&(at, high)| !high && at >= last && at <= last + us_to_cycles(20)),
                    "DE low after {last}: {de:?}"
                );
            }
            let reply = if bytes == field {
                polls += 1;
                let mut reply = registers_reply(1, 0x03, values);
                if damaged {
                    let n = reply.len();
                    reply[n - 1] ^= 0x5A;
                }
                reply
            } else if bytes.len() > 6 && bytes[1] == 0x0F {
                sim::with_crc(&bytes[..6])
            } else {
                panic!("the gateway sent {bytes:02x?}");
            };
            // Within the master's response timeout (1 s), though after T3.5.
            let at = line.uno.now() + 100;
            line.uno.send_pin_uart(line.rx, &reply, UART, at, 0).unwrap();
        }
    };
    let scada_reads = |line: &mut PinLine| {
        let request = read_request(ID, 0x03, 0, 10);
        let end = line.uno.send_frame(&request, line.uno.now() + LINE.t35(), 0).unwrap();
        let reply = line.uno.run_until_tx_idle(us_to_cycles(3_000), end + us_to_cycles(50_000)).unwrap();
        reply.iter().map(|t| t.byte).collect::<Vec<u8>>()
    };
    let good: Vec<u16> = (0..10).map(|i| 0x100 + i).collect();
    answer(&mut line, &good, false, 3);
    assert_eq!(
        scada_reads(&mut line),
        registers_reply(ID, 0x03, &good),
        "the SCADA reads the field device's registers"
    );
    let other: Vec<u16> = (0..10).map(|i| 0x200 + i).collect();
    answer(&mut line, &other, true, 2);
    assert_eq!(scada_reads(&mut line), registers_reply(ID, 0x03, &good), "a reply with a bad CRC was taken");
    answer(&mut line, &other, false, 2);
    assert_eq!(scada_reads(&mut line), registers_reply(ID, 0x03, &other), "the next good reply");
}

/// Every rate and format the line takes, switched at run time: `boards` with the line
/// settings in EEPROM and ASCII (features `eeprom-settings`, `ascii`) on pins 8/9. The master
/// writes id, rate, parity, stop bits and mode to 40101–40105; the reply leaves at the old
/// settings, and the slave answers at the new ones: 38 400 8O1 (a bit is 52 ticks of
/// Timer1), 1200 8N2 (a character 18 333 ticks, T3.5 32 ms), then ASCII at 9600 7E1.
#[test]
fn rates_from_1200_to_38400_parities_stop_bits_and_ascii_on_pins_8_9() {
    let mut line = PinLine::uno(&elf("atmega328p-capture-settings", "boards"));
    let mut uart = UART;
    let mut t35 = LINE.t35();
    let mut id = ID;
    // (id, baud/100, parity 0 none 1 odd 2 even, stop bits, mode 0 RTU)
    for (new_id, baud, parity, stop_bits) in [(7u8, 384u16, 1u16, 1u16), (9, 12, 0, 2)] {
        let mut write = vec![id, 0x10, 0x00, 0x64, 0x00, 0x04, 0x08];
        for value in [u16::from(new_id), baud, parity, stop_bits] {
            write.extend_from_slice(&value.to_be_bytes());
        }
        let write = sim::with_crc(&write);
        let start = line.quiet_since.max(line.uno.now()) + t35;
        let end = line.uno.send_pin_uart(line.rx, &write, uart, start, 0).unwrap();
        let reply: Vec<u8> = line.collect_in(end, uart, SLOW_QUIET_US).iter().map(|b| b.byte).collect();
        assert_eq!(reply, sim::with_crc(&[id, 0x10, 0x00, 0x64, 0x00, 0x04]), "the write's reply, at the old settings");
        let parity = [Parity::None, Parity::Odd, Parity::Even][usize::from(parity)];
        uart = PinUart::new(u32::from(baud) * 100).parity(parity).stop_bits(stop_bits as u8);
        let bits = u64::from(uart.char_bits());
        t35 =
            if baud > 192 { us_to_cycles(1750) } else { (35 * bits * 16_000_000).div_ceil(10 * u64::from(baud) * 100) };
        id = new_id;
        // Reads and a write at the new settings.
        for round in 0..3u16 {
            let write = write_register_request(id, 5, 0x1000 + round);
            let start = line.quiet_since.max(line.uno.now()) + t35 + us_to_cycles(2_000);
            let end = line.uno.send_pin_uart(line.rx, &write, uart, start, 0).unwrap();
            let echo = line.collect_in(end, uart, SLOW_QUIET_US);
            assert_eq!(echo.iter().map(|b| b.byte).collect::<Vec<_>>(), write, "{baud}00: FC 6");
            assert!(echo.iter().all(|b| b.parity_ok && b.stop_ok), "{baud}00: characters {echo:?}");
            assert!(echo[0].start_cycle >= end + t35, "{baud}00: the reply before T3.5");
            let read = read_request(id, 0x03, 5, 1);
            let start = line.quiet_since.max(line.uno.now()) + t35 + us_to_cycles(2_000);
            let end = line.uno.send_pin_uart(line.rx, &read, uart, start, 0).unwrap();
            let reply: Vec<u8> = line.collect_in(end, uart, SLOW_QUIET_US).iter().map(|b| b.byte).collect();
            assert_eq!(reply, registers_reply(id, 0x03, &[0x1000 + round]), "{baud}00: FC 3");
        }
    }
    // ASCII at 9600 7E1, id 3.
    let mut write = vec![id, 0x10, 0x00, 0x64, 0x00, 0x05, 0x0A];
    for value in [3u16, 96, 2, 1, 1] {
        write.extend_from_slice(&value.to_be_bytes());
    }
    let write = sim::with_crc(&write);
    let start = line.quiet_since.max(line.uno.now()) + t35;
    let end = line.uno.send_pin_uart(line.rx, &write, uart, start, 0).unwrap();
    assert_eq!(line.collect_in(end, uart, SLOW_QUIET_US).len(), 8, "the write's reply, at the old settings");
    let ascii = PinUart::new(9600).parity(Parity::Even).data_bits(7);
    let read = ascii_frame(&[3, 0x03, 0x00, 0x05, 0x00, 0x01]);
    let start = line.uno.now() + us_to_cycles(20_000);
    let end = line.uno.send_pin_uart(line.rx, &read, ascii, start, 0).unwrap();
    let reply = line.collect_in(end, ascii, SLOW_QUIET_US);
    assert!(reply.iter().all(|b| b.parity_ok && b.stop_ok), "ASCII characters {reply:?}");
    let text: Vec<u8> = reply.iter().map(|b| b.byte).collect();
    assert_eq!(String::from_utf8_lossy(&text), String::from_utf8_lossy(&ascii_frame(&[3, 0x03, 0x02, 0x10, 0x02])));
}

/// An 8 MHz board (the Pro Mini 3.3 V, `AVR_CPU_FREQUENCY_HZ=8000000`): `boards` on pins 8/9
/// at 19200 8E1. The simulated chip runs at 16 MHz, so the firmware runs as on an 8 MHz board
/// with time going twice as fast: its line is at 38 400 on the simulated wire, each bit 416
/// cycles, as on a 16 MHz board at 38 400, and its T3.5 (19200's, 16 042 cycles at 8 MHz)
/// half as long. Every check is in cycles.
#[test]
fn an_8_mhz_board_at_19200_on_pins_8_9() {
    let mut line = PinLine::uno(&elf("atmega328p-8mhz-capture", "boards"));
    let wire = PinUart::new(38_400).parity(Parity::Even);
    let t35 = (7 * 11 * 8_000_000u64).div_ceil(2 * 19_200);
    for round in 0..10u16 {
        let write = write_register_request(ID, 7, 0x2000 + round);
        let start = line.quiet_since.max(line.uno.now()) + t35 + 100;
        let end = line.uno.send_pin_uart(line.rx, &write, wire, start, 0).unwrap();
        let echo = line.collect_in(end, wire, SLOW_QUIET_US);
        assert_eq!(echo.iter().map(|b| b.byte).collect::<Vec<_>>(), write, "round {round}: FC 6");
        assert!(echo[0].start_cycle >= end + t35, "round {round}: the reply before T3.5");
        let read = read_request(ID, 0x03, 0, 16);
        let start = line.quiet_since.max(line.uno.now()) + t35 + 100;
        let end = line.uno.send_pin_uart(line.rx, &read, wire, start, 0).unwrap();
        let reply = line.collect_in(end, wire, SLOW_QUIET_US);
        assert_eq!(reply.len(), 37, "round {round}: FC 3");
        assert!(reply.iter().all(|b| b.parity_ok && b.stop_ok), "round {round}: characters");
    }
}
