//! A USART in asynchronous mode, 8 data bits (or 7 for ASCII framing, feature `ascii`),
//! ATmega328P datasheet §20 (registers §20.11); the same block on every chip the crate
//! runs on, at the address the chip's table gives (`super::chip`). Line
//! [`CAPTURE_LINE`] is the timer's capture line instead (feature `capture-line`,
//! `super::capture`): each method forwards to it, a choice the compiler makes, so a
//! USART's firmware holds none of it.

use core::arch::asm;

#[cfg(feature = "capture-line")]
use super::capture;
use super::chip::CHIP;
use super::reg::Reg;
use crate::link::config::{Line, Parity, StopBits};
use crate::link::framer::UartError;

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

/// What a configuration writes to a USART's registers.
struct Format {
    /// UCSRnA: double speed or not.
    ucsra: u8,
    /// UCSRnC: asynchronous, parity, stop bits, data bits.
    ucsrc: u8,
    /// UBRRn, high byte first.
    ubrr: [u8; 2],
}

impl Format {
    /// The register values for `config`, worked out apart from the USART they go to (so
    /// that every USART shares this code).
    fn of(config: &Line) -> Self {
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
        // Asynchronous, parity, stop bits, 8 data bits (UCSZn1:0 = 11); with feature
        // `ascii` 7 for ASCII framing (UCSZn1:0 = 10).
        #[cfg(not(feature = "ascii"))]
        let size = 0b110;
        #[cfg(feature = "ascii")]
        let size = if config.data_bits() == 7 { 0b100 } else { 0b110 };
        Format {
            ucsra: if divisor.double_speed { U2X0 } else { 0 },
            ucsrc: (parity << 4) | (stop << 3) | size,
            ubrr: divisor.ubrr.to_be_bytes(),
        }
    }
}

/// The line number of the timer's capture line: [`Usart`]`<CAPTURE_LINE>` is that line.
#[cfg(feature = "capture-line")]
pub(crate) use capture::CAPTURE_LINE;
/// No capture line without the feature: no line has this number.
#[cfg(not(feature = "capture-line"))]
pub(crate) const CAPTURE_LINE: u8 = u8::MAX;

/// The capture line's `f`, with interrupts disabled (every caller of a `Usart` method has
/// them so): the methods' forwarding.
#[cfg(feature = "capture-line")]
#[inline(always)]
fn on_capture_line<R>(f: unsafe fn() -> R) -> R {
    // SAFETY: interrupts are disabled: the `Usart` methods run in the roles' interrupt
    // handlers and in their starts and critical sections.
    unsafe { f() }
}

/// USART `U` (USART0 on the Uno's pins 0/1, USART1 on the Leonardo's, USART0–3 on the
/// Mega's): its registers, UCSRnA to UDRn, from the block the chip's table gives; or for
/// `U` = [`CAPTURE_LINE`] the timer's capture line.
pub(crate) struct Usart<const U: u8>;

impl<const U: u8> Usart<U> {
    /// Whether this is the capture line.
    pub(crate) const CAPTURE: bool = U == CAPTURE_LINE;
    /// The register block's data-space address; a build error for a USART the chip lacks
    /// (0 for the capture line, which has none).
    pub(crate) const BLOCK: usize = if Self::CAPTURE { 0 } else { CHIP.usart(U) };
    /// The peripheral a role's start takes for this line: the USART, or the capture line's
    /// timer (`TC1` on the Uno): its address and size as the PAC lays it out.
    pub(crate) const PERIPHERAL: (usize, usize) =
        if Self::CAPTURE { CHIP.capture.peripheral } else { (Self::BLOCK, super::reg::USART_SIZE) };
    /// Control and status A (the flags).
    const UCSRA: Reg = Reg::at(Self::BLOCK);
    /// Control and status B (enables).
    const UCSRB: Reg = Reg::at(Self::BLOCK + 1);
    /// Control and status C (frame format).
    const UCSRC: Reg = Reg::at(Self::BLOCK + 2);
    /// Baud rate, low byte (writing it applies the rate).
    const UBRRL: Reg = Reg::at(Self::BLOCK + 4);
    /// Baud rate, high byte.
    const UBRRH: Reg = Reg::at(Self::BLOCK + 5);
    /// Data.
    const UDR: Reg = Reg::at(Self::BLOCK + 6);

    /// Configures the format and rate, enables receiver, transmitter and the receive
    /// interrupt.
    ///
    /// The frame format (UCSRnC) is written before the rate, and UBRRn's high byte before
    /// its low byte: the low-byte write is what applies the new rate.
    pub(crate) fn new(config: &Line) -> Self {
        let mut usart = Usart;
        usart.configure(config);
        usart
    }

