//! The TCP server's settings, Implementation Guide v1.0b §4.1 (port 502), §4.2 (connection
//! management, access control) and §4.4.1.2 (unit ids): the shield's addresses, the port,
//! which unit ids are answered, how many sockets serve, when an idle connection is closed,
//! and who may connect. `const fn` throughout: a firmware's settings are a constant.

/// The TCP server's settings: build them with [`Network::new`] and the methods after it.
///
/// ```
/// use avr_modbus::tcp::Network;
///
/// const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177])
///     .subnet([255, 255, 255, 0])
///     .gateway([192, 168, 1, 1])
///     .allow(&[[192, 168, 1, 10], [192, 168, 1, 11]]);
/// assert_eq!(NETWORK.port(), 502);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Network {
    /// Gateway, subnet mask, MAC and IP address, in the chips' register order (GAR, SUBR,
    /// SHAR, SIPR): written to the chip as they are.
    pub(crate) addresses: [u8; ADDRESSES],
    pub(crate) port: u16,
    pub(crate) unit: u8,
    pub(crate) sockets: u8,
    pub(crate) idle_timeout_s: u8,
    pub(crate) evict_after_s: u8,
    pub(crate) allow: &'static [[u8; 4]],
    /// The DHCP client's settings ([`Network::dhcp`]).
    #[cfg(feature = "dhcp")]
    pub(crate) dhcp: Option<super::dhcp::Settings>,
}

/// The bytes of the chip's addresses.
pub(crate) const ADDRESSES: usize = 18;
/// Where each address starts in [`Network::addresses`].
pub(crate) const GATEWAY: usize = 0;
pub(crate) const SUBNET: usize = 4;
pub(crate) const MAC: usize = 8;
pub(crate) const IP: usize = 14;

/// `bytes` copied into `addresses` from `at` on.
const fn put<const N: usize>(mut addresses: [u8; ADDRESSES], at: usize, bytes: [u8; N]) -> [u8; ADDRESSES] {
    let mut i = 0;
    while i < N {
        addresses[at + i] = bytes[i];
        i += 1;
    }
    addresses
}

/// `N` bytes of `addresses` from `at` on.
const fn get<const N: usize>(addresses: &[u8; ADDRESSES], at: usize) -> [u8; N] {
    let mut bytes = [0; N];
    let mut i = 0;
    while i < N {
        bytes[i] = addresses[at + i];
        i += 1;
    }
    bytes
}

impl Network {
    /// The most sockets a chip has (the W5500's 8).
    pub const MAX_SOCKETS: u8 = 8;

    /// The shield's MAC and IP address, on a /24 network with no gateway; port 502, every
    /// unit id answered, every socket of the chip serving, idle connections closed after
    /// 60 s (or after 10 s when every socket holds one), any client allowed.
    pub const fn new(mac: [u8; 6], ip: [u8; 4]) -> Network {
        let addresses = put([0; ADDRESSES], SUBNET, [255, 255, 255, 0]);
        Network {
            addresses: put(put(addresses, MAC, mac), IP, ip),
            port: 502,
            unit: 0,
            sockets: Network::MAX_SOCKETS,
            idle_timeout_s: 60,
            evict_after_s: 10,
            allow: &[],
            #[cfg(feature = "dhcp")]
            dhcp: None,
        }
    }

    /// The subnet mask.
    pub const fn subnet(self, subnet: [u8; 4]) -> Network {
        Network { addresses: put(self.addresses, SUBNET, subnet), ..self }
    }

    /// The default gateway (router).
    pub const fn gateway(self, gateway: [u8; 4]) -> Network {
        Network { addresses: put(self.addresses, GATEWAY, gateway), ..self }
    }

    /// Listens on `port` instead of 502 (a port of 0 stops the build).
    pub const fn with_port(self, port: u16) -> Network {
        assert!(port != 0, "port 0 is no TCP port");
        Network { port, ..self }
    }

    /// Answers only unit id `unit` (1–247) besides 0xFF and 0, which always address the
    /// device itself (§4.4.1.2); requests for other units are dropped and counted. By
    /// default every unit id is answered, as most Modbus TCP devices do.
    pub const fn only_unit(self, unit: u8) -> Network {
        assert!(unit >= 1 && unit <= 247, "a unit id is 1-247 (0 and 0xFF are the device itself)");
        Network { unit, ..self }
    }

