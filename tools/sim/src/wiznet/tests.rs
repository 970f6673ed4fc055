//! The model fed SPI bytes directly, as the firmware's driver sends them, one chip-select
//! period per access.

use std::net::{Ipv4Addr, SocketAddrV4};

use super::regs::{cmd, int, mode, sn, state};
use super::{retransmission_time, w5100, w5500, W5x00, Wiznet};

/// A firmware's driver in a few lines: register and buffer accesses as SPI frames.
struct Driver {
    chip: W5x00,
    cycle: u64,
}

impl Driver {
    fn new(model: Wiznet) -> Driver {
        Driver { chip: W5x00::new(model), cycle: 0 }
    }

    /// One chip-select period with `bytes`; the chip's answers.
    fn frame(&mut self, bytes: &[u8]) -> Vec<u8> {
        self.cycle += 100;
        self.chip.select(self.cycle);
        let out = bytes
            .iter()
            .map(|&b| {
                self.cycle += 16;
                self.chip.exchange(b, self.cycle).unwrap()
            })
            .collect();
        self.chip.deselect(self.cycle);
        out
    }

    fn w5100_write(&mut self, addr: u16, data: &[u8]) {
        for (i, &b) in data.iter().enumerate() {
            let a = addr.wrapping_add(i as u16).to_be_bytes();
            assert_eq!(self.frame(&[w5100::WRITE, a[0], a[1], b]), [0, 1, 2, 3]);
        }
    }

    fn w5100_read(&mut self, addr: u16, len: usize) -> Vec<u8> {
        (0..len)
            .map(|i| {
                let a = addr.wrapping_add(i as u16).to_be_bytes();
                self.frame(&[w5100::READ, a[0], a[1], 0])[3]
            })
            .collect()
    }

    fn w5500(&mut self, bsb: u8, addr: u16, write: bool, data: &[u8]) -> Vec<u8> {
        let a = addr.to_be_bytes();
        let mut bytes = vec![a[0], a[1], w5500::control(bsb, write)];
        bytes.extend_from_slice(data);
        self.frame(&bytes)[3..].to_vec()
    }

    fn common_write(&mut self, addr: u16, data: &[u8]) {
        match self.chip.model() {
            Wiznet::W5100 => self.w5100_write(addr, data),
            Wiznet::W5500 => drop(self.w5500(0, addr, true, data)),
        }
    }

    fn common_read(&mut self, addr: u16, len: usize) -> Vec<u8> {
        match self.chip.model() {
            Wiznet::W5100 => self.w5100_read(addr, len),
            Wiznet::W5500 => self.w5500(0, addr, false, &vec![0; len]),
        }
    }

    fn sock_write(&mut self, n: u8, off: u16, data: &[u8]) {
        match self.chip.model() {
            Wiznet::W5100 => self.w5100_write(w5100::socket_addr(n, off), data),
            Wiznet::W5500 => drop(self.w5500(4 * n + 1, off, true, data)),
        }
    }

    fn sock_read(&mut self, n: u8, off: u16, len: usize) -> Vec<u8> {
        match self.chip.model() {
            Wiznet::W5100 => self.w5100_read(w5100::socket_addr(n, off), len),
            Wiznet::W5500 => self.w5500(4 * n + 1, off, false, &vec![0; len]),
        }
    }

    fn read16(&mut self, n: u8, off: u16) -> u16 {
        let b = self.sock_read(n, off, 2);
        u16::from_be_bytes([b[0], b[1]])
    }

    fn write16(&mut self, n: u8, off: u16, v: u16) {
        self.sock_write(n, off, &v.to_be_bytes());
    }

    fn command(&mut self, n: u8, c: u8) {
        self.sock_write(n, sn::CR, &[c]);
        assert_eq!(self.sock_read(n, sn::CR, 1), [0], "Sn_CR reads 0 once the command is taken");
    }

    fn sr(&mut self, n: u8) -> u8 {
        self.sock_read(n, sn::SR, 1)[0]
    }

    /// Socket `n`'s TX buffer from pointer `ptr` (2 KB buffers on the W5100).
    fn tx_write(&mut self, n: u8, ptr: u16, data: &[u8]) {
        match self.chip.model() {
            Wiznet::W5100 => {
                for (i, &b) in data.iter().enumerate() {
                    let off = ptr.wrapping_add(i as u16) & 0x7FF;
                    self.w5100_write(0x4000 + u16::from(n) * 0x800 + off, &[b]);
                }
            }
            Wiznet::W5500 => drop(self.w5500(4 * n + 2, ptr, true, data)),
        }
    }

    fn rx_read(&mut self, n: u8, ptr: u16, len: usize) -> Vec<u8> {
        match self.chip.model() {
            Wiznet::W5100 => (0..len)
                .map(|i| {
                    let off = ptr.wrapping_add(i as u16) & 0x7FF;
                    self.w5100_read(0x6000 + u16::from(n) * 0x800 + off, 1)[0]
                })
                .collect(),
            Wiznet::W5500 => self.w5500(4 * n + 3, ptr, false, &vec![0; len]),
        }
    }

