//! Modbus TCP messages read out of the bytes a TCP bridge carries (Messaging on TCP/IP
//! Implementation Guide v1.0b §3.1.3, the MBAP header), for printing: each request and each
//! answer with its connection, transaction id, unit id and function code.
//!
//! TCP is a byte stream: each connection's bytes are kept, per direction, until a whole ADU
//! (6 + the header's length) is there; several ADUs in one read are several messages. Bytes
//! that cannot be a Modbus TCP header (protocol id not 0, length outside 2..=254) are printed
//! as such and dropped, as a server drops them.

use std::net::SocketAddr;

/// The longest ADU: a 7-byte header and a 253-byte PDU.
const MAX_ADU: usize = 260;

/// One connection's bytes not yet a whole ADU: (client, chip socket, [to the chip, from it]).
struct Conn {
    peer: SocketAddr,
    socket: usize,
    pending: [Vec<u8>; 2],
}

/// Every connection's unfinished ADUs.
#[derive(Default)]
pub struct Streams {
    conns: Vec<Conn>,
}

impl Streams {
    /// Bytes that went `to_chip` (a request's way) or back on `peer`'s connection to socket
    /// `socket`: a line for each whole ADU they finish (and for bytes that are none).
    pub fn feed(&mut self, peer: SocketAddr, socket: usize, to_chip: bool, bytes: &[u8]) -> Vec<String> {
        let at = match self.conns.iter().position(|c| c.peer == peer && c.socket == socket) {
            Some(at) => at,
            None => {
                self.conns.push(Conn { peer, socket, pending: [Vec::new(), Vec::new()] });
                self.conns.len() - 1
            }
        };
        let who = connection(peer, socket);
        let pending = &mut self.conns[at].pending[usize::from(!to_chip)];
        pending.extend_from_slice(bytes);
        let mut lines = Vec::new();
        while pending.len() >= 7 {
            let length = usize::from(u16::from_be_bytes([pending[4], pending[5]]));
            if pending[2..4] != [0, 0] || !(2..=254).contains(&length) {
                lines.push(format!(
                    "{who} {}: {} bytes that are no Modbus TCP header (protocol id {:02X}{:02X}, length {length}): {}",
                    if to_chip { "request" } else { "answer" },
                    pending.len(),
                    pending[2],
                    pending[3],
                    hex(&pending[..pending.len().min(16)])
                ));
                pending.clear();
                break;
            }
            if pending.len() < 6 + length {
                break;
            }
            let adu: Vec<u8> = pending.drain(..6 + length).collect();
            lines.push(format!("{who} {}", describe(&adu, to_chip)));
        }
        lines
    }

    /// `peer`'s connection to `socket` ended: a line for each unfinished ADU it left.
    pub fn closed(&mut self, peer: SocketAddr, socket: usize) -> Vec<String> {
        let Some(at) = self.conns.iter().position(|c| c.peer == peer && c.socket == socket) else {
            return Vec::new();
        };
        let conn = self.conns.remove(at);
        let ways = ["request", "answer"];
        conn.pending
            .iter()
            .zip(ways)
            .filter(|(bytes, _)| !bytes.is_empty())
            .map(|(bytes, way)| {
                format!(
                    "{} {way} cut short: {} bytes of an ADU when the connection ended: {}",
                    connection(peer, socket),
                    bytes.len(),
                    hex(&bytes[..bytes.len().min(MAX_ADU)])
                )
            })
            .collect()
    }
}

/// A line for one datagram of Modbus UDP: one ADU, whole, per datagram (else it is none).
pub fn datagram(peer: SocketAddr, socket: usize, to_chip: bool, bytes: &[u8]) -> String {
    let who = format!("udp {peer} (socket {socket})");
    let whole = bytes.len() >= 8
        && bytes[2..4] == [0, 0]
        && usize::from(u16::from_be_bytes([bytes[4], bytes[5]])) + 6 == bytes.len();
    if whole {
        return format!("{who} {}", describe(bytes, to_chip));
    }
    format!(
        "{who} {}: a datagram of {} bytes that is no Modbus ADU: {}",
        if to_chip { "request" } else { "answer" },
        bytes.len(),
        hex(&bytes[..bytes.len().min(MAX_ADU)])
    )
}

/// `conn 127.0.0.1:40022 (socket 0)`.
fn connection(peer: SocketAddr, socket: usize) -> String {
    format!("conn {peer} (socket {socket})")
}

