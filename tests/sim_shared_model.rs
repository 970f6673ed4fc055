//! One model on two ports on the simulated Uno (`examples/tcp_rtu.rs`: the contract's map
//! served by the RTU slave on pins 0/1, 19200 8E1, and by the TCP server on a W5100, one
//! `shared_model!`): a write on either port is read back on the other at once; two masters
//! hammering the same 32-bit pair from both ports never read it torn, on either port, and
//! the last write wins; the application learns which port wrote. The control,
//! `examples/tcp_rtu_copy.rs` (two maps and a copy in the loop, the way before), shows torn
//! pairs under the same hammer, so the hammer can see one.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, read_request, us_to_cycles, with_crc, Rng};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Uno, Wiznet};

/// The serial slave's id.
const ID: u8 = 1;

/// The firmware `name` of `make tcp-firmware`'s `atmega328p-tcp` build, a connection made
/// to its TCP server.
struct Both {
    uno: Uno,
    /// The simulated shield's connection.
    n: usize,
    /// A character on the serial line, in cycles.
    char_time: u64,
    transaction: u16,
}

impl Both {
    fn boot(name: &str) -> Both {
        let elf = chip_variant_firmware(Chip::Atmega328p, 0, "-tcp", name);
        let mut uno = Uno::load_with(elf, Options::new().wiznet(Wiznet::W5100)).unwrap();
        while uno.wiznet().unwrap().status(0) != state::LISTEN {
            assert!(uno.now() < us_to_cycles(50_000), "{name}: socket 0 never listened");
            uno.run_for(us_to_cycles(100)).unwrap();
        }
        let peer = SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 20), 40000);
        let n = uno.wiznet_mut().unwrap().connect(502, peer).expect("a socket listens");
        uno.run_for(us_to_cycles(5000)).unwrap();
        let char_time = uno.wire_char_cycles().expect("the USART is set up");
        Both { uno, n, char_time, transaction: 0 }
    }

    /// The ADU of `pdu` for unit 1, with the next transaction id.
    fn adu(&mut self, pdu: &[u8]) -> Vec<u8> {
        self.transaction = self.transaction.wrapping_add(1);
        let mut adu = self.transaction.to_be_bytes().to_vec();
        adu.extend_from_slice(&[0, 0, 0, pdu.len() as u8 + 1, 1]);
        adu.extend_from_slice(pdu);
        adu
    }

    /// The serial master sends `frame` (address and PDU; the CRC is added) and, while it is
    /// on the line, the TCP master's `tcp` PDU lands on the shield `tcp_at` characters after
    /// the frame's first. Returns the serial reply's PDU and the TCP reply's PDU.
    fn both(&mut self, frame: &[u8], tcp: &[u8], tcp_at: u64) -> (Vec<u8>, Vec<u8>) {
        let adu = self.adu(tcp);
        let now = self.uno.now();
        self.uno.wiznet_mut().unwrap().deliver_at(self.n, &adu, now + self.char_time * tcp_at);
        let first = now + self.char_time;
        let last = self.uno.send_frame(&with_crc(frame), first, 0).unwrap();
        let reply = self.uno.run_until_tx_idle(4 * self.char_time, last + us_to_cycles(100_000)).unwrap();
        let reply: Vec<u8> = reply.iter().map(|b| b.byte).collect();
        assert!(reply.len() >= 5, "serial reply {reply:02X?} to {frame:02X?}");
        assert_eq!(with_crc(&reply[..reply.len() - 2]), reply, "serial reply's CRC");
        let tcp_reply = self.tcp_reply(adu.len());
        (reply[1..reply.len() - 2].to_vec(), tcp_reply)
    }

    /// The TCP reply's PDU to the request of `transaction`, waited for up to 50 ms.
    fn tcp_reply(&mut self, _request_len: usize) -> Vec<u8> {
        let mut got = Vec::new();
        let until = self.uno.now() + us_to_cycles(50_000);
        loop {
            got.extend(self.uno.wiznet_mut().unwrap().take_sent(self.n));
            if got.len() >= 7 && got.len() >= 6 + usize::from(got[5]) {
                break;
            }
            assert!(self.uno.now() < until, "no TCP reply: {got:02X?}");
            self.uno.run_for(us_to_cycles(200)).unwrap();
        }
        assert_eq!(got[..2], self.transaction.to_be_bytes(), "TCP reply's transaction id");
        got[7..].to_vec()
    }

    /// The TCP master alone: `pdu`'s reply PDU.
    fn tcp(&mut self, pdu: &[u8]) -> Vec<u8> {
        let adu = self.adu(pdu);
        assert_eq!(self.uno.wiznet_mut().unwrap().deliver(self.n, &adu), adu.len());
        self.tcp_reply(adu.len())
    }

    /// The serial master alone: `frame`'s reply PDU.
    fn rtu(&mut self, frame: &[u8]) -> Vec<u8> {
        let first = self.uno.now() + self.char_time;
        let last = self.uno.send_frame(&with_crc(frame), first, 0).unwrap();
        let reply = self.uno.run_until_tx_idle(4 * self.char_time, last + us_to_cycles(100_000)).unwrap();
        let reply: Vec<u8> = reply.iter().map(|b| b.byte).collect();
        assert!(reply.len() >= 5, "serial reply {reply:02X?} to {frame:02X?}");
        reply[1..reply.len() - 2].to_vec()
    }
}

