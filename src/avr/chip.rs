//! What differs between the chips the crate runs on, as the chosen chip's table: the USARTs'
//! register blocks, the interrupt vectors the slave binds, the EEPROM's size and the board's
//! LED. Everything else the slave uses — Timer0's registers, the EEPROM's, SREG — sits at
//! the same addresses on all of them. The facts are data, one block per chip in
//! `chips/chips.txt`.
//!
//! The chip is the one the build is for (`-C target-cpu`, or a JSON target's name); build.rs
//! writes its table from the file, and it is included here: the drivers read [`CHIP`] and
//! carry no `cfg` of their own. Vector names must be literals where [`crate::slave!`] binds
//! them, so the table has a twin, the `__chip!` macro, that names them.

/// One chip's facts.
pub(crate) struct Chip {
    /// The data-space address of each USART's register block (UCSRnA … UDRn, 7 bytes), by
    /// number; `None` where the chip has no such USART.
    pub(crate) usarts: [Option<usize>; 4],
    /// The EEPROM's size in bytes.
    #[cfg_attr(not(any(feature = "examples", feature = "eeprom-settings")), allow(dead_code))]
    pub(crate) eeprom_size: u16,
    /// The on-board LED "L" of the chip's Arduino boards: the data-space address of its
    /// port's PINx register (DDRx and PORTx follow), and its bit (the examples' `board`).
    #[cfg_attr(not(feature = "examples"), allow(dead_code))]
    pub(crate) led: (usize, u8),
    /// The SPI's SS, MOSI and SCK, and the board's pin 10 (the Ethernet shields' chip
    /// select): their bits on port B (feature `tcp`).
    #[cfg_attr(not(feature = "tcp"), allow(dead_code))]
    pub(crate) spi: [u8; 4],
    /// The board's pin 2 as an external interrupt (the W5100 shield's INT jumper, feature
    /// `tcp`): the EICRx address and the shift of its sense bits there, its EIMSK bit, its
    /// port's PINx address and its bit.
    #[cfg_attr(not(feature = "tcp"), allow(dead_code))]
    pub(crate) pin2_int: (usize, u8, u8, usize, u8),
    /// The timer of the capture line (`super::capture`).
    #[cfg_attr(not(feature = "capture-line"), allow(dead_code))]
    pub(crate) capture: CaptureTimer,
}

/// The timer whose input capture and output compare A make the capture line, AltSoftSerial's
/// pins (`super::capture`): Timer1 on the 328P and 168, Timer3 on the 32U4, Timer5 on the
/// Megas.
#[cfg_attr(not(feature = "capture-line"), allow(dead_code))]
pub(crate) struct CaptureTimer {
    /// The data-space address of TCCRnA; TCCRnB, TCCRnC, TCNTn, ICRn, OCRnA and OCRnB follow
    /// at +1, +2, +4, +6, +8 and +10.
    pub(crate) block: usize,
    /// TIMSKn.
    pub(crate) timsk: usize,
    /// TIFRn.
    pub(crate) tifr: usize,
    /// The PINx address of the port with both pins (DDRx and PORTx follow).
    pub(crate) port: usize,
    /// The ICP pin's bit: the line's RX.
    pub(crate) rx: u8,
    /// The OCnA pin's bit: the line's TX.
    pub(crate) tx: u8,
    /// The PAC's register block for the timer (`TC1`, `TC3`, `TC5`): address and size.
    pub(crate) peripheral: (usize, usize),
}

impl Chip {
    /// The register block of USART `number`; a build error for one the chip lacks (the
    /// `slave!` that names it has already failed the build with a message of its own).
    pub(crate) const fn usart(&self, number: u8) -> usize {
        match self.usarts[number as usize] {
            Some(address) => address,
            None => panic!("this chip has no such USART"),
        }
    }
}

// The chip's `CHIP` and `__chip!`, written by build.rs from its block of chips/chips.txt
// (on the host, for the docs: the first chip's `CHIP`, the Uno's, which no page shows).
include!(concat!(env!("OUT_DIR"), "/chip.rs"));
