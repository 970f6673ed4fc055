//! A simulated Arduino Uno: an ATmega328P at 16 MHz in [simavr] 1.6, with USART0 driven on
//! simulated time as a real wire would drive it; or any other [`Chip`] a Modbus slave runs on
//! (ATmega168, ATmega32U4, ATmega1280, ATmega2560), with the wire on any of its USARTs.
//!
//! Used by the integration tests (Modbus RTU T1.5/T3.5 timing), by the benchmarks (cycles spent in
//! interrupt handlers) and by the virtual Uno. The tests find the firmware `make` built with
//! [`built::built`], which skips them on a fresh clone and fails them under `make` and in CI.
//!
//! [`Uno::load`] runs the chip the ELF file was linked for (avr-gcc records it in every
//! executable it links, Rust firmware included), an ATmega328P if the file does not say, with
//! the wire on the chip's default USART (USART0, or USART1 on the 32U4).
//! [`Uno::load_with`] picks the chip and the USART:
//!
//! ```no_run
//! use uno_sim::{Chip, Options, Uno};
//!
//! let mega = Uno::load_with("mega_slave.elf", Options::new().chip(Chip::Atmega2560).usart(1))?;
//! assert_eq!(mega.vectors().usart_rx, 36);
//! # Ok::<(), uno_sim::Error>(())
//! ```
//!
//! The chip's other USARTs work as simavr models them; [`Uno::take_usart_output`] collects what
//! they send (e.g. a firmware's debug print on a Mega's USART0 while Modbus uses USART1).
//!
//! A second USART can be timed as a wire too ([`Options::second_usart`]), for a firmware that
//! talks on two lines at once (a Mega gateway: a slave on USART0, a master on USART1). It
//! follows the same timing model as the wire, with its own schedule and format: the `_on`
//! methods take the USART's number and work on either wire ([`Uno::send_byte_on`],
//! [`Uno::send_frame_on`], [`Uno::take_tx_on`], [`Uno::run_until_tx_idle_on`],
//! [`Uno::tx_busy_until_on`], ...); the methods without `_on` stay the wire's.
//!
//! ```no_run
//! use uno_sim::{us_to_cycles, Options, Uno};
//!
//! let options = Options::new().usart(0).second_usart(1);
//! let mut mega = Uno::load_with("gateway.elf", options)?;
//! mega.run_until(us_to_cycles(10_000))?;
//! let char_time = mega.wire_char_cycles_on(1).expect("USART1 enabled");
//! mega.send_frame_on(1, &[0x01, 0x03, 0x02, 0x00, 0x2A, 0x38, 0x5B], mega.now() + char_time, 0)?;
//! mega.run_for(us_to_cycles(20_000))?;
//! let on_usart0 = mega.take_tx(); // the wire's frames
//! let on_usart1 = mega.take_tx_on(1)?; // the second wire's
//! # Ok::<(), uno_sim::Error>(())
//! ```
//! Arduino pin numbers ([`Uno::pin`]) are the Uno's and work on the 328P and 168 only; every
//! chip's pins can be named by port and bit ([`Uno::port_pin`]).
//!
//! A serial line can also run on plain pins, for a UART a firmware builds from a timer (the
//! timer's input capture on RX, its compare output on TX, as AltSoftSerial does: Timer1 on the
//! Uno's pins 8 and 9, Timer3's PC7/PC6 on the 32U4, Timer5's PL1/PL3 on the Megas): levels
//! scheduled on the RX pin at exact cycles ([`Uno::send_pin_uart`], [`Uno::schedule_pin`]),
//! the TX pin's level changes logged with their cycles and read back as characters
//! ([`Uno::watch_pin`], [`Uno::take_pin_uart`]). simavr 1.6's timers are corrected for it
//! (compare output latch and port override, input capture synchronizer and noise canceller,
//! TEMP; see `csrc/timers.c`).
//!
//! ```no_run
//! use uno_sim::{Parity, PinUart, Uno};
//!
//! let mut uno = Uno::load("soft_uart.elf")?;
//! uno.run_until(160_000)?; // the firmware sets up Timer1
//! uno.watch_pin(9)?;
//! let uart = PinUart::new(19200).parity(Parity::Even);
//! let end = uno.send_pin_uart(8, b"ping", uart, uno.now() + 1000, 0)?;
//! uno.run_until(end + 200_000)?;
//! for reply in uno.take_pin_uart(9, uart)? {
//!     println!("{:#04x} from cycle {}, parity ok: {}", reply.byte, reply.start_cycle, reply.parity_ok);
//! }
//! # Ok::<(), uno_sim::Error>(())
//! ```
//!
//! ```no_run
//! use uno_sim::{us_to_cycles, Uno};
//!
//! let mut uno = Uno::load("target/avr-atmega328p/release/examples/minimal.elf")?;
//! uno.run_until(us_to_cycles(10_000))?; // let the firmware set up its USART
//! let char_time = uno.wire_char_cycles().expect("USART enabled");
//! let last_end = uno.send_frame(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A], uno.now() + char_time, 0)?;
//! let reply = uno.run_until_tx_idle(4 * char_time, last_end + us_to_cycles(100_000))?;
//! println!("reply starts {} cycles after the request", reply[0].start_cycle - last_end);
//! # Ok::<(), uno_sim::Error>(())
//! ```
//!
//! # Timing model
//!
//! All times are CPU cycles since reset (16 per µs, whatever the chip or the file says). The
//! character time of the wire's USART (USART0 here; USARTn reads the same) is exact: a bit lasts
//! `16 * (UBRR0 + 1)` cycles (`8 *` with U2X0), a character `1 + data + parity + stop` bits
//! ([`Uno::wire_char_cycles`]).
//!
//! simavr 1.6's own USART timing is not wire-accurate: its character time always counts a parity
//! bit, it reads the frame format only when UBRR0L is written, a received byte gets RXC0 one of its
//! character times after it is handed over (at the end of the whole character, where the chip
//! raises it at the middle of the first stop bit), bytes that are already queued can be read
//! early, and UDRE0 stays clear for a whole character after every UDR0 write. This crate therefore keeps
//! simavr's USART registers but does the timing itself (in `csrc/shim.c`):
//!
//! * **RX**: [`Uno::send_byte`] schedules a byte whose character ends on the line (its last stop
//!   bit over) at `end_cycle`. As on the chip, the receiver is done with it earlier: once it has
//!   sampled the first stop bit, at that bit's middle (a second stop bit is ignored by the
//!   receiver; ATmega328P datasheet, "Receiving Frames with 5 to 8 Data Bits"). So the byte
//!   enters the receive buffer and RXC0 rises half a bit before `end_cycle` with one stop bit,
//!   one and a half bits before it with two ([`Uno::rx_flag_lead`], from the bit time the
//!   firmware configured: UBRR0 and U2X0). A firmware that counts a silence from its receive
//!   interrupt starts that much before the character's end, as on a board. The firmware sees
//!   RXC0 at the first instruction boundary at or after it rises: at once when the CPU sleeps,
//!   at most 3 cycles later when it runs (an instruction takes at most 4 cycles, and the AVR
//!   also only reacts between instructions). Never earlier. [`RxFlag::CharEnd`] raises RXC0 at
//!   `end_cycle` instead, as simavr's own USART and earlier versions of this crate did, for a
//!   test that needs that by name. The receive buffer holds 2 bytes plus the shift register,
//!   like the chip's; a fourth unread byte overruns (DOR0).
//! * **TX**: a UDR0 write lands at the end of its ST/STS instruction; if the transmitter is idle the
//!   start bit begins then, otherwise right after the previous frame's stop bit (one byte can wait
//!   in UDR0, like on the chip; a write while UDRE0 is clear is ignored, as on the chip). UDRE0 and
//!   TXC0 (and their interrupts) rise at those moments. [`TxByte`] gives each frame's start and end.
//!   (On silicon the start bit waits for the next edge of the free-running transmit bit clock, i.e.
//!   up to one bit time longer; the simulation does not model that phase.)
//! * **Interrupts**: simavr 1.6 enters an interrupt handler in zero cycles; this crate adds the
//!   AVR's 4-cycle interrupt response (8 when waking up from sleep; 5 and 10 on the ATmega2560,
//!   which pushes a 3-byte return address, see [`Chip::interrupt_response_cycles`]), so handler
//!   timing and [`Uno::isr_stats`] match the data sheet. simavr already counts RETI as 4 cycles
//!   (5 on the 2560).
//!
//! [simavr]: https://github.com/buserror/simavr

