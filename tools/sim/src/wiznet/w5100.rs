//! The W5100's SPI frames and address map (W5100 datasheet §3, §6.3.2).
//!
//! Every frame is 4 bytes with the chip selected: `0xF0 addr_hi addr_lo data` writes,
//! `0x0F addr_hi addr_lo 0x00` reads (the data comes back on the 4th byte). Frames follow
//! each other while the chip stays selected; a frame with another opcode is ignored. The chip
//! answers 0x00, 0x01, 0x02 on the first three bytes and 0x03 on a write's 4th.
//!
//! Common registers 0x0000–0x002F, socket n's registers at 0x0400 + n·0x100, TX memory
//! 0x4000–0x5FFF, RX memory 0x6000–0x7FFF (physical: socket n's buffer starts where the
//! buffers before it end, 2 KB each by default).

use super::regs::{sn, MR_RST};
use super::W5x00;

/// The write opcode.
pub const WRITE: u8 = 0xF0;
/// The read opcode.
pub const READ: u8 = 0x0F;

/// IR: the chip's own bits (CONFLICT, UNREACH, PPPoE), cleared by writing 1; bits 3..0 are
/// the sockets'.
const IR: u16 = 0x15;
/// RTR, 2 bytes (index in the common registers).
pub(super) const RTR: usize = 0x17;
/// RCR.
pub(super) const RCR: usize = 0x19;
/// RMSR: RX memory per socket, 2 bits each (1, 2, 4, 8 KB).
const RMSR: u16 = 0x1A;
/// TMSR: TX memory per socket.
const TMSR: u16 = 0x1B;
/// The last common register.
const COMMON_END: u16 = 0x2F;

const SOCKETS: u16 = 0x0400;
const TX_MEMORY: u16 = 0x4000;
const RX_MEMORY: u16 = 0x6000;
const MEMORY_END: u16 = 0x7FFF;

/// The common registers' values after reset, but zeros.
pub(super) const COMMON_DEFAULTS: &[(u16, u8)] =
    &[(0x17, 0x07), (0x18, 0xD0), (0x19, 0x08), (RMSR, 0x55), (TMSR, 0x55), (0x28, 0x28)];

/// A socket's register values after reset, but zeros.
pub(super) const SOCKET_DEFAULTS: &[(u16, u8)] = &[(sn::TTL, 0x80)];

/// The sockets' TX and RX buffer sizes TMSR and RMSR give.
pub(super) fn buffer_sizes(common: &[u8; 0x40]) -> (Vec<usize>, Vec<usize>) {
    let sizes = |reg: u8| (0..4).map(|n| 1024 << ((reg >> (2 * n)) & 3)).collect();
    (sizes(common[usize::from(TMSR)]), sizes(common[usize::from(RMSR)]))
}

impl W5x00 {
    /// One byte of a W5100 frame.
    pub(super) fn w5100_byte(&mut self, mosi: u8) -> u8 {
        let index = self.frame.index % 4;
        self.frame.index = self.frame.index.wrapping_add(1);
        match index {
            0 => {
                self.frame.control = mosi;
                0x00
            }
            1 => {
                self.frame.addr = u16::from(mosi) << 8;
                0x01
            }
            2 => {
                self.frame.addr |= u16::from(mosi);
                0x02
            }
            _ => match self.frame.control {
                READ => self.w5100_read(self.frame.addr),
                WRITE => {
                    self.w5100_write(self.frame.addr, mosi);
                    0x03
                }
                _ => 0x03,
            },
        }
    }

    /// The byte at `addr` of the W5100's address space.
    pub(super) fn w5100_read(&self, addr: u16) -> u8 {
        match addr {
            IR => self.common[usize::from(IR)] & 0xE0 | self.socket_interrupts(),
            0..=COMMON_END => self.common[usize::from(addr)],
            SOCKETS..=0x07FF if addr & 0xFF < 0x2A => self.socket_read(usize::from((addr - SOCKETS) >> 8), addr & 0xFF),
            TX_MEMORY..=0x5FFF => self.tx_mem[usize::from(addr - TX_MEMORY)],
            RX_MEMORY..=MEMORY_END => self.rx_mem[usize::from(addr - RX_MEMORY)],
            _ => 0,
        }
    }

    /// Writes `v` at `addr` of the W5100's address space.
    pub(super) fn w5100_write(&mut self, addr: u16, v: u8) {
        match addr {
            0 if v & MR_RST != 0 => self.reset(),
            IR => self.common[usize::from(IR)] &= !(v & 0xE0),
            RMSR | TMSR => {
                self.common[usize::from(addr)] = v;
                self.relayout();
            }
            0..=COMMON_END => self.common[usize::from(addr)] = v,
            SOCKETS..=0x07FF if addr & 0xFF < 0x2A => {
                self.socket_write(usize::from((addr - SOCKETS) >> 8), addr & 0xFF, v)
            }
            TX_MEMORY..=0x5FFF => self.tx_mem[usize::from(addr - TX_MEMORY)] = v,
            RX_MEMORY..=MEMORY_END => self.rx_mem[usize::from(addr - RX_MEMORY)] = v,
            _ => {}
        }
    }
}

/// Socket `n`'s register `off` as a W5100 address.
pub const fn socket_addr(n: u8, off: u16) -> u16 {
    SOCKETS + (n as u16) * 0x100 + off
}