    fn listen(&mut self, n: u8, port: u16) {
        self.sock_write(n, sn::MR, &[mode::TCP]);
        self.write16(n, sn::PORT, port);
        self.command(n, cmd::OPEN);
        assert_eq!(self.sr(n), state::INIT);
        self.command(n, cmd::LISTEN);
        assert_eq!(self.sr(n), state::LISTEN);
    }

    /// What the firmware's receive does: RSR bytes from RX_RD, RX_RD moved, RECV.
    fn receive(&mut self, n: u8) -> Vec<u8> {
        let len = self.read16(n, sn::RX_RSR);
        let rd = self.read16(n, sn::RX_RD);
        let data = self.rx_read(n, rd, usize::from(len));
        self.write16(n, sn::RX_RD, rd.wrapping_add(len));
        self.command(n, cmd::RECV);
        data
    }

    /// What the firmware's send does: data at TX_WR, TX_WR moved, SEND.
    fn send(&mut self, n: u8, data: &[u8]) {
        let wr = self.read16(n, sn::TX_WR);
        self.tx_write(n, wr, data);
        self.write16(n, sn::TX_WR, wr.wrapping_add(data.len() as u16));
        self.command(n, cmd::SEND);
    }

    /// Socket `n` listening on 502 with a peer connected.
    fn connected(model: Wiznet, n: u8) -> Driver {
        let mut d = Driver::new(model);
        d.listen(n, 502);
        assert_eq!(d.chip.connect(502, peer()), Some(usize::from(n)));
        d
    }
}

fn peer() -> SocketAddrV4 {
    SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10), 40000)
}

const BOTH: [Wiznet; 2] = [Wiznet::W5100, Wiznet::W5500];

// ---- SPI framing ----------------------------------------------------------------------------

#[test]
fn w5100_write_and_read_frames_reach_the_common_registers() {
    let mut d = Driver::new(Wiznet::W5100);
    // SHAR 0x0009-0x000E
    d.w5100_write(0x0009, &[0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0x01]);
    assert_eq!(d.w5100_read(0x0009, 6), [0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0x01]);
    // the read's answers: 0x00, 0x01, 0x02, then the data
    assert_eq!(d.frame(&[0x0F, 0x00, 0x09, 0x00]), [0x00, 0x01, 0x02, 0xDE]);
}

#[test]
fn w5100_frames_follow_each_other_in_one_chip_select() {
    let mut d = Driver::new(Wiznet::W5100);
    let answers = d.frame(&[
        0xF0, 0x00, 0x0F, 192, // SIPR[0] = 192
        0xF0, 0x00, 0x10, 168, // SIPR[1] = 168
        0x0F, 0x00, 0x0F, 0x00, // read SIPR[0]
    ]);
    assert_eq!(answers, [0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 192]);
}

#[test]
fn w5100_frame_with_another_opcode_is_ignored() {
    let mut d = Driver::new(Wiznet::W5100);
    d.frame(&[0xAA, 0x00, 0x01, 0x55]);
    assert_eq!(d.w5100_read(0x0001, 1), [0]);
}

#[test]
fn chip_select_high_ends_a_frame() {
    let mut d = Driver::new(Wiznet::W5100);
    // two bytes of a write, then CS high: the next frame starts afresh
    d.frame(&[0xF0, 0x00]);
    d.w5100_write(0x0001, &[10]);
    assert_eq!(d.w5100_read(0x0001, 1), [10]);
    let mut d = Driver::new(Wiznet::W5500);
    d.frame(&[0x00, 0x01]);
    d.common_write(0x0001, &[10, 20]);
    assert_eq!(d.common_read(0x0001, 2), [10, 20]);
}

#[test]
fn not_selected_the_chip_does_not_answer() {
    let mut chip = W5x00::new(Wiznet::W5100);
    assert_eq!(chip.exchange(0x0F, 16), None);
    chip.select(20);
    assert_eq!(chip.exchange(0x0F, 36), Some(0));
    chip.deselect(40);
    assert_eq!(chip.exchange(0x00, 56), None);
    assert_eq!(chip.spi_bytes(), 1);
}

#[test]
fn w5500_burst_increments_the_address() {
    let mut d = Driver::new(Wiznet::W5500);
    // GAR..SUBR in one burst: 0x0001-0x0008
    d.common_write(0x0001, &[192, 168, 1, 1, 255, 255, 255, 0]);
    assert_eq!(d.common_read(0x0005, 4), [255, 255, 255, 0]);
    assert_eq!(d.common_read(0x0039, 1), [0x04], "VERSIONR");
    assert_eq!(d.common_read(0x002E, 1), [0xBF], "PHYCFGR: link up, 100 Mbit/s, full duplex");
}

