//! An imitation of a chip's TCP sockets for the host tests of the server and the gateway:
//! 2 KB rings with free-running pointers, as the W5100's and W5500's, every byte read or
//! written checked to lie between the pointers.

use super::server::Sockets;
use super::wiznet::{command, state, SEND_OK};

pub(crate) const SIZE: u16 = 0x800;
/// Sn_SR open in UDP mode.
pub(crate) const UDP: u8 = 0x22;

/// One socket of the imitation chip.
#[derive(Clone)]
pub(crate) struct Sock {
    pub(crate) status: u8,
    pub(crate) ir: u8,
    pub(crate) peer: [u8; 4],
    pub(crate) port: u16,
    pub(crate) rx: Vec<u8>,
    pub(crate) rx_wr: u16,
    pub(crate) rx_rd: u16,
    pub(crate) tx: Vec<u8>,
    pub(crate) tx_wr: u16,
    pub(crate) tx_rd: u16,
    /// The peer reads what is sent.
    pub(crate) reading: bool,
    /// What the peer got.
    pub(crate) sent: Vec<u8>,
    /// SEND commands given.
    pub(crate) sends: usize,
    /// Closed by the server (RST).
    pub(crate) reset: bool,
    /// A FIN sent by the server.
    pub(crate) fin: bool,
    /// UDP: where the next SEND goes (address, port).
    pub(crate) dest: [u8; 6],
    /// UDP: the datagrams sent, each with where it went.
    pub(crate) datagrams: Vec<([u8; 6], Vec<u8>)>,
}

impl Default for Sock {
    fn default() -> Self {
        Sock {
            status: state::CLOSED,
            ir: 0,
            peer: [0; 4],
            port: 0,
            rx: vec![0; SIZE as usize],
            rx_wr: 0xFFF0,
            rx_rd: 0xFFF0,
            tx: vec![0; SIZE as usize],
            tx_wr: 0x7FF0,
            tx_rd: 0x7FF0,
            reading: true,
            sent: Vec::new(),
            sends: 0,
            reset: false,
            fin: false,
            dest: [0; 6],
            datagrams: Vec::new(),
        }
    }
}

/// The imitation chip: its sockets, and every byte the server read or wrote checked to lie
/// between the pointers.
#[derive(Default)]
pub(crate) struct Fake {
    pub(crate) socks: [Sock; 4],
    /// Reads of the received count and of received bytes: what a poll costs.
    pub(crate) reads: usize,
    /// The chip lost its settings (a reset): the health check finds it so.
    pub(crate) lost: bool,
    /// The chip answers nothing: it cannot be set up again.
    pub(crate) hung: bool,
    /// The link is down.
    pub(crate) link_down: bool,
    /// Resets the health check tried, answered or not.
    pub(crate) restarts: usize,
}

impl Fake {
    /// A master at `peer` connects to socket `s`, which must listen.
    pub(crate) fn connect(&mut self, s: usize, peer: [u8; 4]) {
        let sock = &mut self.socks[s];
        assert_eq!(sock.status, state::LISTEN, "socket {s} does not listen");
        sock.status = state::ESTABLISHED;
        sock.peer = peer;
        sock.ir |= 0x01;
        sock.reset = false;
        sock.fin = false;
        sock.sent.clear();
    }

    /// Bytes arrive on socket `s`.
    pub(crate) fn deliver(&mut self, s: usize, bytes: &[u8]) {
        let sock = &mut self.socks[s];
        assert!(sock.rx_wr.wrapping_sub(sock.rx_rd) as usize + bytes.len() <= SIZE as usize);
        for &b in bytes {
            sock.rx[usize::from(sock.rx_wr % SIZE)] = b;
            sock.rx_wr = sock.rx_wr.wrapping_add(1);
        }
        sock.ir |= 0x04;
    }

    /// A datagram from `from` (address, port) arrives on UDP socket `s`, behind the chip's
    /// 8-byte header; false, nothing written, when it does not fit whole (the chip drops
    /// it) or the socket is not open in UDP mode.
    #[cfg(feature = "udp")]
    pub(crate) fn datagram(&mut self, s: usize, from: [u8; 6], payload: &[u8]) -> bool {
        let sock = &mut self.socks[s];
        if sock.status != UDP || sock.rx_wr.wrapping_sub(sock.rx_rd) as usize + 8 + payload.len() > SIZE as usize {
            return false;
        }
        let mut bytes = from.to_vec();
        bytes.extend_from_slice(&(payload.len() as u16).to_be_bytes());
        bytes.extend_from_slice(payload);
        for b in bytes {
            sock.rx[usize::from(sock.rx_wr % SIZE)] = b;
            sock.rx_wr = sock.rx_wr.wrapping_add(1);
        }
        sock.ir |= 0x04;
        true
    }

    /// The chip resets while it runs (a brown-out): every socket closed, its peer's
    /// connection reset, the settings lost.
    pub(crate) fn chip_reset(&mut self) {
        for sock in &mut self.socks {
            sock.reset |= sock.status != state::CLOSED && sock.status != state::LISTEN;
            sock.status = state::CLOSED;
        }
        self.lost = true;
    }

    /// The peer takes what was sent and acknowledges it.
    pub(crate) fn ack(&mut self, s: usize) {
        let sock = &mut self.socks[s];
        while sock.tx_rd != sock.tx_wr {
            sock.sent.push(sock.tx[usize::from(sock.tx_rd % SIZE)]);
            sock.tx_rd = sock.tx_rd.wrapping_add(1);
        }
    }
}

