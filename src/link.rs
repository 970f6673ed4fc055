//! The link layer both roles share, Modbus over Serial Line v1.02 §2.5: the line's
//! configuration, the character times and Timer0's arithmetic, the RTU framer (frames by
//! silence, CRC-16) and ASCII framing (frames by `:` and CR LF, LRC). The slave
//! (`crate::slave`) and the master (`crate::master`) sit above it; the AVR layer
//! (`crate::avr`) drives it from the USART's and Timer0's interrupts.

pub(crate) mod config;
pub(crate) mod crc;
pub(crate) mod framer;
pub(crate) mod timing;
