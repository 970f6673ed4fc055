//! The gateway's answers to RTU over TCP's sockets (feature `rtu-over-tcp`): the line's
//! answer goes back as an RTU frame (the request's address, the answer's PDU as the slave
//! sent it, a CRC), and so does exception 0B. The requests need nothing of their own: the
//! server puts a frame's address where an MBAP request's unit id is, so the gateway's
//! checks, routes and own unit apply as they are, and a frame goes to the line as the
//! master builds it (its address routed, its CRC the master's).

use super::{Answered, RtuSide, Server, Sockets};
use crate::link::crc::Crc16;

/// Sends the answer to socket `s` as an RTU frame: `head` is the request's address, then
/// the function code with its top bit and the exception code; only the address is sent
/// when `head[2]` is 0, and the answer's PDU of `pdu` bytes is read from the line after
/// it; then the CRC.
pub(super) fn answer<S: Sockets, L: RtuSide, const B: usize>(
    server: &mut Server<B>,
    chip: &mut S,
    line: &mut L,
    s: u8,
    head: [u8; 3],
    pdu: usize,
) -> Answered {
    let exception = head[2] != 0;
    let len = 1 + pdu;
    server.answer(chip, s, len as u16 + 2, exception, |chip, at, buf| {
        let Some(first) = buf.get_mut(..head.len()) else { return };
        first.copy_from_slice(&head);
        let lead = if exception { 3 } else { 1 };
        let mut crc = Crc16::new().update_slice(&first[..lead]);
        chip.write(s, at, &mut first[..lead]);
        // The answer's bytes, a buffer at a time.
        let mut done = 0;
        while lead + done < len {
            let n = (len - lead - done).min(buf.len());
            let chunk = &mut buf[..n];
            line.reply(done, chunk);
            crc = crc.update_slice(chunk);
            chip.write(s, at.wrapping_add((lead + done) as u16), chunk);
            done += n;
        }
        let mut tail = crc.to_wire();
        chip.write(s, at.wrapping_add(len as u16), &mut tail);
    })
}
