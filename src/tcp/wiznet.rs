//! The WIZnet W5100 (Arduino Ethernet Shield R3) and W5500 (Ethernet Shield 2, the common
//! modules) over SPI, from their datasheets (W5100 v1.2.x §3–§6, W5500 v1.0.x §2–§4): the
//! SPI frames, where the registers and the socket buffers lie, the commands.
//!
//! The two chips share the socket registers' offsets and meanings; they differ in how an
//! address goes over SPI and where a socket's registers and buffers are:
//!
//! * W5100: one 4-byte frame per data byte, chip select toggled around each: `0xF0`
//!   (write) or `0x0F` (read), address high, address low, data. Socket n's registers at
//!   0x0400 + n·0x100, its 2 KB transmit buffer at 0x4000 + n·0x800, receive at 0x6000 +
//!   n·0x800; a buffer pointer runs freely over 16 bits, its place is `pointer & 0x7FF`,
//!   so a run of bytes that passes the buffer's end continues at its start.
//! * W5500: a 3-byte header (address high, low, control: block << 3 | write << 2), then the
//!   data bytes, as many as chip select stays low. Socket n's registers in block 4n + 1,
//!   transmit buffer 4n + 2, receive 4n + 3; the chip wraps a pointer in its buffer itself.
//!
//! [`Wiznet`] is the driver over a [`Bus`] (the SPI and the chip-select pin); it is the
//! [`Sockets`](super::server::Sockets) the server runs on.

use core::marker::PhantomData;

use super::network::Network;
use super::server::Sockets;

/// The SPI bus with the chip's select line: what the driver needs of the hardware.
pub trait Bus {
    /// Chip select low: a frame begins.
    fn select(&mut self);
    /// Chip select high: the frame ends.
    fn deselect(&mut self);
    /// Sends `out` and returns the byte received meanwhile.
    fn transfer(&mut self, out: u8) -> u8;

    /// Sends zeros, `buf` receiving each byte that comes meanwhile.
    fn read_into(&mut self, buf: &mut [u8]) {
        for byte in buf.iter_mut() {
            *byte = self.transfer(0);
        }
    }

    /// Sends `data`.
    fn write_from(&mut self, data: &[u8]) {
        for &byte in data {
            self.transfer(byte);
        }
    }
}

/// Socket register offsets, the same on both chips.
pub mod sn {
    /// Sn_MR, the mode.
    pub const MR: u8 = 0x00;
    /// Sn_CR, the command.
    pub const CR: u8 = 0x01;
    /// Sn_IR, the events (cleared by writing 1s).
    pub const IR: u8 = 0x02;
    /// Sn_SR, the state.
    pub const SR: u8 = 0x03;
    /// Sn_PORT, the local port.
    pub const PORT: u8 = 0x04;
    /// Sn_DIPR, the peer's address.
    pub const DIPR: u8 = 0x0C;
    /// Sn_DPORT, the peer's port (a client writes it before CONNECT).
    pub const DPORT: u8 = 0x10;
    /// Sn_IMR, the W5500's mask of the socket's events on the INT line.
    pub const IMR: u8 = 0x2C;
    /// Sn_TX_FSR, the free bytes of the transmit buffer.
    pub const TX_FSR: u8 = 0x20;
    /// Sn_TX_WR, where the next byte to send goes.
    pub const TX_WR: u8 = 0x24;
    /// Sn_RX_RSR, the bytes received and not yet taken.
    pub const RX_RSR: u8 = 0x26;
    /// Sn_RX_RD, where the next byte to take is.
    pub const RX_RD: u8 = 0x28;
}

/// Sn_MR: TCP.
pub const MODE_TCP: u8 = 0x01;
/// Sn_MR: UDP (Modbus UDP's socket, the DHCP client's).
#[cfg(any(feature = "udp", feature = "dhcp"))]
pub const MODE_UDP: u8 = 0x02;
/// The header the chip puts before each datagram in a UDP socket's receive buffer: the
/// sender's address (4 bytes), port (2), the data's length (2), big-endian.
#[cfg(feature = "udp")]
pub const UDP_HEADER: usize = 8;

