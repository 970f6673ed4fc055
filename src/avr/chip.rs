//! What differs between the chips the crate runs on, one table each (data sheets' register
//! summaries and interrupt vector tables; avr-libc's `io*.h`): the USARTs' register
//! blocks, the interrupt vectors the slave binds, the EEPROM's size and the board's LED.
//! Everything else the slave uses — Timer0, the EEPROM's registers, SREG — sits at the same
//! addresses on all of them.
//!
//! The chip is the one the build is for (`-C target-cpu`, or a JSON target's name; see
//! `build.rs`), chosen once here: the drivers read [`CHIP`] and carry no `cfg` of their
//! own. Vector names must be literals where [`crate::slave!`] binds them, so each table has
//! a twin `__chip!` macro that names them, picked by the same `cfg`.

/// One chip's facts.
pub(crate) struct Chip {
    /// The data-space address of each USART's register block (UCSRnA … UDRn, 7 bytes), by
    /// number; `None` where the chip has no such USART.
    pub(crate) usarts: [Option<usize>; 4],
    /// The EEPROM's size in bytes.
    pub(crate) eeprom_size: u16,
    /// The on-board LED "L" of the chip's Arduino boards: the data-space address of its
    /// port's PINx register (DDRx and PORTx follow), and its bit.
    pub(crate) led: (usize, u8),
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

/// ATmega328P and ATmega168 (Uno, Nano, Pro Mini, Nano168): USART0 on pins 0/1, LED on
/// PB5 (pin 13). Also the table the docs built on the host with `--cfg docsrs` name (see
/// `src/lib.rs`): no page shows a value of it.
#[cfg(any(avr_chip = "atmega328p", avr_chip = "atmega168", all(doc, docsrs, not(target_arch = "avr"))))]
pub(crate) const CHIP: Chip = Chip {
    usarts: [Some(0xC0), None, None, None],
    eeprom_size: if cfg!(avr_chip = "atmega168") { 512 } else { 1024 },
    led: (0x23, 5),
};

/// The ATmega328P's and ATmega168's vectors (`__vector_N`).
#[cfg(any(avr_chip = "atmega328p", avr_chip = "atmega168"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __chip {
    (vector TIMER0_COMPA) => { "__vector_14" };
    (vector TIMER0_COMPB) => { "__vector_15" };
    (vector TIMER0_OVF) => { "__vector_16" };
    (vector USART0 RX) => { "__vector_18" };
    (vector USART0 UDRE) => { "__vector_19" };
    (vector USART0 TX) => { "__vector_20" };
    (usart USART0) => { 0 };
    (usart $other:ident) => {
        ::core::compile_error!(::core::concat!(
            "the ATmega328P and ATmega168 have one USART, USART0 (pins 0/1), not ",
            ::core::stringify!($other)
        ))
    };
    (vector $other:ident $what:ident) => { "" };
    (default $($slave:tt)*) => { $crate::slave!(@on USART0 $($slave)*); };
    (default_master $($master:tt)*) => { $crate::master!(@on USART0 $($master)*); };
}

/// ATmega32U4 (Leonardo, Micro, Pro Micro): USART1 on pins 0/1 (USB is the chip's own),
/// LED on PC7 (pin 13 of the Leonardo and Micro; the Pro Micro has no LED there).
#[cfg(avr_chip = "atmega32u4")]
pub(crate) const CHIP: Chip = Chip { usarts: [None, Some(0xC8), None, None], eeprom_size: 1024, led: (0x26, 7) };

