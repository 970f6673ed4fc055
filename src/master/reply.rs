//! Checking a reply against its request, Modbus over Serial Line v1.02 §2.4.1 (the master's
//! states) and Application Protocol v1.1b3 §7 (exception responses): the address, the
//! function code or its exception form, the byte count against the quantity asked, the
//! echo of a write. The framer has checked the CRC and the silences already.

use super::request::{Expect, Shape};
use crate::protocol::FunctionCode;

/// What a frame that ended while the master waited is to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// The answer to the request: its PDU is the frame's bytes 1 to `len` − 2.
    Answer,
    /// The slave answered with this exception.
    Exception(crate::protocol::Exception),
    /// A frame from another slave: not for this master's request.
    OtherSlave,
    /// From the slave asked, but no answer to the request: wrong function code, byte
    /// count, length or echo.
    Mismatch,
}

impl Expect {
    /// Judges the frame of `len` bytes at the start of `frame` (address to CRC, CRC
    /// checked, 4 bytes or more) against the request it should answer, at the start of
    /// `request` (address to CRC, as sent). Both buffers hold at least 8 bytes
    /// ([`crate::link::framer::MIN_CAPACITY`]), so every byte read here is inside them.
    pub(crate) fn check<const N: usize>(&self, request: &[u8; N], frame: &[u8; N], len: usize) -> Verdict {
        let at = |i: usize| frame.get(i).copied().unwrap_or(0);
        if at(0) != self.slave {
            return Verdict::OtherSlave;
        }
        let function = at(1);
        if function == self.function | 0x80 {
            // An exception reply is 5 bytes; code 0 is no exception: no answer either.
            return match crate::protocol::Exception::from_code(at(2)) {
                Some(exception) if len == 5 => Verdict::Exception(exception),
                _ => Verdict::Mismatch,
            };
        }
        let fits = function == self.function
            && match self.shape {
                Shape::Count(count) => at(2) == count && len == 5 + usize::from(count),
                Shape::Echo => len == 8 && frame.get(2..6) == request.get(2..6),
                // In ASCII a frame past the buffer still ends (RTU drops it): no answer.
                Shape::Any => len >= 4 && len <= N,
            };
        if fits {
            Verdict::Answer
        } else {
            Verdict::Mismatch
        }
    }
}

/// A slave's answer to the master's request: its PDU, read in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply<'a> {
    /// The PDU after the function code (empty after a broadcast).
    data: &'a [u8],
    function: u8,
    quantity: u16,
}

impl<'a> Reply<'a> {
    /// The answer at the start of `buffer` (address, function code, `len` bytes of PDU
    /// data, CRC) to a request of `expect`; after a broadcast, `len` is 0.
    pub(crate) fn new(buffer: &'a [u8], len: u8, expect: &Expect) -> Self {
        let data = buffer.get(2..2 + usize::from(len)).unwrap_or_default();
        Reply { data, function: expect.function, quantity: expect.quantity }
    }

    /// The function code answered.
    pub fn function(&self) -> FunctionCode {
        FunctionCode::from_code(self.function)
    }

    /// How many coils, inputs or registers the request asked to read (10 for a read of 10
    /// coils, whose values come in 2 bytes; 0 for writes, broadcasts and raw requests).
    pub fn len(&self) -> usize {
        usize::from(self.quantity)
    }

    /// True when the reply carries no values ([`Reply::len`] is 0).
    pub fn is_empty(&self) -> bool {
        self.quantity == 0
    }

    /// The reply's PDU after the function code, as the slave sent it: for a raw request,
    /// the answer itself; for a read, the byte count and the values; for a write, the echo.
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// The values of a read of registers, two bytes each (the master checked that the byte
    /// count before them is twice the quantity asked); none for any other reply.
    fn register_bytes(&self) -> &'a [u8] {
        if matches!(self.function, 0x03 | 0x04 | 0x17) {
            self.data.get(1..).unwrap_or_default()
        } else {
            &[]
        }
    }

    /// Register `index` of a read of registers (FC 3, 4, 23), counted from the first one
    /// asked; `None` past the last, and for any other reply.
    pub fn register(&self, index: usize) -> Option<u16> {
        let at = index.checked_mul(2)?;
        let pair = self.register_bytes().get(at..at.checked_add(2)?)?;
        Some(u16::from_be_bytes([pair[0], pair[1]]))
    }

    /// The registers read (FC 3, 4, 23), from the first one asked; none for any other
    /// reply (a write's echo is in [`Reply::data`]).
    pub fn registers(&self) -> impl Iterator<Item = u16> + 'a {
        self.register_bytes().chunks_exact(2).map(|pair| u16::from_be_bytes([pair[0], pair[1]]))
    }

    /// The `u32`, `i32` or `f32` registers `index` and `index + 1` of a read of registers
    /// hold in `order` (see [`crate::WordOrder`]): `reply.wide::<f32>(0, WordOrder::HighFirst)`;
    /// `None` past the last register.
    pub fn wide<T: crate::Wide>(&self, index: usize, order: crate::WordOrder) -> Option<T> {
        Some(order.join([self.register(index)?, self.register(index.checked_add(1)?)?]))
    }

    /// Coil or input `index` of a read of bits (FC 1, 2), counted from the first one
    /// asked; `None` past the last, and for any other reply.
    pub fn bit(&self, index: usize) -> Option<bool> {
        if index >= self.len() || !matches!(self.function, 0x01 | 0x02) {
            return None;
        }
        let byte = self.data.get(1 + index / 8)?;
        Some(byte >> (index % 8) & 1 != 0)
    }
}