/// Sn_CR's commands.
pub mod command {
    /// Opens the socket in Sn_MR's mode (→ `INIT`).
    pub const OPEN: u8 = 0x01;
    /// Waits for a connection (`INIT` → `LISTEN`).
    pub const LISTEN: u8 = 0x02;
    /// Connects to Sn_DIPR:Sn_DPORT, a SYN sent (`INIT` → `SYNSENT`, then `ESTABLISHED`, or
    /// `CLOSED` on a refusal or the chip's timeout).
    pub const CONNECT: u8 = 0x04;
    /// Sends a FIN.
    pub const DISCON: u8 = 0x08;
    /// Closes at once (an RST to a connected peer).
    pub const CLOSE: u8 = 0x10;
    /// Sends the transmit buffer's bytes up to Sn_TX_WR.
    pub const SEND: u8 = 0x20;
    /// Takes the received bytes up to Sn_RX_RD.
    pub const RECV: u8 = 0x40;
}

/// Sn_SR's states.
pub mod state {
    /// No connection.
    pub const CLOSED: u8 = 0x00;
    /// Opened, not listening.
    pub const INIT: u8 = 0x13;
    /// Waiting for a connection.
    pub const LISTEN: u8 = 0x14;
    /// A client's SYN sent, no answer yet.
    pub const SYNSENT: u8 = 0x15;
    /// Connected.
    pub const ESTABLISHED: u8 = 0x17;
    /// The peer closed its side; this side may still send.
    pub const CLOSE_WAIT: u8 = 0x1C;
    /// Opened in UDP mode.
    #[cfg(any(feature = "udp", feature = "dhcp"))]
    pub const UDP: u8 = 0x22;
}

/// Sn_IR's send-done event.
pub const SEND_OK: u8 = 0x10;
/// Sn_IR's data-received event.
pub const RECV: u8 = 0x04;
/// Sn_IR's timeout event (UDP: the destination's ARP went unanswered, nothing sent).
#[cfg(feature = "udp")]
pub const TIMEOUT: u8 = 0x08;

/// Where a transfer goes, as the W5500's block select numbers it (the W5100 maps it to its
/// one address space): the common registers, or socket n's registers, transmit buffer or
/// receive buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block(u8);

impl Block {
    /// The common registers.
    pub const COMMON: Block = Block(0);

    /// Socket `s`'s registers.
    pub const fn socket(s: u8) -> Block {
        Block(4 * s + 1)
    }

    /// Socket `s`'s transmit buffer.
    pub const fn tx(s: u8) -> Block {
        Block(4 * s + 2)
    }

    /// Socket `s`'s receive buffer.
    pub const fn rx(s: u8) -> Block {
        Block(4 * s + 3)
    }
}

/// A WIZnet chip: how many sockets it has and how its addresses go over SPI.
pub trait Chip {
    /// Its sockets.
    const SOCKETS: u8;
    /// The common register whose bit n says socket n has events (W5100 IR, W5500 SIR).
    const SOCKET_EVENTS: u16;
    /// The mask of that register's socket bits (W5100 IMR, W5500 SIMR), for the INT pin.
    const SOCKET_EVENT_MASK: u16;
    /// A common register and the value it holds after a reset, which says the chip is this
    /// one (the W5100's TMSR, 2 KB a socket; the W5500's VERSIONR).
    const IDENTITY: (u16, u8);
    /// Each socket's events that reach the INT line (the W5500's Sn_IMR), if the chip can
    /// choose them.
    const SOCKET_EVENT_BITS: Option<u8> = None;
    /// The common register whose bit 0 is the link (1: up; the W5500's PHYCFGR), if the chip
    /// has one.
    const LINK: Option<u16> = None;
    /// A register [`Wiznet::init`] sets and the value it gives it, neither 0x00 nor 0xFF (what
    /// a hung chip reads) nor the register's value after a reset: the health check reads it
    /// back (`super::health`). The W5100's IMR (0x0F, every socket's events; 0 after a
    /// reset), the W5500's socket 0 Sn_IMR ([`Chip::SOCKET_EVENT_BITS`], 0x0F; 0xFF after a
    /// reset).
    const SETTING: (Block, u16, u8);
    /// Reads (`write` false: each byte of `buf` replaced by the one received) or writes
    /// `buf` at `offset` in `block`; in a buffer, `offset` is the free-running pointer.
    fn transfer<B: Bus>(bus: &mut B, block: Block, offset: u16, buf: &mut [u8], write: bool);
}

