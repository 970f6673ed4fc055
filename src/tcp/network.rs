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
    /// The clients that may connect and only read ([`Network::allow_reading`]).
    #[cfg(feature = "write-protect")]
    pub(crate) allow_reading: &'static [[u8; 4]],
    /// The port of the sockets that speak RTU over TCP ([`Network::rtu_over_tcp`]).
    #[cfg(feature = "rtu-over-tcp")]
    pub(crate) rtu_port: u16,
    /// Bit n: socket n speaks RTU over TCP.
    #[cfg(feature = "rtu-over-tcp")]
    pub(crate) rtu_sockets: u8,
    /// The socket serving Modbus UDP, or [`NO_UDP`].
    #[cfg(feature = "udp")]
    pub(crate) udp: u8,
    /// The DHCP client's settings ([`Network::dhcp`]).
    #[cfg(feature = "dhcp")]
    pub(crate) dhcp: Option<super::dhcp::Settings>,
}

/// [`Network::udp`]'s socket when no socket serves UDP.
#[cfg(feature = "udp")]
pub(crate) const NO_UDP: u8 = 0xFF;

/// The bytes of the chip's addresses.
pub(crate) const ADDRESSES: usize = 18;
/// Where each address starts in [`Network::addresses`].
pub(crate) const GATEWAY: usize = 0;
pub(crate) const SUBNET: usize = 4;
pub(crate) const MAC: usize = 8;
pub(crate) const IP: usize = 14;

/// What a client may do ([`Network::rights`], feature `write-protect`).
#[cfg(feature = "write-protect")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rights {
    /// Not connect.
    None,
    /// Connect and read.
    Read,
    /// Connect, read and write.
    Write,
}

/// True when `peer` is one of `clients` (one loop for both lists).
#[cfg(feature = "write-protect")]
#[inline(never)]
fn listed(clients: &[[u8; 4]], peer: [u8; 4]) -> bool {
    let peer = u32::from_ne_bytes(peer);
    clients.iter().any(|&client| u32::from_ne_bytes(client) == peer)
}

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
            #[cfg(feature = "write-protect")]
            allow_reading: &[],
            #[cfg(feature = "rtu-over-tcp")]
            rtu_port: 0,
            #[cfg(feature = "rtu-over-tcp")]
            rtu_sockets: 0,
            #[cfg(feature = "udp")]
            udp: NO_UDP,
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
        let () = rtu::apart(&self, port);
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
        let () = rtu::serving(&self, n);
        #[cfg(feature = "udp")]
        assert!(self.udp == NO_UDP || n <= self.udp, "the UDP socket is one TCP does not serve");
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
    /// Empty, the default: any client (unless [`Network::allow_reading`] lists some).
    pub const fn allow(self, clients: &'static [[u8; 4]]) -> Network {
        Network { allow: clients, ..self }
    }

    /// Accepts connections from these client addresses too, which may read but not write
    /// (feature `write-protect`): a SCADA or a home-automation server that must never change
    /// a setpoint. Their FC 5, 6, 15 (0x0F), 16 (0x10), 22 (0x16) and 23 (0x17) get
    /// exception 01 (Illegal Function), change nothing and are counted
    /// ([`crate::tcp::TcpCounters::refused_writes`]); a gateway never forwards them. With
    /// either list given, a client on neither is refused; one on both may write. The right
    /// is the client's address's: over Modbus UDP each datagram's sender's.
    ///
    /// ```
    /// use avr_modbus::tcp::Network;
    ///
    /// // The panel at .10 writes, the SCADA at .20 only reads, nobody else connects.
    /// const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177])
    ///     .allow(&[[192, 168, 1, 10]])
    ///     .allow_reading(&[[192, 168, 1, 20]]);
    /// ```
    #[cfg(feature = "write-protect")]
    pub const fn allow_reading(self, clients: &'static [[u8; 4]]) -> Network {
        Network { allow_reading: clients, ..self }
    }

    /// Serves Modbus UDP too (feature `udp`): the same ADUs, one per datagram, on the same
    /// port, each answered to the address and port it came from, on socket `socket`, one
    /// that TCP does not serve (give TCP fewer with [`Network::sockets`] first: `.sockets(3)
    /// .udp(3)`). The allow-list, the unit ids and the counters are TCP's; a datagram from
    /// an address not allowed is dropped unanswered. A socket the chip lacks (4–7 on the
    /// W5100) serves nothing.
    #[cfg(feature = "udp")]
    pub const fn udp(self, socket: u8) -> Network {
        assert!(socket < Network::MAX_SOCKETS, "a socket is 0-7");
        assert!(socket >= self.sockets, "a socket TCP does not serve: .sockets(n) with n <= the UDP socket first");
        Network { udp: socket, ..self }
    }

    /// The socket serving Modbus UDP ([`Network::udp`]), if any.
    #[cfg(feature = "udp")]
    pub const fn udp_socket(&self) -> Option<u8> {
        if self.udp == NO_UDP {
            None
        } else {
            Some(self.udp)
        }
    }

    /// The port the server listens on (MBAP's).
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
    #[cfg(not(feature = "write-protect"))]
    pub(crate) fn allows(&self, peer: [u8; 4]) -> bool {
        let peer = u32::from_ne_bytes(peer);
        self.allow.is_empty() || self.allow.iter().any(|&client| u32::from_ne_bytes(client) == peer)
    }

    /// True when a client at `peer` may connect (the tests' view of [`Network::rights`]).
    #[cfg(all(test, feature = "write-protect"))]
    pub(crate) fn allows(&self, peer: [u8; 4]) -> bool {
        self.rights(peer) != Rights::None
    }

    /// What a client at `peer` may do (feature `write-protect`): [`Rights::Write`] for every
    /// client when neither list is given, else for those of [`Network::allow`];
    /// [`Rights::Read`] for those of [`Network::allow_reading`] alone; [`Rights::None`] for
    /// the others, which may not connect.
    #[cfg(feature = "write-protect")]
    pub(crate) fn rights(&self, peer: [u8; 4]) -> Rights {
        if (self.allow.is_empty() && self.allow_reading.is_empty()) || listed(self.allow, peer) {
            Rights::Write
        } else if listed(self.allow_reading, peer) {
            Rights::Read
        } else {
            Rights::None
        }
    }

    /// True when a request for `unit` is this device's.
    pub(crate) fn answers(&self, unit: u8) -> bool {
        self.unit == 0 || unit == self.unit || unit == 0 || unit == super::mbap::DEVICE_UNIT
    }
}

