//! One socket of a W5100 or W5500: its registers, its commands (Sn_CR) and its TCP states, the
//! same on both chips (W5100 datasheet §4.2 and §5.2.1, W5500 datasheet §4.2 and §5.1.2).
//!
//! Pointers are free-running 16-bit counters; a byte's place in the socket's buffer is the
//! pointer modulo the buffer's size. TX_FSR = size − (TX_WR − TX_RD), RX_RSR = RX_WR − the
//! RX_RD of the last RECV, both in wrapping 16-bit arithmetic.

use std::collections::VecDeque;
use std::net::{Ipv4Addr, SocketAddrV4};

use super::connection::Connection;
use super::regs::{cmd, int, mode, sn, state};

/// A SEND command the firmware gave: when, and the bytes it sent with it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Send {
    /// The cycle of the SPI byte that wrote Sn_CR.
    pub cycle: u64,
    /// The bytes from the previous end of sending to Sn_TX_WR.
    pub data: Vec<u8>,
}

/// Bytes from the peer that land in the RX buffer at `at` or, if it is full then, once the
/// firmware has made room.
#[derive(Debug)]
struct Inbound {
    at: u64,
    bytes: Vec<u8>,
    /// Part of it found no room at `at`: the rest lands when room comes.
    stalled: bool,
}

/// What a command needs from the chip around the socket.
pub(crate) struct Context<'a> {
    /// The socket's TX buffer.
    pub tx: &'a [u8],
    /// The socket's RX buffer.
    pub rx: &'a mut [u8],
    /// The cycle now.
    pub now: u64,
    /// Cycles until an unacknowledged segment times out (RTR, RCR).
    pub rto: u64,
    /// What OPEN sets the four pointers to.
    pub open_pointers: u16,
    /// Whether the socket may open in MAC raw mode (socket 0).
    pub macraw: bool,
}

/// One socket.
#[derive(Debug)]
pub(crate) struct Socket {
    /// The plain registers (written by the firmware, read back as written).
    regs: [u8; sn::BLOCK],
    pub(crate) sr: u8,
    pub(crate) ir: u8,
    tx_rd: u16,
    rx_wr: u16,
    /// Sn_RX_RD as of the last RECV.
    rx_taken: u16,
    /// Sn_TX_WR as of the last SEND: TX_RD runs up to it.
    send_end: u16,
    sending: bool,
    /// DISCON given: a FIN goes once the data before it is taken.
    fin_queued: bool,
    timeout_at: Option<u64>,
    pub(crate) tx_size: u16,
    pub(crate) rx_size: u16,
    pub(crate) conn: Option<Connection>,
    pub(crate) sends: Vec<Send>,
    pub(crate) last_delivery: Option<u64>,
    inbound: VecDeque<Inbound>,
    /// UDP mode: the datagrams sent and not taken yet (destination, payload).
    pub(crate) datagrams_out: Vec<(SocketAddrV4, Vec<u8>)>,
}

fn get16(regs: &[u8], off: u16) -> u16 {
    u16::from_be_bytes([regs[usize::from(off)], regs[usize::from(off) + 1]])
}

fn set16(regs: &mut [u8], off: u16, v: u16) {
    regs[usize::from(off)..usize::from(off) + 2].copy_from_slice(&v.to_be_bytes());
}

/// The byte at `off` of the big-endian 16-bit register at `reg`.
fn byte_of(v: u16, reg: u16, off: u16) -> u8 {
    v.to_be_bytes()[usize::from(off - reg)]
}

impl Socket {
    /// A socket as after reset: closed, pointers 0, `defaults` in its plain registers.
    pub(crate) fn new(defaults: &[(u16, u8)]) -> Socket {
        let mut regs = [0; sn::BLOCK];
        for &(off, v) in defaults {
            regs[usize::from(off)] = v;
        }
        Socket {
            regs,
            sr: state::CLOSED,
            ir: 0,
            tx_rd: 0,
            rx_wr: 0,
            rx_taken: 0,
            send_end: 0,
            sending: false,
            fin_queued: false,
            timeout_at: None,
            tx_size: 0,
            rx_size: 0,
            conn: None,
            sends: Vec::new(),
            last_delivery: None,
            inbound: VecDeque::new(),
            datagrams_out: Vec::new(),
        }
    }

    pub(crate) fn reg(&self, off: u16) -> u8 {
        self.regs.get(usize::from(off)).copied().unwrap_or(0)
    }

    pub(crate) fn reg16(&self, off: u16) -> u16 {
        get16(&self.regs, off)
    }

    pub(crate) fn tx_wr(&self) -> u16 {
        get16(&self.regs, sn::TX_WR)
    }

    fn rx_rd(&self) -> u16 {
        get16(&self.regs, sn::RX_RD)
    }