#[test]
fn w5500_fixed_length_frames_need_no_chip_select() {
    let mut d = Driver::new(Wiznet::W5500);
    // OM = 01 (1 byte) twice, then OM = 10 (2 bytes) reading both back, all in one CS period
    let answers = d.frame(&[
        0x00, 0x0F, 0x05, 10, // SIPR[0] = 10 (BSB 0, write, OM 01)
        0x00, 0x10, 0x05, 20, // SIPR[1] = 20
        0x00, 0x0F, 0x02, 0, 0, // read SIPR[0..2] (OM 10)
    ]);
    assert_eq!(answers[11..], [10, 20]);
}

#[test]
fn w5500_blocks_select_socket_registers_and_buffers() {
    let mut d = Driver::new(Wiznet::W5500);
    d.sock_write(5, sn::PORT, &[0x01, 0xF6]);
    assert_eq!(d.read16(5, sn::PORT), 502);
    assert_eq!(d.read16(4, sn::PORT), 0, "socket 4 untouched");
    assert_eq!(d.sock_read(3, sn::RXBUF_SIZE, 2), [2, 2], "2 KB each by default");
    assert_eq!(d.sock_read(0, sn::IMR, 1), [0xFF]);
    // socket 1's TX buffer (BSB 6) wraps at its size: offset 0x800 is offset 0
    d.tx_write(1, 0x07FF, &[1, 2]);
    assert_eq!(d.w5500(6, 0, false, &[0]), [2]);
    assert_eq!(d.w5500(6, 0xF7FF, false, &[0]), [1]);
}

// ---- registers ------------------------------------------------------------------------------

#[test]
fn defaults_after_reset() {
    let mut d = Driver::new(Wiznet::W5100);
    assert_eq!(d.common_read(0x0017, 5), [0x07, 0xD0, 0x08, 0x55, 0x55], "RTR, RCR, RMSR, TMSR");
    assert_eq!(d.read16(2, sn::TX_FSR), 2048);
    let mut d = Driver::new(Wiznet::W5500);
    assert_eq!(d.common_read(0x0019, 3), [0x07, 0xD0, 0x08], "RTR, RCR");
    assert_eq!(d.read16(7, sn::TX_FSR), 2048);
}

#[test]
fn software_reset_restores_the_defaults_and_clears_itself() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.common_write(0x0001, &[10, 0, 0, 1]);
        d.common_write(0x0000, &[0x80]);
        assert_eq!(d.common_read(0x0000, 1), [0], "{model}: RST clears itself");
        assert_eq!(d.common_read(0x0001, 4), [0, 0, 0, 0], "{model}");
        assert_eq!(d.sr(0), state::CLOSED, "{model}");
        assert!(d.chip.connection(0).unwrap().reset_by_chip(), "{model}: the peer got an RST");
    }
}

#[test]
fn w5100_tmsr_sets_the_buffer_sizes() {
    let mut d = Driver::new(Wiznet::W5100);
    // 8 KB to socket 0, none left for the others
    d.common_write(0x001B, &[0x03]);
    assert_eq!(d.read16(0, sn::TX_FSR), 8192);
    assert_eq!(d.read16(1, sn::TX_FSR), 0);
    d.common_write(0x001B, &[0x55]);
    assert_eq!(d.read16(3, sn::TX_FSR), 2048);
}

#[test]
fn w5500_buffer_sizes_are_per_socket() {
    let mut d = Driver::new(Wiznet::W5500);
    d.sock_write(0, sn::TXBUF_SIZE, &[16]);
    assert_eq!(d.read16(0, sn::TX_FSR), 16384);
    assert_eq!(d.read16(1, sn::TX_FSR), 0, "the 16 KB are gone");
}

#[test]
fn interrupt_bits_clear_by_writing_one_and_show_in_ir_or_sir() {
    for model in BOTH {
        let mut d = Driver::connected(model, 2);
        assert_eq!(d.sock_read(2, sn::IR, 1), [int::CON]);
        let summary = if model == Wiznet::W5100 { 0x0015 } else { 0x0017 };
        assert_eq!(d.common_read(summary, 1), [0b0100], "{model}");
        d.sock_write(2, sn::IR, &[int::DISCON]);
        assert_eq!(d.sock_read(2, sn::IR, 1), [int::CON], "{model}: writing 0 to a set bit keeps it");
        d.sock_write(2, sn::IR, &[int::CON]);
        assert_eq!(d.sock_read(2, sn::IR, 1), [0]);
        assert_eq!(d.common_read(summary, 1), [0], "{model}");
    }
}

#[test]
fn read_only_registers_ignore_writes() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    d.write16(0, sn::TX_FSR, 5);
    d.write16(0, sn::TX_RD, 5);
    d.write16(0, sn::RX_RSR, 5);
    d.sock_write(0, sn::SR, &[0]);
    assert_eq!((d.read16(0, sn::TX_FSR), d.read16(0, sn::TX_RD), d.read16(0, sn::RX_RSR)), (2048, 0, 0));
    assert_eq!(d.sr(0), state::ESTABLISHED);
}

// ---- commands and states --------------------------------------------------------------------

