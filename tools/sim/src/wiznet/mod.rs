//! A simulated WIZnet W5100 or W5500 Ethernet controller (W5100 datasheet v1.2.x, W5500
//! datasheet v1.0.x), as on the Arduino Ethernet shields: an SPI slave with TCP sockets whose
//! network side a test (or the host TCP [`Bridge`]) plays.
//!
//! The SPI side is fed one byte at a time ([`W5x00::exchange`]) between chip-select edges
//! ([`W5x00::select`], [`W5x00::deselect`]); the simulator does that from the firmware's SPI
//! port ([`crate::Options::wiznet`]). The network side ([`W5x00::connect`],
//! [`W5x00::deliver`], [`W5x00::take_sent`], ...) acts on the sockets as a peer would.
//!
//! Time: the part knows the cycle of every SPI byte and of every [`crate::Uno::wiznet_mut`];
//! data queued for later ([`W5x00::deliver_at`]) and retransmission timeouts take effect at
//! the first frame that starts once they are due (W5100: every 4-byte frame; W5500: every
//! chip select), that is between two SPI frames, never inside one.
//!
//! What is modelled: the registers the Arduino and WIZnet drivers use, TCP server sockets
//! (OPEN, LISTEN, DISCON, CLOSE, SEND, RECV) and client sockets (CONNECT to SOCK_SYNSENT,
//! then [`W5x00::accept_connect`] or [`W5x00::refuse_connect`] as the peer answers), UDP
//! sockets (OPEN to SOCK_UDP on Sn_PORT; each datagram behind its 8-byte header, one that
//! finds no room dropped; SEND as one datagram to Sn_DIPR:Sn_DPORT: [`W5x00::udp_deliver`],
//! [`W5x00::udp_sent`]), buffer sizes (TMSR/RMSR, Sn_TXBUF_SIZE/Sn_RXBUF_SIZE). Not:
//! IP raw and MAC raw data (the sockets open, nothing moves), PPPoE, the INT pin,
//! keep-alives, the W5500's PHY beyond PHYCFGR's link bit. Commands take effect at once; a
//! SEND completes as soon as the peer has taken its data. Faults a test plays
//! ([`W5x00::set_link`], [`W5x00::reset`], [`W5x00::hang`]): the link down and up, a reset
//! while the board runs, a chip that answers nothing.

mod bridge;
mod connection;
pub mod dhcp_server;
mod faults;
mod network;
pub mod regs;
mod socket;
pub mod w5100;
pub mod w5500;

#[cfg(test)]
mod bridge_tests;
#[cfg(test)]
mod tests;

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

pub use bridge::{Bridge, BridgeEvent, Mapping};
pub use connection::Connection;
pub use socket::Send;

use regs::sn;
use socket::{Context, Socket};

/// Which WIZnet chip to simulate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wiznet {
    /// W5100 (Arduino Ethernet shield up to R3): 4 sockets, 8 KB of TX and of RX memory,
    /// 4-byte SPI frames.
    W5100,
    /// W5500 (Ethernet shield 2, most modules today): 8 sockets, 16 KB of TX and of RX memory,
    /// variable-length SPI frames with a block select.
    W5500,
}

impl Wiznet {
    /// Its sockets: 4 or 8.
    pub const fn sockets(self) -> usize {
        match self {
            Wiznet::W5100 => 4,
            Wiznet::W5500 => 8,
        }
    }

    /// Bytes of TX memory, and as many of RX memory, shared by its sockets.
    pub const fn memory(self) -> usize {
        match self {
            Wiznet::W5100 => 8 * 1024,
            Wiznet::W5500 => 16 * 1024,
        }
    }

    /// `"w5100"` or `"w5500"`.
    pub const fn name(self) -> &'static str {
        match self {
            Wiznet::W5100 => "w5100",
            Wiznet::W5500 => "w5500",
        }
    }
}

impl fmt::Display for Wiznet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Wiznet {
    type Err = String;

    fn from_str(s: &str) -> Result<Wiznet, String> {
        match s.to_ascii_lowercase().as_str() {
            "w5100" => Ok(Wiznet::W5100),
            "w5500" => Ok(Wiznet::W5500),
            _ => Err(format!("`{s}` is no WIZnet chip simulated here (w5100, w5500)")),
        }
    }
}

