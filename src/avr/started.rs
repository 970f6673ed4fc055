//! The cell a role (slave or master) lives in once started: written by its `start`, then
//! reached only with interrupts disabled, by the application's calls and by the role's
//! interrupt handlers.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::ops::Deref;

use embedded_hal::digital::OutputPin;

use super::reg::{self, claim, claim_at};
use super::timer::{FrameTimer, Unit};
use super::usart::Usart;
use crate::error::Error;
use crate::link::config::Line;
use crate::peripheral::may_be_usart;

const EMPTY: u8 = 0;
const READY: u8 = 1;
const IN_USE: u8 = 2;

/// A role `R` written once by [`Started::start`]; all zero before, so it lives in `.bss` and
/// costs no flash for an initializer. A flag refuses re-entry.
pub(crate) struct Started<R> {
    state: UnsafeCell<u8>,
    value: UnsafeCell<MaybeUninit<R>>,
}

// SAFETY: the chip has one core, and the cell is only touched with interrupts disabled
// (`reg::free`, or inside the role's interrupt handlers), so no two accesses overlap. What
// it holds moves in from `start`'s caller and is used from interrupts, hence `Send`.
unsafe impl<R: Send> Sync for Started<R> {}

impl<R> Started<R> {
    /// Not started.
    pub(crate) const fn new() -> Self {
        Started { state: UnsafeCell::new(EMPTY), value: UnsafeCell::new(MaybeUninit::zeroed()) }
    }

    /// Writes the value `make` builds, with interrupts disabled; [`Error::AlreadyStarted`]
    /// the second time.
    pub(crate) fn start(&self, make: impl FnOnce() -> R) -> Result<(), Error> {
        reg::free(|| {
            // SAFETY: interrupts are disabled, so nothing else accesses the cell.
            unsafe {
                if *self.state.get() != EMPTY {
                    return Err(Error::AlreadyStarted);
                }
                (*self.value.get()).write(make());
                *self.state.get() = READY;
            }
            Ok(())
        })
    }

    /// A role's start: takes USART `U` and `TC0` from the application's `Peripherals`
    /// (another USART is a build error, or [`Error::WrongPeripheral`] with a PAC whose
    /// types don't tell), writes the value `make` builds (which configures them), and
    /// enables interrupts.
    #[inline(always)]
    pub(crate) fn start_on<P: Deref, T: Deref, const U: u8>(
        &self,
        usart: P,
        tc0: T,
        make: impl FnOnce() -> R,
    ) -> Result<(), Error>
    where
        P::Target: Sized,
        T::Target: Sized,
    {
        const {
            assert!(
                may_be_usart(core::any::type_name::<P>(), U, Usart::<U>::PERIPHERAL.0),
                "start takes the USART that slave! or master! names: dp.USART0 for slave!(SLAVE: …) or \
                 master!(MASTER: …) on pins 0/1 (dp.USART1 on the ATmega32U4), dp.USARTn for … on USARTn, \
                 the timer for … on TIMERn (dp.TC1 on the Uno's pins 8/9)"
            );
            assert!(
                core::mem::size_of::<P::Target>() == Usart::<U>::PERIPHERAL.1,
                "start takes the USART that slave! or master! names, or for … on TIMERn that timer (dp.TC1 on the Uno)"
            );
        };
        claim_at(usart, Usart::<U>::PERIPHERAL.0)?;
        claim::<_, { reg::TC0.1 }>(tc0, reg::TC0.0)?;
        self.start(make)?;
        // SAFETY: the role is in its cell, so its interrupt handlers can run.
        unsafe { reg::enable_interrupts() };
        Ok(())
    }

    /// Runs `f` on the value.
    ///
    /// # Safety
    /// Interrupts must be disabled for the whole call.
    #[inline(always)]
    unsafe fn access<Q>(&self, f: impl FnOnce(&mut R) -> Q) -> Option<Q> {
        // SAFETY: no other access can run (the caller's promise); READY means the value
        // was written by `start`, and IN_USE keeps a nested call from aliasing it.
        unsafe {
            if *self.state.get() != READY {
                return None;
            }
            *self.state.get() = IN_USE;
            let result = f((*self.value.get()).assume_init_mut());
            *self.state.get() = READY;
            Some(result)
        }
    }

    /// Runs `f` on the value, marked in use meanwhile, from an interrupt handler that
    /// enables interrupts inside `f` (the TCP server's poll): a nested handler or a call
    /// from another interrupt finds it in use and gets `None`.
    ///
    /// # Safety
    /// Interrupts disabled on entry, and `f` returns with them disabled.
    #[cfg(feature = "tcp")]
    #[inline(always)]
    pub(crate) unsafe fn access_marked<Q>(&self, f: impl FnOnce(&mut R) -> Q) -> Option<Q> {
        // SAFETY: the caller's promise, which is `access`'s.
        unsafe { self.access(f) }
    }

    /// Runs `f` on the value from one of the role's interrupt handlers, without
    /// [`Started::access`]'s check, which keeps them short.
    ///
    /// # Safety
    /// Only from the role's interrupt handlers (interrupts disabled, and they stay so), so
    /// no other access overlaps this one: the application's run with interrupts disabled,
    /// and the handlers don't nest. The value is there: only `start` enables the receive
    /// and Timer0 interrupts, after writing it, and only the handlers enable the transmit
    /// ones.
    #[inline(always)]
    pub(crate) unsafe fn access_in_handler<Q>(&self, f: impl FnOnce(&mut R) -> Q) -> Q {
        // SAFETY: as promised by the caller, nothing else reaches the value meanwhile, and
        // it was written.
        unsafe { f((*self.value.get()).assume_init_mut()) }
    }

    /// Runs `f` on the value with interrupts disabled: `None` before the start or inside
    /// another access.
    pub(crate) fn locked<Q>(&self, f: impl FnOnce(&mut R) -> Q) -> Option<Q> {
        // SAFETY: interrupts are disabled for the whole access.
        reg::free(|| unsafe { self.access(f) })
    }
}

/// A role's line as it starts, the same for the slave and the master: the RS-485 driver
/// and the LED off, Timer0's compare unit `T` and USART `U` configured for `config`, and
/// the power-up wait begun (T3.5 of silence before the first frame; none in ASCII framing,
/// which the role sets up next). Call with interrupts disabled, from the role's `start`.
#[inline(always)]
pub(crate) fn open_line<T: Unit, const U: u8>(
    config: &Line,
    driver_enable: &mut impl OutputPin,
    led: &mut impl OutputPin,
) -> (Usart<U>, FrameTimer<T>) {
    let _ = driver_enable.set_low();
    let _ = led.set_low();
    let mut timer = FrameTimer::new(config.timer_plan());
    let usart = Usart::new(config);
    timer.restart();
    (usart, timer)
}