    /// Serves on the chip's first `n` sockets (1 to the chip's count: 4 on the W5100, 8 on
    /// the W5500), leaving the others to the application. Default: every socket (with
    /// feature `dhcp`'s [`Network::dhcp`], every socket below the client's).
    pub const fn sockets(self, n: u8) -> Network {
        assert!(n >= 1 && n <= Network::MAX_SOCKETS, "1-8 sockets");
        #[cfg(feature = "dhcp")]
        if let Some(settings) = self.dhcp {
            assert!(n <= settings.socket, "the server's sockets are those below the DHCP socket");
        }
        Network { sockets: n, ..self }
    }

    /// Closes a connection after `seconds` (at most 255) without a request (0: never), so
    /// that a master that vanished without closing (the chips have no keep-alive of their own
    /// that the server could rely on) does not hold a socket for ever. Default 60 s.
    pub const fn idle_timeout(self, seconds: u8) -> Network {
        Network { idle_timeout_s: seconds, ..self }
    }

    /// When every socket holds a connection, the one idle longest is closed once it has
    /// been idle `seconds` (1–255), so that a newcomer finds a socket listening
    /// (§4.2.1).
    /// The chips refuse a connection when no socket listens and cannot tell the server that
    /// one knocked, so this happens whether or not a newcomer waits: keep it longer than your
    /// masters' poll period. Default 10 s.
    pub const fn evict_after(self, seconds: u8) -> Network {
        assert!(seconds >= 1, "at least 1 s: a master polling now and then keeps its connection");
        Network { evict_after_s: seconds, ..self }
    }

    /// Accepts connections only from these client addresses (§4.2.3's access control);
    /// every other is closed at once and counted ([`crate::tcp::TcpCounters::refused`]).
    /// Empty, the default: any client.
    pub const fn allow(self, clients: &'static [[u8; 4]]) -> Network {
        Network { allow: clients, ..self }
    }

    /// The port the server listens on.
    pub const fn port(&self) -> u16 {
        self.port
    }

    /// The IP address.
    pub const fn ip(&self) -> [u8; 4] {
        get(&self.addresses, IP)
    }

    /// The MAC address.
    pub const fn mac(&self) -> [u8; 6] {
        get(&self.addresses, MAC)
    }

    /// The subnet mask.
    pub const fn subnet_mask(&self) -> [u8; 4] {
        get(&self.addresses, SUBNET)
    }

    /// The default gateway.
    pub const fn gateway_address(&self) -> [u8; 4] {
        get(&self.addresses, GATEWAY)
    }

    /// True when a client at `peer` may connect.
    pub(crate) fn allows(&self, peer: [u8; 4]) -> bool {
        let peer = u32::from_ne_bytes(peer);
        self.allow.is_empty() || self.allow.iter().any(|&client| u32::from_ne_bytes(client) == peer)
    }

    /// True when a request for `unit` is this device's.
    pub(crate) fn answers(&self, unit: u8) -> bool {
        self.unit == 0 || unit == self.unit || unit == 0 || unit == super::mbap::DEVICE_UNIT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]);

    #[test]
    fn the_addresses_are_in_the_chips_register_order() {
        let net = NET.gateway([10, 0, 0, 1]).subnet([255, 255, 0, 0]);
        assert_eq!(net.addresses, [10, 0, 0, 1, 255, 255, 0, 0, 2, 0, 0, 0, 0, 1, 10, 0, 0, 2]);
        assert_eq!(
            (net.ip(), net.mac(), net.subnet_mask(), net.gateway_address()),
            ([10, 0, 0, 2], [2, 0, 0, 0, 0, 1], [255, 255, 0, 0], [10, 0, 0, 1])
        );
    }

    #[test]
    fn every_unit_is_answered_by_default() {
        assert!((0..=255).all(|unit| NET.answers(unit)));
    }

    #[test]
    fn only_unit_keeps_0_and_ff() {
        let net = NET.only_unit(17);
        let answered: Vec<u8> = (0..=255).filter(|&u| net.answers(u)).collect();
        assert_eq!(answered, [0, 17, 0xFF]);
    }

    #[test]
    fn the_allow_list_is_empty_by_default_and_exact_otherwise() {
        assert!(NET.allows([1, 2, 3, 4]));
        let net = NET.allow(&[[10, 0, 0, 9]]);
        assert!(net.allows([10, 0, 0, 9]));
        assert!(!net.allows([10, 0, 0, 8]));
    }
}
