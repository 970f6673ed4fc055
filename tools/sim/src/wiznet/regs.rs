//! The register facts both chips share (W5100 datasheet v1.2.x §3–4, W5500 datasheet v1.0.x
//! §4): socket register offsets, commands, states and interrupt bits.

/// A socket register's offset in its socket's register block.
pub mod sn {
    /// Sn_MR: mode (protocol in bits 3..0).
    pub const MR: u16 = 0x00;
    /// Sn_CR: command; the chip clears it once it has taken the command.
    pub const CR: u16 = 0x01;
    /// Sn_IR: interrupt flags, cleared by writing 1.
    pub const IR: u16 = 0x02;
    /// Sn_SR: status (read only).
    pub const SR: u16 = 0x03;
    /// Sn_PORT: local port, 2 bytes.
    pub const PORT: u16 = 0x04;
    /// Sn_DHAR: the peer's MAC address, 6 bytes.
    pub const DHAR: u16 = 0x06;
    /// Sn_DIPR: the peer's IP address, 4 bytes.
    pub const DIPR: u16 = 0x0C;
    /// Sn_DPORT: the peer's port, 2 bytes.
    pub const DPORT: u16 = 0x10;
    /// Sn_MSSR: maximum segment size, 2 bytes.
    pub const MSSR: u16 = 0x12;
    /// Sn_TTL.
    pub const TTL: u16 = 0x16;
    /// Sn_RXBUF_SIZE (W5500 only): RX buffer size in KB.
    pub const RXBUF_SIZE: u16 = 0x1E;
    /// Sn_TXBUF_SIZE (W5500 only): TX buffer size in KB.
    pub const TXBUF_SIZE: u16 = 0x1F;
    /// Sn_TX_FSR: free bytes in the TX buffer (read only), 2 bytes.
    pub const TX_FSR: u16 = 0x20;
    /// Sn_TX_RD: where the chip sends from (read only), 2 bytes.
    pub const TX_RD: u16 = 0x22;
    /// Sn_TX_WR: where the firmware writes next, 2 bytes.
    pub const TX_WR: u16 = 0x24;
    /// Sn_RX_RSR: received bytes not yet taken with RECV (read only), 2 bytes.
    pub const RX_RSR: u16 = 0x26;
    /// Sn_RX_RD: where the firmware reads next, 2 bytes.
    pub const RX_RD: u16 = 0x28;
    /// Sn_RX_WR (W5500 only, read only): where the chip writes next, 2 bytes.
    pub const RX_WR: u16 = 0x2A;
    /// Sn_IMR (W5500 only): interrupt mask.
    pub const IMR: u16 = 0x2C;
    /// Sn_FRAG (W5500 only), 2 bytes.
    pub const FRAG: u16 = 0x2D;
    /// Sn_KPALVTR (W5500 only): keep-alive timer.
    pub const KPALVTR: u16 = 0x2F;
    /// Bytes of a socket's register block that hold registers.
    pub const BLOCK: usize = 0x30;
}

/// Sn_MR's protocol bits.
pub mod mode {
    /// TCP.
    pub const TCP: u8 = 0x01;
    /// UDP.
    pub const UDP: u8 = 0x02;
    /// IP raw.
    pub const IPRAW: u8 = 0x03;
    /// MAC raw (socket 0 only).
    pub const MACRAW: u8 = 0x04;
}

/// Sn_CR's commands.
pub mod cmd {
    /// Opens the socket in Sn_MR's protocol.
    pub const OPEN: u8 = 0x01;
    /// TCP server: waits for a SYN on Sn_PORT.
    pub const LISTEN: u8 = 0x02;
    /// TCP client: sends a SYN to Sn_DIPR:Sn_DPORT.
    pub const CONNECT: u8 = 0x04;
    /// Sends a FIN.
    pub const DISCON: u8 = 0x08;
    /// Closes at once (an RST to a connected peer).
    pub const CLOSE: u8 = 0x10;
    /// Sends Sn_TX_RD..Sn_TX_WR.
    pub const SEND: u8 = 0x20;
    /// Takes the firmware's Sn_RX_RD: what it read is free again.
    pub const RECV: u8 = 0x40;
}

/// Sn_SR's states.
pub mod state {
    /// Closed.
    pub const CLOSED: u8 = 0x00;
    /// Opened in TCP mode.
    pub const INIT: u8 = 0x13;
    /// Waiting for a SYN.
    pub const LISTEN: u8 = 0x14;
    /// SYN sent (CONNECT).
    pub const SYNSENT: u8 = 0x15;
    /// Connected.
    pub const ESTABLISHED: u8 = 0x17;
    /// The firmware sent its FIN (DISCON); the peer's has not come.
    pub const FIN_WAIT: u8 = 0x18;
    /// Both FINs exchanged.
    pub const TIME_WAIT: u8 = 0x1B;
    /// The peer sent its FIN; the firmware may still send.
    pub const CLOSE_WAIT: u8 = 0x1C;
    /// The peer's FIN came, then the firmware's: waiting for the last ACK.
    pub const LAST_ACK: u8 = 0x1D;
    /// Opened in UDP mode.
    pub const UDP: u8 = 0x22;
    /// Opened in IP raw mode (no network side here).
    pub const IPRAW: u8 = 0x32;
    /// Opened in MAC raw mode (no network side here).
    pub const MACRAW: u8 = 0x42;
}

/// Sn_IR's bits.
pub mod int {
    /// A connection was established.
    pub const CON: u8 = 0x01;
    /// The peer sent a FIN or an RST, or the connection closed.
    pub const DISCON: u8 = 0x02;
    /// Data arrived.
    pub const RECV: u8 = 0x04;
    /// A retransmission ran out (ARP or TCP).
    pub const TIMEOUT: u8 = 0x08;
    /// A SEND completed.
    pub const SEND_OK: u8 = 0x10;
}

/// Common register MR's software reset bit (both chips).
pub const MR_RST: u8 = 0x80;
