//! The SPI as a bus master for the Ethernet chip (feature `tcp`), ATmega328P datasheet §19:
//! mode 0, most significant bit first, the CPU clock / 2 (8 MHz at 16 MHz, the AVR's
//! fastest), polled (no SPI interrupt); chip select on a port B pin, the board's pin 10 (the
//! shields') unless the application hands another [`OutputPin`].

use embedded_hal::digital::{ErrorType, OutputPin};

use super::reg::Reg;
use crate::tcp::wiznet::Bus;

const SPCR: Reg = Reg::at(0x4C);
const SPSR: Reg = Reg::at(0x4D);
const SPDR: Reg = Reg::at(0x4E);
const DDRB: Reg = Reg::at(0x24);
const PORTB: Reg = Reg::at(0x25);

/// SPCR: SPI enable, master; mode 0, MSB first, divider 4 (halved by SPI2X).
const SPE_MSTR: u8 = 1 << 6 | 1 << 4;
/// SPSR: double speed.
const SPI2X: u8 = 1 << 0;
/// SPSR: the byte is done.
const SPIF: u8 = 1 << 7;

/// The SPI's register block (SPCR, SPSR, SPDR) where the application's HAL has it.
pub(crate) const SPI_BLOCK: (usize, usize) = (0x4C, 3);

/// The board's pin 10 (the shields' chip select) as an output pin: PB2 on the Uno, PB4 on the
/// Mega, PB6 on the Leonardo. What [`crate::tcp_server!`] uses unless told another pin.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pin10;

const PIN10: u8 = 1 << super::chip::CHIP.spi[3];

impl ErrorType for Pin10 {
    type Error = core::convert::Infallible;
}

impl OutputPin for Pin10 {
    #[inline(always)]
    fn set_low(&mut self) -> Result<(), Self::Error> {
        PORTB.modify(|p| p & !PIN10);
        Ok(())
    }

    #[inline(always)]
    fn set_high(&mut self) -> Result<(), Self::Error> {
        PORTB.modify(|p| p | PIN10);
        Ok(())
    }
}

/// The SPI with chip select `CS`.
pub(crate) struct Spi<CS> {
    cs: CS,
}

impl<CS: OutputPin> Spi<CS> {
    /// Takes SS, MOSI, SCK and pin 10 as outputs (SS high: as an output it keeps the SPI
    /// master whatever drives it), the chip deselected, and sets the SPI up.
    pub(crate) fn new(mut cs: CS) -> Self {
        let [ss, mosi, sck, pin10] = super::chip::CHIP.spi;
        let _ = cs.set_high();
        PORTB.modify(|p| p | 1 << ss | 1 << pin10);
        DDRB.modify(|d| d | 1 << ss | 1 << mosi | 1 << sck | 1 << pin10);
        let mut spi = Spi { cs };
        spi.configure();
        spi
    }

    /// Sets the SPI up again, as another driver may have left it otherwise.
    #[inline(always)]
    pub(crate) fn configure(&mut self) {
        SPCR.write(SPE_MSTR);
        SPSR.write(SPI2X);
    }
}

impl<CS: OutputPin> Bus for Spi<CS> {
    #[inline(always)]
    fn select(&mut self) {
        let _ = self.cs.set_low();
    }

    #[inline(always)]
    fn deselect(&mut self) {
        let _ = self.cs.set_high();
    }

    #[inline(always)]
    fn transfer(&mut self, out: u8) -> u8 {
        SPDR.write(out);
        wait();
        SPDR.read()
    }

    /// Each next byte starts as soon as the last is in, and the last is stored while the
    /// next one shifts: the SPI never waits for the loop.
    fn read_into(&mut self, buf: &mut [u8]) {
        let Some((last, rest)) = buf.split_last_mut() else { return };
        SPDR.write(0);
        for byte in rest {
            wait();
            let got = SPDR.read();
            SPDR.write(0);
            *byte = got;
        }
        wait();
        *last = SPDR.read();
    }

    /// Each next byte is loaded while the last one shifts.
    fn write_from(&mut self, data: &[u8]) {
        let Some((&first, rest)) = data.split_first() else { return };
        SPDR.write(first);
        for &byte in rest {
            wait();
            SPDR.write(byte);
        }
        wait();
        // SPIF cleared (SPSR read with it set, then SPDR), as after `transfer`.
        let _ = SPDR.read();
    }
}

/// Until the byte under way is done.
#[inline(always)]
fn wait() {
    while SPSR.read() & SPIF == 0 {}
}