/// FC 16's PDU: `values` to the holding registers from `start`.
fn write_pdu(start: u16, values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![0x10];
    pdu.extend_from_slice(&start.to_be_bytes());
    pdu.extend_from_slice(&(values.len() as u16).to_be_bytes());
    pdu.push(2 * values.len() as u8);
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    pdu
}

/// FC 3's PDU: `qty` holding registers from `start`.
fn read_pdu(start: u16, qty: u16) -> Vec<u8> {
    read_request(ID, 0x03, start, qty)[1..6].to_vec()
}

/// The registers of a FC 3/4 reply PDU.
fn values(pdu: &[u8]) -> Vec<u16> {
    assert!(pdu.len() >= 2 && pdu[0] & 0x80 == 0, "reply {pdu:02X?}");
    pdu[2..].chunks(2).map(|w| u16::from_be_bytes([w[0], w[1]])).collect()
}

/// The serial frame of `pdu` for the slave.
fn frame(pdu: &[u8]) -> Vec<u8> {
    let mut frame = vec![ID];
    frame.extend_from_slice(pdu);
    frame
}

/// `rounds` rounds in which each port writes a pair of equal words to 40001–40002 or reads
/// it while the other does the same, at a random moment of the serial request. Returns the
/// torn pairs read (words not equal) on the serial side and on the TCP side.
fn hammer(both: &mut Both, rounds: u16, seed: u64) -> (usize, usize) {
    let mut rng = Rng(seed);
    let (mut torn_rtu, mut torn_tcp) = (0, 0);
    for round in 0..rounds {
        let (a, b) = (2 * round + 1, 2 * round + 2);
        // Either the serial master reads while TCP writes, or the other way round; both
        // write in one round out of four.
        let (rtu_pdu, tcp_pdu) = match rng.below(4) {
            0 => (read_pdu(0, 2), write_pdu(0, &[b, b])),
            1 => (write_pdu(0, &[a, a]), read_pdu(0, 2)),
            2 => (write_pdu(0, &[a, a]), write_pdu(0, &[b, b])),
            _ => (read_pdu(0, 2), read_pdu(0, 2)),
        };
        let (rtu, tcp) = both.both(&frame(&rtu_pdu), &tcp_pdu, rng.range(0, 12));
        for (reply, torn) in [(rtu, &mut torn_rtu), (tcp, &mut torn_tcp)] {
            if reply[0] == 0x03 {
                let pair = values(&reply);
                if pair[0] != pair[1] {
                    *torn += 1;
                }
            } else {
                assert_eq!(reply[0], 0x10, "a write's reply: {reply:02X?}");
            }
        }
        // The control copies one way, every 4 ms: let it, so that the next round starts
        // from a pair copied whole.
        both.uno.run_for(us_to_cycles(rng.range(0, 5000))).unwrap();
    }
    (torn_rtu, torn_tcp)
}

