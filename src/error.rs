//! The one error type of the crate: everything that can go wrong while the application
//! sets the slave up or reads and writes its data. (What goes wrong on the line is no
//! error here: a bad frame is dropped and counted, a bad request gets its Modbus
//! exception.)

/// Why a configuration, a register-bank operation or the start of the slave was refused.
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// A slave id outside 1–247 (0 is broadcast, 248–255 are reserved).
    SlaveId,
    /// A baud rate outside [`crate::Config::MIN_BAUD`]–[`crate::Config::MAX_BAUD`].
    Baud,
    /// A baud rate the USART can't make within 2.5 % at the CPU clock (16 MHz, or 8 MHz when
    /// the build sets `AVR_CPU_FREQUENCY_HZ=8000000`).
    BaudError,
    /// A classic reference outside 00001–09999, 10001–19999, 30001–39999, 40001–49999.
    BadReference,
    /// The address was never added to the bank.
    NotFound,
    /// The address (or one in the range) was added already.
    Duplicate,
    /// A range runs past address 65535, or is empty.
    BadRange,
    /// No room for another contiguous run of addresses (the bank's `RUNS`).
    RunsFull,
    /// No room for more registers (the bank's `REGS`).
    RegistersFull,
    /// No room for more coils or discrete inputs (the bank's `BIT_BYTES` × 8).
    BitsFull,
    /// No room for another read-only range (the bank's `PROTECTED`).
    ProtectionsFull,
    /// No room for another range of holding-register pairs (the bank's `PAIRS`).
    PairsFull,
    /// A peripheral handed to the crate is not the one asked for (another `USART` or
    /// timer, say).
    WrongPeripheral,
    /// The slave or master was started already.
    AlreadyStarted,
    /// The master has a request under way (feature `master`).
    Busy,
    /// A request's quantity outside the spec's limits: 1–2000 coils or inputs read,
    /// 1–125 registers read, 1–1968 coils or 1–123 registers written (1–121 by FC 23).
    Quantity,
    /// A read sent to the broadcast address 0: no slave answers a broadcast.
    Broadcast,
    /// A raw request's function code outside 1–127.
    Function,
    /// A request, or the longest reply it can get, does not fit the master's buffer.
    TooLong,
    /// The master was not started.
    NotStarted,
    /// A reference in a table the request does not reach: a master's write to a discrete
    /// input or an input register, a coil's reference for a register write.
    WrongTable,
    /// The Ethernet chip did not answer as the one named (feature `tcp`): not wired, not
    /// powered, held in reset, or the other chip (a W5500 named W5100, say).
    NoChip,
    /// The Modbus TCP client has no connection to its server now (features `tcp` and
    /// `master`): it connects again by itself; ask again later.
    NotConnected,
}

impl Error {
    /// A one-line description, for build errors and logs.
    pub const fn message(self) -> &'static str {
        match self {
            Error::SlaveId => "slave id must be 1-247",
            Error::Baud => "baud rate must be 1200-1000000",
            Error::BaudError => "baud rate more than 2.5% off at the CPU clock",
            Error::BadReference => "not a classic reference (00001, 10001, 30001, 40001 ...)",
            Error::NotFound => "address not in the bank",
            Error::Duplicate => "address added twice",
            Error::BadRange => "empty range, or past address 65535",
            Error::RunsFull => "bank has no room for another run (RUNS)",
            Error::RegistersFull => "bank has no room for more registers (REGS)",
            Error::BitsFull => "bank has no room for more bits (BIT_BYTES)",
            Error::ProtectionsFull => "bank has no room for another protected range",
            Error::PairsFull => "bank has no room for another range of pairs (PAIRS)",
            Error::WrongPeripheral => "wrong peripheral",
            Error::AlreadyStarted => "started twice",
            Error::Busy => "a request is under way",
            Error::Quantity => "quantity outside the spec's limits",
            Error::Broadcast => "a read can't be broadcast",
            Error::Function => "function code must be 1-127",
            Error::TooLong => "request or reply longer than the buffer",
            Error::NotStarted => "not started",
            Error::WrongTable => "reference in another table",
            Error::NoChip => "no Ethernet chip answers",
            Error::NotConnected => "not connected to the server",
        }
    }
}

/// The one-line description ([`Error::message`]).
impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

/// The one-line description ([`Error::message`]), for arduino-hal's serial (feature `ufmt`).
#[cfg(feature = "ufmt")]
impl ufmt::uDisplay for Error {
    fn fmt<W: ufmt::uWrite + ?Sized>(&self, f: &mut ufmt::Formatter<'_, W>) -> Result<(), W::Error> {
        f.write_str(self.message())
    }
}
