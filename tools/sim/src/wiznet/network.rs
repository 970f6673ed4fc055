//! The network side of the chip: what a peer (a test, or the host [`super::Bridge`]) does to
//! the sockets and sees of them. Every action takes effect at the chip's clock
//! ([`W5x00::now`]; [`crate::Uno::wiznet_mut`] sets it to the simulation's).

use std::net::SocketAddrV4;

use super::connection::Connection;
use super::regs::{sn, state};
use super::socket::Send;
use super::W5x00;

impl W5x00 {
    /// Its sockets: 4 (W5100) or 8 (W5500).
    pub fn socket_count(&self) -> usize {
        self.sockets.len()
    }

    /// Socket `n`'s Sn_SR (CLOSED for a socket the chip lacks).
    pub fn status(&self, n: usize) -> u8 {
        self.sockets.get(n).map_or(state::CLOSED, |s| s.sr)
    }

    /// Socket `n`'s Sn_IR.
    pub fn interrupts(&self, n: usize) -> u8 {
        self.sockets.get(n).map_or(0, |s| s.ir)
    }

    /// Socket `n`'s register `off` (see [`super::regs::sn`]), as the firmware would read it.
    pub fn socket_register(&self, n: usize, off: u16) -> u8 {
        self.socket_read(n, off)
    }

    /// Socket `n`'s 16-bit register at `off`, as two reads in a row would give it.
    pub fn socket_register16(&self, n: usize, off: u16) -> u16 {
        u16::from_be_bytes([self.socket_read(n, off), self.socket_read(n, off + 1)])
    }

    /// Common register `off` (0x00–0x3F), stored value (IR and SIR without the socket bits).
    pub fn common_register(&self, off: u16) -> u8 {
        self.common.get(usize::from(off)).copied().unwrap_or(0)
    }

    /// The lowest socket in SOCK_LISTEN on `port`, if any.
    pub fn listening(&self, port: u16) -> Option<usize> {
        self.sockets.iter().position(|s| s.sr == state::LISTEN && s.reg16(sn::PORT) == port)
    }

    /// The ports some socket listens on, in order, each once.
    pub fn listening_ports(&self) -> Vec<u16> {
        let mut ports: Vec<u16> =
            self.sockets.iter().filter(|s| s.sr == state::LISTEN).map(|s| s.reg16(sn::PORT)).collect();
        ports.sort_unstable();
        ports.dedup();
        ports
    }

    /// A SYN from `peer` to `port`: the lowest socket listening there takes it (ESTABLISHED,
    /// Sn_DIPR and Sn_DPORT set, CON) and its index comes back; `None` if no socket listens on
    /// it (a real chip answers such a SYN with an RST).
    pub fn connect(&mut self, port: u16, peer: SocketAddrV4) -> Option<usize> {
        if !self.reachable() {
            return None;
        }
        let n = self.listening(port)?;
        let id = self.next_id;
        self.next_id += 1;
        let mac = [0x02, 0, 0, 0, (id >> 8) as u8, id as u8];
        self.sockets[n].accept(Connection::new(id, peer, port), mac);
        Some(n)
    }

    /// The peer accepts socket `n`'s CONNECT (SOCK_SYNSENT): ESTABLISHED, CON. `false` if the
    /// socket is not connecting.
    pub fn accept_connect(&mut self, n: usize) -> bool {
        if !self.reachable() {
            return false;
        }
        let Some(s) = self.sockets.get_mut(n).filter(|s| s.sr == state::SYNSENT) else { return false };
        let ip = std::net::Ipv4Addr::from(u32::from_be_bytes([
            s.reg(sn::DIPR),
            s.reg(sn::DIPR + 1),
            s.reg(sn::DIPR + 2),
            s.reg(sn::DIPR + 3),
        ]));
        let peer = SocketAddrV4::new(ip, s.reg16(sn::DPORT));
        let local = s.reg16(sn::PORT);
        let id = self.next_id;
        self.next_id += 1;
        let mac = [0x02, 0, 0, 0, (id >> 8) as u8, id as u8];
        self.sockets[n].accept(Connection::new(id, peer, local), mac);
        true
    }