/// RTU over TCP's sockets (feature `rtu-over-tcp`): which sockets frame as RTU and the port
/// they listen on. Without the feature every socket is MBAP's, on [`Network::port`].
#[cfg(not(feature = "rtu-over-tcp"))]
mod rtu {
    use super::Network;

    /// No socket speaks RTU: any port is apart from theirs.
    pub(super) const fn apart(_net: &Network, _port: u16) {}

    /// No socket speaks RTU: any count serves them all.
    pub(super) const fn serving(_net: &Network, _n: u8) {}

    impl Network {
        /// Socket `s`'s port.
        #[inline(always)]
        pub(crate) const fn port_of(&self, _s: u8) -> u16 {
            self.port
        }

        /// True when socket `s` frames as RTU over TCP.
        #[inline(always)]
        pub(crate) const fn is_rtu(&self, _s: u8) -> bool {
            false
        }
    }
}

#[cfg(feature = "rtu-over-tcp")]
mod rtu {
    use super::Network;

    /// Stops the build when `port` is the RTU sockets' port: a listening socket cannot tell
    /// a connection's framing before its bytes come.
    pub(super) const fn apart(net: &Network, port: u16) {
        assert!(net.rtu_sockets == 0 || port != net.rtu_port, "MBAP and RTU over TCP need ports of their own");
    }

    /// Stops the build when an RTU socket is past the first `n`: it would never serve.
    pub(super) const fn serving(net: &Network, n: u8) {
        assert!(n >= 8 || net.rtu_sockets >> n == 0, "an RTU over TCP socket is past the serving sockets");
    }