/// Where the SPI decoder is in a frame: bytes since the frame began, the address, the
/// W5100's opcode or the W5500's control byte.
#[derive(Clone, Copy, Debug, Default)]
struct Frame {
    index: u32,
    addr: u16,
    control: u8,
}

/// One access the firmware made over the SPI, for a record of where its SPI time goes
/// ([`W5x00::record_spi`]): a W5100 frame (4 bytes), or one data byte of a W5500 frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpiAccess {
    /// The cycle its last byte completed.
    pub cycle: u64,
    /// The address in the chip's map (W5100), or in the block (W5500).
    pub addr: u16,
    /// The W5500's block select (BSB, 0 on the W5100).
    pub block: u8,
    /// A write (else a read).
    pub write: bool,
}

/// A simulated W5100 or W5500: its registers and memory, its SPI decoder, and the peers of
/// its sockets' connections.
#[derive(Debug)]
pub struct W5x00 {
    model: Wiznet,
    common: [u8; 0x40],
    sockets: Vec<Socket>,
    tx_mem: Vec<u8>,
    rx_mem: Vec<u8>,
    tx_layout: Vec<Range<usize>>,
    rx_layout: Vec<Range<usize>>,
    frame: Frame,
    selected: bool,
    clock: u64,
    next_id: u64,
    open_pointers: u16,
    spi_bytes: u64,
    /// The accesses recorded since [`W5x00::record_spi`] turned the record on.
    spi_log: Option<Vec<SpiAccess>>,
    /// The link is up (`faults`).
    link: bool,
    /// The chip hangs, MISO stuck at this value (`faults`).
    hung: Option<u8>,
}

impl W5x00 {
    /// A chip as after power-on: every register at its default, every socket closed.
    pub fn new(model: Wiznet) -> W5x00 {
        let mut chip = W5x00 {
            model,
            common: [0; 0x40],
            sockets: Vec::new(),
            tx_mem: vec![0; model.memory()],
            rx_mem: vec![0; model.memory()],
            tx_layout: Vec::new(),
            rx_layout: Vec::new(),
            frame: Frame::default(),
            selected: false,
            clock: 0,
            next_id: 1,
            open_pointers: 0,
            spi_bytes: 0,
            spi_log: None,
            link: true,
            hung: None,
        };
        chip.reset();
        chip
    }

    /// Which chip it is.
    pub fn model(&self) -> Wiznet {
        self.model
    }

    /// A hardware or software reset (RESET pin, MR's RST bit): every register to its default,
    /// the memory cleared, every socket closed (an RST to each connected peer; the
    /// connections stay readable until replaced).
    pub fn reset(&mut self) {
        let defaults = match self.model {
            Wiznet::W5100 => w5100::SOCKET_DEFAULTS,
            Wiznet::W5500 => w5500::SOCKET_DEFAULTS,
        };
        let mut old = std::mem::take(&mut self.sockets);
        self.sockets = (0..self.model.sockets())
            .map(|n| {
                let mut s = Socket::new(defaults);
                if let Some(mut prev) = old.get_mut(n).map(|p| std::mem::replace(p, Socket::new(&[]))) {
                    prev.close_by_chip();
                    s.conn = prev.conn;
                }
                s
            })
            .collect();
        old.clear();
        self.common = [0; 0x40];
        let common = match self.model {
            Wiznet::W5100 => w5100::COMMON_DEFAULTS,
            Wiznet::W5500 => w5500::COMMON_DEFAULTS,
        };
        for &(addr, v) in common {
            self.common[usize::from(addr)] = v;
        }
        self.tx_mem.fill(0);
        self.rx_mem.fill(0);
        self.relayout();
    }