#[test]
fn a_syn_to_a_listening_socket_establishes_the_connection() {
    for model in BOTH {
        let mut d = Driver::connected(model, 1);
        assert_eq!(d.sr(1), state::ESTABLISHED);
        assert_eq!(d.sock_read(1, sn::DIPR, 4), [192, 168, 1, 10]);
        assert_eq!(d.read16(1, sn::DPORT), 40000);
        assert_eq!(d.chip.connection(1).unwrap().local_port(), 502);
    }
}

#[test]
fn a_syn_to_a_port_nobody_listens_on_is_refused() {
    let mut d = Driver::new(Wiznet::W5100);
    d.listen(0, 80);
    assert_eq!(d.chip.connect(502, peer()), None);
    d.command(0, cmd::CLOSE);
    d.sock_write(0, sn::MR, &[mode::TCP]);
    d.command(0, cmd::OPEN);
    assert_eq!(d.chip.connect(80, peer()), None, "INIT is not LISTEN");
}

#[test]
fn more_connections_than_listening_sockets_are_refused() {
    let mut d = Driver::new(Wiznet::W5100);
    d.listen(0, 502);
    d.listen(1, 502);
    assert_eq!(d.chip.connect(502, peer()), Some(0));
    assert_eq!(d.chip.connect(502, peer()), Some(1));
    assert_eq!(d.chip.connect(502, peer()), None);
    assert_eq!(d.chip.listening_ports(), Vec::<u16>::new());
}

#[test]
fn open_in_udp_mode_is_sock_udp() {
    let mut d = Driver::new(Wiznet::W5500);
    d.sock_write(3, sn::MR, &[mode::UDP]);
    d.command(3, cmd::OPEN);
    assert_eq!(d.sr(3), state::UDP);
    d.sock_write(3, sn::MR, &[mode::MACRAW]);
    d.command(3, cmd::OPEN);
    assert_eq!(d.sr(3), state::CLOSED, "MAC raw is socket 0's only");
}

#[test]
fn close_resets_a_connected_peer() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.command(0, cmd::CLOSE);
        assert_eq!(d.sr(0), state::CLOSED);
        let conn = d.chip.connection(0).unwrap();
        assert!(conn.reset_by_chip() && conn.closed() && !conn.fin_from_chip());
    }
}

#[test]
fn discon_sends_a_fin_and_closes_after_the_peers() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.command(0, cmd::DISCON);
        assert_eq!(d.sr(0), state::FIN_WAIT);
        assert!(d.chip.connection(0).unwrap().fin_from_chip());
        d.chip.peer_fin(0);
        assert_eq!(d.sr(0), state::CLOSED);
        assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::DISCON, int::DISCON);
        assert!(!d.chip.connection(0).unwrap().reset_by_chip());
    }
}

#[test]
fn the_peers_fin_is_close_wait_then_discon_closes() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    d.chip.peer_fin(0);
    assert_eq!(d.sr(0), state::CLOSE_WAIT);
    assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::DISCON, int::DISCON);
    // the firmware may still send in CLOSE_WAIT
    d.send(0, b"bye");
    assert_eq!(d.chip.take_sent(0), b"bye");
    d.command(0, cmd::DISCON);
    assert_eq!(d.sr(0), state::CLOSED);
    assert!(d.chip.connection(0).unwrap().fin_from_chip());
}

#[test]
fn the_peers_reset_closes_the_socket() {
    let mut d = Driver::connected(Wiznet::W5500, 4);
    d.chip.peer_reset(4);
    assert_eq!(d.sr(4), state::CLOSED);
    assert_eq!(d.sock_read(4, sn::IR, 1)[0] & int::DISCON, int::DISCON);
    assert_eq!(d.chip.deliver(4, b"late"), 0, "nothing arrives on a closed socket");
}

#[test]
fn connect_waits_in_synsent_until_the_peer_accepts() {
    let mut d = Driver::new(Wiznet::W5100);
    d.sock_write(0, sn::MR, &[mode::TCP]);
    d.sock_write(0, sn::DIPR, &[10, 0, 0, 2]);
    d.write16(0, sn::DPORT, 502);
    d.command(0, cmd::OPEN);
    d.command(0, cmd::CONNECT);
    assert_eq!(d.sr(0), state::SYNSENT);
    assert!(d.chip.accept_connect(0));
    assert_eq!(d.sr(0), state::ESTABLISHED);
    assert_eq!(d.chip.connection(0).unwrap().peer(), SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 2), 502));
}

// ---- data -----------------------------------------------------------------------------------

#[test]
fn delivered_bytes_are_received_and_recv_frees_them() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.sock_write(0, sn::IR, &[int::CON]);
        assert_eq!(d.chip.deliver(0, b"\x00\x01\x00\x00\x00\x06\x01\x03\x00\x00\x00\x01"), 12);
        assert_eq!(d.read16(0, sn::RX_RSR), 12);
        assert_eq!(d.sock_read(0, sn::IR, 1), [int::RECV]);
        assert_eq!(d.receive(0), b"\x00\x01\x00\x00\x00\x06\x01\x03\x00\x00\x00\x01");
        assert_eq!(d.read16(0, sn::RX_RSR), 0, "{model}");
    }
}

