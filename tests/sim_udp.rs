//! Modbus UDP (feature `udp`) on the simulated Uno with its simulated Ethernet shield:
//! `examples/tcp_server.rs` built with the feature (`make tcp-firmware`: Modbus UDP on the
//! chip's socket 3, TCP on sockets 0-2), for the W5100 and the W5500. Datagrams from several
//! senders, a malformed one among them, each answered to its sender in order, while a TCP
//! master is served beside them.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, us_to_cycles};
use uno_sim::wiznet::regs::state;
use uno_sim::{Chip, Options, Uno, Wiznet};

const PORT: u16 = 502;
/// The example's UDP socket.
const UDP: usize = 3;

/// The server for `shield` (`w5100`, `w5500`) with Modbus UDP, running until its TCP sockets
/// listen and its UDP socket is open.
fn boot(shield: &str) -> Uno {
    let chip = if shield == "w5500" { Wiznet::W5500 } else { Wiznet::W5100 };
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, &format!("-{shield}-udp"), "tcp_server");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(chip)).unwrap();
    loop {
        let w = uno.wiznet().unwrap();
        if (0..UDP).all(|n| w.status(n) == state::LISTEN) && w.udp_socket(PORT) == Some(UDP) {
            break;
        }
        assert!(uno.now() < us_to_cycles(50_000), "{shield}: the sockets never opened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno
}

fn sender(i: u8) -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + i), 40000 + u16::from(i))
}

/// FC 4 (input registers), one register from `start`, as an ADU.
fn read(transaction: u16, start: u8) -> Vec<u8> {
    vec![(transaction >> 8) as u8, transaction as u8, 0, 0, 0, 6, 1, 0x04, 0, start, 0, 1]
}

#[test]
fn datagrams_from_several_senders_are_answered_each_to_its_own_beside_tcp() {
    for shield in ["w5100", "w5500"] {
        let mut uno = boot(shield);
        let chip = uno.wiznet_mut().unwrap();
        let tcp = chip.connect(PORT, sender(9)).unwrap();
        assert!(chip.deliver(tcp, &read(0x0900, 2)) == 12);
        let mut malformed = read(0x0666, 2);
        malformed[5] = 7; // the length field one more than the datagram holds
        let datagrams = [(0, read(0x0100, 2)), (1, read(0x0200, 3)), (2, malformed), (0, read(0x0101, 4))];
        for (who, adu) in &datagrams {
            assert!(chip.udp_deliver(UDP, sender(*who), adu), "{shield}");
        }
        let mut answers = Vec::new();
        let until = uno.now() + us_to_cycles(30_000);
        while answers.len() < 3 && uno.now() < until {
            uno.run_for(us_to_cycles(200)).unwrap();
            answers.extend(uno.wiznet_mut().unwrap().udp_sent(UDP));
        }
        // 30002 is the requests answered so far; 30003-30004 read 0.
        let transactions: Vec<(SocketAddrV4, u16, Vec<u8>)> =
            answers.iter().map(|(to, adu)| (*to, u16::from_be_bytes([adu[0], adu[1]]), adu[2..9].to_vec())).collect();
        let reply = [0, 0, 0, 5, 1, 0x04, 2];
        assert_eq!(
            transactions,
            [
                (sender(0), 0x0100, reply.to_vec()),
                (sender(1), 0x0200, reply.to_vec()),
                (sender(0), 0x0101, reply.to_vec())
            ],
            "{shield}"
        );
        assert_eq!(answers[1].1[9..], [0, 0], "{shield}: 30004");
        let tcp_answer = uno.wiznet_mut().unwrap().take_sent(tcp);
        assert_eq!(tcp_answer[..9], [0x09, 0x00, 0, 0, 0, 5, 1, 0x04, 2], "{shield}: TCP served beside");
        uno.run_for(us_to_cycles(5_000)).unwrap();
        assert!(uno.wiznet_mut().unwrap().udp_sent(UDP).is_empty(), "{shield}: the malformed one unanswered");
    }
}