/// `request tid 0x0001 unit 1 fc 0x02 read discrete inputs: 00 01 …` for a whole ADU.
pub fn describe(adu: &[u8], request: bool) -> String {
    let tid = u16::from_be_bytes([adu[0], adu[1]]);
    let unit = adu[6];
    let way = if request { "request" } else { "answer" };
    let what = match adu.get(7) {
        None => "no function code".to_owned(),
        Some(&fc) if fc & 0x80 != 0 && !request => {
            let code = adu.get(8).copied().unwrap_or(0);
            format!("fc 0x{fc:02X} ({} failed): exception {code:02X} {}", function(fc & 0x7F), exception(code))
        }
        Some(&fc) => format!("fc 0x{fc:02X} {}", function(fc)),
    };
    format!("{way} tid 0x{tid:04X} unit {unit} {what}: {}", hex(adu))
}

/// The function code's name (Application Protocol §6).
fn function(fc: u8) -> &'static str {
    match fc {
        0x01 => "read coils",
        0x02 => "read discrete inputs",
        0x03 => "read holding registers",
        0x04 => "read input registers",
        0x05 => "write single coil",
        0x06 => "write single register",
        0x07 => "read exception status",
        0x08 => "diagnostics",
        0x0B => "get comm event counter",
        0x0F => "write multiple coils",
        0x10 => "write multiple registers",
        0x11 => "report server id",
        0x16 => "mask write register",
        0x17 => "read/write multiple registers",
        0x2B => "encapsulated interface",
        _ => "unknown function",
    }
}

/// The exception code's name (Application Protocol §7).
fn exception(code: u8) -> &'static str {
    match code {
        0x01 => "(illegal function)",
        0x02 => "(illegal data address)",
        0x03 => "(illegal data value)",
        0x04 => "(server device failure)",
        0x06 => "(server busy)",
        0x0A => "(gateway path unavailable)",
        0x0B => "(gateway target device failed to respond)",
        _ => "",
    }
}

/// `01 AB`
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peer() -> SocketAddr {
        "127.0.0.1:40022".parse().unwrap()
    }

    #[test]
    fn a_request_split_over_reads_is_one_line_with_tid_unit_and_function() {
        let mut s = Streams::default();
        // tid 0x0001, protocol 0, length 6, unit 1 | fc 02, start 0, quantity 2
        assert!(s.feed(peer(), 0, true, &[0x00, 0x01, 0x00, 0x00]).is_empty());
        let lines = s.feed(peer(), 0, true, &[0x00, 0x06, 0x01, 0x02, 0x00, 0x00, 0x00, 0x02]);
        assert_eq!(
            lines,
            ["conn 127.0.0.1:40022 (socket 0) request tid 0x0001 unit 1 fc 0x02 read discrete inputs: \
              00 01 00 00 00 06 01 02 00 00 00 02"]
        );
    }

    #[test]
    fn two_answers_in_one_read_are_two_lines_and_an_exception_is_named() {
        let mut s = Streams::default();
        let mut bytes = vec![0x00, 0x07, 0x00, 0x00, 0x00, 0x03, 0x05, 0x83, 0x0B];
        bytes.extend([0x00, 0x08, 0x00, 0x00, 0x00, 0x03, 0xF8, 0x83, 0x0A]);
        let lines = s.feed(peer(), 1, false, &bytes);
        assert_eq!(lines.len(), 2);
        assert!(lines[0].contains(
            "answer tid 0x0007 unit 5 fc 0x83 (read holding registers failed): exception 0B (gateway target device failed to respond)"
        ));
        assert!(
            lines[1].contains("tid 0x0008 unit 248") && lines[1].contains("exception 0A (gateway path unavailable)")
        );
    }

    #[test]
    fn a_bad_header_is_reported_and_dropped_and_a_cut_request_is_reported_at_the_close() {
        let mut s = Streams::default();
        let lines = s.feed(peer(), 0, true, &[0, 1, 0, 1, 0, 6, 1, 3]);
        assert!(lines[0].contains("no Modbus TCP header (protocol id 0001, length 6)"), "{lines:?}");
        assert!(s.feed(peer(), 0, true, &[0, 2, 0, 0, 0, 6, 1, 3, 0]).is_empty());
        let lines = s.closed(peer(), 0);
        assert_eq!(
            lines,
            ["conn 127.0.0.1:40022 (socket 0) request cut short: 9 bytes of an ADU when the connection ended: \
              00 02 00 00 00 06 01 03 00"]
        );
        assert!(s.closed(peer(), 0).is_empty());
    }
}
