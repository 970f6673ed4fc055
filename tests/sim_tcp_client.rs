//! The Modbus TCP client on the simulated Uno with its simulated Ethernet shield
//! (`examples/tcp_client_check.rs` as `make tcp-firmware` builds it for the W5100 and the
//! W5500), the server played through the chip's socket as a network would bring its bytes:
//! the connection to the server's address and port, transaction ids, a reply with another id
//! never taken, a reply a byte at a time, the timeout and the retry, a reset connection made
//! again, a refused one tried again every second. Implementation Guide v1.0b §3.1.3 (MBAP),
//! §4.2.1 (the client's connection). All in simulated time.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, us_to_cycles};
use uno_sim::wiznet::regs::{sn, state};
use uno_sim::{Chip, Options, Uno, Wiznet};

/// The server the firmware connects to.
const SERVER: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10), 502);

/// The firmware for `chip`, running until its SYN is out.
fn boot(chip: Wiznet) -> Uno {
    let variant = if chip == Wiznet::W5500 { "-tcp-client-w5500" } else { "-tcp-client" };
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, variant, "tcp_client_check");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(chip)).unwrap();
    run_until(&mut uno, 50_000, |uno| !uno.wiznet().unwrap().connecting().is_empty(), "no SYN");
    uno
}

/// Runs in steps of 100 µs until `done`, for at most `limit_us` more.
fn run_until(uno: &mut Uno, limit_us: u64, mut done: impl FnMut(&mut Uno) -> bool, what: &str) {
    let until = uno.now() + us_to_cycles(limit_us);
    while !done(uno) {
        assert!(uno.now() < until, "{what} within {limit_us} µs");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
}

/// The firmware, booted and connected (its SYN to [`SERVER`] accepted).
fn connected(chip: Wiznet) -> Uno {
    let mut uno = boot(chip);
    assert_eq!(uno.wiznet().unwrap().connecting(), [(0, SERVER)], "{chip}");
    assert!(uno.wiznet_mut().unwrap().accept_connect(0));
    run_until(&mut uno, 5000, |uno| outcome(uno)[3] == 1, "connected");
    uno
}

fn outcome(uno: &Uno) -> Vec<u8> {
    uno.read_symbol("TCP_OUTCOME").unwrap()
}

/// Commands a read of `quantity` holding registers from `address` of `unit`, with a response
/// timeout of `response_ms` and `retries` retries.
fn command(uno: &mut Uno, seq: u8, address: u16, quantity: u8, response_ms: u16, retries: u8, unit: u8) {
    let [a0, a1] = address.to_be_bytes();
    let [t0, t1] = response_ms.to_be_bytes();
    uno.write_symbol("TCP_COMMAND", &[seq, a0, a1, quantity, t0, t1, retries, unit]).unwrap();
}

/// What a command came to: its kind (1 the registers, 2 timeout, 3 bad reply, 4 exception),
/// and the registers.
fn result(uno: &mut Uno, seq: u8, limit_us: u64) -> (u8, Vec<u16>) {
    run_until(uno, limit_us, |uno| outcome(uno)[0] == seq, "the outcome");
    // The main loop writes the counters after the outcome.
    uno.run_for(us_to_cycles(1000)).unwrap();
    let out = outcome(uno);
    (out[1], out[11..27].chunks(2).map(|p| u16::from_be_bytes([p[0], p[1]])).collect())
}

/// An ADU: the MBAP header and `pdu`.
fn adu(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut out = transaction.to_be_bytes().to_vec();
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes());
    out.push(unit);
    out.extend_from_slice(pdu);
    out
}