#![deny(missing_docs)]
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod built;
mod chip;
mod elf;
mod error;
mod ffi;
pub mod hex;
mod pin_uart;
mod pins;
mod shield;
pub mod wiznet;

use std::ffi::{c_char, c_int, CStr, CString};
use std::fmt;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::Mutex;

pub use chip::{Chip, UsartRegs, Vectors};
pub use elf::{Space, Symbol};
pub use error::Error;
pub use pin_uart::{DecodedByte, PinUart};
pub use pins::{PinId, PinState, A0, A1, A2, A3, A4, A5};
pub use wiznet::{W5x00, Wiznet};

/// CPU clock of the Uno, in Hz.
pub const F_CPU: u64 = 16_000_000;
/// CPU cycles per microsecond.
pub const CYCLES_PER_US: u64 = F_CPU / 1_000_000;

/// Converts microseconds to CPU cycles (saturating).
pub const fn us_to_cycles(us: u64) -> u64 {
    us.saturating_mul(CYCLES_PER_US)
}

/// Converts CPU cycles to microseconds.
pub fn cycles_to_us(cycles: u64) -> f64 {
    cycles as f64 / CYCLES_PER_US as f64
}

/// Interrupt vector numbers of the ATmega328P and ATmega168 (vector address = number × 4 bytes).
/// Other chips number them differently: see [`Chip::vectors`] and [`Uno::vectors`].
pub mod vector {
    /// External interrupt 0 (pin 2).
    pub const INT0: u8 = 1;
    /// External interrupt 1 (pin 3).
    pub const INT1: u8 = 2;
    /// Pin change interrupt, port B.
    pub const PCINT0: u8 = 3;
    /// Pin change interrupt, port C.
    pub const PCINT1: u8 = 4;
    /// Pin change interrupt, port D.
    pub const PCINT2: u8 = 5;
    /// Watchdog time-out.
    pub const WDT: u8 = 6;
    /// Timer/Counter2 compare match A.
    pub const TIMER2_COMPA: u8 = 7;
    /// Timer/Counter2 compare match B.
    pub const TIMER2_COMPB: u8 = 8;
    /// Timer/Counter2 overflow.
    pub const TIMER2_OVF: u8 = 9;
    /// Timer/Counter1 capture event.
    pub const TIMER1_CAPT: u8 = 10;
    /// Timer/Counter1 compare match A.
    pub const TIMER1_COMPA: u8 = 11;
    /// Timer/Counter1 compare match B.
    pub const TIMER1_COMPB: u8 = 12;
    /// Timer/Counter1 overflow.
    pub const TIMER1_OVF: u8 = 13;
    /// Timer/Counter0 compare match A.
    pub const TIMER0_COMPA: u8 = 14;
    /// Timer/Counter0 compare match B.
    pub const TIMER0_COMPB: u8 = 15;
    /// Timer/Counter0 overflow.
    pub const TIMER0_OVF: u8 = 16;
    /// SPI transfer complete.
    pub const SPI_STC: u8 = 17;
    /// USART0 receive complete.
    pub const USART_RX: u8 = 18;
    /// USART0 data register empty.
    pub const USART_UDRE: u8 = 19;
    /// USART0 transmit complete.
    pub const USART_TX: u8 = 20;
    /// ADC conversion complete.
    pub const ADC: u8 = 21;
    /// EEPROM ready.
    pub const EE_READY: u8 = 22;
    /// Analog comparator.
    pub const ANALOG_COMP: u8 = 23;
    /// Two-wire interface.
    pub const TWI: u8 = 24;
    /// Store program memory ready.
    pub const SPM_READY: u8 = 25;
}

/// Data-space addresses of the USART0 registers (for [`Uno::read_ram`]). Other USARTs: see
/// [`UsartRegs`] and [`Uno::usart_regs`].
pub mod reg {
    /// USART0 control and status register A (RXC0 0x80, TXC0 0x40, UDRE0 0x20, FE0 0x10, DOR0 0x08, UPE0 0x04, U2X0 0x02).
    pub const UCSR0A: u16 = 0xC0;
    /// USART0 control and status register B.
    pub const UCSR0B: u16 = 0xC1;
    /// USART0 control and status register C.
    pub const UCSR0C: u16 = 0xC2;
    /// USART0 baud rate register, low byte.
    pub const UBRR0L: u16 = 0xC4;
    /// USART0 baud rate register, high byte.
    pub const UBRR0H: u16 = 0xC5;
    /// USART0 data register.
    pub const UDR0: u16 = 0xC6;
}

/// simavr's CPU states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CpuState {
    /// Not initialised.
    Limbo,
    /// Stopped (e.g. waiting for a debugger).
    Stopped,
    /// Executing instructions.
    Running,
    /// In a sleep mode, waiting for an interrupt.
    Sleeping,
    /// Single-stepping (debugger).
    Step,
    /// Single step done (debugger).
    StepDone,
    /// Finished: slept with interrupts disabled.
    Done,
    /// Crashed (bad opcode, bad memory access, watchdog reset without handler, ...).
    Crashed,
    /// A state this crate does not know.
    Unknown(i32),
}

impl CpuState {
    fn from_raw(raw: c_int) -> CpuState {
        match raw {
            0 => CpuState::Limbo,
            1 => CpuState::Stopped,
            2 => CpuState::Running,
            3 => CpuState::Sleeping,
            4 => CpuState::Step,
            5 => CpuState::StepDone,
            6 => CpuState::Done,
            7 => CpuState::Crashed,
            other => CpuState::Unknown(other),
        }
    }

    /// Whether the simulation can go on.
    pub fn is_alive(self) -> bool {
        matches!(self, CpuState::Running | CpuState::Sleeping)
    }
}

/// Parity of a USART frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit (UPM0 = 00, or the reserved 01).
    None,
    /// Even parity (UPM0 = 10).
    Even,
    /// Odd parity (UPM0 = 11).
    Odd,
}

/// The USART format the firmware configured (USART0's bits are named here; USARTn's are the same).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SerialConfig {
    /// UBRR0 (12 bits).
    pub ubrr: u16,
    /// U2X0: double speed.
    pub double_speed: bool,
    /// Cycles per bit: `(UBRR0 + 1) * 16`, or `* 8` with U2X0.
    pub bit_cycles: u64,
    /// Data bits (5-9).
    pub data_bits: u8,
    /// Parity.
    pub parity: Parity,
    /// Stop bits (1 or 2).
    pub stop_bits: u8,
    /// RXEN0: the receiver is on.
    pub rx_enabled: bool,
    /// TXEN0: the transmitter is on.
    pub tx_enabled: bool,
}