    /// Applies `config`'s format and rate, as [`Usart::new`] does. Turning the receiver
    /// and transmitter off first flushes the receive buffer and drops a character being
    /// sent: call it when the reply has left the wire (transmit complete).
    // With the feature it is called twice (start, and a settings switch): once out of line.
    #[cfg_attr(feature = "eeprom-settings", inline(never))]
    pub(crate) fn configure(&mut self, config: &Line) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            return capture::configure(config);
        }
        let Format { ucsra, ucsrc, ubrr: [ubrr_high, ubrr_low] } = Format::of(config);
        Self::UCSRB.write(0);
        Self::UCSRC.write(ucsrc);
        // Writing 1 to TXCn clears a transmit-complete flag left from before (a bootloader
        // that jumps to the application without a reset): from here on each one is the
        // role's own, cleared by the interrupt it brings.
        Self::UCSRA.write(ucsra | TXC0);
        Self::UBRRH.write(ubrr_high);
        Self::UBRRL.write(ubrr_low);
        Self::UCSRB.write(RXCIE0 | RXEN0 | TXEN0);
    }

    /// UCSRnA's error flags (DORn, FEn, UPEn), in one register: written out so that the
    /// compiler keeps no second copy of the status for the error path, which costs the
    /// receive interrupt a saved register.
    #[inline(always)]
    fn read_errors() -> u8 {
        let errors: u8;
        // SAFETY: reads UCSRnA (a read has no side effect) into the one register named.
        unsafe {
            asm!(
                "lds {errors}, {ucsra}",
                "andi {errors}, {mask}",
                errors = out(reg_upper) errors,
                ucsra = const Self::BLOCK,
                mask = const DOR0 | FE0 | UPE0,
                options(nostack),
            );
        }
        errors
    }

    /// Reads the received character, or the error it came with. The status flags belong
    /// to the character in UDRn, so they are read first.
    #[inline(always)]
    pub(crate) fn read(&self) -> Result<u8, UartError> {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            return on_capture_line(capture::read);
        }
        let errors = Self::read_errors();
        let byte = Self::UDR.read();
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

    /// True when a received character waits in Self::UDR.
    pub(crate) fn has_data(&self) -> bool {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            return on_capture_line(capture::has_data);
        }
        Self::UCSRA.read() & RXC0 != 0
    }

    /// Writes one character to the transmit buffer.
    #[inline(always)]
    pub(crate) fn write(&self, byte: u8) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            return unsafe { capture::write(byte) };
        }
        Self::UDR.write(byte);
    }

    /// Starts feeding a reply from the data-register-empty interrupt.
    #[inline(always)]
    pub(crate) fn start_feeding(&self) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            return unsafe { capture::set_events(|events| events | capture::FEED) };
        }
        self.modify_control(|b| b | UDRIE0);
    }

    /// The last character is in the buffer: stop the data-register-empty interrupt and
    /// wait for the transmit-complete one.
    #[inline(always)]
    pub(crate) fn last_written(&self) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            return unsafe { capture::set_events(|_| capture::DONE) };
        }
        // Writing 1 to TXC0 clears it; U2X0 is written back unchanged and the error flags
        // are read-only.
        Self::UCSRA.modify(|bits| (bits & U2X0) | TXC0);
        self.modify_control(|b| (b & !UDRIE0) | TXCIE0);
    }

    /// The first character is in the buffer: each one that leaves the wire brings the
    /// transmit-complete interrupt, which writes the next (the master's way: one handler,
    /// and a few cycles between characters where the slave's data-register-empty feed has
    /// none).
    ///
    /// No transmit-complete flag is left from before: [`Usart::configure`] cleared the
    /// last one not the master's, and the flag of each character it sends is cleared by
    /// the interrupt it brings.
    #[cfg(feature = "master")]
    #[inline(always)]
    pub(crate) fn start_sending(&self) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            return unsafe { capture::set_events(|events| events | capture::DONE) };
        }
        self.modify_control(|b| b | TXCIE0);
    }

    /// True from [`Usart::start_feeding`] until [`Usart::finished`]: a reply is on its
    /// way.
    #[cfg(feature = "eeprom-settings")]
    pub(crate) fn is_sending(&self) -> bool {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            return on_capture_line(capture::is_sending);
        }
        Self::UCSRB.read() & (UDRIE0 | TXCIE0) != 0
    }

    /// Holds received characters back from the role (`true`: its slave processes a request
    /// with interrupts enabled) or lets them through again (`false`): the receive interrupt
    /// masked (a character waits in UDRn, the next in the shift register), or on the capture
    /// line kept in its buffer and handed on after (`capture::hold`).
    #[cfg(feature = "capture-line")]
    #[inline(always)]
    pub(crate) fn hold_received(&self, hold: bool) {
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            unsafe { capture::hold(hold) };
        } else {
            self.modify_control(|b| if hold { b & !RXCIE0 } else { b | RXCIE0 });
        }
    }

    /// The reply has left the wire: stop the transmit-complete interrupt.
    #[inline(always)]
    pub(crate) fn finished(&self) {
        #[cfg(feature = "capture-line")]
        if Self::CAPTURE {
            // SAFETY: as `on_capture_line`'s.
            return unsafe { capture::set_events(|events| events & !capture::DONE) };
        }
        self.modify_control(|b| b & !TXCIE0);
    }

    fn modify_control(&self, f: impl FnOnce(u8) -> u8) {
        // UCSRnB holds enable bits only; `f` changes interrupt enables. Only the slave's
        // interrupt handlers and its critical sections change it.
        Self::UCSRB.modify(f);
    }
}