#[test]
fn a_write_on_either_port_is_read_back_on_the_other_at_once() {
    let mut both = Both::boot("tcp_rtu");
    assert_eq!(both.tcp(&write_pdu(4, &[0x1234, 0x5678])), [0x10, 0x00, 0x04, 0x00, 0x02]);
    assert_eq!(values(&both.rtu(&frame(&read_pdu(4, 2)))), [0x1234, 0x5678], "TCP's write on the serial line");
    assert_eq!(both.rtu(&frame(&write_pdu(6, &[0xBEEF]))), [0x10, 0x00, 0x06, 0x00, 0x01]);
    assert_eq!(values(&both.tcp(&read_pdu(4, 3))), [0x1234, 0x5678, 0xBEEF], "the serial write over TCP");
    // Coils: FC 5 over TCP, FC 1 on the line.
    assert_eq!(both.tcp(&[0x05, 0x00, 0x02, 0xFF, 0x00]), [0x05, 0x00, 0x02, 0xFF, 0x00]);
    assert_eq!(both.rtu(&frame(&[0x01, 0x00, 0x00, 0x00, 0x08])), [0x01, 0x01, 0b100]);
}

#[test]
fn the_application_learns_which_port_wrote() {
    // The loop keeps 30001 at the number of master writes, 30002 at the last writer: 1 the
    // serial line, 2 a TCP client.
    let mut both = Both::boot("tcp_rtu");
    let input = |both: &mut Both| values(&both.tcp(&[0x04, 0x00, 0x00, 0x00, 0x02]));
    assert_eq!(input(&mut both), [0, 0], "no write yet");
    both.tcp(&write_pdu(0, &[7]));
    both.uno.run_for(us_to_cycles(2000)).unwrap();
    assert_eq!(input(&mut both), [1, 2], "a TCP client wrote");
    both.rtu(&frame(&write_pdu(1, &[8])));
    both.uno.run_for(us_to_cycles(2000)).unwrap();
    assert_eq!(input(&mut both), [2, 1], "the serial master wrote");
    // A read, and a refused write, are no writes.
    both.rtu(&frame(&read_pdu(0, 2)));
    assert_eq!(both.rtu(&frame(&write_pdu(16, &[1]))), [0x90, 0x02]);
    both.uno.run_for(us_to_cycles(2000)).unwrap();
    assert_eq!(input(&mut both), [2, 1]);
}

#[test]
fn two_masters_hammering_one_pair_from_both_ports_never_read_it_torn_and_the_last_write_wins() {
    let mut both = Both::boot("tcp_rtu");
    let (rtu, tcp) = hammer(&mut both, 150, 46);
    println!("one model: {rtu} torn pairs read on the serial line, {tcp} over TCP, of 150 rounds");
    assert_eq!((rtu, tcp), (0, 0));
    // The last write wins, and both ports read it.
    both.tcp(&write_pdu(0, &[0xAAAA, 0xAAAA]));
    both.rtu(&frame(&write_pdu(0, &[0x5555, 0x5555])));
    assert_eq!(values(&both.tcp(&read_pdu(0, 2))), [0x5555, 0x5555]);
    assert_eq!(values(&both.rtu(&frame(&read_pdu(0, 2)))), [0x5555, 0x5555]);
}

#[test]
fn two_maps_and_a_copy_show_torn_pairs_under_the_same_hammer() {
    let mut both = Both::boot("tcp_rtu_copy");
    let (rtu, tcp) = hammer(&mut both, 150, 46);
    println!("two maps and a copy: {rtu} torn pairs read on the serial line, {tcp} over TCP, of 150 rounds");
    assert!(rtu > 0, "no torn pair: the hammer would not see one either");
}
