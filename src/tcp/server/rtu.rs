//! How the server finds a request on a socket of RTU over TCP (feature `rtu-over-tcp`): the
//! frame's length from its function code (`crate::tcp::rtu`), then its CRC.
//!
//! The frame is read into the buffer with its address at the MBAP unit id's place, so that
//! its PDU is where every [`super::Handler`] finds an MBAP request's and the address plays
//! the unit id's part ([`Network::only_unit`](crate::tcp::Network::only_unit), the gateway's
//! routes). `Server::serve` does the rest as for MBAP: a frame waits in the chip until it is
//! whole, several in one segment are answered in order with one SEND, a master that does not
//! read keeps its requests; the reply is the address, the reply PDU and the CRC, and a frame
//! to address 0, a broadcast (Serial Line §2.1), is done and never answered.

use super::{Count, Server, Sockets, HEADER};
use crate::link::crc::Crc16;
pub(super) use crate::tcp::rtu::MIN_FRAME;
use crate::tcp::rtu::{frame_len, MAX_FRAME};

/// Where a frame's address goes in the buffer: the MBAP unit id's place.
const ADDRESS: usize = HEADER - 1;

impl<const B: usize> Server<B> {
    /// The frame at `rx` in socket `s` (`received` bytes there), read into the buffer from
    /// [`ADDRESS`] on (as much as fits): its length, or 0 while it is not whole, and when
    /// it is no frame (a bad CRC, bytes no length fits): then everything received is taken
    /// and dropped (counted), and the stream starts again with the next bytes. A frame
    /// longer than the buffer is read through it for its CRC, then its start again.
    pub(super) fn frame_rtu<S: Sockets>(&mut self, chip: &mut S, s: u8, rx: &mut u16, received: &mut u16) -> u16 {
        // What is there, as much as fits: the frame's start, and usually all of it.
        let buf = &mut self.buf[ADDRESS..];
        let n = usize::from(*received).min(buf.len());
        chip.read(s, *rx, &mut buf[..n]);
        let len = match frame_len(&buf[..n], *received) {
            // Its byte count is on its way.
            None if n == usize::from(*received) => return 0,
            Some(len) if (MIN_FRAME..=MAX_FRAME).contains(&len) => len,
            _ => return self.discard(rx, received),
        };
        if *received < len {
            // The rest is on its way.
            return 0;
        }
        // The CRC over the frame, a buffer at a time: one longer than the buffer is read
        // through it, then its start again.
        let mut crc = Crc16::new();
        let mut done = 0;
        while done < len {
            let k = usize::from(len - done).min(n);
            if done != 0 {
                chip.read(s, rx.wrapping_add(done), &mut buf[..k]);
            }
            crc = crc.update_slice(&buf[..k]);
            done += k as u16;
        }
        if usize::from(len) > n {
            chip.read(s, *rx, &mut buf[..n]);
        }
        if !crc.is_residue_ok() {
            return self.discard(rx, received);
        }
        len
    }

    /// Everything received is dropped, counted.
    fn discard(&mut self, rx: &mut u16, received: &mut u16) -> u16 {
        self.bump(Count::BadFrame);
        *rx = rx.wrapping_add(*received);
        *received = 0;
        0
    }
}

#[cfg(test)]
mod tests;
