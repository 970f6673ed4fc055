//! The master's requests, Modbus Application Protocol v1.1b3 §6.1–6.6, §6.11, §6.12 and
//! §6.17: each checked against the spec's limits before a byte is built, then written as
//! an RTU frame (address, PDU, CRC) with what its reply must look like.

use crate::error::Error;
use crate::protocol::limits::{
    MAX_READ_BITS, MAX_READ_REGISTERS, MAX_READ_WRITE_REGISTERS, MAX_WRITE_COILS, MAX_WRITE_REGISTERS,
};
use crate::protocol::reference::{IntoReference, Reference, Table};
use crate::protocol::FunctionCode;

/// What the master asks of a slave. The fields' addresses are protocol addresses, counted
/// from 0: holding register 40001 is address 0, coil 00001 address 0, input register 30005
/// address 4. [`Request::read`] and the `write_*` constructors take the entry as the
/// slave's API does, a classic reference or a [`Reference`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request<'a> {
    /// 0x01 Read Coils, §6.1: 1–2000 coils.
    ReadCoils {
        /// The first coil's address.
        address: u16,
        /// How many.
        quantity: u16,
    },
    /// 0x02 Read Discrete Inputs, §6.2: 1–2000 inputs.
    ReadDiscreteInputs {
        /// The first input's address.
        address: u16,
        /// How many.
        quantity: u16,
    },
    /// 0x03 Read Holding Registers, §6.3: 1–125 registers.
    ReadHoldingRegisters {
        /// The first register's address.
        address: u16,
        /// How many.
        quantity: u16,
    },
    /// 0x04 Read Input Registers, §6.4: 1–125 registers.
    ReadInputRegisters {
        /// The first register's address.
        address: u16,
        /// How many.
        quantity: u16,
    },
    /// 0x05 Write Single Coil, §6.5 (sent as 0xFF00 for on, 0x0000 for off).
    WriteSingleCoil {
        /// The coil's address.
        address: u16,
        /// On or off.
        value: bool,
    },
    /// 0x06 Write Single Register, §6.6.
    WriteSingleRegister {
        /// The register's address.
        address: u16,
        /// Its new value.
        value: u16,
    },
    /// 0x0F Write Multiple Coils, §6.11: 1–1968 coils.
    WriteMultipleCoils {
        /// The first coil's address.
        address: u16,
        /// The coils' new states, from the first.
        values: &'a [bool],
    },
    /// 0x10 Write Multiple Registers, §6.12: 1–123 registers.
    WriteMultipleRegisters {
        /// The first register's address.
        address: u16,
        /// The registers' new values, from the first.
        values: &'a [u16],
    },
    /// 0x17 Read/Write Multiple Registers, §6.17: writes 1–121 registers, then reads 1–125.
    ReadWriteMultipleRegisters {
        /// The first register read.
        read_address: u16,
        /// How many are read.
        read_quantity: u16,
        /// The first register written.
        write_address: u16,
        /// The values written, from the first.
        values: &'a [u16],
    },
    /// Any other function code (1–127) with the request PDU's data as given (FC 8
    /// Diagnostics, 17 Report Server ID, 43 Read Device Identification, a
    /// [`FunctionCode::custom`] one …): the reply's PDU is handed back unchecked beyond its
    /// address, function code and CRC. Servers frame an answer to a code they do not know
    /// as they like; only its exception (01) is sure.
    Raw {
        /// The function code.
        function: FunctionCode,
        /// The PDU after the function code.
        data: &'a [u8],
    },
}

/// What a reply to a request must look like, beside the slave's address and the
/// function code.
///
/// `Any` first: `Expect::NONE` is then all zeros, and so is most of a new master, which
/// its start writes in a few runs of zeros rather than from a copy in flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Anything (a raw request).
    Any,
    /// A byte count, then that many bytes (FC 1–4, 23).
    Count(u8),
    /// An echo of the request's four bytes after the function code (FC 5, 6, 15, 16).
    Echo,
}

/// What the master waits for: a reply from `slave` to `function`, of `shape`, with
/// `quantity` bits or registers (0 for writes and raw requests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Expect {
    pub(crate) slave: u8,
    pub(crate) function: u8,
    pub(crate) shape: Shape,
    pub(crate) quantity: u16,
}

impl Expect {
    /// Nothing expected: the state of a master with no request yet.
    pub(crate) const NONE: Expect = Expect { slave: 0, function: 0, shape: Shape::Any, quantity: 0 };

    /// True for a broadcast, which no slave answers.
    pub(crate) const fn is_broadcast(&self) -> bool {
        self.slave == 0
    }
}