impl SerialConfig {
    /// Decodes the USART0 registers (UCSR0A, UCSR0B, UCSR0C, UBRR0L, UBRR0H).
    pub fn from_registers(ucsr0a: u8, ucsr0b: u8, ucsr0c: u8, ubrr0l: u8, ubrr0h: u8) -> SerialConfig {
        let ubrr = (u16::from(ubrr0h & 0x0f) << 8) | u16::from(ubrr0l);
        let double_speed = ucsr0a & 0x02 != 0;
        let ucsz = ((ucsr0c >> 1) & 3) | if ucsr0b & 0x04 != 0 { 4 } else { 0 };
        let data_bits = match ucsz {
            0..=3 => 5 + ucsz,
            7 => 9,
            _ => 8, // reserved
        };
        let parity = match (ucsr0c >> 4) & 3 {
            2 => Parity::Even,
            3 => Parity::Odd,
            _ => Parity::None,
        };
        SerialConfig {
            ubrr,
            double_speed,
            bit_cycles: (u64::from(ubrr) + 1) * if double_speed { 8 } else { 16 },
            data_bits,
            parity,
            stop_bits: if ucsr0c & 0x08 != 0 { 2 } else { 1 },
            rx_enabled: ucsr0b & 0x10 != 0,
            tx_enabled: ucsr0b & 0x08 != 0,
        }
    }

    /// Bits per character: start + data + parity + stop.
    pub fn char_bits(&self) -> u32 {
        1 + u32::from(self.data_bits) + u32::from(self.parity != Parity::None) + u32::from(self.stop_bits)
    }

    /// Cycles per character on the wire.
    pub fn char_cycles(&self) -> u64 {
        self.bit_cycles * u64::from(self.char_bits())
    }

    /// Cycles from the middle of the first stop bit, where the chip's receiver flags a
    /// character (RXCn), to the end of the character on the line: half a bit with one stop
    /// bit, one and a half bits with two. A bit is a whole even number of cycles, so this is
    /// exact.
    pub fn rx_flag_lead_cycles(&self) -> u64 {
        self.bit_cycles * (2 * u64::from(self.stop_bits) - 1) / 2
    }

    /// The actual baud rate (bits per second).
    pub fn baud(&self) -> f64 {
        F_CPU as f64 / self.bit_cycles as f64
    }

    /// Relative deviation of the actual baud rate from `nominal` (e.g. 0.0016 for 19200 with UBRR0 = 51).
    pub fn baud_error(&self, nominal: u32) -> f64 {
        (self.baud() - f64::from(nominal)) / f64::from(nominal)
    }

    /// Whether a peer using `baud` and this frame format could talk to the firmware:
    /// same data bits, parity and stop bits, and a baud rate within ±2 %.
    pub fn matches(&self, baud: u32, data_bits: u8, parity: Parity, stop_bits: u8) -> bool {
        baud > 0
            && self.baud_error(baud).abs() <= 0.02
            && self.data_bits == data_bits
            && self.parity == parity
            && self.stop_bits == stop_bits
    }
}

/// A receive error to inject with [`Uno::send_byte_with_error`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineError {
    /// The stop bit was 0: FE0 is set while the byte is the oldest one in the receive buffer.
    Framing,
    /// The parity bit was wrong: UPE0 is set while the byte is the oldest one in the receive buffer.
    Parity,
}

impl LineError {
    /// The shim's marker of this error on a received value.
    const fn input_flag(self) -> u16 {
        match self {
            LineError::Framing => ffi::INPUT_FE,
            LineError::Parity => ffi::INPUT_PE,
        }
    }
}

/// A frame the firmware transmitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TxByte {
    /// The data byte.
    pub byte: u8,
    /// Cycle at which its start bit begins on the wire.
    pub start_cycle: u64,
    /// Cycle at which its last stop bit ends (`start_cycle` + character time); TXC0 rises here if no
    /// other byte follows.
    pub end_cycle: u64,
}

/// Counters of unusual USART events.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UartCounters {
    /// Bytes that arrived while the receiver was off (RXEN0 clear).
    pub rx_dropped: u64,
    /// Bytes that arrived with the receive buffer and shift register full (DOR0).
    pub rx_overruns: u64,
    /// UDR0 writes while UDRE0 was clear (ignored by the transmitter).
    pub tx_ignored: u64,
}

/// What one [`Uno::step`] did.
///
/// Summing `cycles` by `vector`, plus `response_cycles` by `entered`, gives [`IsrStats::cycles`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Byte address of the instruction executed (while sleeping: of the instruction after SLEEP).
    pub pc: u32,
    /// The interrupt vector whose handler the instruction belonged to (innermost), if any.
    pub vector: Option<u8>,
    /// Cycles of the instruction (or of the sleep), excluding `response_cycles`.
    pub cycles: u64,
    /// An interrupt handler entered right after the instruction, if any.
    pub entered: Option<u8>,
    /// Cycles of that interrupt response (4, or 8 when waking up; 5 and 10 on the ATmega2560;
    /// 0 if none).
    pub response_cycles: u64,
}

/// Time spent in one interrupt vector since load (or [`Uno::reset_isr_stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IsrStats {
    /// How often the handler was entered.
    pub entries: u64,
    /// Cycles spent in it, from the interrupt response up to and including RETI, excluding
    /// handlers nested in it.
    pub cycles: u64,
    /// The longest single run, interrupt response to end of RETI (including nested handlers).
    pub max_cycles: u64,
}

/// Serialises loading: libelf and simavr's loader are not known to be thread-safe.
static LOAD_LOCK: Mutex<()> = Mutex::new(());

/// Cycles a sleeping CPU may skip in one [`Uno::step`] when nothing is scheduled.
const STEP_SLEEP_LIMIT: u64 = 1000;

/// When the wire's USART flags a received character (RXCn) and puts it in its receive buffer,
/// against the end of the character on the line (see the crate's timing model).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RxFlag {
    /// As the megaAVR's receiver: at the middle of the first stop bit, once it has sampled
    /// it; half a bit before the character's end with one stop bit, one and a half bits
    /// before it with two ([`SerialConfig::rx_flag_lead_cycles`]). The default.
    #[default]
    FirstStopBit,
    /// At the end of the whole character, as simavr's own USART does: later than the chip by
    /// half a bit (one and a half with two stop bits). Only for a test that needs the old
    /// behaviour, by name.
    CharEnd,
}

/// Why the chip reset: MCUSR's flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power applied (PORF).
    PowerOn,
    /// The RESET pin pulled low (EXTRF): the reset button, or DTR on a USB-serial board.
    External,
    /// The watchdog timed out (WDRF), e.g. a bootloader leaving for the application.
    Watchdog,
}

impl ResetCause {
    const fn mcusr_bit(self) -> u8 {
        match self {
            ResetCause::PowerOn => 0x01,
            ResetCause::External => 0x02,
            ResetCause::Watchdog => 0x08,
        }
    }

    /// The cause MCUSR names (the watchdog first, as it is set last).
    fn from_mcusr(mcusr: u8) -> Option<ResetCause> {
        [ResetCause::Watchdog, ResetCause::External, ResetCause::PowerOn]
            .into_iter()
            .find(|cause| mcusr & cause.mcusr_bit() != 0)
    }
}

/// Which chip to simulate, which of its USARTs is the wire and when that USART flags a received
/// character (see [`Uno::load_with`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// The chip; `None`: the one the ELF file names (`.note.gnu.avr.deviceinfo`), or the
    /// ATmega328P if it names none. A chip given here wins over the file's.
    pub chip: Option<Chip>,
    /// The USART the wire is on; `None`: the chip's default ([`Chip::default_usart`]).
    pub usart: Option<u8>,
    /// When RXCn rises for a received character: the chip's moment unless a test asks for
    /// another (on both wires).
    pub rx_flag: RxFlag,
    /// A second timed wire on this USART (e.g. a Mega gateway's other line), with the same
    /// timing model as the wire; `None`: only the wire is timed. See [`Uno::send_byte_on`].
    pub second_usart: Option<u8>,
    /// An Ethernet shield's WIZnet chip on the SPI port ([`Uno::wiznet`]); `None`: nothing on
    /// the SPI bus.
    pub wiznet: Option<Wiznet>,
    /// The shield's chip select, P`port``bit`; `None`: the board's pin 10 (see
    /// [`Options::wiznet_cs`]).
    pub wiznet_cs: Option<(char, u8)>,
    /// The shield's INT line wired to P`port``bit` (the W5100 shield's jumper: the Uno's pin
    /// 2, PD2); `None`: not wired ([`Options::wiznet_int`]).
    pub wiznet_int: Option<(char, u8)>,
}

