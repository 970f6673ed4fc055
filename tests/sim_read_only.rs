//! Clients that may only read (feature `write-protect`) on the simulated Uno with its
//! simulated W5100: `examples/sixteen_each_tcp.rs` as `make tcp-firmware` builds it with the
//! feature (192.168.1.10 writes, 192.168.1.20 only reads, nobody else connects). The reading
//! client's writes get exception 01 and change nothing, its reads are answered; the writing
//! client's write, on another socket at the same time, is done; a third address is refused.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, us_to_cycles};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Uno, Wiznet};

/// The firmware, running until its four sockets listen.
fn boot() -> Uno {
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, "-tcp-read-only", "sixteen_each_tcp");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(Wiznet::W5100)).unwrap();
    while !(0..4).all(|n| uno.wiznet().unwrap().status(n) == state::LISTEN) {
        assert!(uno.now() < us_to_cycles(50_000), "the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno
}

/// A client at 192.168.1.`host` connected to port 502: its socket.
fn connect(uno: &mut Uno, host: u8) -> usize {
    let peer = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, host), 40000 + u16::from(host));
    let n = uno.wiznet_mut().unwrap().connect(502, peer).expect("a socket listens");
    uno.run_for(us_to_cycles(3000)).unwrap();
    n
}

/// An ADU to unit 1: transaction `t`, then `pdu`.
fn adu(t: u8, pdu: &[u8]) -> Vec<u8> {
    let mut out = vec![0, t, 0, 0, 0, pdu.len() as u8 + 1, 1];
    out.extend_from_slice(pdu);
    out
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
fn a_reading_clients_writes_get_01_and_a_writing_clients_write_is_done() {
    let mut uno = boot();
    let reader = connect(&mut uno, 20);
    let writer = connect(&mut uno, 10);
    assert_ne!(reader, writer);
    // The reader: FC 6 to 40001, FC 16 to 40001-40002, FC 5 to coil 1: each 01.
    let fc6 = [0x06, 0x00, 0x00, 0x12, 0x34];
    assert_eq!(ask(&mut uno, reader, &adu(1, &fc6), 9), adu(1, &[0x86, 0x01]));
    let fc16 = [0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0xAB, 0xCD, 0xEF, 0x01];
    assert_eq!(ask(&mut uno, reader, &adu(2, &fc16), 9), adu(2, &[0x90, 0x01]));
    let fc5 = [0x05, 0x00, 0x00, 0xFF, 0x00];
    assert_eq!(ask(&mut uno, reader, &adu(3, &fc5), 9), adu(3, &[0x85, 0x01]));
    // Nothing changed: 40001-40002 still 0.
    let fc3 = [0x03, 0x00, 0x00, 0x00, 0x02];
    assert_eq!(ask(&mut uno, reader, &adu(4, &fc3), 13), adu(4, &[0x03, 4, 0, 0, 0, 0]));
    // The writer's FC 6 is done, and the reader reads it.
    assert_eq!(ask(&mut uno, writer, &adu(5, &fc6), 12), adu(5, &fc6));
    assert_eq!(ask(&mut uno, reader, &adu(6, &fc3), 13), adu(6, &[0x03, 4, 0x12, 0x34, 0, 0]));
    // An address on neither list is refused at once.
    let peer = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 30), 40030);
    let n = uno.wiznet_mut().unwrap().connect(502, peer).expect("a socket listens");
    uno.run_for(us_to_cycles(3000)).unwrap();
    assert_eq!(uno.wiznet().unwrap().status(n), state::LISTEN, "refused and listening again");
}