/// The W5100: 4 sockets, 2 KB buffers each.
#[derive(Clone, Copy, Debug)]
pub struct W5100;

/// The W5500: 8 sockets, 2 KB buffers each.
#[derive(Clone, Copy, Debug)]
pub struct W5500;

impl W5100 {
    /// The high byte of the address of byte `offset` of `block` (the low byte is
    /// `offset`'s): a buffer's byte at its pointer's place, `pointer & 0x7FF`, so that a run
    /// past the buffer's end goes on at its start. Worked out a byte at a time, as the AVR
    /// does it best.
    const fn address_high(block: Block, offset_high: u8) -> u8 {
        let n = block.0 >> 2;
        match block.0 & 3 {
            0 => offset_high,
            // 0x0400 + n·0x100.
            1 => 0x04 + n,
            // 0x4000 (transmit) or 0x6000 (receive) + n·0x800 + the place.
            kind => 0x40 | (kind & 1) << 5 | n << 3 | (offset_high & 0x07),
        }
    }
}

impl Chip for W5100 {
    const SOCKETS: u8 = 4;

    const SOCKET_EVENTS: u16 = 0x0015;
    const SOCKET_EVENT_MASK: u16 = 0x0016;
    const IDENTITY: (u16, u8) = (0x001B, 0x55);
    const SETTING: (Block, u16, u8) = (Block::COMMON, W5100::SOCKET_EVENT_MASK, 0x0F);

    #[inline(never)]
    fn transfer<B: Bus>(bus: &mut B, block: Block, offset: u16, buf: &mut [u8], write: bool) {
        let opcode = if write { 0xF0 } else { 0x0F };
        let [mut offset_high, mut low] = offset.to_be_bytes();
        let mut high = W5100::address_high(block, offset_high);
        for byte in buf.iter_mut() {
            bus.select();
            bus.transfer(opcode);
            bus.transfer(high);
            bus.transfer(low);
            let got = bus.transfer(*byte);
            bus.deselect();
            if !write {
                *byte = got;
            }
            low = low.wrapping_add(1);
            if low == 0 {
                offset_high = offset_high.wrapping_add(1);
                high = W5100::address_high(block, offset_high);
            }
        }
    }
}

/// The W5500's control byte's write bit.
const W5500_WRITE: u8 = 1 << 2;

impl Chip for W5500 {
    const SOCKETS: u8 = 8;
    /// All but SEND_OK, which the server reads when it next looks at the socket: one
    /// interrupt a reply fewer.
    const SOCKET_EVENT_BITS: Option<u8> = Some(0x0F);

    const SOCKET_EVENTS: u16 = 0x0017;
    const SOCKET_EVENT_MASK: u16 = 0x0018;
    const IDENTITY: (u16, u8) = (0x0039, 0x04);
    const LINK: Option<u16> = Some(0x002E);
    const SETTING: (Block, u16, u8) = (Block::socket(0), sn::IMR as u16, 0x0F);

    #[inline(never)]
    fn transfer<B: Bus>(bus: &mut B, block: Block, offset: u16, buf: &mut [u8], write: bool) {
        let [hi, lo] = offset.to_be_bytes();
        bus.select();
        bus.transfer(hi);
        bus.transfer(lo);
        bus.transfer(block.0 << 3 | if write { W5500_WRITE } else { 0 });
        if write {
            bus.write_from(buf);
        } else {
            bus.read_into(buf);
        }
        bus.deselect();
    }
}

