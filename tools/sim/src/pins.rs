//! GPIO and ADC: pins by port and bit on every chip, by Arduino Uno pin number on the 328P and
//! 168 (0-7 = PD0-7, 8-13 = PB0-5, 14-19 = A0-A5 = PC0-5).
//!
//! The Uno numbering does not carry over: a Mega's LED (pin 13) is PB7, a Leonardo's PC7.

use std::ffi::{c_char, c_int};

use crate::{ffi, Error, Uno};

/// Arduino pin number of analog input A0 (PC0); A1..A5 follow.
pub const A0: u8 = 14;
/// Arduino pin number of A1 (PC1).
pub const A1: u8 = 15;
/// Arduino pin number of A2 (PC2).
pub const A2: u8 = 16;
/// Arduino pin number of A3 (PC3).
pub const A3: u8 = 17;
/// Arduino pin number of A4 (PC4).
pub const A4: u8 = 18;
/// Arduino pin number of A5 (PC5).
pub const A5: u8 = 19;

/// Direction and level of a pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinState {
    /// DDR bit set: the firmware drives the pin.
    pub output: bool,
    /// For an output, the level it drives; for an input, what the firmware reads from PINx.
    pub level: bool,
    /// Input with the internal pull-up on (DDR bit clear, PORT bit set).
    pub pull_up: bool,
}

impl Uno {
    /// Port letter and bit of an Arduino Uno pin, on a chip wired like the Uno.
    fn uno_port_bit(&self, pin: u8) -> Result<(char, u8), Error> {
        if !self.chip().has_uno_pinout() {
            return Err(Error::NoArduinoPins(self.chip()));
        }
        match pin {
            0..=7 => Ok(('D', pin)),
            8..=13 => Ok(('B', pin - 8)),
            14..=19 => Ok(('C', pin - 14)),
            _ => Err(Error::BadPin(pin)),
        }
    }

    /// Direction and level of Arduino Uno pin `pin` (0-13, [`A0`]-[`A5`]); on a chip not wired
    /// like the Uno, [`Error::NoArduinoPins`] (use [`Uno::port_pin`]).
    pub fn pin(&self, pin: u8) -> Result<PinState, Error> {
        let (port, bit) = self.uno_port_bit(pin)?;
        self.port_pin(port, bit)
    }

    /// Drives input pin `pin` high or low from outside (`Some(level)`, e.g. a switch), or
    /// releases it (`None`: reads high if its pull-up is on, else low). Pin-change and external
    /// interrupts fire as on the chip. Arduino Uno pin numbers, as [`Uno::pin`].
    pub fn drive_pin(&mut self, pin: u8, level: Option<bool>) -> Result<(), Error> {
        let (port, bit) = self.uno_port_bit(pin)?;
        self.drive_port_pin(port, bit, level).map_err(|_| Error::BadPin(pin))
    }

    /// The port's letter for the shim and the data-space addresses of its PINx, DDRx and PORTx,
    /// if the chip has pin P`port``bit`.
    fn port_regs(&self, port: char, bit: u8) -> Result<(c_char, [usize; 3]), Error> {
        let no_such = Error::NoSuchPortPin { chip: self.chip(), port, bit };
        let (Ok(letter), true) = (u8::try_from(port), bit < 8) else {
            return Err(no_such);
        };
        let letter = letter as c_char;
        let (mut pin, mut ddr, mut port_reg) = (0u16, 0u16, 0u16);
        // SAFETY: `shim` is valid for the lifetime of `self`; the out-pointers are writable.
        match unsafe { ffi::uno_port_regs(self.raw(), letter, &mut pin, &mut ddr, &mut port_reg) } {
            0 => Ok((letter, [pin, ddr, port_reg].map(usize::from))),
            _ => Err(no_such),
        }
    }

    /// Direction and level of pin P`port``bit` (`port_pin('B', 7)`: PB7, a Mega's LED), on any
    /// chip; [`Error::NoSuchPortPin`] if the chip has no such pin.
    pub fn port_pin(&self, port: char, bit: u8) -> Result<PinState, Error> {
        let [pin_reg, ddr, port_reg] = self.port_regs(port, bit)?.1.map(|addr| self.data()[addr]);
        let mask = 1u8 << bit;
        let output = ddr & mask != 0;
        let level = if output { port_reg & mask != 0 } else { pin_reg & mask != 0 };
        Ok(PinState { output, level, pull_up: !output && port_reg & mask != 0 })
    }

    /// Drives input pin P`port``bit` from outside, or releases it, as [`Uno::drive_pin`] does.
    pub fn drive_port_pin(&mut self, port: char, bit: u8, level: Option<bool>) -> Result<(), Error> {
        let (letter, _) = self.port_regs(port, bit)?;
        let level: c_int = match level {
            None => -1,
            Some(high) => c_int::from(high),
        };
        // SAFETY: `shim` is valid and exclusively borrowed; arguments are range-checked in C.
        match unsafe { ffi::uno_pin_drive(self.raw_mut(), letter, c_int::from(bit), level) } {
            0 => Ok(()),
            _ => Err(Error::NoSuchPortPin { chip: self.chip(), port, bit }),
        }
    }

    /// Sets the voltage on ADC channel `channel` (on the Uno 0-5 = A0-A5; 6 and 7 exist on the
    /// chip only; up to 13 on the 32U4, 15 on the Megas), in millivolts. With the AVCC reference
    /// (5 V) the firmware reads `mv * 1023 / 5000` (simavr's scaling; clipped at 1023).
    pub fn set_analog_mv(&mut self, channel: u8, millivolts: u32) -> Result<(), Error> {
        if channel >= self.chip().adc_channels() {
            return Err(Error::BadAdcChannel(channel));
        }
        // SAFETY: `shim` is valid and exclusively borrowed; `channel` is 0-15.
        match unsafe { ffi::uno_adc_set(self.raw_mut(), c_int::from(channel), millivolts) } {
            0 => Ok(()),
            _ => Err(Error::BadAdcChannel(channel)),
        }
    }

    /// Sets the voltage on the AREF pin (default 5000 mV), used when the firmware selects the
    /// external reference.
    pub fn set_aref_mv(&mut self, millivolts: u32) {
        // SAFETY: `shim` is valid and exclusively borrowed.
        unsafe { ffi::uno_set_aref(self.raw_mut(), millivolts) }
    }
}
