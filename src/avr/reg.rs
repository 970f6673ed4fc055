//! I/O registers by data-space address, ATmega328P datasheet §36 (register summary), and
//! the global interrupt flag (§7.3.1, SREG bit 7). Timer0, the EEPROM, the ports and SREG
//! sit at these addresses on every chip the crate runs on; the USARTs' blocks, which
//! differ, are in the chip's table (`super::chip`).
//!
//! The drivers reach their registers here rather than through a PAC type, so the crate
//! works with whichever `avr-device` the application's HAL brings; the slave checks the
//! peripherals it is handed (see `crate::avr::Peripheral`) and keeps them, so nothing else
//! can own the same registers.

use core::arch::asm;
use core::ops::Deref;
use core::ptr;

use crate::error::Error;

/// One 8-bit I/O register.
#[derive(Clone, Copy)]
pub(crate) struct Reg(usize);

impl Reg {
    /// The register at data-space `address`.
    pub(crate) const fn at(address: usize) -> Self {
        Reg(address)
    }

    /// Reads the register.
    #[inline(always)]
    pub(crate) fn read(self) -> u8 {
        // SAFETY: every `Reg` names an I/O register of the ATmega328P; reading one has
        // no effect beyond what the datasheet gives it (UDR0 pops the received byte).
        unsafe { ptr::read_volatile(self.0 as *const u8) }
    }

    /// Writes the register.
    #[inline(always)]
    pub(crate) fn write(self, value: u8) {
        // SAFETY: as in `read`; the callers write values laid out as the datasheet says.
        unsafe { ptr::write_volatile(self.0 as *mut u8, value) }
    }

    /// Reads, changes and writes the register back. Not atomic: use it on registers no
    /// interrupt handler writes, or inside [`free`].
    #[inline(always)]
    pub(crate) fn modify(self, f: impl FnOnce(u8) -> u8) {
        self.write(f(self.read()));
    }
}

/// Data-space address and register-block size of the peripherals the crate takes, as the
/// PAC (`avr-device`, generated from Microchip's ATDF) lays them out.
/// A USART (the address is the chip's, `super::chip`).
pub(crate) const USART_SIZE: usize = 7;
/// Timer0: TIFR0 (0x35) to TIMSK0 (0x6E).
pub(crate) const TC0: (usize, usize) = (0x35, 0x3A);
/// Port B: PINB, DDRB, PORTB.
#[cfg(feature = "examples")]
pub(crate) const PORTB: (usize, usize) = (0x23, 3);
/// Port C.
#[cfg(feature = "examples")]
pub(crate) const PORTC: (usize, usize) = (0x26, 3);
/// Port D.
#[cfg(feature = "examples")]
pub(crate) const PORTD: (usize, usize) = (0x29, 3);
/// The ADC: ADCL (0x78) to DIDR0 (0x7E).
#[cfg(feature = "examples")]
pub(crate) const ADC: (usize, usize) = (0x78, 7);
/// The EEPROM: EECR (0x3F) to EEARH (0x42).
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
pub(crate) const EEPROM: (usize, usize) = (0x3F, 4);

/// Takes a peripheral from the application's PAC (`avr-device`, any version: its
/// peripherals dereference to their register block) and checks that it is the one at
/// `address`: a register block of another size (`SIZE`) is a build error, another address
/// an `Err` (a check the compiler folds away for the right peripheral). The peripheral is
/// consumed, so the application can't use it beside the crate.
pub(crate) fn claim<P: Deref, const SIZE: usize>(peripheral: P, address: usize) -> Result<(), Error>
where
    P::Target: Sized,
{
    const { assert!(core::mem::size_of::<P::Target>() == SIZE, "not the peripheral expected here") };
    claim_at(peripheral, address)
}

/// [`claim`] without the check of the block's size (the caller checks it).
#[inline(always)]
pub(crate) fn claim_at<P: Deref>(peripheral: P, address: usize) -> Result<(), Error>
where
    P::Target: Sized,
{
    if ptr::from_ref(&*peripheral) as usize == address {
        Ok(())
    } else {
        Err(Error::WrongPeripheral)
    }
}

