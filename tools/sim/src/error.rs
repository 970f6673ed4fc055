//! What can go wrong, in one flat enum.

use std::fmt;
use std::path::PathBuf;

use crate::{Chip, CpuState, PinUart};

/// What went wrong.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The firmware file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not an AVR executable.
    BadElf {
        /// The file.
        path: PathBuf,
        /// Why it was refused.
        reason: String,
    },
    /// The ELF file names a device this crate does not simulate.
    UnsupportedChip {
        /// The file.
        path: PathBuf,
        /// The device its `.note.gnu.avr.deviceinfo` names.
        name: String,
    },
    /// The chip has no such USART.
    NoSuchUsart {
        /// The chip.
        chip: Chip,
        /// The USART asked for.
        usart: u8,
    },
    /// The USART is the wire: read what it sends with `take_tx`.
    WireUsart(u8),
    /// simavr refused the file.
    Load {
        /// The file.
        path: PathBuf,
        /// simavr's reason.
        reason: String,
    },
    /// The simulated CPU has stopped (crashed, or slept with interrupts disabled).
    Stopped {
        /// Its state.
        state: CpuState,
        /// The cycle it stopped at.
        cycle: u64,
    },
    /// A byte was scheduled whose RXCn would rise before the current cycle.
    RxInPast {
        /// The cycle at which its RXCn would rise.
        at: u64,
        /// The current cycle.
        now: u64,
    },
    /// A byte was scheduled whose RXCn would rise before a byte already scheduled.
    RxOutOfOrder {
        /// The cycle at which its RXCn would rise.
        at: u64,
    },
    /// The firmware has not enabled the wire's USART in asynchronous mode (needed to know the
    /// character time).
    UartNotConfigured,
    /// Not an Arduino Uno pin number (0-19).
    BadPin(u8),
    /// Arduino pin numbers are mapped for the Uno's chips only (ATmega328P, ATmega168): name
    /// the port and bit instead (`port_pin`, `drive_port_pin`).
    NoArduinoPins(Chip),
    /// The chip has no such port pin.
    NoSuchPortPin {
        /// The chip.
        chip: Chip,
        /// Port letter, `'A'`-`'L'`.
        port: char,
        /// Bit, 0-7.
        bit: u8,
    },
    /// A pin level was scheduled for a cycle already gone.
    PinInPast {
        /// The cycle asked for.
        at: u64,
        /// The current cycle.
        now: u64,
    },
    /// The pin's output is not logged: `watch_pin` it first.
    PinNotWatched {
        /// Port letter.
        port: char,
        /// Bit.
        bit: u8,
    },
    /// A serial format a pin cannot carry: the baud rate must be 1 or more, with 5-8 data bits
    /// and 1 or 2 stop bits.
    BadPinUart(PinUart),
    /// Not an ADC channel of the chip (0-7 on the 328P and 168, 0-15 on the others).
    BadAdcChannel(u8),
    /// A memory access outside the data space.
    OutOfRange {
        /// First address.
        addr: usize,
        /// Length of the access.
        len: usize,
        /// Size of the data space.
        size: usize,
    },
    /// An EEPROM access past its end.
    EepromOutOfRange {
        /// First address.
        addr: usize,
        /// Length of the access.
        len: usize,
    },
    /// No such symbol in the ELF file.
    UnknownSymbol(String),
    /// The symbol is not in the data space.
    NotInRam(String),
    /// More bytes than the variable holds.
    SymbolTooSmall {
        /// The symbol.
        name: String,
        /// Its size.
        size: usize,
        /// Bytes to write.
        len: usize,
    },
    /// A flash access past its end.
    FlashOutOfRange {
        /// First byte address.
        addr: usize,
        /// Length of the access.
        len: usize,
    },
    /// An Intel HEX file could not be used.
    BadHex {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The simulator failed internally (e.g. out of memory).
    Internal(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, source } => write!(f, "cannot read firmware {}: {source}", path.display()),
            Error::BadElf { path, reason } => write!(f, "{}: {reason}", path.display()),
            Error::UnsupportedChip { path, name } => {
                let names: Vec<&str> = Chip::ALL.iter().map(|c| c.name()).collect();
                write!(f, "{}: linked for {name}, which is not simulated (only {})", path.display(), names.join(", "))
            }
            Error::NoSuchUsart { chip, usart } => {
                let have: Vec<String> = chip.usarts().iter().map(|n| format!("USART{n}")).collect();
                write!(f, "the {chip} has no USART{usart} (it has {})", have.join(", "))
            }
            Error::WireUsart(n) => write!(f, "USART{n} is the wire: its bytes come from take_tx"),
            Error::Load { path, reason } => write!(f, "{}: {reason}", path.display()),
            Error::Stopped { state, cycle } => write!(f, "simulated CPU stopped ({state:?}) at cycle {cycle}"),
            Error::RxInPast { at, now } => {
                write!(f, "byte scheduled with RXC at cycle {at}, but it is already cycle {now}")
            }
            Error::RxOutOfOrder { at } => {
                write!(f, "byte scheduled with RXC at cycle {at}, before a byte already scheduled")
            }
            Error::UartNotConfigured => write!(f, "the firmware has not enabled the wire's USART (asynchronous mode)"),
            Error::BadPin(pin) => write!(f, "{pin} is not an Arduino Uno pin (0-13, A0-A5 = 14-19)"),
            Error::NoArduinoPins(chip) => write!(
                f,
                "Arduino pin numbers are mapped for the Uno's chips only, not the {chip}: name the port and bit"
            ),
            Error::NoSuchPortPin { chip, port, bit } => write!(f, "the {chip} has no pin P{port}{bit}"),
            Error::PinInPast { at, now } => {
                write!(f, "pin level scheduled at cycle {at}, but it is already cycle {now}")
            }
            Error::PinNotWatched { port, bit } => write!(f, "pin P{port}{bit} is not logged: watch_pin it first"),
            Error::BadPinUart(uart) => write!(
                f,
                "{} baud, {} data bits, {} stop bits: a pin's serial line needs a baud rate, 5-8 data bits, 1 or 2 stop bits",
                uart.baud, uart.data_bits, uart.stop_bits
            ),
            Error::BadAdcChannel(ch) => write!(f, "{ch} is not an ADC channel of this chip"),
            Error::OutOfRange { addr, len, size } => {
                write!(f, "{len} bytes at 0x{addr:04x} are outside the data space (0x{size:04x} bytes)")
            }
            Error::EepromOutOfRange { addr, len } => {
                write!(f, "{len} bytes at 0x{addr:03x} are past the end of the EEPROM")
            }
            Error::FlashOutOfRange { addr, len } => {
                write!(f, "{len} bytes at 0x{addr:05x} are past the end of the flash")
            }
            Error::BadHex { path, reason } => write!(f, "{}: {reason}", path.display()),
            Error::UnknownSymbol(name) => write!(f, "no symbol `{name}` in the firmware"),
            Error::NotInRam(name) => write!(f, "symbol `{name}` is not in the data space"),
            Error::SymbolTooSmall { name, size, len } => {
                write!(f, "cannot write {len} bytes to `{name}`, which has {size}")
            }
            Error::Internal(msg) => write!(f, "simulator error: {msg}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}
