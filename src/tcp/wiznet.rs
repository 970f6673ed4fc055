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
}

/// Socket register offsets, the same on both chips.
pub(crate) mod sn {
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
pub(crate) const MODE_TCP: u8 = 0x01;

/// Sn_CR's commands.
pub(crate) mod command {
    /// Opens the socket in Sn_MR's mode (→ `INIT`).
    pub const OPEN: u8 = 0x01;
    /// Waits for a connection (`INIT` → `LISTEN`).
    pub const LISTEN: u8 = 0x02;
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
pub(crate) mod state {
    /// No connection.
    pub const CLOSED: u8 = 0x00;
    /// Opened, not listening.
    pub const INIT: u8 = 0x13;
    /// Waiting for a connection.
    pub const LISTEN: u8 = 0x14;
    /// Connected.
    pub const ESTABLISHED: u8 = 0x17;
    /// The peer closed its side; this side may still send.
    pub const CLOSE_WAIT: u8 = 0x1C;
}

/// Sn_IR's send-done event.
pub(crate) const SEND_OK: u8 = 0x10;

/// A WIZnet chip: how many sockets it has and how its addresses go over SPI.
pub trait Chip {
    /// Its sockets.
    const SOCKETS: u8;
    /// Reads `buf.len()` bytes at `address` in `block` (the W5500's block select; the
    /// W5100 has one address space, and its `block` is ignored).
    fn read<B: Bus>(bus: &mut B, address: u16, block: u8, buf: &mut [u8]);
    /// Writes `data` at `address` in `block`.
    fn write<B: Bus>(bus: &mut B, address: u16, block: u8, data: &[u8]);
    /// Socket `s`'s register `offset`: address and block.
    fn socket(s: u8, offset: u8) -> (u16, u8);
    /// Reads socket `s`'s receive buffer from `pointer` on.
    fn read_rx<B: Bus>(bus: &mut B, s: u8, pointer: u16, buf: &mut [u8]);
    /// Writes socket `s`'s transmit buffer from `pointer` on.
    fn write_tx<B: Bus>(bus: &mut B, s: u8, pointer: u16, data: &[u8]);
    /// The common register whose bit n says socket n has events (W5100 IR, W5500 SIR).
    const SOCKET_EVENTS: u16;
    /// The mask of that register's socket bits (W5100 IMR, W5500 SIMR), for the INT pin.
    const SOCKET_EVENT_MASK: u16;
    /// Checks that the chip answers as this chip after its reset.
    fn identify<B: Bus>(bus: &mut B) -> bool;
}

/// The W5100: 4 sockets, 2 KB buffers each.
#[derive(Clone, Copy, Debug)]
pub struct W5100;

/// The W5500: 8 sockets, 2 KB buffers each.
#[derive(Clone, Copy, Debug)]
pub struct W5500;

/// A W5100 buffer's size, and the mask of a pointer's place in it.
const W5100_BUFFER: u16 = 0x800;

impl W5100 {
    /// One byte's frame: opcode, address, data; the byte received during the data.
    #[inline(never)]
    fn frame<B: Bus>(bus: &mut B, opcode: u8, address: u16, data: u8) -> u8 {
        bus.select();
        bus.transfer(opcode);
        let [hi, lo] = address.to_be_bytes();
        bus.transfer(hi);
        bus.transfer(lo);
        let got = bus.transfer(data);
        bus.deselect();
        got
    }

    /// The part of a run of `len` bytes from `pointer` in socket `s`'s buffer at `base`
    /// before the buffer's end: its address and length (the rest starts at the buffer's
    /// start).
    fn split(base: u16, s: u8, pointer: u16, len: usize) -> (u16, usize) {
        let start = base + u16::from(s) * W5100_BUFFER;
        let offset = pointer & (W5100_BUFFER - 1);
        (start + offset, len.min(usize::from(W5100_BUFFER - offset)))
    }
}

impl Chip for W5100 {
    const SOCKETS: u8 = 4;
    const SOCKET_EVENTS: u16 = 0x0015;
    const SOCKET_EVENT_MASK: u16 = 0x0016;