/// The ATmega32U4's vectors.
#[cfg(avr_chip = "atmega32u4")]
#[doc(hidden)]
#[macro_export]
macro_rules! __chip {
    (vector TIMER0_COMPA) => { "__vector_21" };
    (vector TIMER0_COMPB) => { "__vector_22" };
    (vector TIMER0_OVF) => { "__vector_23" };
    (vector USART1 RX) => { "__vector_25" };
    (vector USART1 UDRE) => { "__vector_26" };
    (vector USART1 TX) => { "__vector_27" };
    (usart USART1) => { 1 };
    (usart $other:ident) => {
        ::core::compile_error!(::core::concat!(
            "the ATmega32U4 has one USART, USART1 (pins 0/1), not ",
            ::core::stringify!($other)
        ))
    };
    (vector $other:ident $what:ident) => { "" };
    (default $($slave:tt)*) => { $crate::slave!(@on USART1 $($slave)*); };
    (default_master $($master:tt)*) => { $crate::master!(@on USART1 $($master)*); };
}

/// ATmega2560 and ATmega1280 (Mega): USART0 on pins 0/1 (shared with USB), USART1 on
/// 19/18, USART2 on 17/16, USART3 on 15/14 (extended I/O, `lds`/`sts` only); LED on PB7
/// (pin 13).
#[cfg(any(avr_chip = "atmega2560", avr_chip = "atmega1280"))]
pub(crate) const CHIP: Chip =
    Chip { usarts: [Some(0xC0), Some(0xC8), Some(0xD0), Some(0x130)], eeprom_size: 4096, led: (0x23, 7) };

/// The ATmega2560's and ATmega1280's vectors.
#[cfg(any(avr_chip = "atmega2560", avr_chip = "atmega1280"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __chip {
    (vector TIMER0_COMPA) => { "__vector_21" };
    (vector TIMER0_COMPB) => { "__vector_22" };
    (vector TIMER0_OVF) => { "__vector_23" };
    (vector USART0 RX) => { "__vector_25" };
    (vector USART0 UDRE) => { "__vector_26" };
    (vector USART0 TX) => { "__vector_27" };
    (vector USART1 RX) => { "__vector_36" };
    (vector USART1 UDRE) => { "__vector_37" };
    (vector USART1 TX) => { "__vector_38" };
    (vector USART2 RX) => { "__vector_51" };
    (vector USART2 UDRE) => { "__vector_52" };
    (vector USART2 TX) => { "__vector_53" };
    (vector USART3 RX) => { "__vector_54" };
    (vector USART3 UDRE) => { "__vector_55" };
    (vector USART3 TX) => { "__vector_56" };
    (usart USART0) => { 0 };
    (usart USART1) => { 1 };
    (usart USART2) => { 2 };
    (usart USART3) => { 3 };
    (usart $other:ident) => {
        ::core::compile_error!(::core::concat!(
            "the ATmega2560 and ATmega1280 have USART0 to USART3, not ",
            ::core::stringify!($other)
        ))
    };
    (vector $other:ident $what:ident) => { "" };
    (default $($slave:tt)*) => { $crate::slave!(@on USART0 $($slave)*); };
    (default_master $($master:tt)*) => { $crate::master!(@on USART0 $($master)*); };
}

#[cfg(avr_chip = "unsupported")]
::core::compile_error!(::core::concat!(
    "avr-modbus runs on the ATmega328P, ATmega168, ATmega32U4, ATmega1280 and ATmega2560 ",
    "(build with -C target-cpu=atmega328p, atmega168, atmega32u4, atmega1280 or atmega2560); ",
    "this build is for ",
    env!("AVR_MODBUS_CPU")
));

/// No table, so that the only error is the one above.
#[cfg(avr_chip = "unsupported")]
pub(crate) const CHIP: Chip = Chip { usarts: [None; 4], eeprom_size: 0, led: (0, 0) };

/// No vectors either.
#[cfg(avr_chip = "unsupported")]
#[doc(hidden)]
#[macro_export]
macro_rules! __chip {
    (vector $($what:ident)*) => { "" };
    (usart $what:ident) => { 0 };
    (default $($slave:tt)*) => { $crate::slave!(@on USART0 $($slave)*); };
    (default_master $($master:tt)*) => { $crate::master!(@on USART0 $($master)*); };
}