impl Options {
    /// The chip from the file, its default USART, RXCn where the chip raises it, no second
    /// wire, no shield.
    pub const fn new() -> Options {
        Options {
            chip: None,
            usart: None,
            rx_flag: RxFlag::FirstStopBit,
            second_usart: None,
            wiznet: None,
            wiznet_cs: None,
            wiznet_int: None,
        }
    }

    /// Simulates `chip`, whatever the file names.
    pub const fn chip(self, chip: Chip) -> Options {
        Options { chip: Some(chip), ..self }
    }

    /// Puts the wire on USART`n`.
    pub const fn usart(self, n: u8) -> Options {
        Options { usart: Some(n), ..self }
    }

    /// Raises RXCn for each received character as `flag` says.
    pub const fn rx_flag(self, flag: RxFlag) -> Options {
        Options { rx_flag: flag, ..self }
    }

    /// Times USART`n` as a second wire, besides the wire ([`Options::usart`]): bytes queued
    /// with [`Uno::send_byte_on`], frames collected with [`Uno::take_tx_on`]. It must be
    /// another USART of the chip.
    pub const fn second_usart(self, n: u8) -> Options {
        Options { second_usart: Some(n), ..self }
    }
}

/// A simulated Arduino Uno (or another board's chip) running one firmware.
pub struct Uno {
    shim: NonNull<ffi::Shim>,
    path: PathBuf,
    chip: Chip,
    usart: u8,
    regs: UsartRegs,
    vectors: Vectors,
    symbols: Vec<Symbol>,
    /// The second timed wire: its USART and registers.
    second: Option<(u8, UsartRegs)>,
    /// Frames collected from the shim, per wire (0: the wire, 1: the second one).
    tx: [Vec<TxByte>; WIRES],
    rx_flag: RxFlag,
    /// The Ethernet shield's chip, if any.
    shield: Option<shield::Shield>,
    /// Output pins whose level changes are logged ([`Uno::watch_pin`]).
    logged: Vec<pins::LoggedPin>,
}

/// Timed wires: the wire and an optional second one.
const WIRES: usize = 2;

// SAFETY: the simavr instance behind `shim` is owned exclusively by this value and simavr keeps no
// thread-bound state for it; the only process-wide state (the log hook) is installed once under
// `pthread_once` and loading is serialised by `LOAD_LOCK`.
unsafe impl Send for Uno {}

impl fmt::Debug for Uno {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Uno")
            .field("path", &self.path)
            .field("chip", &self.chip)
            .field("usart", &self.usart)
            .field("second_usart", &self.second_usart())
            .field("cycle", &self.now())
            .finish_non_exhaustive()
    }
}

impl Drop for Uno {
    fn drop(&mut self) {
        // SAFETY: `shim` came from `uno_new` and is freed exactly once, here.
        unsafe { ffi::uno_free(self.shim.as_ptr()) }
        // The simulator that called into the shield's chip is gone: free the chip now.
        self.free_shield();
    }
}

impl Uno {
    /// Loads an ELF file into the chip it was linked for (an ATmega328P if the file does not
    /// say) at 16 MHz (5 V supply and AREF), whatever clock the file names, and resets it. The
    /// wire is on the chip's default USART: USART0, or USART1 on the 32U4.
    ///
    /// Fails with a one-line message if the file is missing, is not a 32-bit AVR executable,
    /// names a chip not simulated here, or does not fit the chip.
    pub fn load(path: impl AsRef<Path>) -> Result<Uno, Error> {
        Uno::load_with(path, Options::new())
    }

    /// Like [`Uno::load`], on the chip and USART `options` give: an explicit chip wins over
    /// the one the file names; a USART the chip lacks is [`Error::NoSuchUsart`].
    pub fn load_with(path: impl AsRef<Path>, options: Options) -> Result<Uno, Error> {
        let path = path.as_ref().to_owned();
        let bytes = std::fs::read(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        elf::check_avr(&path, &bytes)?;
        let chip = match (options.chip, elf::device_name(&bytes)) {
            (Some(chip), _) => chip,
            (None, None) => Chip::Atmega328p,
            (None, Some(name)) => Chip::from_name(&name).ok_or(Error::UnsupportedChip { path: path.clone(), name })?,
        };
        Uno::create(Some(path), chip, elf::symbols(&bytes), options)
    }

    /// A chip with its flash erased (every byte 0xFF) and no program, as it comes from the
    /// factory: the chip `options` names (else an ATmega328P), the wire on its USART. Program it
    /// with [`Uno::write_flash`]; [`Uno::reset`] (which reloads a file) is not for it.
    pub fn erased(options: Options) -> Result<Uno, Error> {
        Uno::create(None, options.chip.unwrap_or(Chip::Atmega328p), Vec::new(), options)
    }

    fn create(path: Option<PathBuf>, chip: Chip, symbols: Vec<Symbol>, options: Options) -> Result<Uno, Error> {
        let usart = options.usart.unwrap_or(chip.default_usart());
        let no_such = Error::NoSuchUsart { chip, usart };
        let (regs, vectors) = chip.usart_regs(usart).zip(chip.vectors(usart)).ok_or(no_such)?;
        let second = match options.second_usart {
            Some(n) => {
                let regs = chip.usart_regs(n).ok_or(Error::NoSuchUsart { chip, usart: n })?;
                Some((n, regs))
            }
            None => None,
        };
        let c_path = match &path {
            Some(path) => Some(
                CString::new(path.as_os_str().as_bytes())
                    .map_err(|_| Error::BadElf { path: path.clone(), reason: "path contains a NUL byte".into() })?,
            ),
            None => None,
        };
        let c_mcu = CString::new(chip.name()).map_err(|_| Error::Internal("chip name with a NUL byte".into()))?;
        let response = u32::try_from(chip.interrupt_response_cycles()).unwrap_or(4);

        let mut err = [0 as c_char; 256];
        let raw = {
            let _guard = LOAD_LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            // SAFETY: `c_path` (if any) and `c_mcu` are NUL-terminated, `err` is writable for its
            // full length.
            unsafe {
                ffi::uno_new(
                    c_path.as_ref().map_or(std::ptr::null(), |p| p.as_ptr()),
                    c_mcu.as_ptr(),
                    c_int::from(usart),
                    regs.ucsra,
                    second.map_or(-1, |(n, _)| c_int::from(n)),
                    second.map_or(0, |(_, regs)| regs.ucsra),
                    response,
                    err.as_mut_ptr(),
                    err.len(),
                )
            }
        };
        let path = path.unwrap_or_default();
        let Some(shim) = NonNull::new(raw) else {
            // SAFETY: `uno_new` always NUL-terminates `err` within its length.
            let msg = unsafe { CStr::from_ptr(err.as_ptr()) }.to_string_lossy().into_owned();
            let reason = if msg.is_empty() { "simavr could not load the file".to_owned() } else { msg };
            return Err(Error::Load { path, reason });
        };
        Uno {
            shim,
            path,
            chip,
            usart,
            regs,
            vectors,
            symbols,
            second,
            tx: Default::default(),
            rx_flag: options.rx_flag,
            shield: None,
            logged: Vec::new(),
        }
        .with_shield(options)
    }

    /// The simulated chip.
    pub fn chip(&self) -> Chip {
        self.chip
    }

    /// The number of the USART the wire is on.
    pub fn usart(&self) -> u8 {
        self.usart
    }

    /// The USART of the second timed wire ([`Options::second_usart`]), if any.
    pub fn second_usart(&self) -> Option<u8> {
        self.second.map(|(n, _)| n)
    }

    /// The wire USART's register addresses.
    pub fn usart_regs(&self) -> UsartRegs {
        self.regs
    }

    /// Timer0's and the wire USART's interrupt vector numbers on this chip.
    pub fn vectors(&self) -> Vectors {
        self.vectors
    }

    /// A reset (power cycle or reset button): the firmware starts again from a freshly
    /// loaded ELF with the EEPROM it had written kept, as on the chip. Everything else
    /// starts over: registers, SRAM, pins driven from outside, pending serial input, the
    /// interrupt statistics and the clock ([`Uno::now`] is 0 again).
    ///
    /// [`Uno::hard_reset`] is the chip's own reset instead: the clock, SRAM and the pins
    /// driven from outside stay.
    pub fn reset(&mut self) -> Result<(), Error> {
        let eeprom = self.eeprom();
        let options = Options {
            second_usart: self.second_usart(),
            wiznet: self.shield.as_ref().map(|s| s.model),
            wiznet_cs: self.shield.as_ref().map(|s| s.cs),
            wiznet_int: self.shield.as_ref().and_then(|s| s.int),
            ..Options::new().chip(self.chip).usart(self.usart).rx_flag(self.rx_flag)
        };
        let mut fresh = Uno::load_with(&self.path, options)?;
        fresh.write_eeprom(0, &eeprom)?;
        *self = fresh;
        Ok(())
    }

    /// The firmware file this simulation runs.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn raw(&self) -> *const ffi::Shim {
        self.shim.as_ptr()
    }