    fn read<B: Bus>(bus: &mut B, address: u16, _block: u8, buf: &mut [u8]) {
        for (i, byte) in buf.iter_mut().enumerate() {
            *byte = W5100::frame(bus, 0x0F, address.wrapping_add(i as u16), 0);
        }
    }

    fn write<B: Bus>(bus: &mut B, address: u16, _block: u8, data: &[u8]) {
        for (i, &byte) in data.iter().enumerate() {
            W5100::frame(bus, 0xF0, address.wrapping_add(i as u16), byte);
        }
    }

    fn socket(s: u8, offset: u8) -> (u16, u8) {
        (0x0400 + u16::from(s) * 0x100 + u16::from(offset), 0)
    }

    fn read_rx<B: Bus>(bus: &mut B, s: u8, pointer: u16, buf: &mut [u8]) {
        let (address, first) = W5100::split(0x6000, s, pointer, buf.len());
        let (head, tail) = buf.split_at_mut(first);
        W5100::read(bus, address, 0, head);
        W5100::read(bus, 0x6000 + u16::from(s) * W5100_BUFFER, 0, tail);
    }

    fn write_tx<B: Bus>(bus: &mut B, s: u8, pointer: u16, data: &[u8]) {
        let (address, first) = W5100::split(0x4000, s, pointer, data.len());
        let (head, tail) = data.split_at(first);
        W5100::write(bus, address, 0, head);
        W5100::write(bus, 0x4000 + u16::from(s) * W5100_BUFFER, 0, tail);
    }

    fn identify<B: Bus>(bus: &mut B) -> bool {
        // TMSR (0x1B) holds 0x55 after a reset: 2 KB for each socket.
        let mut tmsr = [0];
        W5100::read(bus, 0x001B, 0, &mut tmsr);
        tmsr[0] == 0x55
    }
}

impl W5500 {
    /// A transfer: the header, then each byte of `buf` sent (written) or replaced by the
    /// byte received (read).
    #[inline(never)]
    fn burst<B: Bus>(bus: &mut B, address: u16, control: u8, buf: &mut [u8], write: bool) {
        bus.select();
        let [hi, lo] = address.to_be_bytes();
        bus.transfer(hi);
        bus.transfer(lo);
        bus.transfer(control);
        for byte in buf.iter_mut() {
            let got = bus.transfer(*byte);
            if !write {
                *byte = got;
            }
        }
        bus.deselect();
    }
}

/// The W5500's control byte's write bit.
const W5500_WRITE: u8 = 1 << 2;

impl Chip for W5500 {
    const SOCKETS: u8 = 8;
    const SOCKET_EVENTS: u16 = 0x0017;
    const SOCKET_EVENT_MASK: u16 = 0x0018;

    fn read<B: Bus>(bus: &mut B, address: u16, block: u8, buf: &mut [u8]) {
        W5500::burst(bus, address, block << 3, buf, false);
    }

    fn write<B: Bus>(bus: &mut B, address: u16, block: u8, data: &[u8]) {
        // The burst sends each byte and, writing, keeps it: a copy would cost a buffer.
        bus.select();
        let [hi, lo] = address.to_be_bytes();
        bus.transfer(hi);
        bus.transfer(lo);
        bus.transfer(block << 3 | W5500_WRITE);
        for &byte in data {
            bus.transfer(byte);
        }
        bus.deselect();
    }

    fn socket(s: u8, offset: u8) -> (u16, u8) {
        (u16::from(offset), 4 * s + 1)
    }

    fn read_rx<B: Bus>(bus: &mut B, s: u8, pointer: u16, buf: &mut [u8]) {
        W5500::read(bus, pointer, 4 * s + 3, buf);
    }