#[test]
fn rx_rsr_counts_from_the_rx_rd_of_the_last_recv() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    d.chip.deliver(0, b"abcdef");
    d.write16(0, sn::RX_RD, 4);
    assert_eq!(d.read16(0, sn::RX_RSR), 6, "RX_RD moved, no RECV yet");
    d.command(0, cmd::RECV);
    assert_eq!(d.read16(0, sn::RX_RSR), 2);
    assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::RECV, int::RECV, "data left: RECV again");
}

#[test]
fn a_full_rx_buffer_takes_no_more() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    assert_eq!(d.chip.deliver(0, &[7; 3000]), 2048);
    assert_eq!(d.chip.rx_room(0), 0);
    assert_eq!(d.chip.deliver(0, b"x"), 0);
    let got = d.receive(0);
    assert_eq!(got.len(), 2048);
    assert_eq!(d.chip.deliver(0, &[7; 952]), 952);
}

#[test]
fn sent_bytes_reach_the_peer_with_send_ok_and_a_timestamp() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.chip.deliver(0, b"req");
        let landed = d.chip.last_delivery(0).unwrap();
        d.receive(0);
        assert_eq!(d.read16(0, sn::TX_FSR), 2048);
        d.send(0, b"reply");
        assert_eq!(d.chip.take_sent(0), b"reply");
        assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::SEND_OK, int::SEND_OK);
        assert_eq!(d.read16(0, sn::TX_RD), 5);
        assert_eq!(d.read16(0, sn::TX_FSR), 2048);
        let sends = d.chip.sends(0);
        assert_eq!(sends.len(), 1);
        assert_eq!(sends[0].data, b"reply");
        assert!(sends[0].cycle > landed, "{model}: the SEND comes after the request landed");
    }
}

#[test]
fn two_requests_in_one_segment_arrive_together() {
    let mut d = Driver::connected(Wiznet::W5500, 0);
    let one = b"\x00\x01\x00\x00\x00\x06\x01\x03\x00\x00\x00\x01";
    let two = b"\x00\x02\x00\x00\x00\x06\x01\x03\x00\x01\x00\x01";
    d.chip.deliver(0, &[&one[..], &two[..]].concat());
    assert_eq!(d.read16(0, sn::RX_RSR), 24);
}

#[test]
fn a_peer_that_does_not_read_leaves_the_data_in_the_tx_buffer() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.chip.set_peer_window(0, Some(3));
        d.send(0, b"0123456789");
        assert_eq!(d.chip.take_sent(0), b"012");
        assert_eq!(d.read16(0, sn::TX_FSR), 2048 - 7, "{model}");
        assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::SEND_OK, 0, "no SEND_OK yet");
        d.chip.peer_reads(0, 100);
        assert_eq!(d.chip.take_sent(0), b"3456789");
        assert_eq!(d.read16(0, sn::TX_FSR), 2048);
        assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::SEND_OK, int::SEND_OK);
        assert_eq!(d.sr(0), state::ESTABLISHED, "a slow peer is no timeout");
    }
}

#[test]
fn a_vanished_peer_times_out_after_the_retransmissions() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    // RTR = 100 (10 ms), RCR = 2: 10 + 20 + 40 ms
    d.common_write(0x0017, &[0x00, 100, 2]);
    d.chip.peer_vanish(0);
    assert_eq!(d.chip.deliver(0, b"x"), 0, "nothing arrives from a vanished peer");
    d.send(0, b"data");
    let sent_at = d.cycle;
    assert_eq!(d.sr(0), state::ESTABLISHED);
    d.chip.advance(sent_at + 70 * 16_000 - 1_000);
    assert_eq!(d.sr(0), state::ESTABLISHED);
    d.chip.advance(sent_at + 70 * 16_000 + 1_000);
    assert_eq!(d.sr(0), state::CLOSED);
    assert_eq!(d.sock_read(0, sn::IR, 1)[0] & int::TIMEOUT, int::TIMEOUT);
}

#[test]
fn retransmission_time_doubles_up_to_16_bits() {
    assert_eq!(retransmission_time(2000, 8), 318_000, "the datasheet's 31.8 s");
    assert_eq!(retransmission_time(100, 2), 700);
    assert_eq!(retransmission_time(0xFFFF, 0), 0xFFFF);
}

// ---- pointers -------------------------------------------------------------------------------

#[test]
fn pointers_wrap_past_0xffff_and_past_the_buffer_end() {
    for model in BOTH {
        let mut d = Driver::new(model);
        d.chip.set_open_pointers(0xFFFC);
        d.listen(0, 502);
        d.chip.connect(502, peer());
        assert_eq!(d.read16(0, sn::RX_RD), 0xFFFC);
        d.chip.deliver(0, b"abcdefgh");
        assert_eq!(d.read16(0, sn::RX_RSR), 8, "{model}: 0x0004 - 0xFFFC");
        assert_eq!(d.receive(0), b"abcdefgh", "{model}");
        assert_eq!(d.read16(0, sn::RX_RD), 0x0004);
        d.send(0, b"12345678");
        assert_eq!(d.chip.take_sent(0), b"12345678", "{model}");
        assert_eq!(d.read16(0, sn::TX_RD), 0x0004);
        assert_eq!(d.read16(0, sn::TX_FSR), 2048);
        // the bytes straddle the buffer's end: offsets 0x7FC..0x7FF and 0x000..0x003
        assert_eq!(d.rx_read(0, 0x07FC, 4), b"abcd");
        assert_eq!(d.rx_read(0, 0x0000, 4), b"efgh");
    }
}

