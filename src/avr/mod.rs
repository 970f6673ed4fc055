//! The AVR layer: the link's drivers, a USART (USART0 on the Uno's pins 0/1, any of the
//! chip's) and Timer0 as the silence detector and the application's millisecond clock, and
//! the two roles on them, the interrupt-driven [`Slave`] and (feature `master`) [`Master`],
//! each tying them to its protocol engine (Modbus over Serial Line v1.02 §2.5.1.1 and
//! §3.3). What differs between the chips is data, `chips/chips.txt`; the chosen chip's table
//! is `chip`.
//!
//! The link: `usart`, `receive` (a character to either role), `timer` (Timer0's deadlines,
//! a compare unit each role), `clock` (`millis()`), `started` (the cell a role lives in),
//! `reg`, `mem`. The roles: `slave` (its interrupt state in `slave/running.rs`), `master`.
//! The EEPROM (`eeprom`, where `eeprom-settings` keeps the line settings in
//! `eeprom/settings.rs`), and for this repository's examples the board without a HAL
//! (`board`).
//!
//! # A request, from the wire to the reply (the slave)
//!
//! 1. The USART's receive interrupt, bound by `slave!` (here): `__private::usart_rx_arrived`
//!    reads Timer0 first (`timer::on_receive`: the silence deadlines count from the
//!    character's arrival), then `Slave::on_usart_rx` (`slave.rs`) →
//!    `Running::on_usart_rx` (`slave/running.rs`) → `receive` (`receive.rs`: the character
//!    or its damage from `usart.rs`) → `Engine::on_byte` (`crate::slave::engine`) →
//!    `Framer::on_byte` (`crate::link::framer`, which stores it; in ASCII `on_char`,
//!    `link/framer/ascii.rs`, decodes the hex).
//! 2. Timer0's compare B interrupt (a second slave's: compare A): `Slave::on_timer_compare` → `Running::on_timer_compare`
//!    → `FrameTimer::on_compare` (`timer.rs`) says T1.5 passed (`Engine::on_gap_deadline`:
//!    a character after it breaks the frame) or T3.5 did → `Engine::on_end_deadline`: the
//!    framer's length and CRC (`crate::link::crc`), the address; for this slave the first
//!    character goes out at once (`usart.rs`), then `Engine::process` → the one dispatch on
//!    the function code (`Engine::handle`) → `crate::slave::pdu` (FC 1–6, 15, 16; the
//!    checks in the spec's order), `slave/diagnostics.rs`, `slave/pdu/extra.rs` or
//!    `slave/pdu/device_id.rs` → the [`crate::DataModel`] (`slave/map.rs`, `slave/bank.rs`
//!    over `slave/storage.rs` and `slave/words.rs`) → the reply written over the request in
//!    the same buffer, its CRC appended.
//! 3. The USART's data-register-empty interrupt (`Running::on_usart_udre`) writes the
//!    reply's next bytes; the transmit-complete interrupt (`Running::on_usart_tx`) drops
//!    the RS-485 driver enable once the last stop bit has left, and the line is heard again.
//!
//! # A request, from `send` to `poll` (the master)
//!
//! 1. `Master::send` / `Master::broadcast` (`master.rs`), interrupts off: `Engine::begin`
//!    (`crate::master::engine`) checks the request against the spec's limits and builds it
//!    (`master/request.rs`: `Request::encode`, with the expected reply's shape); if the
//!    line has been quiet for T3.5 the address goes out at once (`Running::act`) and the CRC
//!    is appended meanwhile (`Engine::seal`).
//! 2. The transmit-complete interrupt (`Running::on_usart_tx`) writes each next character;
//!    after the last, `Engine::on_sent` starts the response timeout and Timer0 the silences.
//! 3. Each reply character: the receive interrupt, as the slave's step 1 (`receive.rs` →
//!    the master `Engine::on_byte` → the shared `Framer`). Timer0's compare A
//!    (`Running::on_timer_compare`): T1.5, T3.5 → `Engine::on_end_deadline` →
//!    `Expect::check` (`master/reply.rs`: address, function code or its exception, byte
//!    count, echo) → the answer kept in the framer's buffer, or the try failed and sent
//!    again while retries are left; on a turn with neither, `Engine::on_tick` checks the
//!    timeout against `millis()`.
//! 4. `Master::poll` hands the application the [`crate::master::Reply`] (read in place) or
//!    the [`crate::master::Failure`], and frees the buffer (`Engine::collect`).
//!
//! Everything here is thin: register writes and reads, and calls into the pure core. A
//! role takes the USART and `TC0` the application gets from its HAL's
//! `Peripherals::take()` (arduino-hal's, or `avr-device`'s of any version), and reaches
//! their registers by address, so no PAC version is part of this crate's API.
#![allow(unsafe_code)]