impl Sockets for Fake {
    fn events(&mut self) -> u8 {
        (0..4).filter(|&s| self.socks[s].ir != 0).fold(0, |bits, s| bits | 1 << s)
    }
    fn take_events(&mut self, s: u8) -> u8 {
        core::mem::take(&mut self.socks[usize::from(s)].ir)
    }
    fn status(&mut self, s: u8) -> u8 {
        self.socks[usize::from(s)].status
    }
    fn command(&mut self, s: u8, command: u8) {
        let sock = &mut self.socks[usize::from(s)];
        match command {
            command::LISTEN => sock.status = state::LISTEN,
            command::CLOSE => {
                sock.reset |= sock.status != state::LISTEN && sock.status != state::CLOSED && sock.status != UDP;
                sock.status = state::CLOSED;
            }
            command::DISCON => {
                sock.fin = true;
                sock.status = state::CLOSED;
            }
            command::RECV => {}
            other => panic!("command {other:#x}"),
        }
    }
    fn listen(&mut self, s: u8, port: u16) {
        let sock = &mut self.socks[usize::from(s)];
        assert_eq!(sock.status, state::CLOSED, "OPEN on a socket not closed");
        let (sent, reset, fin) = (core::mem::take(&mut sock.sent), sock.reset, sock.fin);
        *sock = Sock { port, status: state::LISTEN, sent, reset, fin, ..Sock::default() };
    }
    fn peer(&mut self, s: u8) -> [u8; 4] {
        self.socks[usize::from(s)].peer
    }
    fn received(&mut self, s: u8) -> u16 {
        self.reads += 1;
        let sock = &self.socks[usize::from(s)];
        sock.rx_wr.wrapping_sub(sock.rx_rd)
    }
    fn rx_pointer(&mut self, s: u8) -> u16 {
        self.socks[usize::from(s)].rx_rd
    }
    fn read(&mut self, s: u8, pointer: u16, buf: &mut [u8]) {
        self.reads += 1;
        let sock = &self.socks[usize::from(s)];
        let end = pointer.wrapping_add(buf.len() as u16);
        assert!(end.wrapping_sub(sock.rx_rd) <= sock.rx_wr.wrapping_sub(sock.rx_rd), "read past the received bytes");
        for (i, b) in buf.iter_mut().enumerate() {
            *b = sock.rx[usize::from(pointer.wrapping_add(i as u16) % SIZE)];
        }
    }
    fn take(&mut self, s: u8, pointer: u16) {
        let sock = &mut self.socks[usize::from(s)];
        assert!(pointer.wrapping_sub(sock.rx_rd) <= sock.rx_wr.wrapping_sub(sock.rx_rd), "took bytes not received");
        sock.rx_rd = pointer;
    }
    fn tx_free(&mut self, s: u8) -> u16 {
        let sock = &self.socks[usize::from(s)];
        SIZE - sock.tx_wr.wrapping_sub(sock.tx_rd)
    }
    fn tx_pointer(&mut self, s: u8) -> u16 {
        self.socks[usize::from(s)].tx_wr
    }
    fn write(&mut self, s: u8, pointer: u16, data: &mut [u8]) {
        let sock = &mut self.socks[usize::from(s)];
        assert!(
            pointer.wrapping_sub(sock.tx_rd) as usize + data.len() <= SIZE as usize,
            "written over bytes not yet sent"
        );
        for (i, &b) in data.iter().enumerate() {
            sock.tx[usize::from(pointer.wrapping_add(i as u16) % SIZE)] = b;
        }
    }
    fn send(&mut self, s: u8, pointer: u16) {
        let sock = &mut self.socks[usize::from(s)];
        sock.tx_wr = pointer;
        sock.sends += 1;
        if sock.status == UDP {
            // One datagram, sent at once unless the chip is held (an ARP under way).
            if sock.reading {
                let mut datagram = Vec::new();
                while sock.tx_rd != sock.tx_wr {
                    datagram.push(sock.tx[usize::from(sock.tx_rd % SIZE)]);
                    sock.tx_rd = sock.tx_rd.wrapping_add(1);
                }
                sock.datagrams.push((sock.dest, datagram));
                sock.ir |= SEND_OK;
            }
            return;
        }
        if sock.reading {
            while sock.tx_rd != sock.tx_wr {
                sock.sent.push(sock.tx[usize::from(sock.tx_rd % SIZE)]);
                sock.tx_rd = sock.tx_rd.wrapping_add(1);
            }
            sock.ir |= SEND_OK;
        }
    }

    #[cfg(feature = "udp")]
    fn open(&mut self, s: u8, port: u16, udp: bool) {
        if !udp {
            return self.listen(s, port);
        }
        let sock = &mut self.socks[usize::from(s)];
        assert_eq!(sock.status, state::CLOSED, "OPEN on a socket not closed");
        let (datagrams, reading) = (core::mem::take(&mut sock.datagrams), sock.reading);
        *sock = Sock { port, status: UDP, datagrams, reading, ..Sock::default() };
    }

    #[cfg(feature = "udp")]
    fn set_peer(&mut self, s: u8, peer: &mut [u8]) {
        self.socks[usize::from(s)].dest.copy_from_slice(peer);
    }
}
