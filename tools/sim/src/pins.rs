//! GPIO and ADC: pins by port and bit on every chip, by Arduino Uno pin number on the 328P and
//! 168 (0-7 = PD0-7, 8-13 = PB0-5, 14-19 = A0-A5 = PC0-5).
//!
//! The Uno numbering does not carry over: a Mega's LED (pin 13) is PB7, a Leonardo's PC7.
//!
//! A pin can be driven from outside now ([`Uno::drive_pin`]) or at an exact future cycle
//! ([`Uno::schedule_pin`], applied by a simulator cycle timer, so that an input capture stamps
//! that very cycle), and an output's level changes can be logged with their cycles
//! ([`Uno::watch_pin`], [`Uno::take_pin_edges`]). What an output shows is PORTx, or a timer's
//! compare output while its COMnx bits connect it (the chip's port override; simavr 1.6 lets
//! PORTx writes overwrite the compare output and drives even an input with it, which
//! `csrc/pins.c` corrects).

use std::ffi::{c_char, c_int};

use crate::{ffi, Error, Uno};

/// A pin: an Arduino Uno pin number (`8`, on the chips wired like the Uno) or a port letter and
/// bit (`('L', 1)`, on every chip).
pub trait PinId: Copy {
    /// Its port letter and bit on `uno`'s chip.
    fn port_bit(self, uno: &Uno) -> Result<(char, u8), Error>;
}

impl PinId for u8 {
    fn port_bit(self, uno: &Uno) -> Result<(char, u8), Error> {
        uno.uno_port_bit(self)
    }
}

impl PinId for (char, u8) {
    fn port_bit(self, _uno: &Uno) -> Result<(char, u8), Error> {
        Ok(self)
    }
}

/// An output pin whose level changes are logged: the changes the shim has handed over and not
/// yet taken, and the level before the first of them.
#[derive(Debug)]
pub(crate) struct LoggedPin {
    pub(crate) port: char,
    pub(crate) bit: u8,
    pub(crate) level: bool,
    pub(crate) edges: Vec<(u64, bool)>,
}

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
    /// For an output, the level it drives (PORTx, or a timer's compare output while COMnx
    /// connects it); for an input, what the firmware reads from PINx.
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
    /// interrupts fire as on the chip. An output pin keeps showing what the chip drives; the
    /// outside level shows once it is an input. Arduino Uno pin numbers, as [`Uno::pin`].
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
        let (letter, [_, ddr, port_reg]) = self.port_regs(port, bit)?;
        let (ddr, port_reg) = (self.data()[ddr], self.data()[port_reg]);
        let mask = 1u8 << bit;
        let output = ddr & mask != 0;
        // SAFETY: `shim` is valid for the lifetime of `self`; the pin exists (port_regs).
        let level = unsafe { ffi::uno_pin_level(self.raw(), letter, c_int::from(bit)) } == 1;
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

    /// Drives input pin `pin` high or low from outside at cycle `at_cycle` (not in the past), as
    /// [`Uno::drive_pin`] would then: a simulator cycle timer applies it, and the change carries
    /// that exact cycle (an input capture stamps it, with the chip's synchronizer delay), though
    /// the CPU sees the new level from the next instruction boundary. Levels may be scheduled in
    /// any order; two for one cycle apply in the order given. Drives from outside outlive a
    /// [`Uno::hard_reset`], as the world outside the chip does.
    pub fn schedule_pin(&mut self, pin: impl PinId, at_cycle: u64, level: bool) -> Result<(), Error> {
        let (port, bit) = pin.port_bit(self)?;
        let (letter, _) = self.port_regs(port, bit)?;
        // SAFETY: `shim` is valid and exclusively borrowed; arguments are range-checked in C.
        match unsafe { ffi::uno_pin_schedule(self.raw_mut(), letter, c_int::from(bit), at_cycle, c_int::from(level)) } {
            0 => Ok(()),
            ffi::ERR_PAST => Err(Error::PinInPast { at: at_cycle, now: self.now() }),
            ffi::ERR_NOMEM => Err(Error::Internal("out of memory".into())),
            _ => Err(Error::NoSuchPortPin { chip: self.chip(), port, bit }),
        }
    }

    /// Levels scheduled with [`Uno::schedule_pin`] (on any pin) not applied yet.
    pub fn pending_pin_levels(&self) -> usize {
        // SAFETY: `shim` is valid for the lifetime of `self`.
        unsafe { ffi::uno_pin_scheduled(self.raw()) }
    }

    /// Starts logging the level changes of `pin` while it is an output (up to 16 pins): every
    /// change of the level it shows, at its exact cycle (the end of the instruction writing
    /// PORTx, DDRx or PINx, or a compare match). Becoming an output at a new level counts;
    /// what the pin does as an input does not. Collect them with [`Uno::take_pin_edges`] or
    /// [`Uno::take_pin_uart`]. Logging a pin twice changes nothing.
    pub fn watch_pin(&mut self, pin: impl PinId) -> Result<(), Error> {
        let (port, bit) = pin.port_bit(self)?;
        let (letter, _) = self.port_regs(port, bit)?;
        if self.logged_pin(port, bit).is_some() {
            return Ok(());
        }
        let mut level: c_int = 0;
        // SAFETY: `shim` is valid and exclusively borrowed; `level` is writable.
        match unsafe { ffi::uno_pin_log(self.raw_mut(), letter, c_int::from(bit), &mut level) } {
            0 => {
                self.logged.push(LoggedPin { port, bit, level: level != 0, edges: Vec::new() });
                Ok(())
            }
            ffi::ERR_NOMEM => Err(Error::Internal("16 pins are logged already".into())),
            _ => Err(Error::NoSuchPortPin { chip: self.chip(), port, bit }),
        }
    }

    /// The logged pin P`port``bit` (index into `self.logged`) with every change the shim holds
    /// moved over; [`Error::PinNotWatched`] if it is not logged.
    pub(crate) fn drain_pin_log(&mut self, pin: impl PinId) -> Result<usize, Error> {
        let (port, bit) = pin.port_bit(self)?;
        let index = self.logged_pin(port, bit).ok_or(Error::PinNotWatched { port, bit })?;
        let letter = port as c_char;
        let mut buf = [ffi::PinEdgeRaw::default(); 256];
        loop {
            // SAFETY: `shim` is valid and exclusively borrowed; `buf` is writable for its length.
            let n =
                unsafe { ffi::uno_pin_log_take(self.raw_mut(), letter, c_int::from(bit), buf.as_mut_ptr(), buf.len()) };
            let Ok(n) = usize::try_from(n) else {
                return Err(Error::Internal(format!("uno_pin_log_take(P{port}{bit}) returned {n}")));
            };
            self.logged[index].edges.extend(buf[..n].iter().map(|e| (e.cycle, e.level != 0)));
            if n < buf.len() {
                return Ok(index);
            }
        }
    }

    fn logged_pin(&self, port: char, bit: u8) -> Option<usize> {
        self.logged.iter().position(|p| p.port == port && p.bit == bit)
    }

    /// Takes the level changes logged on `pin` ([`Uno::watch_pin`]) since the last call, oldest
    /// first: `(cycle, level)`, each a change from the level before.
    pub fn take_pin_edges(&mut self, pin: impl PinId) -> Result<Vec<(u64, bool)>, Error> {
        let index = self.drain_pin_log(pin)?;
        let line = &mut self.logged[index];
        if let Some(&(_, level)) = line.edges.last() {
            line.level = level;
        }
        Ok(std::mem::take(&mut line.edges))
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