/// A WIZnet chip `C` on bus `B`.
pub struct Wiznet<C, B> {
    /// The SPI and chip select.
    pub bus: B,
    chip: PhantomData<C>,
}

/// Common registers: mode, gateway (then subnet, MAC, IP, in a row on both chips).
const MR: u16 = 0x0000;
const GAR: u16 = 0x0001;
/// MR's software reset bit.
const RESET: u8 = 0x80;

impl<C: Chip, B: Bus> Wiznet<C, B> {
    /// The chip on `bus`, not yet set up.
    pub const fn new(bus: B) -> Self {
        Wiznet { bus, chip: PhantomData }
    }

    /// Resets the chip, checks it is a `C`, and gives it `network`'s addresses; socket
    /// events reach the INT pin (for a board that wires it). False when no `C` answers.
    pub fn init(&mut self, network: &Network) -> bool {
        self.set(Block::COMMON, MR, RESET);
        // The reset clears itself within microseconds; a chip that never clears it is not
        // there (reading all ones), which the identity then says.
        let mut tries: u8 = 255;
        while self.get(Block::COMMON, MR) & RESET != 0 && tries != 0 {
            tries -= 1;
        }
        let (register, value) = C::IDENTITY;
        if self.get(Block::COMMON, register) != value {
            return false;
        }
        let mut addresses = network.addresses;
        C::transfer(&mut self.bus, Block::COMMON, GAR, &mut addresses, true);
        self.set(Block::COMMON, C::SOCKET_EVENT_MASK, 0xFF >> (8 - C::SOCKETS));
        if let Some(bits) = C::SOCKET_EVENT_BITS {
            for s in 0..C::SOCKETS {
                self.set(Block::socket(s), sn::IMR.into(), bits);
            }
        }
        true
    }

    /// The byte at `offset` in `block`.
    #[inline(never)]
    pub(crate) fn get(&mut self, block: Block, offset: u16) -> u8 {
        let mut byte = [0];
        C::transfer(&mut self.bus, block, offset, &mut byte, false);
        byte[0]
    }

    /// Writes the byte at `offset` in `block`.
    #[inline(never)]
    fn set(&mut self, block: Block, offset: u16, value: u8) {
        C::transfer(&mut self.bus, block, offset, &mut [value], true);
    }

    /// Socket `s`'s 16-bit register at `offset`.
    #[inline(never)]
    fn get16(&mut self, s: u8, offset: u8) -> u16 {
        let mut bytes = [0; 2];
        C::transfer(&mut self.bus, Block::socket(s), u16::from(offset), &mut bytes, false);
        u16::from_be_bytes(bytes)
    }

    /// Writes socket `s`'s 16-bit register at `offset`.
    #[inline(never)]
    fn set16(&mut self, s: u8, offset: u8, value: u16) {
        C::transfer(&mut self.bus, Block::socket(s), u16::from(offset), &mut value.to_be_bytes(), true);
    }

    /// Gives socket `s` a command without waiting for the chip to take it: for RECV and
    /// SEND, after which the server gives that socket no command before its next poll.
    fn order(&mut self, s: u8, command: u8) {
        self.set(Block::socket(s), sn::CR.into(), command);
    }
}

impl<C: Chip, B: Bus> Sockets for Wiznet<C, B> {
    fn events(&mut self) -> u8 {
        self.get(Block::COMMON, C::SOCKET_EVENTS)
    }

    fn take_events(&mut self, s: u8) -> u8 {
        let ir = self.get(Block::socket(s), sn::IR.into());
        if ir != 0 {
            self.set(Block::socket(s), sn::IR.into(), ir);
        }
        ir
    }

    fn status(&mut self, s: u8) -> u8 {
        self.get(Block::socket(s), sn::SR.into())
    }

    #[inline(never)]
    fn command(&mut self, s: u8, command: u8) {
        self.set(Block::socket(s), sn::CR.into(), command);
        // The chip clears Sn_CR once it took the command: at once, in practice. Bounded, so
        // that a chip gone missing never stops the server.
        let mut tries: u8 = 255;
        while self.get(Block::socket(s), sn::CR.into()) != 0 && tries != 0 {
            tries -= 1;
        }
    }