/// The reply PDU of FC 3 with `values`.
fn registers(values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![0x03, 2 * values.len() as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    pdu
}

/// Runs until the server got `len` bytes (for at most 200 ms); returns them.
fn request(uno: &mut Uno, len: usize) -> Vec<u8> {
    let mut got = Vec::new();
    run_until(
        uno,
        200_000,
        |uno| {
            got.extend(uno.wiznet_mut().unwrap().take_sent(0));
            got.len() >= len
        },
        "the request",
    );
    got
}

#[test]
fn both_chips_connect_to_the_server_and_read_with_transaction_ids_1_2_3() {
    for chip in [Wiznet::W5100, Wiznet::W5500] {
        let mut uno = connected(chip);
        for seq in 1..=3u8 {
            command(&mut uno, seq, 0x0010, 3, 1000, 0, 0xFF);
            assert_eq!(
                request(&mut uno, 12),
                adu(u16::from(seq), 0xFF, &[0x03, 0x00, 0x10, 0x00, 0x03]),
                "{chip}: transaction {seq}"
            );
            let values = [0x1234, 0x5678, u16::from(seq)];
            uno.wiznet_mut().unwrap().deliver(0, &adu(u16::from(seq), 0xFF, &registers(&values)));
            let (kind, got) = result(&mut uno, seq, 5000);
            assert_eq!((kind, &got[..3]), (1, &values[..]), "{chip}");
        }
    }
}

#[test]
fn a_reply_with_another_transaction_id_is_never_taken() {
    let mut uno = connected(Wiznet::W5100);
    command(&mut uno, 1, 0x0171, 1, 200, 0, 0xFF);
    request(&mut uno, 12);
    // libmodbus's test server's answer to a read of 0x171: a reply with the next id of its own.
    uno.wiznet_mut().unwrap().deliver(0, &adu(2, 0xFF, &registers(&[0])));
    let (kind, _) = result(&mut uno, 1, 300_000);
    assert_eq!(kind, 2, "timed out, not taken");
    assert_eq!(outcome(&uno)[9], 1, "counted unexpected");
}

#[test]
fn the_wait_goes_on_past_a_reply_with_another_id_to_the_right_one() {
    let mut uno = connected(Wiznet::W5500);
    command(&mut uno, 1, 0, 2, 1000, 0, 0xFF);
    request(&mut uno, 12);
    uno.wiznet_mut().unwrap().deliver(0, &adu(7, 0xFF, &registers(&[0xBAD, 0xBAD])));
    uno.run_for(us_to_cycles(50_000)).unwrap();
    assert_ne!(outcome(&uno)[0], 1, "ended by the other id");
    uno.wiznet_mut().unwrap().deliver(0, &adu(1, 0xFF, &registers(&[0x600D, 0x0001])));
    let (kind, got) = result(&mut uno, 1, 10_000);
    assert_eq!((kind, &got[..2]), (1, &[0x600D, 0x0001][..]));
}

#[test]
fn a_reply_sent_a_byte_every_5_ms_is_reassembled() {
    let mut uno = connected(Wiznet::W5100);
    command(&mut uno, 1, 0x0173, 1, 1000, 0, 0xFF);
    request(&mut uno, 12);
    let reply = adu(1, 0xFF, &registers(&[0]));
    let t = uno.now();
    for (i, &byte) in reply.iter().enumerate() {
        uno.wiznet_mut().unwrap().deliver_at(0, &[byte], t + us_to_cycles(5000 * (i as u64 + 1)));
    }
    uno.run_for(us_to_cycles(5000 * reply.len() as u64 - 2000)).unwrap();
    assert_ne!(outcome(&uno)[0], 1, "taken before its last byte");
    let (kind, got) = result(&mut uno, 1, 10_000);
    assert_eq!((kind, got[0]), (1, 0));
}

#[test]
fn a_silent_server_times_out_and_the_retry_repeats_the_transaction() {
    let mut uno = connected(Wiznet::W5100);
    command(&mut uno, 1, 0x0172, 1, 100, 1, 0xFF);
    let first = request(&mut uno, 12);
    let sent = uno.now();
    let second = request(&mut uno, 12);
    let retry_after = uno.now() - sent;
    assert_eq!(first, second, "the same ADU, transaction id included");
    assert!((us_to_cycles(99_000)..us_to_cycles(104_000)).contains(&retry_after), "retry after {retry_after} cycles");
    let (kind, _) = result(&mut uno, 1, 200_000);
    assert_eq!(kind, 2);
    let out = outcome(&uno);
    assert_eq!((out[5], out[7], out[8]), (2, 2, 1), "requests, timeouts, retries");
}

#[test]
fn a_reset_connection_is_made_again_from_another_port_and_serves_the_next_request() {
    let mut uno = connected(Wiznet::W5100);
    let first_port = uno.wiznet().unwrap().socket_register16(0, sn::PORT);
    uno.wiznet_mut().unwrap().peer_reset(0);
    run_until(&mut uno, 20_000, |uno| !uno.wiznet().unwrap().connecting().is_empty(), "a new SYN");
    assert_ne!(uno.wiznet().unwrap().socket_register16(0, sn::PORT), first_port, "another local port");
    assert!(uno.wiznet_mut().unwrap().accept_connect(0));
    run_until(&mut uno, 5000, |uno| outcome(uno)[3] == 1 && outcome(uno)[4] == 2, "connected again");
    command(&mut uno, 1, 0, 1, 1000, 0, 0xFF);
    request(&mut uno, 12);
    uno.wiznet_mut().unwrap().deliver(0, &adu(1, 0xFF, &registers(&[42])));
    assert_eq!(result(&mut uno, 1, 10_000), (1, [42].into_iter().chain([0; 7]).collect()));
}

#[test]
fn a_refused_connection_is_tried_again_every_second() {
    let mut uno = boot(Wiznet::W5100);
    let mut syns = vec![uno.now()];
    while syns.len() < 4 {
        assert!(uno.wiznet_mut().unwrap().refuse_connect(0));
        assert_eq!(uno.wiznet().unwrap().status(0), state::CLOSED);
        run_until(&mut uno, 1_500_000, |uno| !uno.wiznet().unwrap().connecting().is_empty(), "another SYN");
        syns.push(uno.now());
    }
    for pair in syns.windows(2) {
        let gap = pair[1] - pair[0];
        assert!((us_to_cycles(1_000_000)..us_to_cycles(1_010_000)).contains(&gap), "{gap} cycles between SYNs");
    }
    assert_eq!(outcome(&uno)[4], 0, "never connected");
}

#[test]
fn the_idle_client_takes_a_few_percent_of_the_cpu_and_a_request_goes_out_within_a_poll() {
    for chip in [Wiznet::W5100, Wiznet::W5500] {
        let mut uno = connected(chip);
        let ovf = uno.vectors().timer0_ovf;
        uno.reset_isr_stats();
        let start = uno.now();
        uno.run_for(us_to_cycles(1_000_000)).unwrap();
        let share = uno.isr_stats(ovf).cycles as f64 / (uno.now() - start) as f64;
        // From the command (the main loop calls send within microseconds) to the SEND.
        let mut delays = Vec::new();
        for seq in 1..=50u8 {
            uno.run_for(us_to_cycles(u64::from(seq) * 37)).unwrap();
            command(&mut uno, seq, 0, 1, 1000, 0, 0xFF);
            let asked = uno.now();
            request(&mut uno, 12);
            delays.push(uno.wiznet().unwrap().sends(0).last().unwrap().cycle - asked);
            uno.wiznet_mut().unwrap().deliver(0, &adu(u16::from(seq), 0xFF, &registers(&[1])));
            assert_eq!(result(&mut uno, seq, 10_000).0, 1);
        }
        delays.sort_unstable();
        eprintln!(
            "tcp_client_check ({chip}): idle, the overflow handler {:.2} % of the CPU; command -> SEND p50 {:.0} µs, max {:.0} µs",
            100.0 * share,
            sim::cycles_to_us(delays[25]),
            sim::cycles_to_us(delays[49])
        );
        assert!(share < 0.03, "{chip}: {:.2} %", 100.0 * share);
        assert!(delays[49] < us_to_cycles(2500), "{chip}: {} cycles", delays[49]);
    }
}

#[test]
fn while_the_application_has_the_spi_the_request_waits_and_goes_out_after() {
    let mut uno = connected(Wiznet::W5100);
    let (w0, w1) = (1000u16.to_be_bytes()[0], 1000u16.to_be_bytes()[1]);
    // A read, then the SPI held 30 ms by the application.
    uno.write_symbol("TCP_COMMAND", &[1, 0, 0, 1, w0, w1, 0, 0xFF, 30]).unwrap();
    let asked = uno.now();
    let request = request(&mut uno, 12);
    assert_eq!(request, adu(1, 0xFF, &[0x03, 0, 0, 0, 1]));
    let waited = uno.wiznet().unwrap().sends(0).last().unwrap().cycle - asked;
    assert!(waited >= us_to_cycles(30_000), "sent {waited} cycles after send, the SPI lent for 30 ms");
    uno.wiznet_mut().unwrap().deliver(0, &adu(1, 0xFF, &registers(&[7])));
    assert_eq!(result(&mut uno, 1, 10_000).0, 1);
}