    /// The peer refuses socket `n`'s CONNECT (an RST to its SYN; a real chip also ends so
    /// once its SYN retransmissions run out): CLOSED, TIMEOUT. `false` if the socket is not
    /// connecting.
    pub fn refuse_connect(&mut self, n: usize) -> bool {
        let Some(s) = self.sockets.get_mut(n).filter(|s| s.sr == state::SYNSENT) else { return false };
        s.refuse();
        true
    }

    /// The sockets in SOCK_SYNSENT (a CONNECT given, no answer yet), each with the address
    /// and port it connects to (Sn_DIPR, Sn_DPORT).
    pub fn connecting(&self) -> Vec<(usize, SocketAddrV4)> {
        self.sockets
            .iter()
            .enumerate()
            .filter(|(_, s)| s.sr == state::SYNSENT && self.reachable())
            .map(|(n, s)| {
                let ip = [s.reg(sn::DIPR), s.reg(sn::DIPR + 1), s.reg(sn::DIPR + 2), s.reg(sn::DIPR + 3)];
                (n, SocketAddrV4::new(ip.into(), s.reg16(sn::DPORT)))
            })
            .collect()
    }

    /// Socket `n`'s connection (the current one, or the last one until another replaces it).
    pub fn connection(&self, n: usize) -> Option<&Connection> {
        self.sockets.get(n)?.conn.as_ref()
    }

    /// Bytes from the peer of socket `n` into its RX buffer, now, as far as it has room
    /// (Sn_RX_RSR grows, RECV); returns how many. None while the socket is not ESTABLISHED
    /// (or FIN_WAIT) or its peer is gone.
    pub fn deliver(&mut self, n: usize, bytes: &[u8]) -> usize {
        let (now, reachable) = (self.clock, self.reachable());
        let Some(s) = self.sockets.get_mut(n).filter(|_| reachable) else { return 0 };
        s.land(&mut self.rx_mem[self.rx_layout[n].clone()], bytes, now)
    }

    /// Bytes from the peer of socket `n` that land at cycle `cycle` (at once if that has
    /// passed), behind any queued before: at the first SPI frame from then on, or as soon as
    /// the firmware makes room (a full buffer: the peer retransmits). For a request split
    /// across segments, or two in one segment, as the test times them.
    pub fn deliver_at(&mut self, n: usize, bytes: &[u8], cycle: u64) {
        let reachable = self.reachable();
        let Some(s) = self.sockets.get_mut(n).filter(|_| reachable) else { return };
        s.queue(bytes.to_vec(), cycle);
        s.pump_inbound(&mut self.rx_mem[self.rx_layout[n].clone()], self.clock);
    }

    /// Bytes queued for socket `n` with [`W5x00::deliver_at`] that have not landed.
    pub fn queued(&self, n: usize) -> usize {
        self.sockets.get(n).map_or(0, |s| s.queued())
    }

    /// Free room in socket `n`'s RX buffer.
    pub fn rx_room(&self, n: usize) -> usize {
        self.sockets.get(n).map_or(0, |s| usize::from(s.rx_size.wrapping_sub(s.rx_received())))
    }

    /// Takes what socket `n`'s peer received since the last call.
    pub fn take_sent(&mut self, n: usize) -> Vec<u8> {
        self.sockets
            .get_mut(n)
            .and_then(|s| s.conn.as_mut())
            .map(|c| std::mem::take(&mut c.to_peer))
            .unwrap_or_default()
    }

    /// Every SEND of socket `n`'s connection, in order, with its cycle and its data.
    pub fn sends(&self, n: usize) -> &[Send] {
        self.sockets.get(n).map_or(&[], |s| &s.sends)
    }

    /// The cycle at which the last byte delivered to socket `n`'s connection landed in its RX
    /// buffer: with [`W5x00::sends`], the chip's latency from a request to its reply.
    pub fn last_delivery(&self, n: usize) -> Option<u64> {
        self.sockets.get(n)?.last_delivery
    }

    /// Sn_TX_WR − Sn_TX_RD of socket `n`: bytes written and not taken by the peer yet.
    pub fn tx_pending(&self, n: usize) -> u16 {
        self.sockets.get(n).map_or(0, |s| s.tx_wr().wrapping_sub(s.tx_rd()))
    }