#[cfg(feature = "examples")]
pub mod board;
// `__chip!` is written into this module by build.rs (an `include!`): the crate's own code
// names it in textual scope, `__chip!`, as a macro-expanded `#[macro_export]` macro cannot be
// named by its path inside the crate that defines it.
#[macro_use]
mod chip;
#[cfg(feature = "capture-line")]
mod capture;
#[cfg(feature = "millis")]
mod clock;
#[cfg(any(feature = "examples", feature = "eeprom-settings"))]
mod eeprom;
#[cfg(all(feature = "tcp", feature = "master"))]
mod gateway;
#[cfg(feature = "master")]
mod master;
mod mem;
mod no_pin;
#[cfg(any(feature = "millis", feature = "tcp"))]
mod overflow;
mod receive;
mod reg;
mod shared;
mod slave;
#[cfg(feature = "tcp")]
mod spi;
mod started;
#[cfg(feature = "tcp")]
mod tcp;
#[cfg(all(feature = "tcp", feature = "master"))]
mod tcp_client;
mod timer;
mod usart;
mod values;

#[cfg(feature = "eeprom-settings")]
pub use eeprom::Eeprom;
#[cfg(all(feature = "tcp", feature = "master"))]
pub use gateway::TcpGateway;
#[cfg(feature = "master")]
pub use master::Master;
pub use no_pin::NoPin;
pub use shared::SharedModel;
pub use slave::Slave;
#[cfg(feature = "tcp")]
pub use tcp::{Pin10, TcpServer};
#[cfg(all(feature = "tcp", feature = "master"))]
pub use tcp_client::TcpClient;

/// Milliseconds since the slave started, wrapping after 49.7 days: Arduino's `millis()`
/// (feature `millis`), kept by Timer0, which the slave owns and runs freely at clk/64 (an
/// overflow interrupt every 1.024 ms, 2.048 ms at 8 MHz). Never ahead of true time and less than a millisecond
/// behind it, with no drift beyond the crystal's; 0 before [`Slave::start`]. Compare times
/// with `wrapping_sub`, as on Arduino: `millis().wrapping_sub(since) >= 500`.
#[cfg(feature = "millis")]
pub fn millis() -> u32 {
    clock::millis()
}

/// For the handlers that [`crate::slave!`] binds.
#[doc(hidden)]
pub mod __private {
    pub use super::shared::SharedHandle;

    /// USART receive complete, before anything else: when the character arrived.
    ///
    /// # Safety
    /// Only first thing in the USART_RX interrupt handler (interrupts disabled).
    #[inline(always)]
    pub unsafe fn usart_rx_arrived() {
        super::timer::on_receive::<super::timer::B>();
    }

    /// A second slave's USART receive complete, before anything else: its deadlines are
    /// compare A's (`slave!(… with TIMER0_COMPA: …)`).
    ///
    /// # Safety
    /// Only first thing in that slave's USART_RX interrupt handler (interrupts disabled).
    #[inline(always)]
    pub unsafe fn usart_rx_arrived_a() {
        super::timer::on_receive::<super::timer::A>();
    }

    /// The master's USART receive complete, before anything else (feature `master`).
    ///
    /// # Safety
    /// Only first thing in the master's USART_RX interrupt handler (interrupts disabled).
    #[cfg(feature = "master")]
    #[inline(always)]
    pub unsafe fn master_rx_arrived() {
        super::timer::on_receive::<super::timer::A>();
    }