    /// Sizes of the sockets' TX and RX buffers from the registers, allocated in socket order
    /// from the start of each memory; a socket past the end gets none.
    fn relayout(&mut self) {
        let (tx, rx) = match self.model {
            Wiznet::W5100 => w5100::buffer_sizes(&self.common),
            Wiznet::W5500 => w5500::buffer_sizes(&self.sockets),
        };
        self.tx_layout = allocate(&tx, self.model.memory());
        self.rx_layout = allocate(&rx, self.model.memory());
        for (s, (t, r)) in self.sockets.iter_mut().zip(self.tx_layout.iter().zip(&self.rx_layout)) {
            s.tx_size = u16::try_from(t.len()).unwrap_or(0);
            s.rx_size = u16::try_from(r.len()).unwrap_or(0);
        }
    }

    // ----------------------------------------------------------------------------------------
    // SPI

    /// Chip select low at cycle `cycle`: a frame (W5500: a burst) begins.
    pub fn select(&mut self, cycle: u64) {
        self.advance(cycle);
        self.selected = true;
        self.frame = Frame::default();
    }

    /// Chip select high: whatever frame was under way ends.
    pub fn deselect(&mut self, cycle: u64) {
        self.advance(cycle);
        self.selected = false;
        self.frame = Frame::default();
    }

    /// Whether the chip is selected.
    pub fn selected(&self) -> bool {
        self.selected
    }

    /// One SPI byte, completed at cycle `cycle`: `mosi` in, the chip's answer out (what the
    /// firmware reads from SPDR next); `None` while the chip is not selected (MISO released).
    pub fn exchange(&mut self, mosi: u8, cycle: u64) -> Option<u8> {
        if !self.selected {
            return None;
        }
        self.spi_bytes += 1;
        if let Some(miso) = self.hung {
            // Nothing decoded, nothing written: MISO stuck.
            return Some(miso);
        }
        let frame_start = match self.model {
            Wiznet::W5100 => self.frame.index.is_multiple_of(4),
            Wiznet::W5500 => self.frame.index == 0,
        };
        if frame_start {
            self.advance(cycle);
        } else {
            self.clock = self.clock.max(cycle);
        }
        let (index, addr, control) = (self.frame.index, self.frame.addr, self.frame.control);
        let miso = match self.model {
            Wiznet::W5100 => self.w5100_byte(mosi),
            Wiznet::W5500 => self.w5500_byte(mosi),
        };
        if let Some(log) = self.spi_log.as_mut() {
            let access = match self.model {
                Wiznet::W5100 if index % 4 == 3 => {
                    Some(SpiAccess { cycle, addr, block: 0, write: control == w5100::WRITE })
                }
                Wiznet::W5500 if index >= 3 => {
                    Some(SpiAccess { cycle, addr, block: control >> 3, write: control & w5500::RWB_WRITE != 0 })
                }
                _ => None,
            };
            log.extend(access);
        }
        Some(miso)
    }

    /// Turns the record of SPI accesses on (emptied) or off: what [`W5x00::take_spi_log`]
    /// returns.
    pub fn record_spi(&mut self, on: bool) {
        self.spi_log = on.then(Vec::new);
    }