/// Timer0 interrupt flags.
pub(crate) const TIFR0: Reg = Reg(0x35);
/// Timer0 control A (waveform generation, compare outputs).
pub(crate) const TCCR0A: Reg = Reg(0x44);
/// Timer0 control B (clock select).
pub(crate) const TCCR0B: Reg = Reg(0x45);
/// Timer0 counter.
pub(crate) const TCNT0: Reg = Reg(0x46);
/// Timer0 output compare A.
pub(crate) const OCR0A: Reg = Reg(0x47);
/// Timer0 output compare B.
pub(crate) const OCR0B: Reg = Reg(0x48);
/// Timer0 interrupt mask.
pub(crate) const TIMSK0: Reg = Reg(0x6E);

/// EEPROM control.
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
pub(crate) const EECR: Reg = Reg(0x3F);
/// EEPROM data.
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
pub(crate) const EEDR: Reg = Reg(0x40);
/// EEPROM address, low byte.
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
pub(crate) const EEARL: Reg = Reg(0x41);
/// EEPROM address, high byte.
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
pub(crate) const EEARH: Reg = Reg(0x42);

/// ADC result, low byte (read it first: that locks the high byte).
#[cfg(feature = "examples")]
pub(crate) const ADCL: Reg = Reg(0x78);
/// ADC result, high byte.
#[cfg(feature = "examples")]
pub(crate) const ADCH: Reg = Reg(0x79);
/// ADC control and status A.
#[cfg(feature = "examples")]
pub(crate) const ADCSRA: Reg = Reg(0x7A);
/// ADC multiplexer selection.
#[cfg(feature = "examples")]
pub(crate) const ADMUX: Reg = Reg(0x7C);

/// Status register; bit 7 is the global interrupt enable.
const SREG: Reg = Reg(0x5F);
const SREG_I: u8 = 1 << 7;

/// Runs `f` with interrupts disabled, then restores the interrupt flag as it was: a
/// critical section that nests. The `cli` and `sei` are compiler barriers (`asm!` without
/// `nomem`), so no memory access moves out of the section.
#[inline(always)]
pub(crate) fn free<R>(f: impl FnOnce() -> R) -> R {
    let sreg = SREG.read();
    // SAFETY: disabling interrupts is always sound.
    unsafe { asm!("cli") };
    let result = f();
    if sreg & SREG_I != 0 {
        // SAFETY: interrupts were enabled when the section began; enabling them again
        // restores that state.
        unsafe { asm!("sei") };
    }
    result
}

/// [`free`], telling `f` whether interrupts were enabled when the section began (true in
/// the main loop and in a handler that enabled them, the TCP server's poll; false inside
/// any other interrupt handler).
#[inline(always)]
pub(crate) fn free_telling<R>(f: impl FnOnce(bool) -> R) -> R {
    let enabled = SREG.read() & SREG_I != 0;
    free(|| f(enabled))
}

/// `value`, computed before this point: an empty `asm!` takes it in registers and, not
/// being pure, keeps its place among the `cli` and `sei` of [`free`]. Without it the
/// compiler may sink a computation whose result only a critical section uses into that
/// section (it moved `millis() / 1000`, a 32-bit division of 600 cycles, between the `cli`
/// and `sei` of `Slave::set`, holding the slave's interrupts off for 40 µs).
#[inline(always)]
pub(crate) fn computed(value: u16) -> u16 {
    let mut value = value;
    // SAFETY: an empty instruction sequence that reads and writes back one register pair.
    unsafe { asm!("/* {0} */", inout(reg_pair) value, options(nomem, nostack, preserves_flags)) };
    value
}

/// Enables interrupts globally.
///
/// # Safety
/// Every interrupt whose enable bit is set must have a handler that is ready to run.
#[inline(always)]
pub(crate) unsafe fn enable_interrupts() {
    // SAFETY: the caller's promise.
    unsafe { asm!("sei") };
}

/// Disables interrupts (the TCP server's poll, at its end; the slave on the capture line
/// after its request).
///
/// # Safety
/// Only where the code that follows expects them off and restores them itself (an
/// interrupt handler's return).
#[cfg(any(feature = "tcp", feature = "capture-line"))]
#[inline(always)]
pub(crate) unsafe fn disable_interrupts() {
    // SAFETY: the caller's promise.
    unsafe { asm!("cli") };
}
