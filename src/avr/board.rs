//! Small drivers for this repository's examples, written without a HAL (feature
//! `examples`; not part of the API): the Uno's digital pins, ATmega328P datasheet §14 (I/O
//! ports), through the `embedded-hal` 1.0 pin traits (an `arduino-hal` pin works the same),
//! the board's LED, the ADC (`adc`) and the EEPROM.

mod adc;

pub use super::eeprom::Eeprom;
pub use adc::Adc;

use core::convert::Infallible;
use core::ops::Deref;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin, StatefulOutputPin};

use super::chip::CHIP;
use super::reg::{self, claim, Reg};
use crate::error::Error;

/// Data-space address of PINB; DDRx and PORTx follow each PINx.
const PINB: usize = reg::PORTB.0;
const PINC: usize = reg::PORTC.0;
const PIND: usize = reg::PORTD.0;

/// One pin of port B, C or D.
pub struct Pin {
    pin_register: usize,
    mask: u8,
}

impl Pin {
    const fn new(pin_register: usize, bit: u8) -> Self {
        Pin { pin_register, mask: 1 << bit }
    }

    /// PINx (offset 0), DDRx (1) or PORTx (2) of a port whose PAC peripheral
    /// [`Pins::new`] took.
    fn register(&self, offset: usize) -> Reg {
        Reg::at(self.pin_register + offset)
    }

    fn read(&self, offset: usize) -> u8 {
        self.register(offset).read()
    }

    fn update(&self, offset: usize, set: bool) {
        // Interrupts may drive other pins of the same port (the LED, driver enable).
        reg::free(|| self.register(offset).modify(|value| if set { value | self.mask } else { value & !self.mask }));
    }

    /// Makes the pin an output, driven low.
    pub fn into_output(self) -> Self {
        self.update(2, false);
        self.update(1, true);
        self
    }

    /// Makes the pin an input with the internal pull-up (a switch to ground reads low).
    pub fn into_pull_up_input(self) -> Self {
        self.update(1, false);
        self.update(2, true);
        self
    }

    /// Makes the pin a floating input (for the ADC).
    pub fn into_floating_input(self) -> Self {
        self.update(1, false);
        self.update(2, false);
        self
    }

    /// True when the pin reads high.
    pub fn is_high(&self) -> bool {
        self.read(0) & self.mask != 0
    }

    /// Drives an output high (on an input, enables the pull-up).
    pub fn set_high(&mut self) {
        self.update(2, true);
    }

    /// Drives an output low.
    pub fn set_low(&mut self) {
        self.update(2, false);
    }

    /// Drives an output to `high`.
    pub fn set(&mut self, high: bool) {
        self.update(2, high);
    }
}

impl ErrorType for Pin {
    type Error = Infallible;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        Pin::set_low(self);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        Pin::set_high(self);
        Ok(())
    }
}

impl StatefulOutputPin for Pin {
    fn is_set_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.read(2) & self.mask != 0)
    }

    fn is_set_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.read(2) & self.mask == 0)
    }
}

impl InputPin for Pin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(Pin::is_high(self))
    }

    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!Pin::is_high(self))
    }
}

/// The Uno's pins by their board names. Pins 0 and 1 belong to USART0 and are left out.
#[allow(missing_docs)]
pub struct Pins {
    pub d2: Pin,
    pub d3: Pin,
    pub d4: Pin,
    pub d5: Pin,
    pub d6: Pin,
    pub d7: Pin,
    pub d8: Pin,
    pub d9: Pin,
    pub d10: Pin,
    pub d11: Pin,
    pub d12: Pin,
    /// Pin 13: the on-board LED "L".
    pub d13: Pin,
    pub a0: Pin,
    pub a1: Pin,
    pub a2: Pin,
    pub a3: Pin,
    pub a4: Pin,
    pub a5: Pin,
}

impl Pins {
    /// Takes the three ports from the application's PAC (`dp.PORTB`, `dp.PORTC`,
    /// `dp.PORTD`); all pins start as inputs, as after reset.
    pub fn new<B: Deref, C: Deref, D: Deref>(portb: B, portc: C, portd: D) -> Result<Self, Error>
    where
        B::Target: Sized,
        C::Target: Sized,
        D::Target: Sized,
    {
        claim::<_, { reg::PORTB.1 }>(portb, reg::PORTB.0)?;
        claim::<_, { reg::PORTC.1 }>(portc, reg::PORTC.0)?;
        claim::<_, { reg::PORTD.1 }>(portd, reg::PORTD.0)?;
        Ok(Pins {
            d2: Pin::new(PIND, 2),
            d3: Pin::new(PIND, 3),
            d4: Pin::new(PIND, 4),
            d5: Pin::new(PIND, 5),
            d6: Pin::new(PIND, 6),
            d7: Pin::new(PIND, 7),
            d8: Pin::new(PINB, 0),
            d9: Pin::new(PINB, 1),
            d10: Pin::new(PINB, 2),
            d11: Pin::new(PINB, 3),
            d12: Pin::new(PINB, 4),
            d13: Pin::new(PINB, 5),
            a0: Pin::new(PINC, 0),
            a1: Pin::new(PINC, 1),
            a2: Pin::new(PINC, 2),
            a3: Pin::new(PINC, 3),
            a4: Pin::new(PINC, 4),
            a5: Pin::new(PINC, 5),
        })
    }
}

/// The board's LED "L" (pin 13: PB5 on the Uno and Nano, PB7 on the Mega, PC7 on the
/// Leonardo and Micro; the Pro Micro has none there) as an output, driven low: takes its port from the application's PAC
/// (`dp.PORTB`, or `dp.PORTC` on the Leonardo), which works on every chip the crate runs
/// on, where [`Pins`] is the Uno's.
pub fn led<P: Deref>(port: P) -> Result<Pin, Error>
where
    P::Target: Sized,
{
    claim::<_, 3>(port, CHIP.led.0)?;
    Ok(Pin::new(CHIP.led.0, CHIP.led.1).into_output())
}

/// Stops the firmware when it could not start: lights the on-board LED "L" (pin 13: PB5
/// on the Uno and Nano, PB7 on the Mega, PC7 on the Leonardo) and sleeps with interrupts
/// off, so that a start-up error is seen rather than a slave that answers half its map.
pub fn halt(error: Error) -> ! {
    let _ = error;
    // An output (DDRx), driven high (PORTx).
    reg::free(|| {
        let led = Pin::new(CHIP.led.0, CHIP.led.1);
        led.register(1).modify(|bits| bits | led.mask);
        led.register(2).modify(|bits| bits | led.mask);
        loop {
            core::hint::spin_loop();
        }
    })
}
