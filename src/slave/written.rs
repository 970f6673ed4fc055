//! Who wrote what in a model several ports serve (`shared_model!`): each port
//! says who asks before it runs a request ([`Port`], the unit id), and the model records
//! the last write a master made ([`Write`]) for the application to take.

use crate::protocol::reference::{Reference, Table};

/// A port a master reaches a shared model through.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Port {
    /// A serial slave (`slave!`): its USART's number (0 on the Uno's pins 0/1,
    /// 1–3 for a Mega's Serial1–3).
    Serial(u8),
    /// The TCP server (`tcp_server!`): the chip's socket the request came on, and
    /// the client's IPv4 address (of the write's connection or datagram).
    Tcp {
        /// The socket (0–3 on the W5100, 0–7 on the W5500).
        socket: u8,
        /// The client's address.
        client: [u8; 4],
    },
}

/// A master's write to a shared model: which port and unit id it came through, and what it
/// wrote. `SharedModel::take_write` hands it over.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Write {
    /// The port.
    pub by: Port,
    /// The unit id the request was addressed to (0 for a serial broadcast).
    pub unit: u8,
    /// The first coil or holding register written.
    pub first: Reference,
    /// How many were written from it.
    pub count: u16,
    /// Writes that came after the one taken before and before this one, not handed over
    /// (wrapping): 0 when the application saw every write.
    pub earlier: u16,
}

/// The record a shared model keeps: who asks now on each side (the TCP server, whose
/// requests run with interrupts enabled; a serial slave, whose run inside its interrupt and
/// may come in the middle of the server's), and the last write not yet taken. All zero at
/// rest (no write, the first serial port), so that a shared model's cell stays in `.bss`.
#[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
#[derive(Clone, Copy, Debug)]
pub(crate) struct WriteLog {
    /// The requests under way and their unit ids: a serial slave's (its USART, its
    /// address), then the TCP server's (its socket and client, its unit id).
    askers: [(Port, u8); 2],
    /// The last write, valid when `fresh`.
    last: Write,
    fresh: bool,
    /// The unit each side selected last, in a model of several ids (`DataModel::UNITS`):
    /// the network's, then the serial lines'.
    selected: [u8; 2],
}

#[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
/// A write's zero value: its slot before the first write.
const NONE: Write =
    Write { by: Port::Serial(0), unit: 0, first: Reference { table: Table::Coils, address: 0 }, count: 0, earlier: 0 };

#[cfg_attr(not(target_arch = "avr"), allow(dead_code))]
impl WriteLog {
    /// Nothing written yet.
    pub(crate) const fn new() -> Self {
        WriteLog { askers: [(Port::Serial(0), 0); 2], last: NONE, fresh: false, selected: [0; 2] }
    }

    /// The requests that follow on `by`'s side (the network's or the serial lines') come
    /// from `by`, addressed to `unit`.
    #[inline(always)]
    pub(crate) fn serve_from(&mut self, by: Port, unit: u8) {
        let network = !matches!(by, Port::Serial(_));
        self.askers[usize::from(network)] = (by, unit);
    }

    /// A master's write of `count` values of `table` from `start` succeeded, on the
    /// network's side (`network`) or a serial line's.
    pub(crate) fn wrote(&mut self, network: bool, table: Table, start: u16, count: u16) {
        let earlier = if self.fresh { self.last.earlier.wrapping_add(1) } else { 0 };
        let (by, unit) = self.askers[usize::from(network)];
        let first = Reference { table, address: start };
        self.last = Write { by, unit, first, count, earlier };
        self.fresh = true;
    }

    /// The network's side (`network`) or the serial lines' selected `unit`.
    #[inline(always)]
    pub(crate) fn select(&mut self, network: bool, unit: u8) {
        self.selected[usize::from(network)] = unit;
    }

    /// The unit the network's side (`network`) or the serial lines' selected last.
    #[inline(always)]
    pub(crate) fn selected(&self, network: bool) -> u8 {
        self.selected[usize::from(network)]
    }

    /// The last write not yet taken.
    pub(crate) fn take(&mut self) -> Option<Write> {
        let fresh = core::mem::take(&mut self.fresh);
        fresh.then_some(self.last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TCP: Port = Port::Tcp { socket: 2, client: [192, 168, 1, 20] };
    /// What `wrote` is told: the write came through the network (the TCP server), or a
    /// serial line.
    const NETWORK: bool = true;
    const LINE: bool = false;

    #[test]
    fn a_write_is_recorded_with_the_port_and_unit_that_asked() {
        let mut log = WriteLog::new();
        log.serve_from(TCP, 255);
        log.wrote(NETWORK, Table::HoldingRegisters, 3, 2);
        let first = Reference { table: Table::HoldingRegisters, address: 3 };
        assert_eq!(log.take(), Some(Write { by: TCP, unit: 255, first, count: 2, earlier: 0 }));
        assert_eq!(log.take(), None, "taken once");
    }

    #[test]
    fn writes_not_taken_are_counted_in_the_next_one() {
        let mut log = WriteLog::new();
        log.serve_from(Port::Serial(0), 1);
        log.wrote(LINE, Table::Coils, 0, 1);
        log.serve_from(TCP, 1);
        log.wrote(NETWORK, Table::HoldingRegisters, 7, 1);
        log.serve_from(Port::Serial(0), 1);
        log.wrote(LINE, Table::HoldingRegisters, 9, 4);
        let write = log.take().unwrap();
        assert_eq!((write.by, write.first.address, write.count, write.earlier), (Port::Serial(0), 9, 4, 2));
        log.wrote(LINE, Table::Coils, 1, 1);
        assert_eq!(log.take().unwrap().earlier, 0, "counted from the last take");
    }

    #[test]
    fn a_serial_request_in_the_middle_of_a_tcp_request_leaves_the_tcp_writes_its_own() {
        let mut log = WriteLog::new();
        log.serve_from(TCP, 7);
        // A serial slave's request comes in between, and writes.
        log.serve_from(Port::Serial(1), 2);
        log.wrote(LINE, Table::Coils, 9, 1);
        let write = log.take().unwrap();
        assert_eq!((write.by, write.unit, write.first.address), (Port::Serial(1), 2, 9));
        // The TCP request's write, after it: the TCP client's.
        log.wrote(NETWORK, Table::HoldingRegisters, 1, 1);
        let write = log.take().unwrap();
        assert_eq!((write.by, write.unit, write.first.address), (TCP, 7, 1));
        // Two writes in one request (a broadcast to several units): both the request's.
        log.serve_from(Port::Serial(0), 0);
        log.wrote(LINE, Table::Coils, 4, 1);
        log.wrote(LINE, Table::Coils, 5, 1);
        let write = log.take().unwrap();
        assert_eq!((write.by, write.unit, write.first.address, write.earlier), (Port::Serial(0), 0, 5, 1));
    }
}
