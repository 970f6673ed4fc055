//! USART0 in asynchronous mode, 8 data bits (or 7 for ASCII framing, feature `ascii`),
//! ATmega328P datasheet §20 (registers §20.11).

use core::arch::asm;

use super::reg::{UBRR0H, UBRR0L, UCSR0A, UCSR0B, UCSR0C, UDR0};
use crate::config::{Config, Parity, StopBits};
use crate::framer::UartError;

const RXC0: u8 = 1 << 7;
const TXC0: u8 = 1 << 6;
const FE0: u8 = 1 << 4;
const DOR0: u8 = 1 << 3;
const UPE0: u8 = 1 << 2;
const U2X0: u8 = 1 << 1;

const RXCIE0: u8 = 1 << 7;
const TXCIE0: u8 = 1 << 6;
const UDRIE0: u8 = 1 << 5;
const RXEN0: u8 = 1 << 4;
const TXEN0: u8 = 1 << 3;

/// UCSR0A's data-space address (`reg::UCSR0A`), for the assembly below.
const UCSR0A_ADDRESS: u16 = 0xC0;

/// UCSR0A's error flags (DOR0, FE0, UPE0), in one register: written out so that the
/// compiler keeps no second copy of the status for the error path, which costs the receive
/// interrupt a saved register.
#[inline(always)]
fn read_errors() -> u8 {
    let errors: u8;
    // SAFETY: reads UCSR0A (a read has no side effect) into the one register named.
    unsafe {
        asm!(
            "lds {errors}, {ucsr0a}",
            "andi {errors}, {mask}",
            errors = out(reg_upper) errors,
            ucsr0a = const UCSR0A_ADDRESS,
            mask = const DOR0 | FE0 | UPE0,
            options(nostack),
        );
    }
    errors
}

/// USART0 on Arduino pins 0 (RX) and 1 (TX).
pub(crate) struct Usart;

impl Usart {
    /// Configures the format and rate, enables receiver, transmitter and the receive
    /// interrupt.
    ///
    /// The frame format (UCSR0C) is written before the rate, and UBRR0's high byte before
    /// its low byte: the low-byte write is what applies the new rate.
    pub(crate) fn new(config: &Config) -> Self {
        let mut usart = Usart;
        usart.configure(config);
        usart
    }

    /// Applies `config`'s format and rate, as [`Usart::new`] does. Turning the receiver
    /// and transmitter off first flushes the receive buffer and drops a character being
    /// sent: call it when the reply has left the wire (transmit complete).
    pub(crate) fn configure(&mut self, config: &Config) {
        let divisor = config.divisor();
        let parity = match config.parity() {
            Parity::None => 0b00,
            Parity::Even => 0b10,
            Parity::Odd => 0b11,
        };
        let stop = match config.stop_bits() {
            StopBits::One => 0,
            StopBits::Two => 1,
        };
        // Asynchronous, parity, stop bits, 8 data bits (UCSZ01:0 = 11); with feature
        // `ascii` 7 for ASCII framing (UCSZ01:0 = 10).
        #[cfg(not(feature = "ascii"))]
        let size = 0b110;
        #[cfg(feature = "ascii")]
        let size = if config.data_bits() == 7 { 0b100 } else { 0b110 };
        let ucsr0c = (parity << 4) | (stop << 3) | size;
        let [ubrr_high, ubrr_low] = divisor.ubrr.to_be_bytes();
        UCSR0B.write(0);
        UCSR0C.write(ucsr0c);
        UCSR0A.write(if divisor.double_speed { U2X0 } else { 0 });
        UBRR0H.write(ubrr_high);
        UBRR0L.write(ubrr_low);
        UCSR0B.write(RXCIE0 | RXEN0 | TXEN0);
    }

    /// Reads the received character, or the error it came with. The status flags belong
    /// to the character in UDR0, so they are read first.
    #[inline(always)]
    pub(crate) fn read(&self) -> Result<u8, UartError> {
        let errors = read_errors();
        let byte = UDR0.read();
        if errors == 0 {
            Ok(byte)
        } else if errors & DOR0 != 0 {
            Err(UartError::Overrun)
        } else if errors & FE0 != 0 {
            Err(UartError::Framing)
        } else {
            Err(UartError::Parity)
        }
    }

    /// True when a received character waits in UDR0.
    pub(crate) fn has_data(&self) -> bool {
        UCSR0A.read() & RXC0 != 0
    }

    /// Writes one character to the transmit buffer.
    #[inline(always)]
    pub(crate) fn write(&self, byte: u8) {
        UDR0.write(byte);
    }

    /// Starts feeding a reply from the data-register-empty interrupt.
    #[inline(always)]
    pub(crate) fn start_feeding(&self) {
        self.modify_control(|b| b | UDRIE0);
    }

    /// The last character is in the buffer: stop the data-register-empty interrupt and
    /// wait for the transmit-complete one.
    #[inline(always)]
    pub(crate) fn last_written(&self) {
        // Writing 1 to TXC0 clears it; U2X0 is written back unchanged and the error flags
        // are read-only.
        UCSR0A.modify(|bits| (bits & U2X0) | TXC0);
        self.modify_control(|b| (b & !UDRIE0) | TXCIE0);
    }

    /// True from [`Usart::start_feeding`] until [`Usart::finished`]: a reply is on its
    /// way.
    #[cfg(feature = "eeprom-settings")]
    pub(crate) fn is_sending(&self) -> bool {
        UCSR0B.read() & (UDRIE0 | TXCIE0) != 0
    }

    /// The reply has left the wire: stop the transmit-complete interrupt.
    #[inline(always)]
    pub(crate) fn finished(&self) {
        self.modify_control(|b| b & !TXCIE0);
    }

    fn modify_control(&self, f: impl FnOnce(u8) -> u8) {
        // UCSR0B holds enable bits only; `f` changes interrupt enables. Only the slave's
        // interrupt handlers and its critical sections change it.
        UCSR0B.modify(f);
    }
}
