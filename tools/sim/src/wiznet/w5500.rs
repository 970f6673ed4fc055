//! The W5500's SPI frames and address map (W5500 datasheet §2.2 and §4).
//!
//! A frame is `addr_hi addr_lo control` and data bytes, the address incrementing after each;
//! control = BSB[4:0] << 3 | RWB << 2 | OM[1:0] (RWB 1: write). In variable-length mode
//! (OM = 00) the frame lasts until the chip select goes high; OM = 01, 10, 11 are fixed
//! frames of 1, 2 and 4 data bytes, after which the next frame starts with the chip still
//! selected. BSB 0: the common registers; socket n: 4n+1 its registers, 4n+2 its TX buffer,
//! 4n+3 its RX buffer, each buffer addressed by the free-running pointer (offset = address
//! mod the buffer's size). The chip's answers during the address and control bytes are not
//! specified; this model answers 0x00.

use super::regs::{sn, MR_RST};
use super::socket::Socket;
use super::W5x00;

/// RWB: the frame writes.
pub const RWB_WRITE: u8 = 0x04;

/// IR: CONFLICT, UNREACH, PPPoE, MP (bits 7..4), cleared by writing 1.
const IR: u16 = 0x15;
/// SIR: socket n's Sn_IR ≠ 0 in bit n (read only).
const SIR: u16 = 0x17;
/// RTR, 2 bytes.
pub(super) const RTR: usize = 0x19;
/// RCR.
pub(super) const RCR: usize = 0x1B;
/// PHYCFGR: bits 6..3 configurable; RST reads 1; 100 Mbit/s full duplex, bit 0 the link
/// ([`W5x00::set_link`]).
const PHYCFGR: u16 = 0x2E;
/// VERSIONR: 0x04.
const VERSIONR: u16 = 0x39;
/// The last common register.
const COMMON_END: u16 = 0x3F;

/// The common registers' values after reset, but zeros (PHYCFGR: its configurable bits).
pub(super) const COMMON_DEFAULTS: &[(u16, u8)] =
    &[(0x19, 0x07), (0x1A, 0xD0), (0x1B, 0x08), (0x1C, 0x28), (PHYCFGR, 0x38)];

/// A socket's register values after reset, but zeros.
pub(super) const SOCKET_DEFAULTS: &[(u16, u8)] = &[
    (0x06, 0xFF),
    (0x07, 0xFF),
    (0x08, 0xFF),
    (0x09, 0xFF),
    (0x0A, 0xFF),
    (0x0B, 0xFF),
    (sn::TTL, 0x80),
    (sn::RXBUF_SIZE, 2),
    (sn::TXBUF_SIZE, 2),
    (sn::IMR, 0xFF),
    (sn::FRAG, 0x40),
];

/// The sockets' TX and RX buffer sizes from Sn_TXBUF_SIZE and Sn_RXBUF_SIZE (KB: 0, 1, 2,
/// 4, 8 or 16; another value counts as 0).
pub(super) fn buffer_sizes(sockets: &[Socket]) -> (Vec<usize>, Vec<usize>) {
    let size = |kb: u8| if matches!(kb, 0 | 1 | 2 | 4 | 8 | 16) { usize::from(kb) * 1024 } else { 0 };
    (
        sockets.iter().map(|s| size(s.reg(sn::TXBUF_SIZE))).collect(),
        sockets.iter().map(|s| size(s.reg(sn::RXBUF_SIZE))).collect(),
    )
}

/// The control byte for block `bsb`, writing or not, in variable-length mode.
pub const fn control(bsb: u8, write: bool) -> u8 {
    bsb << 3 | if write { RWB_WRITE } else { 0 }
}

/// What a block select names.
enum Block {
    Common,
    Registers(usize),
    Tx(usize),
    Rx(usize),
    Reserved,
}

fn block(bsb: u8) -> Block {
    match (bsb, bsb.wrapping_sub(1) / 4) {
        (0, _) => Block::Common,
        (_, n) if n >= 8 => Block::Reserved,
        (_, n) => match (bsb - 1) % 4 {
            0 => Block::Registers(usize::from(n)),
            1 => Block::Tx(usize::from(n)),
            2 => Block::Rx(usize::from(n)),
            _ => Block::Reserved,
        },
    }
}

impl W5x00 {
    /// One byte of a W5500 frame.
    pub(super) fn w5500_byte(&mut self, mosi: u8) -> u8 {
        let index = self.frame.index;
        self.frame.index = self.frame.index.wrapping_add(1);
        match index {
            0 => {
                self.frame.addr = u16::from(mosi) << 8;
                0x00
            }
            1 => {
                self.frame.addr |= u16::from(mosi);
                0x00
            }
            2 => {
                self.frame.control = mosi;
                0x00
            }
            _ => {
                let control = self.frame.control;
                let addr = self.frame.addr;
                self.frame.addr = addr.wrapping_add(1);
                let answer = if control & RWB_WRITE != 0 {
                    self.w5500_write(control >> 3, addr, mosi);
                    0x00
                } else {
                    self.w5500_read(control >> 3, addr)
                };
                let fixed = match control & 3 {
                    0 => None,
                    om => Some(1u32 << (om - 1)),
                };
                if fixed == Some(index - 2) {
                    self.frame.index = 0;
                }
                answer
            }
        }
    }

    /// The byte at `addr` of block `bsb`.
    pub(super) fn w5500_read(&mut self, bsb: u8, addr: u16) -> u8 {
        match block(bsb) {
            Block::Common => match addr {
                IR => self.common[usize::from(IR)] & 0xF0,
                SIR => self.socket_interrupts(),
                PHYCFGR => 0x80 | self.common[usize::from(PHYCFGR)] & 0x78 | 0x06 | u8::from(self.link),
                VERSIONR => 0x04,
                0..=COMMON_END => self.common[usize::from(addr)],
                _ => 0,
            },
            Block::Registers(n) if addr < sn::BLOCK as u16 => self.socket_read(n, addr),
            Block::Tx(n) => buffer_byte(self.tx_buffer(n), addr).map_or(0, |b| *b),
            Block::Rx(n) => buffer_byte(self.rx_buffer(n), addr).map_or(0, |b| *b),
            _ => 0,
        }
    }

    /// Writes `v` at `addr` of block `bsb`.
    pub(super) fn w5500_write(&mut self, bsb: u8, addr: u16, v: u8) {
        match block(bsb) {
            Block::Common => match addr {
                0 if v & MR_RST != 0 => self.reset(),
                IR => self.common[usize::from(IR)] &= !(v & 0xF0),
                SIR | VERSIONR => {}
                PHYCFGR => self.common[usize::from(PHYCFGR)] = v & 0x78,
                0..=COMMON_END => self.common[usize::from(addr)] = v,
                _ => {}
            },
            Block::Registers(n) if addr < sn::BLOCK as u16 => {
                self.socket_write(n, addr, v);
                if matches!(addr, sn::RXBUF_SIZE | sn::TXBUF_SIZE) {
                    self.relayout();
                }
            }
            Block::Tx(n) => {
                if let Some(b) = buffer_byte(self.tx_buffer(n), addr) {
                    *b = v;
                }
            }
            Block::Rx(n) => {
                if let Some(b) = buffer_byte(self.rx_buffer(n), addr) {
                    *b = v;
                }
            }
            _ => {}
        }
    }
}

/// The byte a buffer block's address `addr` names (none in a buffer of size 0).
fn buffer_byte(buf: &mut [u8], addr: u16) -> Option<&mut u8> {
    let len = buf.len();
    buf.get_mut(usize::from(addr) & len.wrapping_sub(1))
}