    /// How much more socket `n`'s peer takes: `None` all (the default), `Some(0)` nothing (a
    /// peer that does not read: the data stays in the TX buffer, Sn_TX_FSR shrinks, no
    /// SEND_OK).
    pub fn set_peer_window(&mut self, n: usize, window: Option<usize>) {
        if let Some(c) = self.sockets.get_mut(n).and_then(|s| s.conn.as_mut()) {
            c.window = window;
        }
        self.pump_tx(n);
    }

    /// Socket `n`'s peer reads `bytes` more (its window opens by that much).
    pub fn peer_reads(&mut self, n: usize, bytes: usize) {
        if let Some(c) = self.sockets.get_mut(n).and_then(|s| s.conn.as_mut()) {
            if let Some(w) = c.window.as_mut() {
                *w = w.saturating_add(bytes);
            }
        }
        self.pump_tx(n);
    }

    fn pump_tx(&mut self, n: usize) {
        let (now, rto) = (self.clock, self.rto_cycles());
        if let Some(s) = self.sockets.get_mut(n) {
            s.pump_tx(&self.tx_mem[self.tx_layout[n].clone()], now, rto);
        }
    }

    /// Socket `n`'s peer sends its FIN: ESTABLISHED → CLOSE_WAIT, FIN_WAIT → CLOSED; DISCON.
    /// Data queued with [`W5x00::deliver_at`] and not landed is dropped.
    pub fn peer_fin(&mut self, n: usize) {
        let reachable = self.reachable();
        if let Some(s) = self.sockets.get_mut(n).filter(|_| reachable) {
            s.peer_fin();
        }
    }

    /// Socket `n`'s peer resets the connection: CLOSED, DISCON.
    pub fn peer_reset(&mut self, n: usize) {
        let reachable = self.reachable();
        if let Some(s) = self.sockets.get_mut(n).filter(|_| reachable) {
            s.peer_reset();
        }
    }

    /// Socket `n`'s peer vanishes without a FIN (cable pulled, host gone): nothing arrives
    /// any more and nothing is acknowledged; data the firmware sends, or its FIN, times out
    /// after the chip's retransmissions ([`super::retransmission_time`]): CLOSED, TIMEOUT.
    pub fn peer_vanish(&mut self, n: usize) {
        let (now, rto) = (self.clock, self.rto_cycles());
        if let Some(s) = self.sockets.get_mut(n) {
            s.peer_vanish(&self.tx_mem[self.tx_layout[n].clone()], now, rto);
        }
    }

    /// The value OPEN gives the four pointers (Sn_TX_RD, Sn_TX_WR, Sn_RX_RD, Sn_RX_WR); 0 by
    /// default. A test sets it near 0xFFFF to see the firmware's pointers wrap.
    pub fn set_open_pointers(&mut self, p: u16) {
        self.open_pointers = p;
    }

    /// Sets socket `n`'s four pointers to `p` now (meant for a closed socket).
    pub fn set_pointers(&mut self, n: usize, p: u16) {
        if let Some(s) = self.sockets.get_mut(n) {
            s.set_pointers(p);
        }
    }

    // ----------------------------------------------------------------------------------------
    // UDP

    /// A datagram from `from` to socket `n` (open in UDP mode): lands behind its 8-byte header,
    /// RECV set. False if the socket is not in UDP mode or has no room (dropped, as the chip
    /// drops it).
    pub fn udp_deliver(&mut self, n: usize, from: SocketAddrV4, payload: &[u8]) -> bool {
        let now = self.clock;
        let Some(s) = self.sockets.get_mut(n) else { return false };
        s.land_datagram(&mut self.rx_mem[self.rx_layout[n].clone()], from, payload, now)
    }

    /// The datagrams socket `n` sent since the last call: (destination, payload), in order.
    pub fn udp_sent(&mut self, n: usize) -> Vec<(SocketAddrV4, Vec<u8>)> {
        self.sockets.get_mut(n).map(|s| std::mem::take(&mut s.datagrams_out)).unwrap_or_default()
    }

    /// The lowest socket open in UDP mode on local `port`, if any.
    pub fn udp_socket(&self, port: u16) -> Option<usize> {
        self.sockets.iter().position(|s| s.sr == state::UDP && s.reg16(sn::PORT) == port)
    }
}
