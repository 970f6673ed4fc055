//! Frames that must get no reply get none at the wire, Modbus over Serial Line v1.02
//! §2.4.1 (broadcast, other slaves), §2.5.1.1 (frames broken by a gap or a damaged
//! character), §2.5.1.2 (CRC), §3.3.1 (the RS-485 driver is on only while the slave
//! transmits), and Application Protocol v1.1b3 §6.8.1 (listen-only mode: FC 8
//! sub-function 04 until sub-function 01, nothing executed, broadcasts included).
//!
//! The release `configurable` firmware (diagnostics, extra function codes) at 19200 8E1
//! with its RS-485 driver enable on pin 10 and its communication LED on pin 13. For every
//! frame that must stay unanswered, the firmware is run one instruction at a time from the
//! moment the frame is scheduled until T3.5 and ten characters after its end (a reply
//! would start at T3.5): not one byte on the line, pin 10 never high, pin 13 never high.
//! Then the next request is answered byte for byte, with both pins raised around the
//! reply, so the pins are seen to work. Where the frame could have written something, the
//! answer shows it did not; where the serial-line counters of FC 8 are meaningful, they
//! are read back.

// The firmware is built with these features (see `make firmware`); the test needs them too
// (`required-features` in Cargo.toml).

mod sim;

use sim::{crc16, read_request, registers_reply, with_crc, write_register_request, Line, Rtu, Watched, ID};
use uno_sim::LineError;

const DRIVER_ENABLE: u8 = 10;
const LED: u8 = 13;
const BROADCAST: u8 = 0;

fn configurable() -> Rtu {
    Rtu::boot("configurable", Line::B19200_8E1)
}

/// From a request's end: T3.5, when a reply would start, and ten characters more.
fn window(rtu: &Rtu) -> u64 {
    rtu.line.t35() + 10 * rtu.char_cycles
}

/// Nothing was sent, and neither the driver enable nor the LED went high.
fn assert_silent(watched: &Watched, what: &str) {
    assert!(watched.exchange.reply.is_empty(), "{what}: the slave sent {:02X?}", watched.exchange.bytes());
    assert_eq!(watched.pin(DRIVER_ENABLE).rose, None, "{what}: the RS-485 driver was enabled");
    assert_eq!(watched.pin(LED).rose, None, "{what}: the communication LED lit");
}

/// Sends `frame` after T3.5 of silence and checks that it gets no reply at the wire.
fn silent(rtu: &mut Rtu, frame: &[u8], what: &str) {
    let window = window(rtu);
    let watched = rtu.exchange_watching(frame, &[DRIVER_ENABLE, LED], window);
    assert_silent(&watched, what);
}

/// Sends `request` and checks the reply byte for byte, with the driver enable and the LED
/// high from before its first start bit until its last stop bit.
fn answered(rtu: &mut Rtu, request: &[u8], reply: &[u8], what: &str) {
    let window = window(rtu) + reply.len() as u64 * rtu.char_cycles;
    let watched = rtu.exchange_watching(request, &[DRIVER_ENABLE, LED], window);
    assert_eq!(watched.exchange.bytes(), reply, "{what}");
    let (first, last) = (watched.exchange.reply[0].start_cycle, watched.exchange.reply.last().unwrap().end_cycle);
    for pin in [DRIVER_ENABLE, LED] {
        let edges = watched.pin(pin);
        let (rose, fell) = (edges.rose.expect("pin rose"), edges.fell.expect("pin fell"));
        assert!(rose <= first && fell >= last, "{what}: pin {pin} high {rose}..{fell}, reply {first}..{last}");
    }
}

// ---------------------------------------------------------------------------------------
// Frames

/// FC 3 of 40001–40004: the request answered after every silent frame.
fn read_holding() -> Vec<u8> {
    read_request(ID, 0x03, 0, 4)
}

/// FC 1 of coils 00001–00008.
fn read_coils() -> Vec<u8> {
    read_request(ID, 0x01, 0, 8)
}

/// The FC 1 reply for coils 00001–00008 packed in `bits`.
fn coils_reply(bits: u8) -> Vec<u8> {
    with_crc(&[
        ID,   // slave address
        0x01, // function
        0x01, // byte count
        bits, // coils 00008..00001
    ])
}

/// 40001–40004 and the coils after reset.
const ZERO_REGISTERS: [u16; 4] = [0; 4];
const ZERO_COILS: u8 = 0x00;

