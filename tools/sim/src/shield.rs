//! The Ethernet shield: a WIZnet W5100 or W5500 ([`crate::wiznet`]) on the chip's SPI port,
//! selected by a GPIO (the board's pin 10 unless [`Options::wiznet_cs`] says otherwise).
//!
//! The shim calls the chip with every SPI byte (when the byte completes, at the SPI clock the
//! firmware set: see `csrc/spi.c`) and every change of the chip-select pin; the chip's answer
//! is what the firmware reads from SPDR next. A reset of the board ([`Uno::hard_reset`])
//! resets the chip too, its RESET being the board's on the shields.

use std::ffi::{c_char, c_int, c_void};
use std::ptr::NonNull;

use crate::wiznet::{W5x00, Wiznet};
use crate::{ffi, Chip, Error, Options, Uno};

/// The shield's chip, owned by the [`Uno`] (freed after the simulator that calls it).
pub(crate) struct Shield {
    chip: NonNull<W5x00>,
    pub(crate) model: Wiznet,
    pub(crate) cs: (char, u8),
    /// Where the chip's INT line is wired, if it is.
    pub(crate) int: Option<(char, u8)>,
}

/// The pin the shields' chip select is wired to on `chip`'s boards: Arduino pin 10, PB2 on the
/// Uno (328P, 168), PB4 on the Megas, PB6 on the Leonardo (32U4).
pub fn default_cs(chip: Chip) -> (char, u8) {
    match chip {
        Chip::Atmega1280 | Chip::Atmega2560 => ('B', 4),
        Chip::Atmega32u4 => ('B', 6),
        _ => ('B', 2),
    }
}

impl Options {
    /// Puts an Ethernet shield with a `chip` (W5100 or W5500) on the SPI port, its chip select
    /// on the board's pin 10 ([`Options::wiznet_cs`] for another).
    pub const fn wiznet(self, chip: Wiznet) -> Options {
        Options { wiznet: Some(chip), ..self }
    }

    /// Wires the shield's chip select to P`port``bit` (`wiznet_cs('B', 4)`: a Mega's pin 10).
    pub const fn wiznet_cs(self, port: char, bit: u8) -> Options {
        Options { wiznet_cs: Some((port, bit)), ..self }
    }

    /// Wires the chip's INT line (low while a socket has unmasked events) to P`port``bit`:
    /// `wiznet_int('D', 2)` is the W5100 shield's solder jumper to the Uno's pin 2. The line
    /// follows the chip at every SPI byte and chip-select change, and the simulation stops at
    /// each delivery's cycle so that the line falls when the data lands.
    pub const fn wiznet_int(self, port: char, bit: u8) -> Options {
        Options { wiznet_int: Some((port, bit)), ..self }
    }
}

/// The shim's call for every SPI byte and chip-select change: hands it to the chip.
///
/// # Safety
///
/// `ctx` is the `W5x00` a [`Shield`] owns, alive as long as the simulator that calls this; no
/// reference to it exists while the simulator runs (running needs `&mut Uno`).
unsafe extern "C" fn spi_event(ctx: *mut c_void, event: c_int, value: u8, cycle: u64) -> c_int {
    // SAFETY: as the function's contract says.
    let chip = unsafe { &mut *ctx.cast::<W5x00>() };
    match event {
        ffi::SPI_EVENT_BYTE => chip.exchange(value, cycle).map_or(-1, c_int::from),
        ffi::SPI_EVENT_INT => c_int::from(!chip.int_asserted()),
        ffi::SPI_EVENT_CS if value == 0 => {
            chip.select(cycle);
            -1
        }
        _ => {
            chip.deselect(cycle);
            -1
        }
    }
}