#[test]
fn tx_fsr_is_the_size_less_what_is_unsent_in_wrapping_arithmetic() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    d.chip.set_peer_window(0, Some(0));
    d.chip.set_pointers(0, 0xFFF0);
    d.write16(0, sn::TX_WR, 0x0010);
    assert_eq!(d.read16(0, sn::TX_FSR), 2048 - 0x20);
}

// ---- time -----------------------------------------------------------------------------------

#[test]
fn queued_data_lands_at_the_first_frame_once_due() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    let due = d.cycle + 1_000;
    d.chip.deliver_at(0, b"late", due);
    assert_eq!(d.read16(0, sn::RX_RSR), 0);
    d.cycle = due + 50;
    assert_eq!(d.read16(0, sn::RX_RSR), 4);
    assert_eq!(d.chip.last_delivery(0), Some(due));
}

#[test]
fn rx_rsr_may_change_between_the_reads_of_its_two_bytes() {
    let mut d = Driver::connected(Wiznet::W5100, 0);
    d.chip.deliver(0, &[0; 255]);
    // one more byte lands between the high byte's frame and the low byte's
    d.chip.deliver_at(0, b"x", d.cycle + 150);
    let hi = d.sock_read(0, sn::RX_RSR, 1)[0];
    let lo = d.sock_read(0, sn::RX_RSR + 1, 1)[0];
    assert_eq!((hi, lo), (0x00, 0x00), "0x00FF then 0x0100: a torn read");
    assert_eq!(d.read16(0, sn::RX_RSR), 0x0100);
}

#[test]
fn queued_data_that_finds_no_room_waits_for_recv() {
    let mut d = Driver::connected(Wiznet::W5500, 0);
    d.chip.deliver_at(0, &[1; 3000], 0);
    assert_eq!(d.read16(0, sn::RX_RSR), 2048);
    assert_eq!(d.chip.queued(0), 952);
    d.receive(0);
    assert_eq!(d.read16(0, sn::RX_RSR), 952);
    assert_eq!(d.chip.queued(0), 0);
}

#[test]
fn model_names_parse() {
    assert_eq!("W5500".parse::<Wiznet>(), Ok(Wiznet::W5500));
    assert!("w5300".parse::<Wiznet>().is_err());
    assert_eq!(Wiznet::W5100.to_string(), "w5100");
}

#[test]
fn the_spi_record_names_each_w5100_frame_and_each_w5500_data_byte() {
    let mut d = Driver::new(Wiznet::W5100);
    d.w5100_write(0x0001, &[0xC0]);
    assert!(d.chip.take_spi_log().is_empty(), "recorded while off");
    d.chip.record_spi(true);
    d.w5100_write(0x0401, &[0x40]);
    d.w5100_read(0x0426, 2);
    let log = d.chip.take_spi_log();
    let seen: Vec<(u16, bool)> = log.iter().map(|a| (a.addr, a.write)).collect();
    assert_eq!(seen, [(0x0401, true), (0x0426, false), (0x0427, false)]);
    assert!(log.windows(2).all(|w| w[0].cycle < w[1].cycle));
    assert!(d.chip.take_spi_log().is_empty(), "taken");

    let mut d = Driver::new(Wiznet::W5500);
    d.chip.record_spi(true);
    d.w5500(0x0D, 0x0024, false, &[0, 0]);
    let seen: Vec<(u8, u16, bool)> = d.chip.take_spi_log().iter().map(|a| (a.block, a.addr, a.write)).collect();
    assert_eq!(seen, [(0x0D, 0x0024, false), (0x0D, 0x0025, false)]);
    d.chip.record_spi(false);
    d.w5500(0x0D, 0x0024, false, &[0, 0]);
    assert!(d.chip.take_spi_log().is_empty(), "recorded while off");
}

// ---- UDP ------------------------------------------------------------------------------------

impl Driver {
    /// Socket `n` open in UDP mode on `port`.
    fn udp(&mut self, n: u8, port: u16) {
        self.sock_write(n, sn::MR, &[mode::UDP]);
        self.write16(n, sn::PORT, port);
        self.command(n, cmd::OPEN);
        assert_eq!(self.sr(n), state::UDP);
    }

    /// What a firmware's UDP send does: the destination in Sn_DIPR/Sn_DPORT, then the data.
    fn send_to(&mut self, n: u8, to: SocketAddrV4, data: &[u8]) {
        self.sock_write(n, sn::DIPR, &to.ip().octets());
        self.write16(n, sn::DPORT, to.port());
        self.send(n, data);
    }
}