impl<'a> Request<'a> {
    /// A read of `quantity` entries from `first`, named as the slave's API names them: a
    /// classic reference (`40001`) or a [`Reference`] (`Reference::holding_register(0)`).
    /// Its table chooses the function code: coils FC 1, discrete inputs FC 2, input
    /// registers FC 4, holding registers FC 3. [`Error::BadReference`] for a number that is
    /// no classic reference; the quantity is checked when the request is sent.
    ///
    /// ```
    /// use avr_modbus::master::Request;
    /// assert_eq!(
    ///     Request::read(40001, 10),
    ///     Ok(Request::ReadHoldingRegisters { address: 0, quantity: 10 })
    /// );
    /// ```
    pub fn read(first: impl IntoReference, quantity: u16) -> Result<Self, Error> {
        let Reference { table, address } = first.into_reference()?;
        Ok(match table {
            Table::Coils => Request::ReadCoils { address, quantity },
            Table::DiscreteInputs => Request::ReadDiscreteInputs { address, quantity },
            Table::InputRegisters => Request::ReadInputRegisters { address, quantity },
            Table::HoldingRegisters => Request::ReadHoldingRegisters { address, quantity },
        })
    }

    /// A write of one coil (FC 5) at a coil's reference (`1` is coil 00001, address 0);
    /// [`Error::WrongTable`] for another table's.
    pub fn write_coil(at: impl IntoReference, value: bool) -> Result<Self, Error> {
        let address = in_table(at, Table::Coils)?;
        Ok(Request::WriteSingleCoil { address, value })
    }

    /// A write of one holding register (FC 6) at its reference (`40001` is address 0);
    /// [`Error::WrongTable`] for another table's.
    pub fn write_register(at: impl IntoReference, value: u16) -> Result<Self, Error> {
        let address = in_table(at, Table::HoldingRegisters)?;
        Ok(Request::WriteSingleRegister { address, value })
    }

    /// A write of coils from `first` (FC 15), one `bool` each: a byte of RAM per coil
    /// where the frame packs eight to a byte.
    pub fn write_coils(first: impl IntoReference, values: &'a [bool]) -> Result<Self, Error> {
        let address = in_table(first, Table::Coils)?;
        Ok(Request::WriteMultipleCoils { address, values })
    }

    /// A write of holding registers from `first` (FC 16). A 32-bit value or a float takes
    /// two: `Request::write_registers(40001, &WordOrder::HighFirst.split(1234.5f32))`.
    pub fn write_registers(first: impl IntoReference, values: &'a [u16]) -> Result<Self, Error> {
        let address = in_table(first, Table::HoldingRegisters)?;
        Ok(Request::WriteMultipleRegisters { address, values })
    }
}

/// The protocol address of `at`, which must be in `table`.
fn in_table(at: impl IntoReference, table: Table) -> Result<u16, Error> {
    let reference = at.into_reference()?;
    if reference.table == table {
        Ok(reference.address)
    } else {
        Err(Error::WrongTable)
    }
}