/// FC 8 with sub-function `sub` and data 0000 to `id`.
fn diagnostic(id: u8, sub: u8) -> Vec<u8> {
    with_crc(&[
        id,   // slave address
        0x08, // function: diagnostics
        0x00, // sub-function hi
        sub,  // sub-function lo
        0x00, // data hi
        0x00, // data lo
    ])
}

/// FC 8/04: force listen-only mode.
fn force_listen_only() -> Vec<u8> {
    diagnostic(ID, 0x04)
}

/// FC 8/01 with data `data`: restart communications (0000, or FF00 to clear the event log).
fn restart_communications(id: u8, data: u16) -> Vec<u8> {
    let [hi, lo] = data.to_be_bytes();
    with_crc(&[
        id,   // slave address
        0x08, // function: diagnostics
        0x00, // sub-function hi
        0x01, // sub-function lo: restart communications
        hi,   // data hi
        lo,   // data lo
    ])
}

/// One valid write of each function code that writes (5, 6, 15, 16, 22, 23) to `id`,
/// each leaving something other than the reset value (zero) behind.
fn writes(id: u8) -> Vec<(&'static str, Vec<u8>)> {
    vec![
        (
            "FC 05",
            with_crc(&[
                id,   // slave address
                0x05, // function: write single coil
                0x00, // address hi
                0x00, // address lo: 00001
                0xFF, // value hi: ON
                0x00, // value lo
            ]),
        ),
        (
            "FC 06",
            with_crc(&[
                id,   // slave address
                0x06, // function: write single register
                0x00, // address hi
                0x00, // address lo: 40001
                0x12, // value hi
                0x34, // value lo
            ]),
        ),
        (
            "FC 15",
            with_crc(&[
                id,   // slave address
                0x0F, // function: write multiple coils
                0x00, // starting address hi
                0x01, // starting address lo: 00002
                0x00, // quantity hi
                0x07, // quantity lo: 7
                0x01, // byte count
                0x55, // coils 00008..00002: 1010101
            ]),
        ),
        (
            "FC 16",
            with_crc(&[
                id,   // slave address
                0x10, // function: write multiple registers
                0x00, // starting address hi
                0x01, // starting address lo: 40002
                0x00, // quantity hi
                0x02, // quantity lo: 2
                0x04, // byte count
                0x0B, 0xB8, // 40002: 3000
                0x0F, 0xA0, // 40003: 4000
            ]),
        ),
        (
            "FC 22",
            with_crc(&[
                id,   // slave address
                0x16, // function: mask write register
                0x00, // address hi
                0x03, // address lo: 40004
                0x00, // AND mask hi
                0x00, // AND mask lo: keep nothing
                0x56, // OR mask hi
                0x78, // OR mask lo: 40004 becomes 0x5678
            ]),
        ),
        (
            "FC 23",
            with_crc(&[
                id,   // slave address
                0x17, // function: read/write multiple registers
                0x00, // read starting address hi
                0x00, // read starting address lo: 40001
                0x00, // quantity to read hi
                0x04, // quantity to read lo: 4
                0x00, // write starting address hi
                0x02, // write starting address lo: 40003
                0x00, // quantity to write hi
                0x01, // quantity to write lo: 1
                0x02, // write byte count
                0xAB, 0xCD, // 40003
            ]),
        ),
    ]
}

/// One valid request of every function code the firmware speaks, to `id`: the reads and
/// diagnostics, then [`writes`]. FC 8 twice: sub-function 00 (echo) and 04 (listen only).
fn every_function_code(id: u8) -> Vec<(&'static str, Vec<u8>)> {
    let mut requests = vec![
        ("FC 01", read_request(id, 0x01, 0, 8)),
        ("FC 02", read_request(id, 0x02, 0, 1)),
        ("FC 03", read_request(id, 0x03, 0, 4)),
        ("FC 04", read_request(id, 0x04, 0, 3)),
        (
            "FC 07",
            with_crc(&[
                id,   // slave address
                0x07, // function: read exception status
            ]),
        ),
        (
            "FC 08/00",
            with_crc(&[
                id,   // slave address
                0x08, // function: diagnostics
                0x00, // sub-function hi
                0x00, // sub-function lo: return query data
                0xA5, // data hi
                0x37, // data lo
            ]),
        ),
        ("FC 08/04", diagnostic(id, 0x04)),
        (
            "FC 11",
            with_crc(&[
                id,   // slave address
                0x0B, // function: get comm event counter
            ]),
        ),
        (
            "FC 17",
            with_crc(&[
                id,   // slave address
                0x11, // function: report server id
            ]),
        ),
    ];
    requests.extend(writes(id));
    requests
}

