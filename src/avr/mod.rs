//! The ATmega328P layer: USART0 on pins 0/1, Timer0 as the silence detector, and the
//! interrupt-driven slave that ties them to [`crate::Slave`] (Modbus over Serial Line
//! v1.02 §2.5.1.1 and §3.3, the communication LED).
//!
//! Everything here is thin: register writes and reads, and calls into the pure core. The
//! drivers take the PAC peripherals (`USART0`, `TC0`, `PORTx`, `ADC`) by value, the same
//! ones an `arduino-hal` application gets from `Peripherals::take()`.
#![allow(unsafe_code)]

mod adc;
mod eeprom;
mod pins;
mod rtu;
mod timer;
mod usart;

pub use adc::Adc;
pub use eeprom::Eeprom;
pub use pins::{NoPin, Pin, Pins};
pub use rtu::{ModbusSlave, Shared};
pub use timer::FrameTimer;
pub use usart::Usart;

/// Re-exported for the [`crate::modbus_slave!`] macro.
#[doc(hidden)]
pub use avr_device;

/// Declares the shared slave `NAME` for a data model type and binds the five interrupts it
/// needs (USART0 RX, UDRE and TX complete; Timer0 compare A and B).
///
/// ```ignore
/// avr_modbus_slave::modbus_slave!(SLAVE: Bank<4, 16, 2>);
/// // in main:
/// SLAVE.start(ModbusSlave::new(CONFIG, dp.USART0, dp.TC0, bank));
/// unsafe { avr_device::interrupt::enable() };
/// SLAVE.set(30001, reading);
/// ```
#[macro_export]
macro_rules! modbus_slave {
    ($name:ident : $model:ty) => {
        $crate::modbus_slave!($name: $model, $crate::avr::NoPin, $crate::avr::NoPin);
    };
    ($name:ident : $model:ty, $de:ty, $led:ty) => {
        static $name: $crate::avr::Shared<$model, $de, $led> = $crate::avr::Shared::new();

        #[doc(hidden)]
        mod __modbus_slave_interrupts {
            /// USART0 RX complete.
            #[$crate::avr::avr_device::interrupt(atmega328p)]
            fn USART_RX() {
                super::$name.in_interrupt(|s| s.on_usart_rx());
            }

            /// USART0 data register empty.
            #[$crate::avr::avr_device::interrupt(atmega328p)]
            fn USART_UDRE() {
                super::$name.in_interrupt(|s| s.on_usart_udre());
            }

            /// USART0 TX complete.
            #[$crate::avr::avr_device::interrupt(atmega328p)]
            fn USART_TX() {
                super::$name.in_interrupt(|s| s.on_usart_tx());
            }

            /// Timer0 compare A: gap deadline.
            #[$crate::avr::avr_device::interrupt(atmega328p)]
            fn TIMER0_COMPA() {
                super::$name.in_interrupt(|s| s.on_timer_compare_a());
            }

            /// Timer0 compare B: T3.5.
            #[$crate::avr::avr_device::interrupt(atmega328p)]
            fn TIMER0_COMPB() {
                super::$name.in_interrupt(|s| s.on_timer_compare_b());
            }
        }
    };
}