    /// Sn_TX_FSR.
    pub(crate) fn tx_free(&self) -> u16 {
        self.tx_size.wrapping_sub(self.tx_wr().wrapping_sub(self.tx_rd))
    }

    /// Sn_RX_RSR.
    pub(crate) fn rx_received(&self) -> u16 {
        self.rx_wr.wrapping_sub(self.rx_taken)
    }

    pub(crate) fn tx_rd(&self) -> u16 {
        self.tx_rd
    }

    /// Reads register `off`.
    pub(crate) fn read(&self, off: u16) -> u8 {
        match off {
            sn::CR => 0,
            sn::IR => self.ir,
            sn::SR => self.sr,
            0x20..=0x21 => byte_of(self.tx_free(), sn::TX_FSR, off),
            0x22..=0x23 => byte_of(self.tx_rd, sn::TX_RD, off),
            0x26..=0x27 => byte_of(self.rx_received(), sn::RX_RSR, off),
            0x2A..=0x2B => byte_of(self.rx_wr, sn::RX_WR, off),
            _ => self.reg(off),
        }
    }

    /// Writes register `off`, but Sn_CR, which the chip handles ([`Socket::command`]).
    /// Read-only registers ignore it; Sn_IR clears the bits written as 1.
    pub(crate) fn write(&mut self, off: u16, v: u8) {
        match off {
            sn::IR => self.ir &= !v,
            sn::SR | 0x20..=0x23 | 0x26..=0x27 | 0x2A..=0x2B => {}
            _ => {
                if let Some(r) = self.regs.get_mut(usize::from(off)) {
                    *r = v;
                }
            }
        }
    }

    /// Whether a TCP connection is up (or being closed) on it.
    fn connected(&self) -> bool {
        matches!(self.sr, state::SYNSENT | state::ESTABLISHED | state::FIN_WAIT | state::CLOSE_WAIT | state::LAST_ACK)
    }

    /// Carries out command `c` at once (the chip then reads Sn_CR as 0).
    pub(crate) fn command(&mut self, c: u8, cx: &mut Context) {
        match c {
            cmd::OPEN => self.open(cx),
            cmd::LISTEN if self.sr == state::INIT => self.sr = state::LISTEN,
            cmd::CONNECT if self.sr == state::INIT => self.sr = state::SYNSENT,
            cmd::DISCON => self.discon(cx),
            cmd::CLOSE => self.close_by_chip(),
            cmd::SEND if matches!(self.sr, state::ESTABLISHED | state::CLOSE_WAIT) => self.send(cx),
            cmd::SEND if self.sr == state::UDP => self.send_datagram(cx),
            cmd::RECV => {
                self.rx_taken = self.rx_rd();
                self.pump_inbound(cx.rx, cx.now);
                if self.rx_received() != 0 {
                    self.ir |= int::RECV;
                }
            }
            _ => {}
        }
    }

    fn open(&mut self, cx: &Context) {
        self.close_by_chip();
        let p = cx.open_pointers;
        self.tx_rd = p;
        self.send_end = p;
        self.rx_wr = p;
        self.rx_taken = p;
        set16(&mut self.regs, sn::TX_WR, p);
        set16(&mut self.regs, sn::RX_RD, p);
        self.sr = match self.regs[usize::from(sn::MR)] & 0x0F {
            mode::TCP => state::INIT,
            mode::UDP => state::UDP,
            mode::IPRAW => state::IPRAW,
            mode::MACRAW if cx.macraw => state::MACRAW,
            _ => state::CLOSED,
        };
    }

    fn discon(&mut self, cx: &Context) {
        match self.sr {
            state::ESTABLISHED => self.sr = state::FIN_WAIT,
            state::CLOSE_WAIT => self.sr = state::LAST_ACK,
            state::SYNSENT => return self.close_quietly(),
            _ => return,
        }
        self.fin_queued = true;
        self.pump_tx(cx.tx, cx.now, cx.rto);
    }

    fn send(&mut self, cx: &Context) {
        let from = if self.sending { self.send_end } else { self.tx_rd };
        let to = self.tx_wr();
        let data = ring_read(cx.tx, from, to.wrapping_sub(from));
        self.sends.push(Send { cycle: cx.now, data });
        self.send_end = to;
        self.sending = true;
        self.pump_tx(cx.tx, cx.now, cx.rto);
    }

    /// UDP mode: the bytes from the end of the last SEND to Sn_TX_WR go as one datagram to
    /// Sn_DIPR:Sn_DPORT, at once (SEND_OK).
    fn send_datagram(&mut self, cx: &Context) {
        let to = self.tx_wr();
        let data = ring_read(cx.tx, self.tx_rd, to.wrapping_sub(self.tx_rd));
        self.datagrams_out.push((self.destination(), data));
        self.tx_rd = to;
        self.send_end = to;
        self.ir |= int::SEND_OK;
    }

