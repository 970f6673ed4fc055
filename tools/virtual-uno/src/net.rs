//! A simulated board's Ethernet shield on the host's network: its TCP bridge (chip ports on
//! 127.0.0.1, `uno_sim::wiznet::Bridge`), polled from the simulation loop every
//! [`BRIDGE_CYCLES`], and its UDP ports (SIMAVR.md item 12: never block, the host's time is not the chip's).
//! Optionally each Modbus TCP request and answer it carries is printed (`mbap`). The single
//! board (`virtual-uno --tcp`, `--connect`, `--udp`) and a board on the line (`virtual-line
//! --board … tcp=`, `connect=`, `udp=`) share it.

use uno_sim::wiznet::{Bridge, BridgeEvent, Mapping};
use uno_sim::Uno;

use crate::mbap::Streams;

/// The simulated time between two polls of the bridge, at most (250 µs).
pub const BRIDGE_CYCLES: u64 = 4_000;

/// The bridge of one board's shield.
pub struct Net {
    bridge: Bridge,
    /// The messages, when they are printed.
    messages: Option<Streams>,
    /// The cycle of the last poll.
    polled: u64,
    /// The firmware's own connections (`--connect`), server and socket: their requests go
    /// from the chip.
    dialed: Vec<(std::net::SocketAddr, usize)>,
}

impl Net {
    /// Listens on 127.0.0.1 for each mapping; with `messages`, the Modbus TCP messages are
    /// reported too.
    pub fn bind(mappings: &[Mapping], messages: bool) -> Result<Net, String> {
        let bridge = Bridge::bind(mappings).map_err(|e| format!("cannot listen on 127.0.0.1: {e}"))?;
        let (bridge, messages) = match messages {
            true => (bridge.with_traffic(), Some(Streams::default())),
            false => (bridge, None),
        };
        Ok(Net { bridge, messages, polled: 0, dialed: Vec::new() })
    }

    /// Also bridges the firmware's connections to each mapping's chip port, whatever the
    /// address, to 127.0.0.1:`host_port` (`virtual-uno --connect`, `virtual-line --board …
    /// connect=`).
    pub fn with_outgoing(self, mappings: &[Mapping]) -> Net {
        Net { bridge: self.bridge.with_outgoing(mappings), ..self }
    }

    /// Also bridges UDP: datagrams to each mapping's host port go to the chip's UDP socket on
    /// its chip port, and its answers back (`virtual-uno --udp`, `virtual-line --board …
    /// udp=`).
    pub fn with_udp(self, mappings: &[Mapping]) -> Result<Net, String> {
        let bridge = self.bridge.with_udp(mappings).map_err(|e| format!("cannot bind on 127.0.0.1: {e}"))?;
        Ok(Net { bridge, ..self })
    }

    /// Also plays the network's DHCP server, leases of `lease` seconds (`virtual-uno --dhcp`).
    // virtual-line, which shares this file, has no DHCP server for its boards.
    #[allow(dead_code)]
    pub fn with_dhcp(self, lease: u32) -> Net {
        Net { bridge: self.bridge.with_dhcp(lease), ..self }
    }

    /// The cycle the next poll is due.
    pub fn next_poll(&self) -> u64 {
        self.polled + BRIDGE_CYCLES
    }

    /// One round of the bridge at the board's clock: what happened, as lines to print (`tcp:
    /// …` for the connections, `conn … request/answer …` for the messages).
    pub fn poll(&mut self, uno: &mut Uno) -> Vec<String> {
        self.polled = uno.now();
        let Some(chip) = uno.wiznet_mut() else { return Vec::new() };
        let mut lines = Vec::new();
        for event in self.bridge.poll(chip) {
            match (&event, &mut self.messages) {
                (BridgeEvent::Dialed { socket, host, .. }, _) => {
                    self.dialed.push((*host, *socket));
                    lines.push(event.to_string());
                }
                (BridgeEvent::Bytes { peer, socket, to_chip, bytes }, Some(streams)) => {
                    // Requests go to the chip, but on the firmware's own connections.
                    let requests = *to_chip != self.dialed.contains(&(*peer, *socket));
                    lines.extend(streams.feed(*peer, *socket, requests, bytes));
                }
                (BridgeEvent::Datagram { peer, socket, to_chip, bytes }, Some(_)) => {
                    lines.push(crate::mbap::datagram(*peer, *socket, *to_chip, bytes));
                }
                (BridgeEvent::Closed { peer, socket, .. }, Some(streams)) => {
                    self.dialed.retain(|d| *d != (*peer, *socket));
                    lines.extend(streams.closed(*peer, *socket));
                    lines.push(event.to_string());
                }
                _ => lines.push(event.to_string()),
            }
        }
        lines
    }
}