impl Uno {
    /// Attaches the shield `options` ask for, if any.
    pub(crate) fn with_shield(mut self, options: Options) -> Result<Uno, Error> {
        let Some(model) = options.wiznet else { return Ok(self) };
        let (port, bit) = options.wiznet_cs.unwrap_or(default_cs(self.chip));
        let board = self.chip;
        let no_pin = || Error::NoSuchPortPin { chip: board, port, bit };
        let letter = u8::try_from(port).map_err(|_| no_pin())? as c_char;
        let chip = NonNull::from(Box::leak(Box::new(W5x00::new(model))));
        self.shield = Some(Shield { chip, model, cs: (port, bit), int: options.wiznet_int });
        // SAFETY: `shim` is valid and exclusively borrowed; `chip` lives until `free_shield`,
        // which runs after the simulator is freed, and `spi_event` is its callback.
        let attached =
            unsafe { ffi::uno_spi_attach(self.raw_mut(), letter, c_int::from(bit), spi_event, chip.as_ptr().cast()) };
        if attached != 0 {
            return Err(no_pin());
        }
        if let Some((port, bit)) = options.wiznet_int {
            let no_pin = || Error::NoSuchPortPin { chip: board, port, bit };
            let letter = u8::try_from(port).map_err(|_| no_pin())? as c_char;
            // SAFETY: `shim` is valid and exclusively borrowed; the part is attached.
            if unsafe { ffi::uno_spi_int(self.raw_mut(), letter, c_int::from(bit)) } != 0 {
                return Err(no_pin());
            }
        }
        Ok(self)
    }

    /// True when the shield's INT line is wired.
    pub(crate) fn shield_int(&self) -> bool {
        self.shield.as_ref().is_some_and(|s| s.int.is_some())
    }

    /// Runs to `cycle` with the INT line kept up to date: the chip brought to each cycle
    /// something is due on its network side (data landing, a timeout), and the line driven
    /// from it, before the firmware runs on.
    pub(crate) fn run_with_int(&mut self, cycle: u64) -> Result<(), Error> {
        loop {
            let now = self.now();
            let Some(chip) = self.wiznet_mut() else { break };
            let due = chip.next_due().filter(|&due| due > now).map_or(cycle, |due| due.min(cycle));
            // SAFETY: `shim` is valid and exclusively borrowed.
            unsafe { ffi::uno_spi_sync(self.raw_mut()) };
            if now >= cycle {
                break;
            }
            // SAFETY: as above.
            unsafe { ffi::uno_run(self.raw_mut(), due, 0) };
            self.drain_tx();
            self.check_alive()?;
        }
        self.check_alive()
    }

    /// Frees the shield's chip (the simulator calling it must be gone).
    pub(crate) fn free_shield(&mut self) {
        if let Some(shield) = self.shield.take() {
            // SAFETY: `chip` came from `Box::leak` in `with_shield` and is freed once, here.
            drop(unsafe { Box::from_raw(shield.chip.as_ptr()) });
        }
    }

    /// The board's reset reaches the shield's chip.
    pub(crate) fn reset_shield(&mut self) {
        if let Some(chip) = self.wiznet_mut() {
            chip.reset();
            chip.deselect(chip.now());
        }
    }

    /// The Ethernet shield's chip ([`Options::wiznet`]), if the board has one.
    pub fn wiznet(&self) -> Option<&W5x00> {
        // SAFETY: the chip lives as long as `self`; the simulator, its only other user, runs
        // only under `&mut self`.
        self.shield.as_ref().map(|s| unsafe { s.chip.as_ref() })
    }

    /// The shield's chip, to act as its network (see [`W5x00`]): its clock is brought to
    /// [`Uno::now`] first, so that what is done now is stamped now.
    pub fn wiznet_mut(&mut self) -> Option<&mut W5x00> {
        let now = self.now();
        // SAFETY: as in `wiznet`; `&mut self` makes this the only reference.
        let chip = self.shield.as_mut().map(|s| unsafe { s.chip.as_mut() })?;
        chip.advance(now);
        Some(chip)
    }

    /// The shield's chip-select pin, P`port``bit`, if the board has a shield.
    pub fn wiznet_cs(&self) -> Option<(char, u8)> {
        self.shield.as_ref().map(|s| s.cs)
    }
}