    fn raw_mut(&mut self) -> *mut ffi::Shim {
        self.shim.as_ptr()
    }

    /// Current simulated time, in CPU cycles since reset.
    pub fn now(&self) -> u64 {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_cycle(self.raw()) }
    }

    /// simavr's CPU state.
    pub fn state(&self) -> CpuState {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        CpuState::from_raw(unsafe { ffi::uno_state(self.raw()) })
    }

    fn check_alive(&self) -> Result<(), Error> {
        let state = self.state();
        if state.is_alive() {
            Ok(())
        } else {
            Err(Error::Stopped { state, cycle: self.now() })
        }
    }

    /// Runs until the clock reaches `cycle` (it may end up to a few cycles later, as instructions
    /// are not divisible). Events due exactly at the returned time are handled by the next run,
    /// before any further instruction. Does nothing if `cycle` has already passed.
    pub fn run_until(&mut self, cycle: u64) -> Result<(), Error> {
        self.check_alive()?;
        if self.shield_int() {
            return self.run_with_int(cycle);
        }
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_run(self.raw_mut(), cycle, 0) };
        self.drain_tx();
        self.check_alive()
    }

    /// Runs for `cycles` more cycles.
    pub fn run_for(&mut self, cycles: u64) -> Result<(), Error> {
        self.run_until(self.now().saturating_add(cycles))
    }

    /// Executes one instruction (while the CPU sleeps: advances to the next scheduled event, by at
    /// most 1000 cycles). Useful to attribute cycles to code, e.g. by [`Step::vector`]. A shield's
    /// INT line, if wired, is brought up to date first, as [`Uno::run_until`] keeps it.
    pub fn step(&mut self) -> Result<Step, Error> {
        self.check_alive()?;
        if self.shield_int() {
            // The INT line as `run_until` keeps it: the chip brought to now (data due lands),
            // the line driven from it.
            let _ = self.wiznet_mut();
            // SAFETY: `shim` is valid and exclusively borrowed.
            unsafe { ffi::uno_spi_sync(self.raw_mut()) };
        }
        let before = self.now();
        let (mut pc, mut vector, mut entered, mut response) = (0u32, -1 as c_int, -1 as c_int, 0u64);
        let limit = before.saturating_add(STEP_SLEEP_LIMIT);
        // SAFETY: `shim` is valid and exclusively borrowed; the out-pointers are writable.
        unsafe { ffi::uno_step(self.raw_mut(), limit, &mut pc, &mut vector, &mut entered, &mut response) };
        self.drain_tx();
        self.check_alive()?;
        Ok(Step {
            pc,
            vector: u8::try_from(vector).ok(),
            cycles: self.now() - before - response,
            entered: u8::try_from(entered).ok(),
            response_cycles: response,
        })
    }

    /// Byte address of the next instruction.
    pub fn pc(&self) -> u32 {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_pc(self.raw()) }
    }

    /// The status register (bit 7 = I, global interrupt enable).
    pub fn sreg(&self) -> u8 {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_sreg(self.raw()) }
    }

    /// The stack pointer.
    pub fn sp(&self) -> u16 {
        let data = self.data();
        u16::from_le_bytes([data[0x5d], data[0x5e]])
    }

    /// The interrupt vector whose handler is executing (innermost), if any.
    pub fn in_isr(&self) -> Option<u8> {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        u8::try_from(unsafe { ffi::uno_running_vector(self.raw()) }).ok()
    }

    /// Time spent in the handler of `vector` (see [`vector`]).
    pub fn isr_stats(&self, vector: u8) -> IsrStats {
        let mut raw = ffi::IsrRaw::default();
        // SAFETY: `shim` is valid; `raw` is writable.
        unsafe { ffi::uno_isr_stats(self.raw(), vector, &mut raw) };
        IsrStats { entries: raw.entries, cycles: raw.cycles, max_cycles: raw.max_cycles }
    }

    /// Zeroes all [`IsrStats`].
    pub fn reset_isr_stats(&mut self) {
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_isr_reset(self.raw_mut()) }
    }

    // ----------------------------------------------------------------------------------------
    // USART

    /// The format the firmware configured on the wire's USART (USART0 on the Uno), or `None`
    /// while it is off (neither RXENn nor TXENn) or not in asynchronous mode.
    pub fn serial_config(&self) -> Option<SerialConfig> {
        self.serial_config_at(self.regs)
    }

    /// [`Uno::serial_config`] of USART`usart`, any USART of the chip (a wire or not); `None`
    /// also for a USART the chip lacks.
    pub fn serial_config_on(&self, usart: u8) -> Option<SerialConfig> {
        self.serial_config_at(self.chip.usart_regs(usart)?)
    }

    fn serial_config_at(&self, regs: UsartRegs) -> Option<SerialConfig> {
        let d = self.data();
        let base = usize::from(regs.ucsra);
        let cfg = SerialConfig::from_registers(d[base], d[base + 1], d[base + 2], d[base + 4], d[base + 5]);
        let asynchronous = d[base + 2] & 0xc0 == 0;
        (asynchronous && (cfg.rx_enabled || cfg.tx_enabled)).then_some(cfg)
    }

    /// Cycles per character on the wire for the format the firmware configured (see
    /// [`Uno::serial_config`]).
    pub fn wire_char_cycles(&self) -> Option<u64> {
        self.serial_config().map(|cfg| cfg.char_cycles())
    }

    /// [`Uno::wire_char_cycles`] of USART`usart` (see [`Uno::serial_config_on`]).
    pub fn wire_char_cycles_on(&self, usart: u8) -> Option<u64> {
        self.serial_config_on(usart).map(|cfg| cfg.char_cycles())
    }

    /// When RXCn rises for each received character ([`Options::rx_flag`]).
    pub fn rx_flag(&self) -> RxFlag {
        self.rx_flag
    }

    /// Cycles by which RXCn rises before the end of a received character on the line, for the
    /// format the firmware configured: half a bit with one stop bit, one and a half with two
    /// ([`SerialConfig::rx_flag_lead_cycles`]); 0 with [`RxFlag::CharEnd`]. `None` while the
    /// wire's USART is off (see [`Uno::serial_config`]).
    pub fn rx_flag_lead(&self) -> Option<u64> {
        self.rx_flag_lead_for(self.serial_config()?)
    }

    /// [`Uno::rx_flag_lead`] of USART`usart` (see [`Uno::serial_config_on`]).
    pub fn rx_flag_lead_on(&self, usart: u8) -> Option<u64> {
        self.rx_flag_lead_for(self.serial_config_on(usart)?)
    }

    fn rx_flag_lead_for(&self, cfg: SerialConfig) -> Option<u64> {
        Some(match self.rx_flag {
            RxFlag::FirstStopBit => cfg.rx_flag_lead_cycles(),
            RxFlag::CharEnd => 0,
        })
    }

    /// The wire (0) or the second wire (1) that USART`usart` is.
    fn wire_of(&self, usart: u8) -> Result<usize, Error> {
        if usart == self.usart {
            Ok(0)
        } else if self.second_usart() == Some(usart) {
            Ok(1)
        } else if !self.chip.has_usart(usart) {
            Err(Error::NoSuchUsart { chip: self.chip, usart })
        } else {
            Err(Error::Internal(format!(
                "USART{usart} is not a timed wire (the wire is USART{}; a second one: Options::second_usart)",
                self.usart
            )))
        }
    }

    /// The USART of wire `wire` (see [`Uno::wire_of`]).
    fn usart_of(&self, wire: usize) -> u8 {
        match (wire, self.second) {
            (1, Some((n, _))) => n,
            _ => self.usart,
        }
    }

    /// Schedules a character that ends at `end_cycle` on wire `wire`: RXCn rises
    /// [`Uno::rx_flag_lead`] earlier (at `end_cycle` while the USART is off).
    fn push_rx(&mut self, wire: usize, end_cycle: u64, value: u16) -> Result<(), Error> {
        let lead = self.rx_flag_lead_on(self.usart_of(wire)).unwrap_or(0);
        let flag_cycle = end_cycle.saturating_sub(lead);
        // SAFETY: `shim` is valid and exclusively borrowed.
        match unsafe { ffi::uno_rx_push(self.raw_mut(), wire as c_int, flag_cycle, value) } {
            0 => Ok(()),
            ffi::ERR_PAST => Err(Error::RxInPast { at: flag_cycle, now: self.now() }),
            ffi::ERR_ORDER => Err(Error::RxOutOfOrder { at: flag_cycle }),
            ffi::ERR_NOMEM => Err(Error::Internal("out of memory".into())),
            ffi::ERR_ARG => Err(Error::Internal(format!("uno_rx_push refused wire {wire}, value {value:#06x}"))),
            other => Err(Error::Internal(format!("uno_rx_push returned {other}"))),
        }
    }

    /// Schedules a byte from the bus master whose character ends on the line (its last stop bit
    /// over) at `end_cycle`. The firmware gets RXCn [`Uno::rx_flag_lead`] cycles before that, at
    /// the middle of the first stop bit as on the chip (at `end_cycle` with [`RxFlag::CharEnd`];
    /// not before; see the crate docs for the residual), using the format configured when the
    /// byte is scheduled. Bytes must be scheduled in time order and their RXCn not in the past.
    /// Bytes arriving while RXENn is clear are lost.
    pub fn send_byte(&mut self, byte: u8, end_cycle: u64) -> Result<(), Error> {
        self.push_rx(0, end_cycle, u16::from(byte))
    }

    /// [`Uno::send_byte`] on USART`usart`: the wire or the second wire
    /// ([`Options::second_usart`]), each with its own schedule (in time order per wire) and
    /// format.
    pub fn send_byte_on(&mut self, usart: u8, byte: u8, end_cycle: u64) -> Result<(), Error> {
        let wire = self.wire_of(usart)?;
        self.push_rx(wire, end_cycle, u16::from(byte))
    }

    /// Like [`Uno::send_byte`], with a framing or parity error.
    pub fn send_byte_with_error(&mut self, byte: u8, end_cycle: u64, error: LineError) -> Result<(), Error> {
        self.push_rx(0, end_cycle, u16::from(byte) | error.input_flag())
    }

    /// [`Uno::send_byte_with_error`] on USART`usart` (see [`Uno::send_byte_on`]).
    pub fn send_byte_with_error_on(
        &mut self,
        usart: u8,
        byte: u8,
        end_cycle: u64,
        error: LineError,
    ) -> Result<(), Error> {
        let wire = self.wire_of(usart)?;
        self.push_rx(wire, end_cycle, u16::from(byte) | error.input_flag())
    }

    /// Schedules `bytes` at the configured character time: the first ends at `first_end_cycle`,
    /// each next one `gap_cycles` of idle line after the previous one (0 = back to back).
    /// Returns the end cycle of the last byte (its end on the line: each byte's RXCn rises
    /// earlier, as [`Uno::send_byte`] says).
    pub fn send_frame(&mut self, bytes: &[u8], first_end_cycle: u64, gap_cycles: u64) -> Result<u64, Error> {
        self.send_frame_on(self.usart, bytes, first_end_cycle, gap_cycles)
    }

    /// [`Uno::send_frame`] on USART`usart`, at its configured character time (see
    /// [`Uno::send_byte_on`]).
    pub fn send_frame_on(
        &mut self,
        usart: u8,
        bytes: &[u8],
        first_end_cycle: u64,
        gap_cycles: u64,
    ) -> Result<u64, Error> {
        let wire = self.wire_of(usart)?;
        let char_cycles = self.wire_char_cycles_on(usart).ok_or(Error::UartNotConfigured)?;
        let step = char_cycles.saturating_add(gap_cycles);
        let mut end = first_end_cycle;
        for (i, &byte) in bytes.iter().enumerate() {
            if i > 0 {
                end = end.saturating_add(step);
            }
            self.push_rx(wire, end, u16::from(byte))?;
        }
        Ok(end)
    }

    /// Bytes scheduled with [`Uno::send_byte`] that have not arrived yet.
    pub fn pending_rx(&self) -> usize {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_rx_pending(self.raw(), 0) }
    }

    /// [`Uno::pending_rx`] of USART`usart` (a wire).
    pub fn pending_rx_on(&self, usart: u8) -> Result<usize, Error> {
        let wire = self.wire_of(usart)?;
        // SAFETY: `shim` is valid for the lifetime of `self`.
        Ok(unsafe { ffi::uno_rx_pending(self.raw(), wire as c_int) })
    }

    /// Drops all bytes that have not arrived yet.
    pub fn cancel_rx(&mut self) {
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_rx_clear(self.raw_mut(), 0) }
    }

    /// [`Uno::cancel_rx`] on USART`usart` (a wire).
    pub fn cancel_rx_on(&mut self, usart: u8) -> Result<(), Error> {
        let wire = self.wire_of(usart)?;
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_rx_clear(self.raw_mut(), wire as c_int) };
        Ok(())
    }

    fn counters_of(&self, wire: usize) -> UartCounters {
        let mut c = UartCounters::default();
        // SAFETY: `shim` is valid; the three pointers are writable.
        unsafe {
            ffi::uno_uart_counters(self.raw(), wire as c_int, &mut c.rx_dropped, &mut c.rx_overruns, &mut c.tx_ignored)
        };
        c
    }

    /// Counters of dropped, overrun and ignored bytes.
    pub fn uart_counters(&self) -> UartCounters {
        self.counters_of(0)
    }

    /// [`Uno::uart_counters`] of USART`usart` (a wire).
    pub fn uart_counters_on(&self, usart: u8) -> Result<UartCounters, Error> {
        Ok(self.counters_of(self.wire_of(usart)?))
    }

    /// simavr's flags (`AVR_UART_FLAG_*`) of the wire's USART; this crate clears POLL_SLEEP and
    /// STDIO on every USART.
    pub fn uart_sim_flags(&self) -> u32 {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_uart_flags(self.raw()) }
    }

    fn wires(&self) -> usize {
        if self.second.is_some() {
            2
        } else {
            1
        }
    }

    fn drain_tx(&mut self) {
        let mut buf = [ffi::TxRaw::default(); 256];
        for wire in 0..self.wires() {
            loop {
                // SAFETY: `shim` is valid for the lifetime of `self`.
                if unsafe { ffi::uno_tx_len(self.raw(), wire as c_int) } == 0 {
                    break;
                }
                // SAFETY: `shim` is valid; `buf` is writable for `buf.len()` entries.
                let n = unsafe { ffi::uno_tx_take(self.raw_mut(), wire as c_int, buf.as_mut_ptr(), buf.len()) };
                self.tx[wire].extend(buf[..n].iter().map(|t| TxByte {
                    byte: t.byte,
                    start_cycle: t.start,
                    end_cycle: t.end,
                }));
            }
        }
    }

    /// Takes every frame the firmware has transmitted on the wire since the last call, oldest
    /// first. A frame is listed as soon as UDRn is written, so its `end_cycle` may still be in
    /// the future.
    pub fn take_tx(&mut self) -> Vec<TxByte> {
        self.drain_tx();
        std::mem::take(&mut self.tx[0])
    }

    /// [`Uno::take_tx`] of USART`usart`: the wire or the second wire ([`Options::second_usart`]),
    /// each with its own frames.
    pub fn take_tx_on(&mut self, usart: u8) -> Result<Vec<TxByte>, Error> {
        let wire = self.wire_of(usart)?;
        self.drain_tx();
        Ok(std::mem::take(&mut self.tx[wire]))
    }

    /// Takes the bytes the firmware has transmitted on USART`usart`, another USART than the
    /// wires, since the last call (oldest first; simavr's own timing, not modelled here: a byte
    /// is listed when it is written to UDRn). [`Error::WireUsart`] for the wire's USART (and
    /// the second wire's), [`Error::NoSuchUsart`] for one the chip lacks.
    pub fn take_usart_output(&mut self, usart: u8) -> Result<Vec<u8>, Error> {
        if !self.chip.has_usart(usart) {
            return Err(Error::NoSuchUsart { chip: self.chip, usart });
        }
        if usart == self.usart || self.second_usart() == Some(usart) {
            return Err(Error::WireUsart(usart));
        }
        let mut out = Vec::new();
        let mut buf = [0u8; 256];
        loop {
            // SAFETY: `shim` is valid and exclusively borrowed; `buf` is writable for its length.
            let n = unsafe { ffi::uno_usart_take(self.raw_mut(), c_int::from(usart), buf.as_mut_ptr(), buf.len()) };
            let Ok(n) = usize::try_from(n) else {
                return Err(Error::Internal(format!("uno_usart_take({usart}) returned {n}")));
            };
            out.extend_from_slice(&buf[..n]);
            if n < buf.len() {
                return Ok(out);
            }
        }
    }

    fn busy_until_of(&self, wire: usize) -> Option<u64> {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        match unsafe { ffi::uno_tx_busy_until(self.raw(), wire as c_int) } {
            0 => None,
            cycle => Some(cycle),
        }
    }

    /// Cycle at which the transmitter becomes idle, if it is busy.
    pub fn tx_busy_until(&self) -> Option<u64> {
        self.busy_until_of(0)
    }

    /// [`Uno::tx_busy_until`] of USART`usart` (a wire).
    pub fn tx_busy_until_on(&self, usart: u8) -> Result<Option<u64>, Error> {
        Ok(self.busy_until_of(self.wire_of(usart)?))
    }

    /// Runs until the firmware has sent something and then left the line idle for `idle_cycles`
    /// after the end of its last frame, or until `deadline`. Returns what [`Uno::take_tx`] would
    /// (empty if nothing was sent by `deadline`).
    pub fn run_until_tx_idle(&mut self, idle_cycles: u64, deadline: u64) -> Result<Vec<TxByte>, Error> {
        self.run_until_tx_idle_of(0, idle_cycles, deadline)
    }

    /// [`Uno::run_until_tx_idle`] on USART`usart` (a wire): what the firmware sends on the other
    /// wire meanwhile stays for [`Uno::take_tx_on`].
    pub fn run_until_tx_idle_on(&mut self, usart: u8, idle_cycles: u64, deadline: u64) -> Result<Vec<TxByte>, Error> {
        let wire = self.wire_of(usart)?;
        self.run_until_tx_idle_of(wire, idle_cycles, deadline)
    }

    fn run_until_tx_idle_of(&mut self, wire: usize, idle_cycles: u64, deadline: u64) -> Result<Vec<TxByte>, Error> {
        loop {
            self.drain_tx();
            let now = self.now();
            let target = match self.tx[wire].last() {
                Some(last) => {
                    let busy = self.busy_until_of(wire).unwrap_or(0);
                    let quiet_at = last.end_cycle.max(busy).saturating_add(idle_cycles);
                    if now >= quiet_at {
                        return Ok(std::mem::take(&mut self.tx[wire]));
                    }
                    quiet_at.min(deadline)
                }
                None => deadline,
            };
            if now >= deadline {
                return Ok(std::mem::take(&mut self.tx[wire]));
            }
            self.check_alive()?;
            // SAFETY: `shim` is valid and exclusively borrowed.
            unsafe { ffi::uno_run(self.raw_mut(), target, ffi::stop_on_tx_of(wire)) };
            self.check_alive()?;
        }
    }

    // ----------------------------------------------------------------------------------------
    // memory

    fn data(&self) -> &[u8] {
        let mut len = 0usize;
        // SAFETY: `uno_data` only reads the simavr instance; the returned buffer (registers, I/O and
        // SRAM) is `len` bytes long, lives as long as the instance and is only written by the
        // simulation, which needs `&mut self`.
        unsafe {
            let ptr = ffi::uno_data(self.shim.as_ptr(), &mut len);
            std::slice::from_raw_parts(ptr, len)
        }
    }

    fn data_mut(&mut self) -> &mut [u8] {
        let mut len = 0usize;
        // SAFETY: as in `data`; `&mut self` makes this the only access to the buffer.
        unsafe {
            let ptr = ffi::uno_data(self.shim.as_ptr(), &mut len);
            std::slice::from_raw_parts_mut(ptr, len)
        }
    }

    fn range(&self, addr: usize, len: usize) -> Result<std::ops::Range<usize>, Error> {
        let size = self.data().len();
        match addr.checked_add(len) {
            Some(end) if end <= size => Ok(addr..end),
            _ => Err(Error::OutOfRange { addr, len, size }),
        }
    }

    /// Reads `len` bytes of data space at `addr` (0x000-0x01F registers, 0x020-0x0FF I/O,
    /// 0x100-0x8FF SRAM on the 328P; up to RAMEND on other chips). Reads raw memory: no I/O
    /// side effects (reading UDR0 does not pop a byte).
    pub fn read_ram(&self, addr: u16, len: usize) -> Result<Vec<u8>, Error> {
        let range = self.range(usize::from(addr), len)?;
        Ok(self.data()[range].to_vec())
    }

    /// Writes `bytes` to data space at `addr`. Writes raw memory: I/O registers change without
    /// side effects.
    pub fn write_ram(&mut self, addr: u16, bytes: &[u8]) -> Result<(), Error> {
        let range = self.range(usize::from(addr), bytes.len())?;
        self.data_mut()[range].copy_from_slice(bytes);
        Ok(())
    }

    /// Size of the EEPROM (1024 bytes on the 328P and 32U4, 512 on the 168, 4096 on the Megas).
    pub fn eeprom_size(&self) -> usize {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_eeprom_size(self.raw()) as usize }
    }

    /// The whole EEPROM (a fresh Uno's reads 0xFF; the ELF's `.eeprom` section is loaded).
    pub fn eeprom(&self) -> Vec<u8> {
        let mut bytes = vec![0xFF; self.eeprom_size()];
        // The range is the whole EEPROM, so the read can't fail.
        let _ = self.read_eeprom_into(0, &mut bytes);
        bytes
    }

    fn read_eeprom_into(&self, addr: usize, out: &mut [u8]) -> Result<(), Error> {
        let (Ok(offset), Ok(len)) = (u32::try_from(addr), u32::try_from(out.len())) else {
            return Err(Error::EepromOutOfRange { addr, len: out.len() });
        };
        // SAFETY: `shim` is valid (the simulation is not running: `&self` excludes `&mut self`
        // users); `out` is writable for `len` bytes; the shim checks the range.
        match unsafe { ffi::uno_eeprom_read(self.shim.as_ptr(), offset, out.as_mut_ptr(), len) } {
            0 => Ok(()),
            _ => Err(Error::EepromOutOfRange { addr, len: out.len() }),
        }
    }

    /// Reads `len` EEPROM bytes from `addr`.
    pub fn read_eeprom(&self, addr: usize, len: usize) -> Result<Vec<u8>, Error> {
        let mut bytes = vec![0; len];
        self.read_eeprom_into(addr, &mut bytes)?;
        Ok(bytes)
    }

    /// Overwrites EEPROM bytes from `addr`, at once and without the firmware noticing (as if
    /// written by a programmer, or damaged).
    pub fn write_eeprom(&mut self, addr: usize, bytes: &[u8]) -> Result<(), Error> {
        let (Ok(offset), Ok(len)) = (u32::try_from(addr), u32::try_from(bytes.len())) else {
            return Err(Error::EepromOutOfRange { addr, len: bytes.len() });
        };
        // SAFETY: `shim` is valid and exclusively borrowed; `bytes` is readable for `len`
        // bytes; the shim checks the range.
        match unsafe { ffi::uno_eeprom_write(self.raw_mut(), offset, bytes.as_ptr(), len) } {
            0 => Ok(()),
            _ => Err(Error::EepromOutOfRange { addr, len: bytes.len() }),
        }
    }

    /// The flash's size in bytes (32 KiB on the Uno).
    pub fn flash_size(&self) -> usize {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_flash_size(self.raw()) as usize }
    }

    /// The whole flash, as a programmer would read it back.
    pub fn flash(&self) -> Vec<u8> {
        let mut bytes = vec![0xFF; self.flash_size()];
        // SAFETY: `shim` is valid; `bytes` is writable for the whole flash, the range the
        // shim checks.
        unsafe { ffi::uno_flash_read(self.raw(), 0, bytes.as_mut_ptr(), bytes.len() as u32) };
        bytes
    }

    /// Programs `bytes` at flash byte address `addr`, as an ISP programmer would (the running
    /// program is not told; reset it to start what was written).
    pub fn write_flash(&mut self, addr: usize, bytes: &[u8]) -> Result<(), Error> {
        let out_of_range = Error::FlashOutOfRange { addr, len: bytes.len() };
        let (Ok(offset), Ok(len)) = (u32::try_from(addr), u32::try_from(bytes.len())) else {
            return Err(out_of_range);
        };
        // SAFETY: `shim` is valid and exclusively borrowed; `bytes` is readable for `len`
        // bytes; the shim checks the range.
        match unsafe { ffi::uno_flash_write(self.raw_mut(), offset, bytes.as_ptr(), len) } {
            0 => Ok(()),
            _ => Err(out_of_range),
        }
    }

    /// Programs a bootloader from an Intel HEX file into the boot section it was linked for
    /// and makes the chip start there at every reset, as the BOOTRST fuse of a board with a
    /// bootloader does. Returns that address. The section must start 256 B to 8 KiB below the
    /// top of the flash (a power of two), as the chips' BOOTSZ fuses allow.
    pub fn install_bootloader(&mut self, path: &Path) -> Result<u32, Error> {
        let bad = |reason: String| Error::BadHex { path: path.to_owned(), reason };
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
        let chunks = hex::parse(&text).map_err(bad)?;
        let start = chunks.iter().map(|c| c.addr).min().ok_or_else(|| bad("holds no data".into()))?;
        let below_top = (self.flash_size() as u64).saturating_sub(u64::from(start));
        if !(below_top.is_power_of_two() && (256..=8192).contains(&below_top)) {
            return Err(bad(format!(
                "starts at 0x{start:05x}, not at a boot section of the {}'s {} KiB flash",
                self.chip,
                self.flash_size() / 1024
            )));
        }
        for chunk in &chunks {
            self.write_flash(chunk.addr as usize, &chunk.bytes)?;
        }
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_set_reset_address(self.raw_mut(), start) };
        Ok(start)
    }

    /// Resets the chip with the clock running on: its RESET pin pulled low
    /// ([`ResetCause::External`], what a USB-serial board's DTR does) or power applied
    /// ([`ResetCause::PowerOn`]). The core starts at its reset address (0, or the bootloader's
    /// after [`Uno::install_bootloader`]) with MCUSR telling why; I/O registers start over;
    /// flash, EEPROM, SRAM, pins driven from outside and [`Uno::now`] stay; characters on the
    /// wire are lost. A watchdog reset happens on its own ([`Uno::resets`] counts it).
    pub fn hard_reset(&mut self, cause: ResetCause) {
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_reset(self.raw_mut(), cause.mcusr_bit()) }
        self.reset_shield();
    }

    /// Resets since the simulation started ([`Uno::hard_reset`] and the watchdog's), and the
    /// cause of the last one, read from MCUSR as the chip set it.
    pub fn resets(&self) -> (u64, Option<ResetCause>) {
        let mut mcusr = 0u8;
        // SAFETY: `shim` is valid for the lifetime of `self`; `mcusr` is writable.
        let count = unsafe { ffi::uno_resets(self.raw(), &mut mcusr) };
        (count, ResetCause::from_mcusr(mcusr))
    }

    /// The firmware's symbol table (empty for a stripped file).
    pub fn symbols(&self) -> &[Symbol] {
        &self.symbols
    }

    /// Looks up a symbol by name.
    pub fn symbol(&self, name: &str) -> Option<&Symbol> {
        self.symbols.iter().find(|s| s.name == name)
    }

    /// Reads the current value of a variable in SRAM (its full size).
    pub fn read_symbol(&self, name: &str) -> Result<Vec<u8>, Error> {
        let sym = self.symbol(name).ok_or_else(|| Error::UnknownSymbol(name.to_owned()))?;
        if sym.space != Space::Ram {
            return Err(Error::NotInRam(name.to_owned()));
        }
        let range = self.range(sym.addr as usize, sym.size as usize)?;
        Ok(self.data()[range].to_vec())
    }

    /// Overwrites a variable in SRAM; `bytes` must not be longer than the variable.
    pub fn write_symbol(&mut self, name: &str, bytes: &[u8]) -> Result<(), Error> {
        let sym = self.symbol(name).ok_or_else(|| Error::UnknownSymbol(name.to_owned()))?;
        if sym.space != Space::Ram {
            return Err(Error::NotInRam(name.to_owned()));
        }
        let (addr, size) = (sym.addr as usize, sym.size as usize);
        if bytes.len() > size {
            return Err(Error::SymbolTooSmall { name: name.to_owned(), size, len: bytes.len() });
        }
        let range = self.range(addr, bytes.len())?;
        self.data_mut()[range].copy_from_slice(bytes);
        Ok(())
    }
}