    /// Sn_DIPR:Sn_DPORT.
    fn destination(&self) -> SocketAddrV4 {
        let ip = [self.reg(sn::DIPR), self.reg(sn::DIPR + 1), self.reg(sn::DIPR + 2), self.reg(sn::DIPR + 3)];
        SocketAddrV4::new(Ipv4Addr::from(ip), self.reg16(sn::DPORT))
    }

    /// UDP mode: a datagram from `from` lands in the RX buffer behind its 8-byte header
    /// (source IP, source port, data length, big endian), RECV. `false`, nothing written, if
    /// the socket is not in UDP mode or the whole of it finds no room (the chip drops it).
    pub(crate) fn land_datagram(&mut self, rx: &mut [u8], from: SocketAddrV4, payload: &[u8], at: u64) -> bool {
        let room = usize::from(self.rx_size.wrapping_sub(self.rx_received())).min(rx.len());
        let Ok(len) = u16::try_from(payload.len()) else { return false };
        if self.sr != state::UDP || payload.len() + 8 > room {
            return false;
        }
        let mut bytes = Vec::with_capacity(payload.len() + 8);
        bytes.extend_from_slice(&from.ip().octets());
        bytes.extend_from_slice(&from.port().to_be_bytes());
        bytes.extend_from_slice(&len.to_be_bytes());
        bytes.extend_from_slice(payload);
        for (i, &b) in bytes.iter().enumerate() {
            rx[ring_offset(rx.len(), self.rx_wr.wrapping_add(i as u16))] = b;
        }
        self.rx_wr = self.rx_wr.wrapping_add(bytes.len() as u16);
        self.ir |= int::RECV;
        self.last_delivery = Some(at);
        true
    }

    /// Hands the peer what it takes of the data sent, then the FIN if one is queued; arms the
    /// retransmission timeout while a vanished peer leaves something unacknowledged.
    pub(crate) fn pump_tx(&mut self, tx: &[u8], now: u64, rto: u64) {
        let Some(conn) = self.conn.as_mut().filter(|c| c.alive()) else {
            if self.conn.as_ref().is_some_and(|c| c.vanished && !c.closed) && (self.sending || self.fin_queued) {
                self.timeout_at.get_or_insert(now.saturating_add(rto));
            }
            return;
        };
        if self.sending {
            let pending = self.send_end.wrapping_sub(self.tx_rd);
            let n = conn.window.map_or(pending, |w| pending.min(u16::try_from(w).unwrap_or(u16::MAX)));
            conn.to_peer.extend(ring_read(tx, self.tx_rd, n));
            if let Some(w) = conn.window.as_mut() {
                *w -= usize::from(n);
            }
            self.tx_rd = self.tx_rd.wrapping_add(n);
            if self.tx_rd == self.send_end {
                self.sending = false;
                self.ir |= int::SEND_OK;
            }
        }
        if self.fin_queued && !self.sending {
            self.fin_queued = false;
            conn.chip_fin = true;
            if self.sr == state::LAST_ACK {
                // the peer acknowledges at once
                self.close_quietly();
            }
        }
    }

    /// Closes with no word to the peer (its connection is over, or never was).
    fn close_quietly(&mut self) {
        self.sr = state::CLOSED;
        self.sending = false;
        self.fin_queued = false;
        self.timeout_at = None;
        self.inbound.clear();
        if let Some(conn) = self.conn.as_mut() {
            conn.closed = true;
        }
    }

    /// CLOSE (and a chip reset): an RST to a connected peer.
    pub(crate) fn close_by_chip(&mut self) {
        if self.connected() {
            if let Some(conn) = self.conn.as_mut().filter(|c| !c.closed) {
                conn.chip_rst = true;
            }
        }
        self.close_quietly();
    }

    /// The peer's SYN to a LISTEN socket: established.
    pub(crate) fn accept(&mut self, conn: Connection, peer_mac: [u8; 6]) {
        let ip = conn.peer.ip().octets();
        self.regs[usize::from(sn::DIPR)..usize::from(sn::DIPR) + 4].copy_from_slice(&ip);
        set16(&mut self.regs, sn::DPORT, conn.peer.port());
        self.regs[usize::from(sn::DHAR)..usize::from(sn::DHAR) + 6].copy_from_slice(&peer_mac);
        self.conn = Some(conn);
        self.sends.clear();
        self.last_delivery = None;
        self.sr = state::ESTABLISHED;
        self.ir |= int::CON;
    }

    /// The peer's RST to a SYN: CLOSED, TIMEOUT (as the chips report a failed CONNECT).
    pub(crate) fn refuse(&mut self) {
        self.ir |= int::TIMEOUT;
        self.close_quietly();
    }