// ---------------------------------------------------------------------------------------
// The serial-line counters (FC 8 sub-functions 0B–12)

/// The FC 8 counters the silent paths move.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Counters {
    /// 0B bus message count: every frame that ended, good or bad.
    bus_messages: u16,
    /// 0C bus communication error count: frames with a bad CRC.
    crc_errors: u16,
    /// 0D slave exception error count.
    exceptions: u16,
    /// 0E slave message count: good frames for this slave or broadcast.
    slave_messages: u16,
    /// 0F slave no-response count.
    no_response: u16,
}

/// Counter `sub` of FC 8, checking the reply's echo and CRC.
fn counter(rtu: &mut Rtu, sub: u8) -> u16 {
    let reply = rtu.ask(&diagnostic(ID, sub));
    assert_eq!(reply.len(), 8, "FC 8/{sub:02X} answered {reply:02X?}");
    assert_eq!(reply[..4], [ID, 0x08, 0x00, sub], "FC 8/{sub:02X}: echo of the sub-function");
    assert_eq!(crc16(&reply), 0, "FC 8/{sub:02X}: CRC of {reply:02X?}");
    u16::from_be_bytes([reply[4], reply[5]])
}

/// The counters as they stood before this read: 0B counts its own request, and 0E the
/// three reads before it as well.
fn counters(rtu: &mut Rtu) -> Counters {
    Counters {
        bus_messages: counter(rtu, 0x0B) - 1,
        crc_errors: counter(rtu, 0x0C),
        exceptions: counter(rtu, 0x0D),
        slave_messages: counter(rtu, 0x0E) - 4,
        no_response: counter(rtu, 0x0F),
    }
}

/// FC 8/0A: the counters are zero after its reply.
fn clear_counters(rtu: &mut Rtu) {
    let clear = diagnostic(ID, 0x0A);
    assert_eq!(rtu.ask(&clear), clear, "FC 8/0A echoes");
}

// ---------------------------------------------------------------------------------------
// Listen-only mode

#[test]
fn fc8_sub04_force_listen_only_is_not_answered() {
    let mut rtu = configurable();
    silent(&mut rtu, &force_listen_only(), "FC 8/04");
    rtu.send(&restart_communications(ID, 0x0000));
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3 after FC 8/01");
}

#[test]
fn every_request_while_listen_only_is_silent() {
    let mut rtu = configurable();
    rtu.send(&force_listen_only());
    let mut requests = every_function_code(ID);
    // Requests that would be answered with an exception stay silent too.
    requests.push(("FC 43/14 read device identification", with_crc(&[ID, 0x2B, 0x0E, 0x01, 0x00])));
    requests.push(("FC 43/13 (exception 01)", with_crc(&[ID, 0x2B, 0x0D, 0x01, 0x00])));
    requests.push(("FC 03 of 40005 (exception 02)", read_request(ID, 0x03, 4, 1)));
    requests.push(("FC 03 quantity 0 (exception 03)", read_request(ID, 0x03, 0, 0)));
    requests.push(("FC 08/02 (exception 01)", diagnostic(ID, 0x02)));
    requests.push(("FC 08/0A (clear counters)", diagnostic(ID, 0x0A)));
    for (what, request) in &requests {
        silent(&mut rtu, request, &format!("{what} while listen-only"));
    }
    rtu.send(&restart_communications(ID, 0x0000));
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3 after FC 8/01");
}

#[test]
fn fc8_sub01_leaves_listen_only_without_a_reply() {
    for data in [0x0000, 0xFF00] {
        let mut rtu = configurable();
        rtu.send(&force_listen_only());
        silent(&mut rtu, &restart_communications(ID, data), &format!("FC 8/01 data {data:04X} while listen-only"));
        answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3 after FC 8/01");
    }
}

#[test]
fn broadcast_fc8_sub01_does_not_leave_listen_only() {
    let mut rtu = configurable();
    rtu.send(&force_listen_only());
    silent(&mut rtu, &restart_communications(BROADCAST, 0x0000), "broadcast FC 8/01");
    silent(&mut rtu, &read_holding(), "FC 3 after the broadcast FC 8/01");
    rtu.send(&restart_communications(ID, 0x0000));
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3 after FC 8/01");
}