    /// The line number `slave!` and `master!` give a role on the timer's capture line
    /// (`… on TIMER1`, feature `capture-line`).
    #[cfg(feature = "capture-line")]
    pub const fn capture_line() -> u8 {
        super::usart::CAPTURE_LINE
    }
    /// Without feature `capture-line`, a role on a timer does not build.
    #[cfg(not(feature = "capture-line"))]
    pub const fn capture_line() -> u8 {
        panic!("slave! or master! on TIMERn (pins 8/9 on the Uno) needs avr-modbus's feature `capture-line`")
    }

    /// The capture line's edge interrupt (TIMERn_CAPT).
    ///
    /// # Safety
    /// Only from that interrupt's handler, interrupts disabled.
    #[cfg(feature = "capture-line")]
    #[inline(always)]
    pub unsafe fn capture_edge() {
        // SAFETY: the caller's promise.
        unsafe { super::capture::on_edge() }
    }

    /// The capture line's first-stop-bit interrupt (TIMERn_COMPB): when a character is
    /// complete, `arrived` (its deadlines) first thing, then `received` (the role's receive
    /// handler).
    ///
    /// # Safety
    /// Only from that interrupt's handler, interrupts disabled; `arrived` and `received`
    /// must not enable them.
    #[cfg(feature = "capture-line")]
    #[inline(always)]
    pub unsafe fn capture_stop_bit(unit: u8, arrived: impl FnOnce(), received: impl FnOnce()) {
        // SAFETY: the caller's promise; the role's receive handler reaches the role and its
        // unit's deadlines, which no other handler reaches.
        unsafe { super::capture::on_stop_bit(unit, arrived, received) }
    }

    /// Timer0's compare units' bits in TIMSK0, by the names `__bind_capture!` gets.
    #[cfg(feature = "capture-line")]
    pub const TIMER0_COMPA: u8 = 1 << 1;
    /// See [`TIMER0_COMPA`].
    #[cfg(feature = "capture-line")]
    pub const TIMER0_COMPB: u8 = 1 << 2;

    /// The capture line's transmit interrupt (TIMERn_COMPA): `feed` runs when the role asked
    /// for the next character and the buffer is empty (the USART's data register empty),
    /// `done` when the last character has left the wire (its transmit complete).
    ///
    /// # Safety
    /// As for [`capture_stop_bit`], from TIMERn_COMPA's handler.
    #[cfg(feature = "capture-line")]
    #[inline(always)]
    pub unsafe fn capture_transmit(feed: impl FnOnce(), done: impl FnOnce()) {
        use super::capture::{on_transmit, settle, Transmit};
        // SAFETY: the caller's promise.
        match unsafe { on_transmit() } {
            Transmit::Nothing => {}
            Transmit::Feed => feed(),
            Transmit::Done => done(),
        }
        // SAFETY: as above.
        unsafe { settle() };
    }
}

