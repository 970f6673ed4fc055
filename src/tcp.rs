//! Modbus TCP (feature `tcp`), Modbus Messaging on TCP/IP Implementation Guide v1.0b: the
//! server over the WIZnet W5100 and W5500 Ethernet chips, and with feature `master` the
//! client.
//!
//! The pure core, tested on the host: the MBAP header (`mbap`), the settings
//! ([`Network`]), the connections and requests over any chip's TCP sockets (`server`), the
//! client's connection and transactions (`client`), the chips' SPI frames and registers
//! (`wiznet`). The AVR layer drives either from Timer0's overflow interrupt (`TcpServer`,
//! `TcpClient`, AVR only).

#[cfg(feature = "master")]
pub(crate) mod client;
#[cfg(feature = "dhcp")]
pub(crate) mod dhcp;
#[cfg(test)]
pub(crate) mod fake;
#[cfg(feature = "master")]
pub(crate) mod gateway;
pub(crate) mod health;
pub(crate) mod mbap;
mod network;
#[cfg(feature = "eeprom-settings")]
pub(crate) mod record;
#[cfg(feature = "rtu-over-tcp")]
pub(crate) mod rtu;
pub(crate) mod server;
pub(crate) mod wiznet;

#[cfg(feature = "dhcp")]
pub use dhcp::{DhcpCounters, DhcpState, DhcpStatus, INFINITE};
#[cfg(feature = "master")]
#[doc(hidden)]
pub use gateway::BUFFER as GATEWAY_BUFFER;
#[cfg(feature = "master")]
pub use gateway::{
    Direct, GatewayCounters, GatewaySettings, Routes, SlaveHealth, HEALTH_REGISTERS, STATUS_REGISTERS, TRACKED,
};
pub use network::Network;
#[cfg(all(feature = "udp", target_arch = "avr"))]
pub(crate) use network::NO_UDP;
#[cfg(feature = "eeprom-settings")]
pub use record::NETWORK_SLOTS_LEN;
pub use server::TcpCounters;
pub use wiznet::{W5100, W5500};

use crate::slave::counters::SlaveCounters;
use crate::slave::engine::dispatch;
use crate::slave::model::DataModel;
use crate::slave::pdu::{encode_exception, Answer, Exception, FunctionCode};

/// Handles the request of an ADU in `adu` (header, then the first bytes of a PDU of
/// `pdu_len` bytes) against `model`, as the RTU slave would: the reply PDU written over the
/// request. Returns its length and whether it is an exception. FC 8's listen-only mode
/// belongs to the serial line (Application Protocol §6.8.1): over TCP it is exception 01.
pub fn respond<M: DataModel + ?Sized>(adu: &mut [u8], pdu_len: usize, model: &mut M) -> Option<(usize, bool)> {
    let unit = adu.get(mbap::HEADER - 1).copied().unwrap_or(mbap::DEVICE_UNIT);
    let pdu = adu.get_mut(mbap::HEADER..)?;
    let result = match dispatch(pdu, pdu_len, model, &SlaveCounters::new(), unit, true) {
        Ok(Answer::Reply(n) | Answer::Restart(n)) => Ok(n),
        Ok(Answer::ListenOnly) => Err(Exception::IllegalFunction),
        Err(exception) => Err(exception),
    };
    Some(match result {
        Ok(n) => (n, false),
        Err(exception) => (encode_exception(pdu, exception), true),
    })
}

/// The handler of a server serving `model`.
pub struct Serving<'a, M: ?Sized>(pub &'a mut M);

impl<M: DataModel> server::Handler for Serving<'_, M> {
    fn handle(&mut self, adu: &mut [u8], pdu_len: usize) -> Option<(usize, bool)> {
        respond(adu, pdu_len, self.0)
    }

    /// A model other ports serve too ([`DataModel::SHARED`]) is told who asks (for a write,
    /// the client's address, read from the chip before the model is locked), and runs the
    /// request with no other port's in between: a write lands whole, a read sees no half
    /// of another port's write.
    #[inline(always)]
    fn handle_from<S: server::Sockets>(
        &mut self,
        adu: &mut [u8],
        pdu_len: usize,
        chip: &mut S,
        s: u8,
        _at: u16,
    ) -> Option<(usize, bool)> {
        if !M::SHARED {
            return respond(adu, pdu_len, self.0);
        }
        // The client's address for every write (FC 5 and up: the few codes past 5 that do
        // not write are rare, and one comparison is less code than six).
        let code = adu.get(mbap::HEADER).copied().unwrap_or(0);
        let client = if code >= FunctionCode::WriteSingleCoil.code() { chip.peer(s) } else { [0; 4] };
        let unit = adu.get(mbap::HEADER - 1).copied().unwrap_or(mbap::DEVICE_UNIT);
        self.0.exclusive(|model| {
            model.serve_from(crate::Port::Tcp { socket: s, client }, unit);
            respond(adu, pdu_len, model)
        })
    }
}