    fn listen(&mut self, s: u8, port: u16) {
        self.set(Block::socket(s), sn::MR.into(), MODE_TCP);
        self.set16(s, sn::PORT, port);
        self.command(s, command::OPEN);
        self.command(s, command::LISTEN);
    }

    fn peer(&mut self, s: u8) -> [u8; 4] {
        let mut ip = [0; 4];
        C::transfer(&mut self.bus, Block::socket(s), sn::DIPR.into(), &mut ip, false);
        ip
    }

    /// One read, where the datasheets advise reading until two agree: Sn_RX_RSR only grows
    /// while the server takes nothing, and read high byte first a growing count is never
    /// read larger than it is (a byte landing between the two reads gives the old count, or
    /// one too small by whole 256s: the rest is taken at the next poll, which the RECV event
    /// of that byte, set after this socket's events were taken, brings).
    fn received(&mut self, s: u8) -> u16 {
        self.get16(s, sn::RX_RSR)
    }

    fn rx_pointer(&mut self, s: u8) -> u16 {
        self.get16(s, sn::RX_RD)
    }

    fn read(&mut self, s: u8, pointer: u16, buf: &mut [u8]) {
        C::transfer(&mut self.bus, Block::rx(s), pointer, buf, false);
    }

    fn take(&mut self, s: u8, pointer: u16) {
        self.set16(s, sn::RX_RD, pointer);
        self.order(s, command::RECV);
    }

    /// One read, as [`Sockets::received`]: Sn_TX_FSR only grows while the server writes
    /// nothing.
    fn tx_free(&mut self, s: u8) -> u16 {
        self.get16(s, sn::TX_FSR)
    }

    fn tx_pointer(&mut self, s: u8) -> u16 {
        self.get16(s, sn::TX_WR)
    }

    fn write(&mut self, s: u8, pointer: u16, data: &mut [u8]) {
        C::transfer(&mut self.bus, Block::tx(s), pointer, data, true);
    }

    fn send(&mut self, s: u8, pointer: u16) {
        self.set16(s, sn::TX_WR, pointer);
        self.order(s, command::SEND);
    }

    #[cfg(feature = "udp")]
    fn open(&mut self, s: u8, port: u16, udp: bool) {
        // MODE_TCP (1) or MODE_UDP (2).
        const { assert!(MODE_UDP == MODE_TCP + 1) };
        self.set(Block::socket(s), sn::MR.into(), MODE_TCP + u8::from(udp));
        self.set16(s, sn::PORT, port);
        self.command(s, command::OPEN);
        if !udp {
            self.command(s, command::LISTEN);
        }
    }

    /// Sn_DIPR and Sn_DPORT, next to each other on both chips: one transfer.
    #[cfg(feature = "udp")]
    fn set_peer(&mut self, s: u8, peer: &mut [u8]) {
        C::transfer(&mut self.bus, Block::socket(s), sn::DIPR.into(), peer, true);
    }
}

#[cfg(feature = "master")]
impl<C: Chip, B: Bus> super::client::Connect for Wiznet<C, B> {
    fn connect(&mut self, s: u8, local_port: u16, ip: [u8; 4], port: u16) {
        self.set(Block::socket(s), sn::MR.into(), MODE_TCP);
        self.set16(s, sn::PORT, local_port);
        self.command(s, command::OPEN);
        let mut ip = ip;
        C::transfer(&mut self.bus, Block::socket(s), sn::DIPR.into(), &mut ip, true);
        self.set16(s, sn::DPORT, port);
        self.command(s, command::CONNECT);
    }
}

#[cfg(feature = "dhcp")]
impl<C: Chip, B: Bus> super::dhcp::Udp for Wiznet<C, B> {
    fn open_udp(&mut self, s: u8, port: u16) {
        self.set(Block::socket(s), sn::MR.into(), MODE_UDP);
        self.set16(s, sn::PORT, port);
        self.command(s, command::OPEN);
    }

