//! What the slave counts, Modbus over Serial Line v1.02 §6.1.3 (the serial-line diagnostic
//! counters FC 8 reports) and the comm event counter of FC 11: the engine keeps them, FC 8
//! reads and clears them, the application reads them with `counters()`.

/// What the slave counted since start-up (each wraps at 65535).
#[cfg_attr(feature = "ufmt", derive(ufmt::derive::uDebug))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlaveCounters {
    /// Frames that ended with T3.5 of silence, good or bad.
    pub frames: u16,
    /// Frames dropped for a bad CRC.
    pub crc_errors: u16,
    /// Frames dropped for a parity or framing error.
    pub uart_errors: u16,
    /// Frames dropped for a lost character (USART overrun) or for exceeding 256 bytes.
    pub overruns: u16,
    /// Frames dropped for being shorter than 4 bytes or for a gap longer than T1.5.
    pub malformed: u16,
    /// Good frames addressed to this slave or broadcast.
    pub messages: u16,
    /// Exception responses produced (for broadcasts too, though not sent).
    pub exceptions: u16,
    /// Replies sent, normal or exception.
    pub replies: u16,
    /// Broadcast frames received.
    pub broadcasts: u16,
    /// Good frames for this slave or broadcast that got no reply (broadcasts, and every
    /// frame while in listen-only mode).
    pub no_response: u16,
    /// Requests completed without an exception (the comm event counter of FC 11 (0x0B), which
    /// does not count its own requests).
    pub events: u16,
    /// Writes refused with exception 01 while the slave is read-only (feature
    /// `write-protect`, `set_read_only`), broadcasts included; each counts in
    /// [`SlaveCounters::exceptions`] too.
    #[cfg(feature = "write-protect")]
    pub refused_writes: u16,
}

impl SlaveCounters {
    /// All zero.
    pub const fn new() -> Self {
        SlaveCounters {
            frames: 0,
            crc_errors: 0,
            uart_errors: 0,
            overruns: 0,
            malformed: 0,
            messages: 0,
            exceptions: 0,
            replies: 0,
            broadcasts: 0,
            no_response: 0,
            events: 0,
            #[cfg(feature = "write-protect")]
            refused_writes: 0,
        }
    }
}
