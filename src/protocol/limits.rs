//! The quantity limits of the Modbus Application Protocol v1.1b3 (§6.1–6.4, §6.11, §6.12,
//! §6.17) that both roles keep: the slave refuses a request over them with exception 03,
//! the master refuses to send one.

/// Largest quantity of bits in one read (FC 1, 2): 2000.
pub const MAX_READ_BITS: u16 = 0x07D0;
/// Largest quantity of registers in one read (FC 3, 4): 125.
pub const MAX_READ_REGISTERS: u16 = 0x007D;
/// Largest quantity of coils in one write (FC 15): 1968.
pub const MAX_WRITE_COILS: u16 = 0x07B0;
/// Largest quantity of registers in one write (FC 16): 123.
pub const MAX_WRITE_REGISTERS: u16 = 0x007B;
/// Largest quantity of registers written by FC 23 (Read/Write Multiple): 121.
pub const MAX_READ_WRITE_REGISTERS: u16 = 0x0079;