    fn send_to(&mut self, s: u8, ip: [u8; 4], port: u16, pointer: u16) {
        let mut ip = ip;
        C::transfer(&mut self.bus, Block::socket(s), sn::DIPR.into(), &mut ip, true);
        self.set16(s, sn::DPORT, port);
        self.set16(s, sn::TX_WR, pointer);
        self.command(s, command::SEND);
    }

    fn take_now(&mut self, s: u8, pointer: u16) {
        self.set16(s, sn::RX_RD, pointer);
        self.command(s, command::RECV);
    }

    fn set_addresses(&mut self, addresses: &mut [u8; super::network::ADDRESSES]) {
        C::transfer(&mut self.bus, Block::COMMON, GAR, addresses, true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bus that records what was sent, frame by frame, and answers from a script.
    #[derive(Default)]
    struct Log {
        frames: Vec<Vec<u8>>,
        open: bool,
    }

    impl Bus for Log {
        fn select(&mut self) {
            assert!(!self.open, "select twice");
            self.open = true;
            self.frames.push(Vec::new());
        }
        fn deselect(&mut self) {
            assert!(self.open, "deselect without select");
            self.open = false;
        }
        fn transfer(&mut self, out: u8) -> u8 {
            assert!(self.open, "a byte outside a frame");
            self.frames.last_mut().unwrap().push(out);
            0
        }
    }

    fn addresses(bus: &Log) -> Vec<u16> {
        bus.frames.iter().map(|f| u16::from_be_bytes([f[1], f[2]])).collect()
    }

    #[test]
    fn w5100_writes_one_frame_per_byte() {
        let mut bus = Log::default();
        W5100::transfer(&mut bus, Block::socket(1), sn::PORT.into(), &mut [0x01, 0xF6], true);
        assert_eq!(bus.frames, [vec![0xF0, 0x05, 0x04, 0x01], vec![0xF0, 0x05, 0x05, 0xF6]]);
    }

    #[test]
    fn w5100_receive_buffer_wraps_at_its_2k_end() {
        // Socket 2's buffer is 0x7000-0x77FF; pointer 0xA7FE's place is 0x7FE: two bytes
        // at 0x77FE, then the buffer's start.
        let mut bus = Log::default();
        W5100::transfer(&mut bus, Block::rx(2), 0xA7FE, &mut [0; 4], false);
        assert_eq!(addresses(&bus), [0x77FE, 0x77FF, 0x7000, 0x7001]);
        assert!(bus.frames.iter().all(|f| f[0] == 0x0F));
    }

    #[test]
    fn w5100_transmit_buffer_of_socket_3_ends_at_5fff() {
        let mut bus = Log::default();
        W5100::transfer(&mut bus, Block::tx(3), 0xFFFF, &mut [1, 2], true);
        assert_eq!(addresses(&bus), [0x5FFF, 0x5800]);
    }

    #[test]
    fn w5100_common_registers_are_at_their_address() {
        let mut bus = Log::default();
        W5100::transfer(&mut bus, Block::COMMON, W5100::SOCKET_EVENTS, &mut [0], false);
        assert_eq!(bus.frames, [vec![0x0F, 0x00, 0x15, 0x00]]);
    }

    #[test]
    fn w5500_writes_a_burst_with_the_socket_block() {
        let mut bus = Log::default();
        W5500::transfer(&mut bus, Block::socket(7), sn::TX_WR.into(), &mut [0x12, 0x34], true);
        // Block 4·7 + 1 = 29: control 29 << 3 | write.
        assert_eq!(bus.frames, [vec![0x00, 0x24, 29 << 3 | 0x04, 0x12, 0x34]]);
    }

    #[test]
    fn w5500_reads_the_receive_buffer_at_the_free_running_pointer() {
        let mut bus = Log::default();
        W5500::transfer(&mut bus, Block::rx(0), 0xFFFE, &mut [0; 3], false);
        assert_eq!(bus.frames, [vec![0xFF, 0xFE, 3 << 3, 0, 0, 0]]);
    }
}
