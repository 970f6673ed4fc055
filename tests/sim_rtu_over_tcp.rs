//! Modbus RTU over TCP (feature `rtu-over-tcp`) on the simulated Uno with its simulated
//! W5100, as `make tcp-firmware` builds it with the feature (socket 3 speaks RTU over TCP on
//! port 5020, sockets 0-2 MBAP on 502): the serial frame (address, PDU, CRC) on the TCP
//! stream, framed by its function code. The server (`examples/sixteen_each_tcp.rs`): reads,
//! writes, exceptions, a frame split over segments, frames in one segment, a bad CRC, and
//! MBAP beside on the same chip. The gateway (`examples/tcp_gateway.rs`): a frame to the
//! line as it came, the slave's answer back as it came off the line, 0B framed for a slave
//! that does not answer, a bad CRC never on the line.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, crc16, us_to_cycles};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Uno, Wiznet};

/// The RTU over TCP socket's port, and the socket.
const RTU_PORT: u16 = 5020;
const RTU_SOCKET: usize = 3;

/// The firmware, running until its four sockets listen.
fn boot() -> Uno {
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, "-tcp-rtu", "sixteen_each_tcp");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(Wiznet::W5100)).unwrap();
    while !(0..4).all(|n| uno.wiznet().unwrap().status(n) == state::LISTEN) {
        assert!(uno.now() < us_to_cycles(50_000), "the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno
}

/// A master connected to `port`, seen by the firmware: its socket.
fn connect(uno: &mut Uno, port: u16, who: u8) -> usize {
    let peer = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + who), 40000 + u16::from(who));
    let n = uno.wiznet_mut().unwrap().connect(port, peer).expect("a socket listens");
    uno.run_for(us_to_cycles(3000)).unwrap();
    n
}

/// `body` (address and PDU) with its CRC, low byte first.
fn frame(body: &[u8]) -> Vec<u8> {
    let mut frame = body.to_vec();
    frame.extend_from_slice(&crc16(body).to_le_bytes());
    frame
}

/// Sends `request` on socket `n` and runs until `expected_len` bytes came back (at most 20 ms).
fn ask(uno: &mut Uno, n: usize, request: &[u8], expected_len: usize) -> Vec<u8> {
    assert_eq!(uno.wiznet_mut().unwrap().deliver(n, request), request.len());
    let mut got = Vec::new();
    let until = uno.now() + us_to_cycles(20_000);
    while got.len() < expected_len && uno.now() < until {
        uno.run_for(us_to_cycles(100)).unwrap();
        got.extend(uno.wiznet_mut().unwrap().take_sent(n));
    }
    got
}

#[test]
fn reads_writes_and_exceptions_come_back_as_rtu_frames() {
    let mut uno = boot();
    let n = connect(&mut uno, RTU_PORT, 0);
    assert_eq!(n, RTU_SOCKET);
    // FC 16: 40001-40003 = 1, 2, 3, at address 0x11; the echo with its CRC.
    let write = frame(&[0x11, 0x10, 0x00, 0x00, 0x00, 0x03, 0x06, 0, 1, 0, 2, 0, 3]);
    assert_eq!(ask(&mut uno, n, &write, 8), frame(&[0x11, 0x10, 0x00, 0x00, 0x00, 0x03]));
    let read = frame(&[0x11, 0x03, 0x00, 0x00, 0x00, 0x03]);
    assert_eq!(ask(&mut uno, n, &read, 11), frame(&[0x11, 0x03, 6, 0, 1, 0, 2, 0, 3]));
    // 40017 is past the map: 02; 126 registers: 03; FC 0x41: 01.
    assert_eq!(ask(&mut uno, n, &frame(&[0x11, 0x03, 0, 16, 0, 1]), 5), frame(&[0x11, 0x83, 0x02]));
    assert_eq!(ask(&mut uno, n, &frame(&[0x11, 0x03, 0, 0, 0, 126]), 5), frame(&[0x11, 0x83, 0x03]));
    assert_eq!(ask(&mut uno, n, &frame(&[0x11, 0x41]), 5), frame(&[0x11, 0xC1, 0x01]));
}