/// After writes sent while listen-only and FC 8/01, the coils and the registers still
/// hold their reset values.
fn writes_while_listen_only_change_nothing(id: u8) {
    let mut rtu = configurable();
    rtu.send(&force_listen_only());
    for (what, write) in writes(id) {
        silent(&mut rtu, &write, &format!("{what} to {id} while listen-only"));
    }
    rtu.send(&restart_communications(ID, 0x0000));
    answered(&mut rtu, &read_coils(), &coils_reply(ZERO_COILS), "coils after FC 8/01");
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "40001-40004 after FC 8/01");
}

#[test]
fn writes_while_listen_only_are_not_executed() {
    writes_while_listen_only_change_nothing(ID);
}

#[test]
fn broadcast_writes_while_listen_only_are_not_executed() {
    writes_while_listen_only_change_nothing(BROADCAST);
}

// ---------------------------------------------------------------------------------------
// Broadcast

#[test]
fn broadcast_of_every_function_code_is_silent() {
    let mut rtu = configurable();
    // FC 8/04 among them: a broadcast does not put the slave in listen-only mode, so the
    // ones after it and the last request below are seen as well.
    for (what, request) in every_function_code(BROADCAST) {
        silent(&mut rtu, &request, &format!("broadcast {what}"));
    }
    answered(
        &mut rtu,
        &read_coils(),
        &coils_reply(0xAB),
        "coils after the broadcasts: 00001 by FC 5, 00002-00008 by FC 15",
    );
}

#[test]
fn broadcasts_count_as_messages_without_response_and_without_exceptions() {
    let mut rtu = configurable();
    clear_counters(&mut rtu);
    let requests = every_function_code(BROADCAST);
    for (_, request) in &requests {
        rtu.send(request);
    }
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &[0x1234, 3000, 0xABCD, 0x5678]), "FC 3");
    let n = requests.len() as u16;
    assert_eq!(
        counters(&mut rtu),
        Counters { bus_messages: n + 1, slave_messages: n + 1, no_response: n, ..Counters::default() },
        "{n} valid broadcasts and one FC 3"
    );
}

/// Broadcast `write` gets no reply; `read` then answers `reply`.
fn broadcast_executed(rtu: &mut Rtu, write: &[u8], read: &[u8], reply: &[u8], what: &str) {
    silent(rtu, write, what);
    answered(rtu, read, reply, &format!("read back after {what}"));
}

fn broadcast_write(fc: &str) -> Vec<u8> {
    writes(BROADCAST).into_iter().find(|(what, _)| *what == fc).map(|(_, frame)| frame).expect("a write")
}

#[test]
fn broadcast_fc5_is_executed() {
    broadcast_executed(&mut configurable(), &broadcast_write("FC 05"), &read_coils(), &coils_reply(0x01), "FC 5");
}

#[test]
fn broadcast_fc6_is_executed() {
    let reply = registers_reply(ID, 0x03, &[0x1234, 0, 0, 0]);
    broadcast_executed(&mut configurable(), &broadcast_write("FC 06"), &read_holding(), &reply, "FC 6");
}

#[test]
fn broadcast_fc15_is_executed() {
    broadcast_executed(&mut configurable(), &broadcast_write("FC 15"), &read_coils(), &coils_reply(0xAA), "FC 15");
}

#[test]
fn broadcast_fc16_is_executed() {
    let reply = registers_reply(ID, 0x03, &[0, 3000, 4000, 0]);
    broadcast_executed(&mut configurable(), &broadcast_write("FC 16"), &read_holding(), &reply, "FC 16");
}

#[test]
fn broadcast_fc22_is_executed() {
    let mut rtu = configurable();
    // The spec's example: 0x0012 AND 0x00F2 OR 0x0025 gives 0x0017.
    let preset = write_register_request(ID, 3, 0x0012);
    answered(&mut rtu, &preset, &preset, "FC 6 of 40004");
    let mask = with_crc(&[
        BROADCAST, // slave address
        0x16,      // function: mask write register
        0x00,      // address hi
        0x03,      // address lo: 40004
        0x00,      // AND mask hi
        0xF2,      // AND mask lo
        0x00,      // OR mask hi
        0x25,      // OR mask lo
    ]);
    let reply = registers_reply(ID, 0x03, &[0, 0, 0, 0x0017]);
    broadcast_executed(&mut rtu, &mask, &read_holding(), &reply, "FC 22");
}

#[test]
fn broadcast_fc23_is_executed() {
    let reply = registers_reply(ID, 0x03, &[0, 0, 0xABCD, 0]);
    broadcast_executed(&mut configurable(), &broadcast_write("FC 23"), &read_holding(), &reply, "FC 23");
}