impl Request<'_> {
    /// The function code.
    pub const fn function(&self) -> FunctionCode {
        FunctionCode::from_code(self.code())
    }

    /// The function code's byte.
    pub(crate) const fn code(&self) -> u8 {
        match self {
            Request::ReadCoils { .. } => 0x01,
            Request::ReadDiscreteInputs { .. } => 0x02,
            Request::ReadHoldingRegisters { .. } => 0x03,
            Request::ReadInputRegisters { .. } => 0x04,
            Request::WriteSingleCoil { .. } => 0x05,
            Request::WriteSingleRegister { .. } => 0x06,
            Request::WriteMultipleCoils { .. } => 0x0F,
            Request::WriteMultipleRegisters { .. } => 0x10,
            Request::ReadWriteMultipleRegisters { .. } => 0x17,
            Request::Raw { function, .. } => function.code(),
        }
    }

    /// True for the requests a broadcast can carry: the writes (FC 5, 6, 15, 16) and raw
    /// requests. A read has no one to answer it (Serial Line v1.02 §2.1).
    const fn may_broadcast(&self) -> bool {
        !matches!(
            self,
            Request::ReadCoils { .. }
                | Request::ReadDiscreteInputs { .. }
                | Request::ReadHoldingRegisters { .. }
                | Request::ReadInputRegisters { .. }
                | Request::ReadWriteMultipleRegisters { .. }
        )
    }

    /// Writes the request to `slave` (0: broadcast, 1–247) as an RTU frame into `frame`,
    /// all but the CRC ([`seal`] appends it), and returns the length written and what its
    /// reply must be. Refused before a byte is written
    /// when a quantity or value is outside the spec's limits ([`Error::Quantity`]), the
    /// slave address is reserved ([`Error::SlaveId`]), a read is broadcast
    /// ([`Error::Broadcast`]), a raw function code is not 1–127 ([`Error::Function`]), or
    /// the request or its reply does not fit the master's buffers, `frame` and `reply_room`
    /// bytes ([`Error::TooLong`]).
    ///
    /// Every check comes first, the room in `frame` included; the writes that follow
    /// cannot fail, so they carry no error paths (the firmware's largest part of a request).
    pub(crate) fn encode(&self, slave: u8, frame: &mut [u8], reply_room: usize) -> Result<(usize, Expect), Error> {
        if slave > 247 {
            return Err(Error::SlaveId);
        }
        if slave == 0 && !self.may_broadcast() {
            return Err(Error::Broadcast);
        }
        let function = self.code();
        // The two words after the function code, the frame's length without its CRC, the
        // reply's length with its CRC, and what the reply must be.
        let (first, second, len, reply, shape, quantity) = match *self {
            Request::ReadCoils { address, quantity } | Request::ReadDiscreteInputs { address, quantity } => {
                let bytes = checked(quantity, MAX_READ_BITS)?.div_ceil(8);
                (address, quantity, 6, 5 + bytes, Shape::Count(bytes as u8), quantity)
            }
            Request::ReadHoldingRegisters { address, quantity } | Request::ReadInputRegisters { address, quantity } => {
                let bytes = checked(quantity, MAX_READ_REGISTERS)? * 2;
                (address, quantity, 6, 5 + bytes, Shape::Count(bytes as u8), quantity)
            }
            Request::WriteSingleCoil { address, value } => {
                (address, if value { 0xFF00 } else { 0x0000 }, 6, 8, Shape::Echo, 0)
            }
            Request::WriteSingleRegister { address, value } => (address, value, 6, 8, Shape::Echo, 0),
            Request::WriteMultipleCoils { address, values } => {
                let quantity = checked_len(values.len(), MAX_WRITE_COILS)?;
                (address, quantity, 7 + quantity.div_ceil(8), 8, Shape::Echo, 0)
            }
            Request::WriteMultipleRegisters { address, values } => {
                let quantity = checked_len(values.len(), MAX_WRITE_REGISTERS)?;
                (address, quantity, 7 + 2 * quantity, 8, Shape::Echo, 0)
            }
            Request::ReadWriteMultipleRegisters { read_address, read_quantity, values, .. } => {
                let bytes = checked(read_quantity, MAX_READ_REGISTERS)? * 2;
                let write_quantity = checked_len(values.len(), MAX_READ_WRITE_REGISTERS)?;
                (
                    read_address,
                    read_quantity,
                    11 + 2 * write_quantity,
                    5 + bytes,
                    Shape::Count(bytes as u8),
                    read_quantity,
                )
            }
            Request::Raw { function, data } => {
                if !(1..=0x7F).contains(&function.code()) {
                    return Err(Error::Function);
                }
                (0, 0, u16::try_from(data.len()).unwrap_or(u16::MAX).saturating_add(2), 5, Shape::Any, 0)
            }
        };
        let len = usize::from(len);
        // At most 256 bytes with the CRC, and room for it; room for the reply (none comes
        // to a broadcast).
        if len > 254 || len + 2 > frame.len() || (slave != 0 && usize::from(reply) > reply_room) {
            return Err(Error::TooLong);
        }
        let Some(frame) = frame.get_mut(..len) else { return Err(Error::TooLong) };
        put(frame, 0, slave);
        put(frame, 1, function);
        match *self {
            Request::Raw { data, .. } => {
                for (i, &byte) in data.iter().enumerate() {
                    put(frame, 2 + i, byte);
                }
            }
            _ => {
                put_word(frame, 2, first);
                put_word(frame, 4, second);
                match *self {
                    Request::WriteMultipleCoils { values, .. } => {
                        put(frame, 6, second.div_ceil(8) as u8);
                        for (i, byte) in values.chunks(8).enumerate() {
                            put(frame, 7 + i, byte.iter().rev().fold(0u8, |bits, &on| (bits << 1) | u8::from(on)));
                        }
                    }
                    Request::WriteMultipleRegisters { values, .. } => registers(frame, 6, values),
                    Request::ReadWriteMultipleRegisters { write_address, values, .. } => {
                        put_word(frame, 6, write_address);
                        put_word(frame, 8, values.len() as u16);
                        registers(frame, 10, values);
                    }
                    _ => {}
                }
            }
        }
        Ok((len, Expect { slave, function, shape, quantity }))
    }
}

/// Writes `byte` at `at` in `frame`, which [`Request::encode`] sized for it.
fn put(frame: &mut [u8], at: usize, byte: u8) {
    if let Some(slot) = frame.get_mut(at) {
        *slot = byte;
    }
}

/// Writes `word` at `at` in `frame`, high byte first.
fn put_word(frame: &mut [u8], at: usize, word: u16) {
    let [high, low] = word.to_be_bytes();
    put(frame, at, high);
    put(frame, at + 1, low);
}

/// The byte count and the values of FC 16 and 23, from `at` on.
fn registers(frame: &mut [u8], at: usize, values: &[u16]) {
    put(frame, at, (values.len() * 2) as u8);
    let out = frame.get_mut(at + 1..).unwrap_or_default();
    for (pair, value) in out.chunks_exact_mut(2).zip(values) {
        pair.copy_from_slice(&value.to_be_bytes());
    }
}

/// A quantity inside 1–`max`.
fn checked(quantity: u16, max: u16) -> Result<u16, Error> {
    if quantity == 0 || quantity > max {
        Err(Error::Quantity)
    } else {
        Ok(quantity)
    }
}

/// The number of values written, inside 1–`max`.
fn checked_len(len: usize, max: u16) -> Result<u16, Error> {
    checked(u16::try_from(len).unwrap_or(u16::MAX), max)
}