    impl Network {
        /// Serves Modbus RTU over TCP on the sockets whose bits are set in `sockets` (bit n:
        /// socket n; `0b1000`: socket 3), listening on `port`; the others serve MBAP on
        /// [`Network::port`]. RTU over TCP is the serial frame (address, PDU, CRC-16) on the
        /// TCP stream with no MBAP header, as Home Assistant's `rtuovertcp` and
        /// serial-to-Ethernet converters send it. The build stops for port 0, for MBAP's
        /// port, for no socket, and for a socket past [`Network::sockets`]. A socket the
        /// chip does not have (4–7 on the W5100) never serves.
        ///
        /// ```
        /// use avr_modbus::tcp::Network;
        ///
        /// // MBAP on 502 on sockets 0-2, RTU over TCP on 5020 on socket 3.
        /// const NETWORK: Network =
        ///     Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x01], [192, 168, 1, 177]).sockets(4).rtu_over_tcp(5020, 0b1000);
        /// assert_eq!(NETWORK.rtu_port(), Some(5020));
        /// ```
        ///
        /// MBAP's port, no socket, a socket past the serving ones, or a port given to MBAP
        /// after: each stops the build.
        ///
        /// ```compile_fail,E0080
        /// # use avr_modbus::tcp::Network;
        /// const SAME_PORT: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).rtu_over_tcp(502, 0b1000);
        /// ```
        ///
        /// ```compile_fail,E0080
        /// # use avr_modbus::tcp::Network;
        /// const NO_SOCKET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).rtu_over_tcp(5020, 0);
        /// ```
        ///
        /// ```compile_fail,E0080
        /// # use avr_modbus::tcp::Network;
        /// const PAST: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(2).rtu_over_tcp(5020, 0b0100);
        /// ```
        ///
        /// ```compile_fail,E0080
        /// # use avr_modbus::tcp::Network;
        /// const FEWER: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).rtu_over_tcp(5020, 0b1000).sockets(3);
        /// ```
        ///
        /// ```compile_fail,E0080
        /// # use avr_modbus::tcp::Network;
        /// const CLASH: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).rtu_over_tcp(5020, 0b1000).with_port(5020);
        /// ```
        pub const fn rtu_over_tcp(self, port: u16, sockets: u8) -> Network {
            assert!(port != 0, "port 0 is no TCP port");
            assert!(port != self.port, "MBAP and RTU over TCP need ports of their own");
            assert!(sockets != 0, "no socket for RTU over TCP");
            assert!(
                self.sockets >= 8 || sockets >> self.sockets == 0,
                "an RTU over TCP socket is past the serving sockets"
            );
            Network { rtu_port: port, rtu_sockets: sockets, ..self }
        }

        /// The port of RTU over TCP's sockets, if any.
        pub const fn rtu_port(&self) -> Option<u16> {
            if self.rtu_sockets == 0 {
                None
            } else {
                Some(self.rtu_port)
            }
        }

        /// Socket `s`'s port.
        #[inline(always)]
        pub(crate) const fn port_of(&self, s: u8) -> u16 {
            if self.is_rtu(s) {
                self.rtu_port
            } else {
                self.port
            }
        }

        /// True when socket `s` frames as RTU over TCP.
        #[inline(always)]
        pub(crate) const fn is_rtu(&self, s: u8) -> bool {
            self.rtu_sockets & (1 << (s & 7)) != 0
        }
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

    #[cfg(feature = "udp")]
    #[test]
    fn udp_takes_a_socket_tcp_does_not_serve() {
        assert_eq!(NET.udp_socket(), None);
        assert_eq!(NET.sockets(3).udp(3).udp_socket(), Some(3));
        assert_eq!(NET.sockets(2).udp(7).sockets(1).udp_socket(), Some(7));
        let refused = |f: fn() -> Network| std::panic::catch_unwind(f).is_err();
        assert!(refused(|| NET.udp(7)), "every socket serves TCP by default");
        assert!(refused(|| NET.sockets(3).udp(2)));
        assert!(refused(|| NET.sockets(3).udp(8)));
        assert!(refused(|| NET.sockets(3).udp(3).sockets(4)), "TCP given the UDP socket later");
    }

    #[test]
    fn the_allow_list_is_empty_by_default_and_exact_otherwise() {
        assert!(NET.allows([1, 2, 3, 4]));
        let net = NET.allow(&[[10, 0, 0, 9]]);
        assert!(net.allows([10, 0, 0, 9]));
        assert!(!net.allows([10, 0, 0, 8]));
    }

    #[cfg(feature = "write-protect")]
    #[test]
    fn a_client_allowed_to_read_connects_and_does_not_write() {
        assert_eq!(NET.rights([1, 2, 3, 4]), Rights::Write, "no list: anyone writes");
        let net = NET.allow(&[[10, 0, 0, 9]]).allow_reading(&[[10, 0, 0, 7], [10, 0, 0, 9]]);
        assert_eq!(net.rights([10, 0, 0, 9]), Rights::Write, "on both lists");
        assert_eq!(net.rights([10, 0, 0, 7]), Rights::Read);
        assert_eq!(net.rights([10, 0, 0, 8]), Rights::None);
        let readers = NET.allow_reading(&[[10, 0, 0, 7]]);
        assert_eq!(readers.rights([10, 0, 0, 7]), Rights::Read);
        assert_eq!(readers.rights([10, 0, 0, 8]), Rights::None, "a reading list alone refuses the others");
    }

    #[cfg(feature = "rtu-over-tcp")]
    #[test]
    fn rtu_sockets_listen_on_their_own_port() {
        let net = NET.sockets(4).rtu_over_tcp(5020, 0b1010);
        let ports: Vec<u16> = (0..4).map(|s| net.port_of(s)).collect();
        assert_eq!(ports, [502, 5020, 502, 5020]);
        assert_eq!((net.is_rtu(1), net.is_rtu(2)), (true, false));
        assert_eq!((NET.rtu_port(), net.rtu_port()), (None, Some(5020)));
    }
}