    fn write_tx<B: Bus>(bus: &mut B, s: u8, pointer: u16, data: &[u8]) {
        W5500::write(bus, pointer, 4 * s + 2, data);
    }

    fn identify<B: Bus>(bus: &mut B) -> bool {
        let mut version = [0];
        W5500::read(bus, 0x0039, 0, &mut version);
        version[0] == 0x04
    }
}

/// A WIZnet chip `C` on bus `B`.
pub struct Wiznet<C, B> {
    pub(crate) bus: B,
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
        C::write(&mut self.bus, MR, 0, &[RESET]);
        // The reset clears itself within microseconds; a chip that never clears it is not
        // there (reading all ones), which `identify` then says.
        let mut mode = [RESET];
        for _ in 0..255 {
            C::read(&mut self.bus, MR, 0, &mut mode);
            if mode[0] & RESET == 0 {
                break;
            }
        }
        if !C::identify(&mut self.bus) {
            return false;
        }
        let mut addresses = [0u8; 18];
        addresses[..4].copy_from_slice(&network.gateway);
        addresses[4..8].copy_from_slice(&network.subnet);
        addresses[8..14].copy_from_slice(&network.mac);
        addresses[14..].copy_from_slice(&network.ip);
        C::write(&mut self.bus, GAR, 0, &addresses);
        C::write(&mut self.bus, C::SOCKET_EVENT_MASK, 0, &[0xFF >> (8 - C::SOCKETS)]);
        true
    }

    #[inline(never)]
    fn read_reg(&mut self, s: u8, offset: u8, buf: &mut [u8]) {
        let (address, block) = C::socket(s, offset);
        C::read(&mut self.bus, address, block, buf);
    }

    #[inline(never)]
    fn write_reg(&mut self, s: u8, offset: u8, data: &[u8]) {
        let (address, block) = C::socket(s, offset);
        C::write(&mut self.bus, address, block, data);
    }

    fn reg16(&mut self, s: u8, offset: u8) -> u16 {
        let mut bytes = [0; 2];
        self.read_reg(s, offset, &mut bytes);
        u16::from_be_bytes(bytes)
    }

    /// A 16-bit register the chip changes as data moves: read until two reads agree (its
    /// two bytes are read apart, and a byte may land in between), at most four times.
    #[inline(never)]
    fn stable16(&mut self, s: u8, offset: u8) -> u16 {
        let mut last = self.reg16(s, offset);
        for _ in 0..3 {
            let again = self.reg16(s, offset);
            if again == last {
                break;
            }
            last = again;
        }
        last
    }
}

impl<C: Chip, B: Bus> Sockets for Wiznet<C, B> {
    fn events(&mut self) -> u8 {
        let mut bits = [0];
        C::read(&mut self.bus, C::SOCKET_EVENTS, 0, &mut bits);
        bits[0]
    }

    fn take_events(&mut self, s: u8) -> u8 {
        let mut ir = [0];
        self.read_reg(s, sn::IR, &mut ir);
        if ir[0] != 0 {
            self.write_reg(s, sn::IR, &ir);
        }
        ir[0]
    }

    fn status(&mut self, s: u8) -> u8 {
        let mut sr = [0];
        self.read_reg(s, sn::SR, &mut sr);
        sr[0]
    }

    fn command(&mut self, s: u8, command: u8) {
        self.write_reg(s, sn::CR, &[command]);
        // The chip clears Sn_CR once it took the command: at once, in practice. Bounded, so
        // that a chip gone missing never stops the server.
        let mut cr = [command];
        for _ in 0..255 {
            self.read_reg(s, sn::CR, &mut cr);
            if cr[0] == 0 {
                break;
            }
        }
    }

    fn listen(&mut self, s: u8, port: u16) {
        self.write_reg(s, sn::MR, &[MODE_TCP]);
        self.write_reg(s, sn::PORT, &port.to_be_bytes());
        self.command(s, command::OPEN);
        self.command(s, command::LISTEN);
    }