    /// The SPI accesses recorded since the last call (none while the record is off).
    pub fn take_spi_log(&mut self) -> Vec<SpiAccess> {
        self.spi_log.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// SPI bytes exchanged while selected, since power-on.
    pub fn spi_bytes(&self) -> u64 {
        self.spi_bytes
    }

    // ----------------------------------------------------------------------------------------
    // time

    /// The cycle the chip has reached: the last SPI event's, or [`W5x00::advance`]'s.
    pub fn now(&self) -> u64 {
        self.clock
    }

    /// Tells the chip the time (never backwards): queued data that is due lands, timeouts that
    /// ran out fire. The simulator calls it at every chip select, W5100 frame and
    /// [`crate::Uno::wiznet_mut`].
    pub fn advance(&mut self, cycle: u64) {
        self.clock = self.clock.max(cycle);
        let now = self.clock;
        for (n, s) in self.sockets.iter_mut().enumerate() {
            s.tick(now);
            s.pump_inbound(&mut self.rx_mem[self.rx_layout[n].clone()], now);
        }
    }

    /// Cycles a vanished peer leaves unacknowledged data before TIMEOUT: the chip's
    /// retransmissions, RTR (100 µs units) doubling up to 0xFFFF, RCR + 1 of them.
    fn rto_cycles(&self) -> u64 {
        let (rtr, rcr) = match self.model {
            Wiznet::W5100 => (w5100::RTR, w5100::RCR),
            Wiznet::W5500 => (w5500::RTR, w5500::RCR),
        };
        let rtr = u16::from_be_bytes([self.common[rtr], self.common[rtr + 1]]);
        retransmission_time(rtr, self.common[rcr]) * 1_600
    }

    /// The INT line, low (`true` here) while a socket's events are unmasked: the W5100's IR
    /// socket bits under IMR (0x16), the W5500's SIR under SIMR (0x18), each socket's Sn_IR
    /// under its Sn_IMR.
    pub fn int_asserted(&self) -> bool {
        let (mask, socket_masks) = match self.model {
            Wiznet::W5100 => (self.common[0x16], false),
            Wiznet::W5500 => (self.common[0x18], true),
        };
        self.sockets.iter().enumerate().any(|(n, s)| {
            let unmasked = if socket_masks { s.ir & s.reg(regs::sn::IMR) } else { s.ir };
            unmasked != 0 && mask & (1 << n) != 0
        })
    }

    /// The next cycle at which something is due on the network side: bytes queued to land
    /// ([`W5x00::deliver_at`]) or a retransmission timing out. A harness with the INT line
    /// wired runs the chip up to it, so that the line falls when the data lands.
    pub fn next_due(&self) -> Option<u64> {
        self.sockets.iter().filter_map(|s| s.next_due()).min()
    }

    /// Sn_IR ≠ 0, one bit per socket (IR's low bits on the W5100, SIR on the W5500).
    fn socket_interrupts(&self) -> u8 {
        self.sockets.iter().enumerate().filter(|(_, s)| s.ir != 0).fold(0, |bits, (n, _)| bits | 1 << n)
    }

    // ----------------------------------------------------------------------------------------
    // the sockets, for the chips' address maps

    fn socket_read(&self, n: usize, off: u16) -> u8 {
        self.sockets.get(n).map_or(0, |s| s.read(off))
    }

    fn socket_write(&mut self, n: usize, off: u16, v: u8) {
        if n >= self.sockets.len() {
            return;
        }
        if off == sn::CR {
            self.command(n, v);
        } else {
            self.sockets[n].write(off, v);
        }
    }

    /// Sn_CR written: the command is carried out at once.
    fn command(&mut self, n: usize, c: u8) {
        let rto = self.rto_cycles();
        let mut cx = Context {
            tx: &self.tx_mem[self.tx_layout[n].clone()],
            rx: &mut self.rx_mem[self.rx_layout[n].clone()],
            now: self.clock,
            rto,
            open_pointers: self.open_pointers,
            macraw: n == 0,
        };
        self.sockets[n].command(c, &mut cx);
    }

    /// Byte `off` of socket `n`'s TX buffer (`off` wraps at its size).
    fn tx_buffer(&mut self, n: usize) -> &mut [u8] {
        match self.tx_layout.get(n) {
            Some(r) => &mut self.tx_mem[r.clone()],
            None => &mut [],
        }
    }

    fn rx_buffer(&mut self, n: usize) -> &mut [u8] {
        match self.rx_layout.get(n) {
            Some(r) => &mut self.rx_mem[r.clone()],
            None => &mut [],
        }
    }
}

/// Consecutive ranges of `memory` bytes for `sizes`; a size that does not fit gets an empty
/// range.
fn allocate(sizes: &[usize], memory: usize) -> Vec<Range<usize>> {
    let mut next = 0;
    sizes
        .iter()
        .map(|&size| {
            if next + size <= memory {
                next += size;
                next - size..next
            } else {
                next..next
            }
        })
        .collect()
}

/// The chip's TCP retransmission time in 100 µs units: RCR + 1 transmissions, the first
/// after RTR, each next one twice as long as long as it stays within 16 bits (W5500
/// datasheet §4.1, RCR: with RTR 2000 and RCR 8, 31.8 s).
pub fn retransmission_time(rtr: u16, rcr: u8) -> u64 {
    let mut wait = u64::from(rtr);
    let mut total = 0;
    for _ in 0..=rcr {
        total += wait;
        if wait * 2 <= 0xFFFF {
            wait *= 2;
        }
    }
    total
}