/// `payload` behind the chip's 8-byte UDP header from `from`.
fn with_header(from: SocketAddrV4, payload: &[u8]) -> Vec<u8> {
    let mut v = from.ip().octets().to_vec();
    v.extend_from_slice(&from.port().to_be_bytes());
    v.extend_from_slice(&(payload.len() as u16).to_be_bytes());
    v.extend_from_slice(payload);
    v
}

#[test]
fn a_datagram_lands_behind_its_header_and_recv_frees_it() {
    for model in BOTH {
        let mut d = Driver::new(model);
        d.udp(2, 502);
        assert_eq!(d.chip.udp_socket(502), Some(2), "{model}");
        assert_eq!(d.chip.udp_socket(503), None);
        assert!(d.chip.udp_deliver(2, peer(), b"\x00\x01\x00\x00\x00\x06\x01\x03\x00\x00\x00\x01"));
        assert_eq!(d.read16(2, sn::RX_RSR), 20, "{model}: header and data");
        assert_eq!(d.sock_read(2, sn::IR, 1), [int::RECV]);
        assert_eq!(d.receive(2), with_header(peer(), b"\x00\x01\x00\x00\x00\x06\x01\x03\x00\x00\x00\x01"));
        assert_eq!(d.read16(2, sn::RX_RSR), 0, "{model}");
        assert_eq!(d.chip.rx_room(2), 2048);
    }
}

#[test]
fn datagrams_queue_in_order_and_an_empty_one_is_a_bare_header() {
    let mut d = Driver::new(Wiznet::W5500);
    d.udp(0, 502);
    let other = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 7), 5020);
    assert!(d.chip.udp_deliver(0, peer(), b"one"));
    assert!(d.chip.udp_deliver(0, other, b""));
    assert!(d.chip.udp_deliver(0, peer(), b"three"));
    let mut want = with_header(peer(), b"one");
    want.extend(with_header(other, b""));
    want.extend(with_header(peer(), b"three"));
    assert_eq!(d.receive(0), want);
}

#[test]
fn a_datagram_that_finds_no_room_is_dropped_whole() {
    for model in BOTH {
        let mut d = Driver::new(model);
        d.udp(1, 502);
        assert!(!d.chip.udp_deliver(1, peer(), &[7; 2041]), "{model}: 2049 bytes with its header");
        assert_eq!(d.read16(1, sn::RX_RSR), 0, "{model}: nothing of it written");
        assert_eq!(d.sock_read(1, sn::IR, 1), [0]);
        assert!(d.chip.udp_deliver(1, peer(), &[7; 2030]));
        assert!(!d.chip.udp_deliver(1, peer(), &[8; 3]), "{model}: 11 bytes, 10 free");
        assert!(d.chip.udp_deliver(1, peer(), &[9; 2]), "{model}: 10 bytes fill it");
        assert_eq!(d.chip.rx_room(1), 0);
        assert!(!d.chip.udp_deliver(1, peer(), b""), "{model}: not even a header fits");
        let got = d.receive(1);
        assert_eq!(got.len(), 2048);
        assert_eq!(got[2038..], with_header(peer(), &[9; 2])[..], "{model}");
        assert!(d.chip.udp_deliver(1, peer(), &[7; 2040]), "{model}: room again after RECV");
    }
}

#[test]
fn send_is_one_datagram_to_dipr_and_dport() {
    for model in BOTH {
        let mut d = Driver::new(model);
        d.udp(3, 502);
        d.send_to(3, peer(), b"reply");
        assert_eq!(d.sock_read(3, sn::IR, 1)[0] & int::SEND_OK, int::SEND_OK, "{model}");
        assert_eq!(d.read16(3, sn::TX_FSR), 2048, "{model}: sent at once");
        let broadcast = SocketAddrV4::new(Ipv4Addr::BROADCAST, 67);
        d.send_to(3, broadcast, b"discover");
        d.send_to(3, broadcast, b"");
        assert_eq!(
            d.chip.udp_sent(3),
            [(peer(), b"reply".to_vec()), (broadcast, b"discover".to_vec()), (broadcast, Vec::new())],
            "{model}"
        );
        assert_eq!(d.chip.udp_sent(3), [], "taken");
        assert_eq!(d.chip.take_sent(3), b"", "no TCP peer saw it");
    }
}

#[test]
fn only_a_socket_open_in_udp_mode_takes_datagrams() {
    let mut d = Driver::new(Wiznet::W5100);
    assert!(!d.chip.udp_deliver(0, peer(), b"closed"));
    assert!(!d.chip.udp_deliver(9, peer(), b"no such socket"));
    d.listen(0, 502);
    assert!(!d.chip.udp_deliver(0, peer(), b"listening"));
    assert_eq!(d.chip.udp_socket(502), None, "a TCP socket on the port is no UDP socket");
    d.udp(1, 502);
    d.udp(2, 502);
    assert_eq!(d.chip.udp_socket(502), Some(1), "the lowest");
    assert_eq!(d.read16(0, sn::RX_RSR), 0);
    d.command(1, cmd::CLOSE);
    assert_eq!(d.sr(1), state::CLOSED);
    assert!(!d.chip.udp_deliver(1, peer(), b"closed"));
    assert_eq!(d.chip.udp_socket(502), Some(2));
    d.send(1, b"closed");
    assert_eq!(d.chip.udp_sent(1), [], "a closed socket sends nothing");
}