// ---------------------------------------------------------------------------------------
// Other slaves

/// Slave 2, the highest slave address, and two reserved ones.
const OTHER_IDS: [u8; 4] = [2, 247, 248, 255];

#[test]
fn frames_for_other_slave_ids_are_silent_and_not_executed() {
    let mut rtu = configurable();
    for id in OTHER_IDS {
        silent(&mut rtu, &read_request(id, 0x03, 0, 4), &format!("FC 3 to {id}"));
        silent(&mut rtu, &diagnostic(id, 0x04), &format!("FC 8/04 to {id}"));
        for (what, write) in writes(id) {
            silent(&mut rtu, &write, &format!("{what} to {id}"));
        }
    }
    answered(&mut rtu, &read_coils(), &coils_reply(ZERO_COILS), "coils");
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "40001-40004");
}

#[test]
fn frames_for_other_slave_ids_count_as_bus_messages_only() {
    let mut rtu = configurable();
    clear_counters(&mut rtu);
    for id in OTHER_IDS {
        rtu.send(&read_request(id, 0x03, 0, 4));
    }
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3");
    assert_eq!(counters(&mut rtu), Counters { bus_messages: 5, slave_messages: 1, ..Counters::default() });
}

// ---------------------------------------------------------------------------------------
// Damaged frames

#[test]
fn frames_with_a_bad_crc_are_silent_and_counted_by_fc8_sub0c() {
    let mut rtu = configurable();
    clear_counters(&mut rtu);
    let frames = [read_holding(), force_listen_only(), write_register_request(ID, 0, 0x1234)];
    for frame in &frames {
        let mut bad = frame.clone();
        *bad.last_mut().unwrap() ^= 0x01; // CRC hi off by one bit
        silent(&mut rtu, &bad, &format!("{frame:02X?} with a bad CRC"));
    }
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3");
    assert_eq!(
        counters(&mut rtu),
        Counters { bus_messages: 4, crc_errors: 3, slave_messages: 1, ..Counters::default() }
    );
}

#[test]
fn frames_broken_by_a_gap_over_t15_are_silent_and_counted_as_bus_messages() {
    let mut rtu = configurable();
    clear_counters(&mut rtu);
    let window = window(&rtu);
    // Two characters of idle line: the next character ends 3 characters after the one
    // before it, past T1.5 and before T3.5, so the frame is broken but not ended.
    let gap = 2 * rtu.char_cycles;
    for frame in [write_register_request(ID, 0, 0x1234), force_listen_only()] {
        // `gap` cycles of idle line after byte 2.
        let end = rtu.send_with_gap(&frame, 3, gap);
        assert_silent(&rtu.watch(end, &[DRIVER_ENABLE, LED], window), &format!("{frame:02X?} with a gap"));
    }
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3");
    assert_eq!(counters(&mut rtu), Counters { bus_messages: 3, slave_messages: 1, ..Counters::default() });
}

/// `frame` with byte `index` flagged with `error` (the byte itself intact, so the CRC is
/// good) is silent, changes nothing, and counts as a bus message only.
fn damaged_byte_is_silent_and_counted(error: LineError) {
    let mut rtu = configurable();
    clear_counters(&mut rtu);
    let window = window(&rtu);
    for frame in [write_register_request(ID, 0, 0x1234), force_listen_only()] {
        let index = 3;
        let first_end = rtu.first_end_after_silence(2 * rtu.tick);
        let head_end = rtu.send_at(&frame[..index], first_end, 0);
        let damaged_end = head_end + rtu.char_cycles;
        rtu.uno.send_byte_with_error(frame[index], damaged_end, error).unwrap();
        let end = rtu.send_at(&frame[index + 1..], damaged_end + rtu.char_cycles, 0);
        assert_silent(&rtu.watch(end, &[DRIVER_ENABLE, LED], window), &format!("{frame:02X?} with a {error:?} error"));
    }
    answered(&mut rtu, &read_holding(), &registers_reply(ID, 0x03, &ZERO_REGISTERS), "FC 3");
    assert_eq!(counters(&mut rtu), Counters { bus_messages: 3, slave_messages: 1, ..Counters::default() });
}

#[test]
fn frames_with_a_parity_error_are_silent_and_counted_as_bus_messages() {
    damaged_byte_is_silent_and_counted(LineError::Parity);
}

#[test]
fn frames_with_a_framing_error_are_silent_and_counted_as_bus_messages() {
    damaged_byte_is_silent_and_counted(LineError::Framing);
}