/// Declares the slave `NAME` for a data model type and binds the four interrupts it needs:
/// its USART's RX complete, data register empty and TX complete, and Timer0 compare B (the
/// silences; compare A for a second slave, below). With feature `millis` the crate binds
/// Timer0's overflow too, the clock of `millis()`.
///
/// ```ignore
/// avr_modbus::slave!(SLAVE: Registers);                  // the board's pins 0/1, no pins
/// avr_modbus::slave!(SLAVE: Registers, NoPin, LedPin);   // driver enable, LED
/// avr_modbus::slave!(SLAVE on USART1: Registers);        // a Mega's Serial1 (pins 19/18)
/// avr_modbus::slave!(SLAVE2 on USART1 with TIMER0_COMPA: MODEL);  // a second slave
/// ```
///
/// Without `on`, the slave serves the USART on the board's pins 0/1: USART0 on the
/// ATmega328P, ATmega168, ATmega2560 and ATmega1280, USART1 on the ATmega32U4. `on USARTn`
/// names any USART the chip has (USART0–USART3 on the Mega's chips); one it lacks fails the
/// build. [`Slave::start`] then takes that USART (`dp.USART1`, …).
///
/// Two slaves run at once on a chip with two USARTs (a Mega): the second one names
/// `with TIMER0_COMPA`, and keeps its silences on Timer0's compare A, the first on compare B
/// (`with TIMER0_COMPB`, the default, may be written out). Each has its own line settings,
/// slave id and counters; they serve one [`crate::shared_model!`] (name it in both) or a
/// model each. Compare A is the master's: no `master!` or `tcp_gateway!` beside
/// them (the build fails on the vector bound twice). Hand the first one started `&*dp.TC0`,
/// the second `dp.TC0`. The interrupt handlers go in a module named `NAME`.
///
/// The handlers use the `avr-interrupt` calling convention: the firmware crate needs
/// `#![feature(abi_avr_interrupt)]`, as every AVR interrupt handler does. Nothing else in
/// the firmware may handle these interrupts, nor Timer0's overflow (no `default_serial!` on
/// the slave's USART, nothing on TC0).
#[cfg_attr(docsrs, doc(cfg(target_arch = "avr")))]
#[macro_export]
macro_rules! slave {
    (@on $usart:ident $name:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::slave!(@unit $usart TIMER0_COMPB $name: $model, $de, $led);
    };
    (@unit $usart:ident TIMER0_COMPB $name:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::slave!(@declare $usart 'B' $name: $model, $de, $led);
        $crate::__bind_role!($name, $name, $usart, TIMER0_COMPB, usart_rx_arrived, on_usart_udre);
    };
    (@unit $usart:ident TIMER0_COMPA $name:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::slave!(@declare $usart 'A' $name: $model, $de, $led);
        $crate::__bind_role!($name, $name, $usart, TIMER0_COMPA, usart_rx_arrived_a, on_usart_udre);
    };
    (@declare $usart:ident $unit:literal $name:ident : $model:ty, $de:ty, $led:ty) => {
        static $name: $crate::Slave<
            $model,
            $de,
            $led,
            { <$model as $crate::DataModel>::FRAME },
            { $crate::__chip!(usart $usart) },
            $unit,
        > = $crate::Slave::new();
    };
    ($name:ident on $usart:ident with $compare:ident : $model:ty) => {
        $crate::slave!(@unit $usart $compare $name: $model, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident on $usart:ident with $compare:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::slave!(@unit $usart $compare $name: $model, $de, $led);
    };
    ($name:ident on $usart:ident : $model:ty) => {
        $crate::slave!(@on $usart $name: $model, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident on $usart:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::slave!(@on $usart $name: $model, $de, $led);
    };
    ($name:ident : $model:ty) => {
        $crate::__chip!(default $name: $model, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident : $model:ty, $de:ty, $led:ty) => {
        $crate::__chip!(default $name: $model, $de, $led);
    };
}

/// Declares the master `NAME` (feature `master`) with buffers of `N` bytes each way (the
/// request as sent, the reply; 256 when left out) and binds the three interrupts it needs,
/// as [`crate::slave!`] does for a slave: its USART's RX complete and TX complete (each
/// character of a request is written when the one before has left; the data register empty
/// interrupt stays free), and Timer0 compare A (the silences, the timeouts; the slave has
/// compare B, and a second slave compare A: no master beside two slaves).
///
/// ```ignore
/// avr_modbus::master!(MASTER);                       // the board's pins 0/1, 256-byte buffers
/// avr_modbus::master!(MASTER: 32);                   // 32-byte buffers
/// avr_modbus::master!(MASTER: 32, DePin, NoPin);     // RS-485 driver enable, no LED
/// avr_modbus::master!(MASTER on USART1: 64);         // a Mega's Serial1 (pins 19/18)
/// ```
///
/// [`Master::start`] then takes that USART. A master and a slave on two USARTs of one chip
/// share Timer0 (a gateway): hand the first one started `&*dp.TC0`, the second `dp.TC0`.
#[cfg(feature = "master")]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "master"))))]
#[macro_export]
macro_rules! master {
    (@on $usart:ident $name:ident : $n:expr, $de:ty, $led:ty) => {
        static $name: $crate::Master<$de, $led, { $n }, { $crate::__chip!(usart $usart) }> = $crate::Master::new();

        $crate::__bind_role!(__avr_modbus_master_interrupts, $name, $usart, TIMER0_COMPA, master_rx_arrived);
    };
    ($name:ident on $usart:ident : $n:expr) => {
        $crate::master!(@on $usart $name: $n, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident on $usart:ident : $n:expr, $de:ty, $led:ty) => {
        $crate::master!(@on $usart $name: $n, $de, $led);
    };
    ($name:ident) => {
        $crate::__chip!(default_master $name: 256, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident : $n:expr) => {
        $crate::__chip!(default_master $name: $n, $crate::NoPin, $crate::NoPin);
    };
    ($name:ident : $n:expr, $de:ty, $led:ty) => {
        $crate::__chip!(default_master $name: $n, $de, $led);
    };
}

/// The interrupts a role (`slave!`, `master!`) binds, in module `$module` (a slave's is
/// named after its static, so that two slaves' differ): Timer0's
/// compare unit `$compare` (its silences, and the master's timeouts), and USART `$usart`'s
/// RX complete (first `__private::$arrived`, which starts the silence deadlines), data
/// register empty (the slave's, whose handler is `$feed`; the master sends from TX complete
/// alone) and TX complete, each calling the static `$name`'s handler.
#[doc(hidden)]
#[macro_export]
macro_rules! __bind_role {
    ($module:ident, $name:ident, TIMER1, $($rest:tt)*) => {
        $crate::__bind_capture!($module, $name, TIMER1, $($rest)*);
    };
    ($module:ident, $name:ident, TIMER3, $($rest:tt)*) => {
        $crate::__bind_capture!($module, $name, TIMER3, $($rest)*);
    };
    ($module:ident, $name:ident, TIMER5, $($rest:tt)*) => {
        $crate::__bind_capture!($module, $name, TIMER5, $($rest)*);
    };
    ($module:ident, $name:ident, $usart:ident, $compare:ident, $arrived:ident $(, $feed:ident)?) => {
        #[doc(hidden)]
        #[allow(non_snake_case)]
        mod $module {
            $crate::__bind_timer0_compare!($compare, $name);

            /// USARTn_RX: a character arrived.
            #[export_name = $crate::__chip!(vector $usart RX)]
            unsafe extern "avr-interrupt" fn USART_RX() {
                // SAFETY: the first statement of the USART's receive interrupt handler,
                // which runs with interrupts disabled.
                unsafe { $crate::__private::$arrived() };
                // SAFETY: the receive interrupt handler, interrupts disabled, and it does
                // not enable them.
                unsafe { super::$name.on_usart_rx() }
            }

            $(
            /// USARTn_UDRE: room for the next character of a frame.
            #[export_name = $crate::__chip!(vector $usart UDRE)]
            unsafe extern "avr-interrupt" fn USART_UDRE() {
                // SAFETY: the data-register-empty interrupt handler, interrupts disabled,
                // and it does not enable them.
                unsafe { super::$name.$feed() }
            }
            )?

            /// USARTn_TX: a character (the master's) or the frame (the slave's) has left
            /// the wire.
            #[export_name = $crate::__chip!(vector $usart TX)]
            unsafe extern "avr-interrupt" fn USART_TX() {
                // SAFETY: the transmit-complete interrupt handler, interrupts disabled, and
                // it does not enable them.
                unsafe { super::$name.on_usart_tx() }
            }
        }
    };
}

/// Timer0's compare unit `$compare` for the role `super::$name`, in the module a role's
/// interrupts are bound in (`__bind_role`, `__bind_capture`): the same on either line.
#[doc(hidden)]
#[macro_export]
macro_rules! __bind_timer0_compare {
    ($compare:ident, $name:ident) => {
        /// TIMER0_COMPx: the gap deadline, then T3.5 (and the master's timeouts).
        #[export_name = $crate::__chip!(vector $compare)]
        unsafe extern "avr-interrupt" fn TIMER0_COMPARE() {
            // SAFETY: an interrupt handler, which runs with interrupts disabled.
            unsafe { super::$name.on_timer_compare() }
        }
    };
}

/// The interrupts a role binds on the timer's capture line (`… on TIMER1`, feature
/// `capture-line`), as `__bind_role` does on a USART: Timer0's compare unit `$compare`, and
/// the timer's capture (an edge on RX), compare B (the middle of a character's first stop
/// bit) and compare A (TX). A character completed runs `__private::$arrived` first, then
/// the role's receive handler; the transmitter's events run its data-register-empty
/// handler `$feed` (the slave's) and its transmit-complete one.
#[doc(hidden)]
#[macro_export]
macro_rules! __bind_capture {
    ($module:ident, $name:ident, $timer:ident, $compare:ident, $arrived:ident $(, $feed:ident)?) => {
        #[doc(hidden)]
        #[allow(non_snake_case)]
        mod $module {
            $crate::__bind_timer0_compare!($compare, $name);

            /// TIMERn_CAPT: an edge on RX.
            #[export_name = $crate::__chip!(vector $timer CAPT)]
            unsafe extern "avr-interrupt" fn CAPTURE() {
                // SAFETY: the capture interrupt's handler, interrupts disabled.
                unsafe { $crate::__private::capture_edge() }
            }

            /// TIMERn_COMPB: the middle of a character's first stop bit: the character to
            /// the role, its deadlines first, the edge interrupt free to run meanwhile.
            #[export_name = $crate::__chip!(vector $timer COMPB)]
            unsafe extern "avr-interrupt" fn STOP_BIT() {
                // SAFETY: compare B's handler, interrupts disabled; the role's receive
                // handler does not enable them.
                unsafe {
                    $crate::__private::capture_stop_bit(
                        $crate::__private::$compare,
                        || $crate::__private::$arrived(),
                        || super::$name.on_usart_rx(),
                    )
                }
            }

            /// TIMERn_COMPA: TX changed its level, or a character's end.
            #[export_name = $crate::__chip!(vector $timer COMPA)]
            unsafe extern "avr-interrupt" fn TRANSMIT() {
                // SAFETY: as in CAPTURE, from compare A's handler; the role's transmit
                // handlers do not enable interrupts.
                unsafe {
                    $crate::__private::capture_transmit(
                        || { $(super::$name.$feed())? },
                        || super::$name.on_usart_tx(),
                    )
                }
            }
        }
    };
}

/// Declares the Modbus TCP server `NAME` (feature `tcp`) for a data model type on a WIZnet
/// chip ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]), its chip select on the board's
/// pin 10 (the Ethernet shields') or on a pin type of the application's. Timer0's overflow
/// interrupt, which the crate binds with feature `tcp` (and `millis`), polls the chip once
/// the server has started; with `pin2_int`, pin 2's external interrupt is bound too.
///
/// ```ignore
/// avr_modbus::tcp_server!(SERVER: Registers, W5100);           // an Ethernet Shield R3
/// avr_modbus::tcp_server!(SERVER: Registers, W5500);           // an Ethernet Shield 2
/// avr_modbus::tcp_server!(SERVER: Registers, W5500, CsPin);    // a module's CS elsewhere
/// avr_modbus::tcp_server!(SERVER: Registers, W5100, pin2_int);  // INT wired to pin 2
/// ```
///
/// Its buffer holds the MBAP header and the model's longest PDU ([`crate::DataModel::FRAME`]
/// less the serial line's address and CRC). With `pin2_int` the handler uses the
/// `avr-interrupt` calling convention: the firmware crate needs
/// `#![feature(abi_avr_interrupt)]`. A serial slave or master may run beside it (they use
/// Timer0's compare units); nothing else may handle Timer0's overflow.
#[cfg(feature = "tcp")]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp"))))]
#[macro_export]
macro_rules! tcp_server {
    ($name:ident : $model:ty, $chip:ty) => {
        $crate::tcp_server!(@declare $name: $model, $chip, $crate::Pin10, false);
    };
    ($name:ident : $model:ty, $chip:ty, pin2_int) => {
        $crate::tcp_server!(@declare $name: $model, $chip, $crate::Pin10, true);
        $crate::tcp_server!(@pin2 $name);
    };
    ($name:ident : $model:ty, $chip:ty, $cs:ty) => {
        $crate::tcp_server!(@declare $name: $model, $chip, $cs, false);
    };
    ($name:ident : $model:ty, $chip:ty, $cs:ty, pin2_int) => {
        $crate::tcp_server!(@declare $name: $model, $chip, $cs, true);
        $crate::tcp_server!(@pin2 $name);
    };
    (@pin2 $name:ident) => {
        #[doc(hidden)]
        #[allow(non_snake_case)]
        mod __avr_modbus_tcp_pin2 {
            /// INTn on pin 2: the chip's INT line is low, a socket has news.
            #[export_name = $crate::__chip!(vector PIN2_INT)]
            unsafe extern "avr-interrupt" fn PIN2_INTERRUPT() {
                // SAFETY: pin 2's external interrupt handler, interrupts disabled.
                unsafe { super::$name.on_pin2() }
            }
        }
    };
    (@declare $name:ident : $model:ty, $chip:ty, $cs:ty, $int:literal) => {
        static $name: $crate::TcpServer<$model, $chip, $cs, { <$model as $crate::DataModel>::FRAME + 4 }, $int> =
            $crate::TcpServer::new();

        $crate::tcp_server!(@overflow $name);
    };
    (@overflow $name:ident) => {
        /// The TCP role's poll, which the crate's Timer0 overflow handler calls: every TCP role
        /// (`tcp_server!`, `tcp_gateway!`, `tcp_client!`) defines it, once per firmware.
        #[doc(hidden)]
        #[export_name = "avr_modbus_feature_tcp_needs_a_tcp_role"]
        unsafe extern "C" fn __avr_modbus_tcp_overflow() {
            // SAFETY: called from the Timer0 overflow handler only, interrupts disabled.
            unsafe { $name.on_overflow() }
        }
    };
}

/// Declares the Modbus TCP to RTU gateway `NAME` (features `tcp` and `master`) on a WIZnet
/// chip ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]) with its select on pin 10, and
/// optionally the RS-485 driver-enable pin type and the [`crate::tcp::Routes`] type; binds
/// the serial line's interrupts as [`crate::master!`] does (its USART's RX and TX complete,
/// Timer0 compare A) and serves the chip from Timer0's overflow as [`crate::tcp_server!`]
/// does.
///
/// ```ignore
/// avr_modbus::tcp_gateway!(GATEWAY: W5100);                   // pins 0/1, no DE pin
/// avr_modbus::tcp_gateway!(GATEWAY: W5100, DePin);            // RS-485 DE pin
/// avr_modbus::tcp_gateway!(GATEWAY: W5500, DePin, MyRoutes);  // routes of its own
/// avr_modbus::tcp_gateway!(GATEWAY on USART1: W5500, DePin);  // a Mega's Serial1
/// avr_modbus::tcp_gateway!(GATEWAY: W5100, DePin; pin2_int);  // INT wired to pin 2
/// ```
///
/// With `; pin2_int` the chip's INT line on pin 2 serves the TCP side as soon as a request
/// lands (as `tcp_server!`'s `pin2_int`).
/// The handlers use the `avr-interrupt` calling convention: the firmware crate needs
/// `#![feature(abi_avr_interrupt)]`. Nothing else may handle those interrupts, nor Timer0.
#[cfg(all(feature = "tcp", feature = "master"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp", feature = "master"))))]
#[macro_export]
macro_rules! tcp_gateway {
    ($name:ident on $usart:ident : $chip:ty $(, $de:ty $(, $routes:ty)?)? $(; $int:ident)?) => {
        $crate::tcp_gateway!(@pick $usart $name: $chip; [$($de)?] [$($($routes)?)?] [$($int)?]);
    };
    ($name:ident : $chip:ty $(, $de:ty $(, $routes:ty)?)? $(; $int:ident)?) => {
        $crate::__chip!(default_gateway $name: $chip; [$($de)?] [$($($routes)?)?] [$($int)?]);
    };
    (@pick $usart:ident $name:ident : $chip:ty; [] $routes:tt $int:tt) => {
        $crate::tcp_gateway!(@pick $usart $name: $chip; [$crate::NoPin] $routes $int);
    };
    (@pick $usart:ident $name:ident : $chip:ty; [$de:ty] [] $int:tt) => {
        $crate::tcp_gateway!(@pick $usart $name: $chip; [$de] [$crate::tcp::Direct] $int);
    };
    (@pick $usart:ident $name:ident : $chip:ty; [$de:ty] [$routes:ty] []) => {
        $crate::tcp_gateway!(@on $usart $name: $chip, $de, $routes, false);
    };
    (@pick $usart:ident $name:ident : $chip:ty; [$de:ty] [$routes:ty] [pin2_int]) => {
        $crate::tcp_gateway!(@on $usart $name: $chip, $de, $routes, true);
        $crate::tcp_server!(@pin2 $name);
    };
    (@on $usart:ident $name:ident : $chip:ty, $de:ty, $routes:ty, $int:literal) => {
        static $name: $crate::TcpGateway<
            $chip,
            $routes,
            $de,
            $crate::Pin10,
            { $crate::tcp::GATEWAY_BUFFER },
            $int,
            { $crate::__chip!(usart $usart) },
        > = $crate::TcpGateway::new();

        $crate::__bind_role!(__avr_modbus_gateway_interrupts, $name, $usart, TIMER0_COMPA, master_rx_arrived);

        $crate::tcp_server!(@overflow $name);
    };
}

/// Declares the Modbus TCP client `NAME` (features `tcp` and `master`) on a WIZnet chip
/// ([`crate::tcp::W5100`] or [`crate::tcp::W5500`]), its chip select on the board's pin 10
/// (the Ethernet shields') or on a pin type of the application's, with buffers of `N` bytes
/// for the request and the reply (256 when left out; a read of `q` registers is answered in
/// 5 + 2`q`). Timer0's overflow interrupt, which the crate binds with feature `tcp`, drives
/// the client once started. One TCP role per firmware: a `tcp_server!` or `tcp_gateway!` beside
/// it does not link.
///
/// ```ignore
/// avr_modbus::tcp_client!(CLIENT: W5100);              // an Ethernet Shield R3, 256-byte buffers
/// avr_modbus::tcp_client!(CLIENT: W5500, 25);          // an Ethernet Shield 2, 25-byte buffers
/// avr_modbus::tcp_client!(CLIENT: W5500, CsPin, 25);   // a module's CS elsewhere
/// ```
#[cfg(all(feature = "tcp", feature = "master"))]
#[cfg_attr(docsrs, doc(cfg(all(target_arch = "avr", feature = "tcp", feature = "master"))))]
#[macro_export]
macro_rules! tcp_client {
    ($name:ident : $chip:ty) => {
        $crate::tcp_client!(@declare $name: $chip, $crate::Pin10, 256);
    };
    ($name:ident : $chip:ty, $n:literal) => {
        $crate::tcp_client!(@declare $name: $chip, $crate::Pin10, $n);
    };
    ($name:ident : $chip:ty, $cs:ty) => {
        $crate::tcp_client!(@declare $name: $chip, $cs, 256);
    };
    ($name:ident : $chip:ty, $cs:ty, $n:literal) => {
        $crate::tcp_client!(@declare $name: $chip, $cs, $n);
    };
    (@declare $name:ident : $chip:ty, $cs:ty, $n:literal) => {
        static $name: $crate::TcpClient<$chip, $cs, { $n }> = $crate::TcpClient::new();

        $crate::tcp_server!(@overflow $name);
    };
}