    /// Writes as much of `bytes` as the RX buffer has room for, as landed at cycle `at`;
    /// returns how many.
    pub(crate) fn land(&mut self, rx: &mut [u8], bytes: &[u8], at: u64) -> usize {
        if !matches!(self.sr, state::ESTABLISHED | state::FIN_WAIT) || !self.conn.as_ref().is_some_and(|c| c.alive()) {
            return 0;
        }
        let room = usize::from(self.rx_size.wrapping_sub(self.rx_received())).min(rx.len());
        let n = bytes.len().min(room);
        if n == 0 {
            return 0;
        }
        for (i, &b) in bytes[..n].iter().enumerate() {
            rx[ring_offset(rx.len(), self.rx_wr.wrapping_add(i as u16))] = b;
        }
        self.rx_wr = self.rx_wr.wrapping_add(n as u16);
        self.ir |= int::RECV;
        self.last_delivery = Some(at);
        n
    }

    /// Queues bytes from the peer that land at cycle `at` (see [`Socket::pump_inbound`]).
    pub(crate) fn queue(&mut self, bytes: Vec<u8>, at: u64) {
        self.inbound.push_back(Inbound { at, bytes, stalled: false });
    }

    /// The next cycle something is due: queued bytes landing (not those waiting for room),
    /// a retransmission timing out.
    pub(crate) fn next_due(&self) -> Option<u64> {
        let landing = self.inbound.front().filter(|i| !i.stalled).map(|i| i.at);
        match (landing, self.timeout_at) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Bytes queued and not landed yet.
    pub(crate) fn queued(&self) -> usize {
        self.inbound.iter().map(|i| i.bytes.len()).sum()
    }

    /// Lands the queued bytes due by `now` as far as there is room: at their own cycle, or at
    /// `now` for those that waited for room.
    pub(crate) fn pump_inbound(&mut self, rx: &mut [u8], now: u64) {
        while let Some(mut item) = self.inbound.pop_front() {
            if item.at > now {
                self.inbound.push_front(item);
                return;
            }
            let at = if item.stalled { now } else { item.at };
            let n = self.land(rx, &item.bytes, at);
            if n < item.bytes.len() {
                item.bytes.drain(..n);
                item.stalled = true;
                self.inbound.push_front(item);
                return;
            }
        }
    }

    /// The retransmission timeout, if it ran out by `now`: CLOSED and TIMEOUT.
    pub(crate) fn tick(&mut self, now: u64) {
        if self.timeout_at.is_some_and(|t| t <= now) {
            self.ir |= int::TIMEOUT;
            self.close_quietly();
        }
    }

    /// The peer's FIN.
    pub(crate) fn peer_fin(&mut self) {
        let Some(conn) = self.conn.as_mut().filter(|c| c.alive()) else { return };
        conn.peer_fin = true;
        self.inbound.clear();
        match self.sr {
            state::ESTABLISHED => {
                self.sr = state::CLOSE_WAIT;
                self.ir |= int::DISCON;
            }
            state::FIN_WAIT if !self.fin_queued => {
                self.ir |= int::DISCON;
                self.close_quietly();
            }
            state::FIN_WAIT => self.ir |= int::DISCON,
            _ => {}
        }
    }

    /// The peer's RST.
    pub(crate) fn peer_reset(&mut self) {
        let Some(conn) = self.conn.as_mut().filter(|c| !c.closed) else { return };
        conn.peer_rst = true;
        if self.connected() {
            self.ir |= int::DISCON;
        }
        self.close_quietly();
    }

    /// The peer is gone without a word: nothing arrives any more, nothing is acknowledged.
    pub(crate) fn peer_vanish(&mut self, tx: &[u8], now: u64, rto: u64) {
        let Some(conn) = self.conn.as_mut().filter(|c| !c.closed) else { return };
        conn.vanished = true;
        self.inbound.clear();
        self.pump_tx(tx, now, rto);
    }

    /// Sets every pointer to `p` (the socket must be closed for this to mean anything).
    pub(crate) fn set_pointers(&mut self, p: u16) {
        self.tx_rd = p;
        self.send_end = p;
        self.rx_wr = p;
        self.rx_taken = p;
        set16(&mut self.regs, sn::TX_WR, p);
        set16(&mut self.regs, sn::RX_RD, p);
    }
}

/// The offset of pointer `ptr` in a buffer of `len` bytes (a power of two, or 0).
pub(crate) fn ring_offset(len: usize, ptr: u16) -> usize {
    usize::from(ptr) & len.wrapping_sub(1)
}

/// `n` bytes of the ring `buf` from pointer `from`.
fn ring_read(buf: &[u8], from: u16, n: u16) -> Vec<u8> {
    if buf.is_empty() {
        return Vec::new();
    }
    (0..n).map(|i| buf[ring_offset(buf.len(), from.wrapping_add(i))]).collect()
}