#[test]
fn udp_pointers_wrap_past_0xffff_and_past_the_buffer_end() {
    for model in BOTH {
        let mut d = Driver::new(model);
        d.chip.set_open_pointers(0xFFFC);
        d.udp(0, 502);
        assert!(d.chip.udp_deliver(0, peer(), b"abcdefgh"));
        assert_eq!(d.read16(0, sn::RX_RSR), 16, "{model}: 0x000C - 0xFFFC");
        assert_eq!(d.receive(0), with_header(peer(), b"abcdefgh"), "{model}");
        assert_eq!(d.rx_read(0, 0x07FC, 4), [192, 168, 1, 10], "{model}: the address before the end");
        assert_eq!(d.rx_read(0, 0x0000, 6), b"\x9c\x40\x00\x08ab", "{model}: port, length, data after it");
        d.send_to(0, peer(), b"12345678");
        assert_eq!(d.chip.udp_sent(0), [(peer(), b"12345678".to_vec())], "{model}");
        assert_eq!(d.read16(0, sn::TX_RD), 0x0004);
    }
}

// ---- faults: the link, a reset while running, a hung chip --------------------------------

#[test]
fn w5500_phycfgr_bit_0_is_the_link() {
    let mut d = Driver::new(Wiznet::W5500);
    assert_eq!(d.common_read(0x2E, 1)[0] & 1, 1);
    d.chip.set_link(false);
    assert_eq!(d.common_read(0x2E, 1)[0] & 1, 0);
    d.chip.set_link(true);
    assert_eq!(d.common_read(0x2E, 1)[0] & 1, 1);
}

#[test]
fn with_the_link_down_nothing_arrives_and_the_chips_data_times_out() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.chip.set_link(false);
        assert_eq!(d.chip.deliver(0, b"lost"), 0, "{model}: data from the peer does not arrive");
        d.chip.peer_reset(0);
        assert_eq!(d.sr(0), state::ESTABLISHED, "{model}: nor does its RST");
        d.send(0, b"reply");
        assert!(d.chip.take_sent(0).is_empty(), "{model}: the reply goes nowhere");
        let rto = d.chip.next_due().expect("the retransmissions time out");
        d.cycle = rto;
        assert_eq!(d.sr(0), state::CLOSED, "{model}: timed out");
        assert!(d.chip.connection(0).unwrap().closed());
        d.listen(1, 502);
        assert_eq!(d.chip.connect(502, peer()), None, "{model}: no SYN arrives");
        d.chip.set_link(true);
        assert_eq!(d.chip.connect(502, peer()), Some(1), "{model}: the link back, a new connection comes");
        assert_eq!(d.chip.deliver(1, b"ok"), 2);
    }
}

#[test]
fn a_reset_while_running_restores_the_defaults_and_resets_the_peers() {
    for model in BOTH {
        let mut d = Driver::connected(model, 0);
        d.common_write(0x0F, &[192, 168, 1, 177]);
        d.chip.reset();
        assert_eq!(d.common_read(0x0F, 4), [0; 4], "{model}: IP 0.0.0.0");
        assert_eq!(d.sr(0), state::CLOSED);
        assert!(d.chip.connection(0).unwrap().reset_by_chip(), "{model}: the peer got an RST");
    }
}

#[test]
fn a_hung_chip_reads_its_stuck_value_takes_no_write_and_comes_back_as_it_was() {
    for model in BOTH {
        for stuck in [0x00, 0xFF] {
            let mut d = Driver::connected(model, 0);
            d.common_write(0x0F, &[192, 168, 1, 177]);
            d.listen(1, 502);
            d.chip.hang(stuck);
            assert_eq!(d.chip.connect(502, peer()), None, "{model}: no SYN taken while hung");
            assert_eq!(d.chip.deliver(0, b"lost"), 0, "{model}: nor data");
            assert_eq!(d.common_read(0x0F, 4), [stuck; 4], "{model}");
            assert_eq!(d.frame(&[0x0F, 0x00, 0x0F, 0x00]), [stuck; 4], "{model}: every byte, address bytes too");
            // A write of SIPR[0] = 10, in the chip's own frame.
            match model {
                Wiznet::W5100 => d.frame(&[w5100::WRITE, 0x00, 0x0F, 10]),
                Wiznet::W5500 => d.frame(&[0x00, 0x0F, w5500::control(0, true), 10]),
            };
            d.chip.unhang();
            assert_eq!(d.common_read(0x0F, 4), [192, 168, 1, 177], "{model}: no write taken");
            assert_eq!(d.sr(0), state::ESTABLISHED, "{model}: its connection as it was");
        }
    }
}