#[test]
fn split_pipelined_and_damaged_frames_beside_an_mbap_master() {
    let mut uno = boot();
    let mbap = connect(&mut uno, 502, 1);
    let n = connect(&mut uno, RTU_PORT, 0);
    // Split: the first 5 bytes, then the rest 3 ms later.
    let read = frame(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x02]);
    let t = uno.now();
    let w = uno.wiznet_mut().unwrap();
    w.deliver_at(n, &read[..5], t + us_to_cycles(200));
    w.deliver_at(n, &read[5..], t + us_to_cycles(3200));
    uno.run_for(us_to_cycles(3000)).unwrap();
    assert!(uno.wiznet_mut().unwrap().take_sent(n).is_empty(), "answered before the frame was whole");
    assert_eq!(ask(&mut uno, n, &[], 9), frame(&[0x01, 0x03, 4, 0, 0, 0, 0]));
    // A bad CRC: silence; the next segment is answered.
    let mut bad = frame(&[0x01, 0x06, 0x00, 0x00, 0x12, 0x34]);
    bad[6] ^= 0xFF;
    assert!(ask(&mut uno, n, &bad, 1).is_empty(), "a damaged frame answered");
    // Three frames in one segment; then an MBAP master reads what the RTU one wrote.
    let segment =
        [frame(&[0x01, 0x06, 0x00, 0x00, 0xBE, 0xEF]), read.clone(), frame(&[0x02, 0x01, 0x00, 0x00, 0x00, 0x08])]
            .concat();
    let expected = [
        frame(&[0x01, 0x06, 0x00, 0x00, 0xBE, 0xEF]),
        frame(&[0x01, 0x03, 4, 0xBE, 0xEF, 0, 0]),
        frame(&[0x02, 0x01, 1, 0]),
    ]
    .concat();
    assert_eq!(ask(&mut uno, n, &segment, expected.len()), expected);
    let mbap_read = [0, 7, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1];
    assert_eq!(ask(&mut uno, mbap, &mbap_read, 11), [0, 7, 0, 0, 0, 5, 1, 3, 2, 0xBE, 0xEF]);
}

/// The gateway (`examples/tcp_gateway.rs` with the feature: RS-485 at 19200 8E1, a response
/// timeout of 200 ms and one retry; socket 3 speaks RTU over TCP on port 5020), running until
/// its sockets listen.
fn boot_gateway() -> Uno {
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, "-tcp-gateway-rtu", "tcp_gateway");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(Wiznet::W5100)).unwrap();
    while !(0..4).all(|n| uno.wiznet().unwrap().status(n) == state::LISTEN) {
        assert!(uno.now() < us_to_cycles(100_000), "the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno.run_for(us_to_cycles(5000)).unwrap();
    uno
}

/// The gateway's next frame on the line, once two characters of idle line end it (within
/// `ms`): its bytes and the cycle its last character ended; what came back on socket `n`
/// meanwhile is added to `answers`.
fn line_frame(uno: &mut Uno, n: usize, ms: u64, answers: &mut Vec<u8>) -> Option<(Vec<u8>, u64)> {
    let char_cycles = uno.wire_char_cycles().unwrap();
    let deadline = uno.now() + us_to_cycles(1000 * ms);
    let mut chars = Vec::new();
    while uno.now() < deadline {
        uno.run_for(char_cycles / 2).unwrap();
        answers.extend(uno.wiznet_mut().unwrap().take_sent(n));
        chars.extend(uno.take_tx());
        if let Some(last) = chars.last() {
            if uno.now() >= last.end_cycle + 2 * char_cycles {
                return Some((chars.iter().map(|c| c.byte).collect(), last.end_cycle));
            }
        }
    }
    None
}

#[test]
fn the_gateway_passes_a_frame_to_the_line_as_it_is_and_the_answer_back() {
    let mut uno = boot_gateway();
    let n = connect(&mut uno, RTU_PORT, 0);
    assert_eq!(n, RTU_SOCKET);
    let mut answers = Vec::new();
    let request = frame(&[0x02, 0x03, 0x00, 0x05, 0x00, 0x02]);
    uno.wiznet_mut().unwrap().deliver(n, &request);
    let (sent, end) = line_frame(&mut uno, n, 50, &mut answers).expect("the request on the line");
    assert_eq!(sent, request);
    // Slave 2 answers 3 ms after the request's end.
    let reply = frame(&[0x02, 0x03, 0x04, 0x12, 0x34, 0x56, 0x78]);
    uno.send_frame(&reply, end + us_to_cycles(3000), 0).unwrap();
    assert_eq!(line_frame(&mut uno, n, 20, &mut answers), None, "the gateway sent again");
    assert_eq!(answers, reply, "the answer as it came off the line");
    // A slave that does not answer: the request and its retry, then 0B in an RTU frame.
    answers.clear();
    let request = frame(&[0x07, 0x06, 0x00, 0x01, 0xAB, 0xCD]);
    uno.wiznet_mut().unwrap().deliver(n, &request);
    for _ in 0..2 {
        let (sent, _) = line_frame(&mut uno, n, 250, &mut answers).expect("a try on the line");
        assert_eq!(sent, request);
    }
    assert_eq!(line_frame(&mut uno, n, 250, &mut answers), None);
    assert_eq!(answers, frame(&[0x07, 0x86, 0x0B]));
    // A bad CRC never reaches the line.
    let mut bad = frame(&[0x02, 0x03, 0x00, 0x05, 0x00, 0x02]);
    bad[7] ^= 1;
    uno.wiznet_mut().unwrap().deliver(n, &bad);
    assert_eq!(line_frame(&mut uno, n, 20, &mut answers), None);
}
