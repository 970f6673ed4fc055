//! The server's sockets of RTU over TCP (feature `rtu-over-tcp`): each frame found by its
//! function code (`crate::tcp::rtu`), its CRC checked, then handled and answered as
//! `Server::serve` handles an MBAP request.
//!
//! The frame is read into the buffer with its address at the MBAP unit id's place, so that
//! its PDU is where every [`Handler`] finds an MBAP request's and the address plays the unit
//! id's part ([`Network::only_unit`], the gateway's routes); the reply is the address, the
//! reply PDU written over the request, and the CRC. A frame to address 0 is a broadcast
//! (Serial Line §2.1): done, never answered. As over MBAP, a frame waits in the chip until
//! it is whole, several in one segment are answered in order with one SEND, and a master
//! that does not read keeps its requests.

use super::{mbap, Count, Handler, Server, Sockets, HEADER, SOCKETS};
use crate::link::crc::Crc16;
use crate::tcp::network::Network;
use crate::tcp::rtu::{frame_len, MAX_FRAME, MIN_FRAME};

/// Where a frame's address goes in the buffer: the MBAP unit id's place.
const ADDRESS: usize = HEADER - 1;

impl<const B: usize> Server<B> {
    /// Answers the whole frames socket `s` holds, in order, their replies sent with one
    /// SEND; a bad CRC, or bytes that make no frame, discard everything received (counted).
    /// True when frames are left (no room to answer, or the handler not ready).
    pub(super) fn serve_rtu<S: Sockets, H: Handler>(
        &mut self,
        chip: &mut S,
        handler: &mut H,
        net: &Network,
        s: u8,
    ) -> bool {
        let mut received = chip.received(s);
        let at = usize::from(s) % SOCKETS;
        let rx_start = self.rx[at];
        let mut rx = rx_start;
        let mut free = chip.tx_free(s);
        let tx_start = self.tx[at];
        let mut tx = tx_start;
        let mut left = false;
        let room = B - ADDRESS;
        while received >= MIN_FRAME {
            if H::DEFERS && !handler.ready() {
                // Taken when the handler is ready (`resume`).
                self.waiting |= 1 << s;
                left = true;
                break;
            }
            let len = self.frame_rtu(chip, s, &mut rx, &mut received);
            if len == 0 {
                break;
            }
            let unit = self.buf[ADDRESS];
            if !net.answers(unit) {
                self.bump(Count::OtherUnit);
                rx = rx.wrapping_add(len);
                received -= len;
                continue;
            }
            if usize::from(free) < if H::LONG { mbap::MAX_ADU } else { B } {
                // No room for the longest reply: the master is not reading.
                left = true;
                break;
            }
            // The handler reads a PDU past the buffer from where an MBAP ADU would start.
            let adu_at = rx.wrapping_sub(ADDRESS as u16);
            rx = rx.wrapping_add(len);
            received -= len;
            if H::DEFERS {
                self.changed &= !(1 << s);
                self.first = s + 1;
            }
            let pdu_len = usize::from(len) - 3;
            let Some((reply, exception)) = handler.handle_from(&mut self.buf, pdu_len, chip, s, adu_at) else {
                continue;
            };
            if unit == 0 {
                // A broadcast: done, unanswered.
                continue;
            }
            self.bump(Count::Requests);
            if exception {
                self.bump(Count::Exceptions);
            }
            // The address, still the request's, and the reply PDU; then the CRC.
            let len = if H::LONG { 1 + reply } else { (1 + reply).min(room) };
            let kept = len.min(room);
            let mut crc = Crc16::new().update_slice(&self.buf[ADDRESS..ADDRESS + kept]);
            chip.write(s, tx, &mut self.buf[ADDRESS..ADDRESS + kept]);
            // A long reply's rest, a buffer at a time.
            let mut done = kept;
            while H::LONG && done < len {
                let chunk = &mut self.buf[..(len - done).min(B)];
                handler.more(ADDRESS + done, chunk);
                crc = crc.update_slice(chunk);
                chip.write(s, tx.wrapping_add(done as u16), chunk);
                done += chunk.len();
            }
            let mut tail = crc.to_wire();
            chip.write(s, tx.wrapping_add(len as u16), &mut tail);
            tx = tx.wrapping_add(len as u16 + 2);
            free = free.wrapping_sub(len as u16 + 2);
            self.idle[at] = 0;
        }
        // The replies' SEND first: the requests' bytes are taken after it.
        if tx != tx_start {
            chip.send(s, tx);
            self.sending |= 1 << s;
            self.tx[at] = tx;
        }
        if rx != rx_start {
            chip.take(s, rx);
            self.rx[at] = rx;
        }
        if left && (!H::DEFERS || self.waiting & (1 << s) == 0) {
            self.again |= 1 << s;
        }
        left
    }

    /// The frame at `rx` in socket `s` (`received` bytes there), read into the buffer from
    /// [`ADDRESS`] on (as much as fits): its length, or 0 while it is not whole, and when
    /// it is no frame (a bad CRC, bytes no length fits): then everything received is taken
    /// and dropped (counted), and the stream starts again with the next bytes. A frame
    /// longer than the buffer is read through it for its CRC, then its start again.
    fn frame_rtu<S: Sockets>(&mut self, chip: &mut S, s: u8, rx: &mut u16, received: &mut u16) -> u16 {
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
        // The CRC over the frame; one longer than the buffer read through it, a buffer at a
        // time, then its start again.
        let mut crc = Crc16::new().update_slice(&buf[..usize::from(len).min(n)]);
        let mut done = n as u16;
        while done < len {
            let k = usize::from(len - done).min(n);
            chip.read(s, rx.wrapping_add(done), &mut buf[..k]);
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
