//! The peer's end of one TCP connection: what the firmware sent it, how it closed, and how
//! the peer behaves (reads or not, vanished or not).

use std::net::SocketAddrV4;

/// One TCP connection of a socket, seen from the peer: a socket keeps its last one after it
/// closes, until the next connection takes its place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Connection {
    pub(crate) id: u64,
    pub(crate) peer: SocketAddrV4,
    pub(crate) local_port: u16,
    /// Bytes the peer took, not yet collected with `W5x00::take_sent`.
    pub(crate) to_peer: Vec<u8>,
    /// Bytes the peer will still take; `None`: all.
    pub(crate) window: Option<usize>,
    pub(crate) chip_fin: bool,
    pub(crate) chip_rst: bool,
    pub(crate) peer_fin: bool,
    pub(crate) peer_rst: bool,
    pub(crate) vanished: bool,
    pub(crate) closed: bool,
}

impl Connection {
    pub(crate) fn new(id: u64, peer: SocketAddrV4, local_port: u16) -> Connection {
        Connection {
            id,
            peer,
            local_port,
            to_peer: Vec::new(),
            window: None,
            chip_fin: false,
            chip_rst: false,
            peer_fin: false,
            peer_rst: false,
            vanished: false,
            closed: false,
        }
    }

    /// Unique on this chip: a new connection on the same socket has another.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The peer's address and port (Sn_DIPR, Sn_DPORT).
    pub fn peer(&self) -> SocketAddrV4 {
        self.peer
    }

    /// The chip's port (Sn_PORT).
    pub fn local_port(&self) -> u16 {
        self.local_port
    }

    /// Whether the firmware's FIN reached the peer (DISCON, after all the data it sent).
    pub fn fin_from_chip(&self) -> bool {
        self.chip_fin
    }

    /// Whether the chip reset the connection (CLOSE while connected, or a chip reset).
    pub fn reset_by_chip(&self) -> bool {
        self.chip_rst
    }

    /// Whether the peer sent its FIN.
    pub fn fin_from_peer(&self) -> bool {
        self.peer_fin
    }

    /// Whether the peer reset the connection.
    pub fn reset_by_peer(&self) -> bool {
        self.peer_rst
    }

    /// Whether the peer vanished without a word (half-open).
    pub fn vanished(&self) -> bool {
        self.vanished
    }

    /// Whether the chip's socket is done with it (closed, reset or timed out).
    pub fn closed(&self) -> bool {
        self.closed
    }

    /// Bytes the peer took and nobody collected yet.
    pub fn unread(&self) -> &[u8] {
        &self.to_peer
    }

    /// Whether the peer still takes data (not vanished, not reset, not closed by either side's
    /// RST).
    pub(crate) fn alive(&self) -> bool {
        !self.vanished && !self.peer_rst && !self.chip_rst && !self.closed
    }
}