    fn peer(&mut self, s: u8) -> [u8; 4] {
        let mut ip = [0; 4];
        self.read_reg(s, sn::DIPR, &mut ip);
        ip
    }

    fn received(&mut self, s: u8) -> u16 {
        self.stable16(s, sn::RX_RSR)
    }

    fn rx_pointer(&mut self, s: u8) -> u16 {
        self.reg16(s, sn::RX_RD)
    }

    fn read(&mut self, s: u8, pointer: u16, buf: &mut [u8]) {
        C::read_rx(&mut self.bus, s, pointer, buf);
    }

    fn take(&mut self, s: u8, pointer: u16) {
        self.write_reg(s, sn::RX_RD, &pointer.to_be_bytes());
        self.command(s, command::RECV);
    }

    fn tx_free(&mut self, s: u8) -> u16 {
        self.stable16(s, sn::TX_FSR)
    }

    fn tx_pointer(&mut self, s: u8) -> u16 {
        self.reg16(s, sn::TX_WR)
    }

    fn write(&mut self, s: u8, pointer: u16, data: &[u8]) {
        C::write_tx(&mut self.bus, s, pointer, data);
    }

    fn send(&mut self, s: u8, pointer: u16) {
        self.write_reg(s, sn::TX_WR, &pointer.to_be_bytes());
        self.command(s, command::SEND);
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

    #[test]
    fn w5100_writes_one_frame_per_byte() {
        let mut bus = Log::default();
        let (address, block) = W5100::socket(1, sn::PORT);
        W5100::write(&mut bus, address, block, &[0x01, 0xF6]);
        assert_eq!(bus.frames, [vec![0xF0, 0x05, 0x04, 0x01], vec![0xF0, 0x05, 0x05, 0xF6]]);
    }

    #[test]
    fn w5100_receive_buffer_wraps_at_its_2k_end() {
        // Socket 2's buffer is 0x7000-0x77FF; pointer 0xA7FE's place is 0x7FE: two bytes
        // at 0x77FE, then the buffer's start.
        let mut bus = Log::default();
        let mut buf = [0; 4];
        W5100::read_rx(&mut bus, 2, 0xA7FE, &mut buf);
        let addresses: Vec<u16> = bus.frames.iter().map(|f| u16::from_be_bytes([f[1], f[2]])).collect();
        assert_eq!(addresses, [0x77FE, 0x77FF, 0x7000, 0x7001]);
        assert!(bus.frames.iter().all(|f| f[0] == 0x0F));
    }

    #[test]
    fn w5100_transmit_buffer_of_socket_3_ends_at_5fff() {
        let mut bus = Log::default();
        W5100::write_tx(&mut bus, 3, 0xFFFF, &[1, 2]);
        let addresses: Vec<u16> = bus.frames.iter().map(|f| u16::from_be_bytes([f[1], f[2]])).collect();
        assert_eq!(addresses, [0x5FFF, 0x5800]);
    }

    #[test]
    fn w5500_writes_a_burst_with_the_socket_block() {
        let mut bus = Log::default();
        let (address, block) = W5500::socket(7, sn::TX_WR);
        W5500::write(&mut bus, address, block, &[0x12, 0x34]);
        // Block 4·7 + 1 = 29: control 29 << 3 | write.
        assert_eq!(bus.frames, [vec![0x00, 0x24, 29 << 3 | 0x04, 0x12, 0x34]]);
    }

    #[test]
    fn w5500_reads_the_receive_buffer_at_the_free_running_pointer() {
        let mut bus = Log::default();
        let mut buf = [0; 3];
        W5500::read_rx(&mut bus, 0, 0xFFFE, &mut buf);
        assert_eq!(bus.frames, [vec![0xFF, 0xFE, 3 << 3, 0, 0, 0]]);
    }
}
