//! The chips the simulator runs and what differs between them, as data: one table row per chip
//! (USART register blocks, interrupt vector numbers, the interrupt response time).
//!
//! Sources: avr-libc's `io*.h` (register addresses, `__vector_N` numbers), the data sheets'
//! "Interrupt Response Time" sections, and simavr 1.6's cores (checked to agree).

use std::fmt;
use std::str::FromStr;

/// A microcontroller the simulator can run, named as avr-gcc's `-mmcu` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Chip {
    /// ATmega328P: Arduino Uno, Nano, Pro Mini. USART0.
    Atmega328p,
    /// ATmega168: Nano168, Diecimila. USART0.
    Atmega168,
    /// ATmega32U4: Leonardo, Micro, Pro Micro. USART1 only (USB is the chip's own).
    Atmega32u4,
    /// ATmega1280: Mega 1280. USART0-3; a 16-bit program counter (2-byte return addresses).
    Atmega1280,
    /// ATmega2560: Mega 2560. USART0-3; a 22-bit program counter (3-byte return addresses).
    Atmega2560,
}

/// Interrupt vector numbers (`__vector_N`) that matter to a Modbus slave or master on one chip and USART.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Vectors {
    /// Timer/Counter0 compare match A (the master's silences and timeouts).
    pub timer0_compa: u8,
    /// Timer/Counter0 compare match B.
    pub timer0_compb: u8,
    /// Timer/Counter0 overflow.
    pub timer0_ovf: u8,
    /// USARTn receive complete.
    pub usart_rx: u8,
    /// USARTn data register empty.
    pub usart_udre: u8,
    /// USARTn transmit complete.
    pub usart_tx: u8,
}

/// Data-space addresses of one USART's registers (UCSRnA ... UDRn).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UsartRegs {
    /// Control and status register A (RXCn 0x80, TXCn 0x40, UDREn 0x20, FEn 0x10, DORn 0x08,
    /// UPEn 0x04, U2Xn 0x02).
    pub ucsra: u16,
    /// Control and status register B.
    pub ucsrb: u16,
    /// Control and status register C.
    pub ucsrc: u16,
    /// Baud rate register, low byte.
    pub ubrrl: u16,
    /// Baud rate register, high byte.
    pub ubrrh: u16,
    /// Data register.
    pub udr: u16,
}

impl UsartRegs {
    /// The block whose UCSRnA is at `base`.
    pub const fn at(base: u16) -> UsartRegs {
        UsartRegs { ucsra: base, ucsrb: base + 1, ucsrc: base + 2, ubrrl: base + 4, ubrrh: base + 5, udr: base + 6 }
    }

    /// USARTn's block (0-3) at its address on every chip here, whether or not a chip has it:
    /// USART0 0xC0, USART1 0xC8, USART2 0xD0, USART3 0x130.
    pub const fn usart(n: u8) -> Option<UsartRegs> {
        match n {
            0 => Some(UsartRegs::at(0xC0)),
            1 => Some(UsartRegs::at(0xC8)),
            2 => Some(UsartRegs::at(0xD0)),
            3 => Some(UsartRegs::at(0x130)),
            _ => None,
        }
    }
}

/// One chip's facts.
struct Info {
    chip: Chip,
    name: &'static str,
    /// Vector numbers of TIMER0_COMPA, TIMER0_COMPB and TIMER0_OVF.
    timer0: (u8, u8, u8),
    /// (USART number, vectors RX, UDRE, TX), first the one a board's Modbus wire uses by default.
    usarts: &'static [(u8, [u8; 3])],
    /// Bytes of a return address (the program counter pushed by CALL and interrupts).
    pc_bytes: u8,
    /// ADC channels the multiplexer can select (single-ended): 0..adc.
    adc: u8,
    /// Ports B, C, D wired as on the Uno (Arduino pins 0-19).
    uno_pins: bool,
}

const MEGA_USARTS: &[(u8, [u8; 3])] = &[(0, [25, 26, 27]), (1, [36, 37, 38]), (2, [51, 52, 53]), (3, [54, 55, 56])];

/// Every chip, in the order of [`Chip::ALL`].
const TABLE: [Info; 5] = [
    Info {
        chip: Chip::Atmega328p,
        name: "atmega328p",
        timer0: (14, 15, 16),
        usarts: &[(0, [18, 19, 20])],
        pc_bytes: 2,
        adc: 8,
        uno_pins: true,
    },
    Info {
        chip: Chip::Atmega168,
        name: "atmega168",
        timer0: (14, 15, 16),
        usarts: &[(0, [18, 19, 20])],
        pc_bytes: 2,
        adc: 8,
        uno_pins: true,
    },
    Info {
        chip: Chip::Atmega32u4,
        name: "atmega32u4",
        timer0: (21, 22, 23),
        usarts: &[(1, [25, 26, 27])],
        pc_bytes: 2,
        adc: 14,
        uno_pins: false,
    },
    Info {
        chip: Chip::Atmega1280,
        name: "atmega1280",
        timer0: (21, 22, 23),
        usarts: MEGA_USARTS,
        pc_bytes: 2,
        adc: 16,
        uno_pins: false,
    },
    Info {
        chip: Chip::Atmega2560,
        name: "atmega2560",
        timer0: (21, 22, 23),
        usarts: MEGA_USARTS,
        pc_bytes: 3,
        adc: 16,
        uno_pins: false,
    },
];

impl Chip {
    /// Every supported chip.
    pub const ALL: [Chip; 5] =
        [Chip::Atmega328p, Chip::Atmega168, Chip::Atmega32u4, Chip::Atmega1280, Chip::Atmega2560];

    fn info(self) -> &'static Info {
        // TABLE is in the order of ALL, and ALL lists every variant.
        &TABLE[Chip::ALL.iter().position(|&c| c == self).unwrap_or(0)]
    }

    /// avr-gcc's name for it (`-mmcu`), also simavr's core name: `"atmega2560"`.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The chip avr-gcc calls `name` (any case), if supported.
    pub fn from_name(name: &str) -> Option<Chip> {
        TABLE.iter().find(|i| i.name.eq_ignore_ascii_case(name)).map(|i| i.chip)
    }

    /// Its USARTs' numbers, the default one first: `[0]`, `[1]` (32U4), `[0, 1, 2, 3]` (Megas).
    pub fn usarts(self) -> Vec<u8> {
        self.info().usarts.iter().map(|u| u.0).collect()
    }

    /// The USART a board's serial pins use unless told otherwise: USART0, or USART1 on the 32U4.
    pub fn default_usart(self) -> u8 {
        self.info().usarts[0].0
    }

    /// Whether it has USARTn.
    pub fn has_usart(self, n: u8) -> bool {
        self.info().usarts.iter().any(|u| u.0 == n)
    }

    /// USARTn's register addresses, if the chip has it.
    pub fn usart_regs(self, n: u8) -> Option<UsartRegs> {
        if self.has_usart(n) {
            UsartRegs::usart(n)
        } else {
            None
        }
    }

    /// Timer0's and USARTn's vector numbers, if the chip has USARTn.
    pub fn vectors(self, usart: u8) -> Option<Vectors> {
        let info = self.info();
        let &(_, [rx, udre, tx]) = info.usarts.iter().find(|u| u.0 == usart)?;
        Some(Vectors {
            timer0_compa: info.timer0.0,
            timer0_compb: info.timer0.1,
            timer0_ovf: info.timer0.2,
            usart_rx: rx,
            usart_udre: udre,
            usart_tx: tx,
        })
    }

    /// Bytes a CALL or an interrupt pushes: 2, or 3 with the 2560's 22-bit program counter.
    pub fn return_address_bytes(self) -> u8 {
        self.info().pc_bytes
    }

    /// Cycles from an interrupt being taken to the first instruction at its vector: 4 with a
    /// 2-byte program counter, 5 with a 3-byte one (data sheets, "Interrupt Response Time").
    /// RETI takes as many; simavr 1.6 already counts RETI (and CALL, RET) that way.
    ///
    /// The ATmega640/1280/2560 data sheet gives five cycles and a three-byte program counter for
    /// the whole family, but only the 2560 has one: the 1280's 64 K words of flash need 16 bits,
    /// avr-gcc builds it as `avr51` (2-byte return addresses) and simavr's core pops two bytes,
    /// so the 1280 is counted like the 328P (the early ATmega644 data sheet had the same slip).
    pub fn interrupt_response_cycles(self) -> u64 {
        2 + u64::from(self.info().pc_bytes)
    }

    /// Cycles an interrupt that wakes the CPU from sleep adds on top of the response: as many
    /// again (4, or 5 with a 3-byte program counter), plus the sleep mode's start-up time,
    /// which is none for idle mode and not modelled.
    pub fn wake_up_extra_cycles(self) -> u64 {
        self.interrupt_response_cycles()
    }
}

impl Chip {
    /// ADC channels (single-ended inputs ADC0..ADCn-1): 8 on the 328P and 168, 14 on the 32U4
    /// (ADC2 and ADC3 are not bonded out), 16 on the Megas.
    pub fn adc_channels(self) -> u8 {
        self.info().adc
    }

    /// Whether Arduino pin numbers 0-19 name its pins as on the Uno (the 328P and 168 boards).
    pub fn has_uno_pinout(self) -> bool {
        self.info().uno_pins
    }
}

impl fmt::Display for Chip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Chip {
    type Err = String;

    fn from_str(s: &str) -> Result<Chip, String> {
        Chip::from_name(s).ok_or_else(|| {
            let names: Vec<&str> = TABLE.iter().map(|i| i.name).collect();
            format!("unsupported chip `{s}` (supported: {})", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_all() {
        for (info, chip) in TABLE.iter().zip(Chip::ALL) {
            assert_eq!(info.chip, chip);
            assert_eq!(Chip::from_name(info.name), Some(chip));
            assert_eq!(chip.name().parse::<Chip>(), Ok(chip));
        }
        assert_eq!(Chip::from_name("ATmega2560"), Some(Chip::Atmega2560));
        assert!("atmega4809".parse::<Chip>().unwrap_err().contains("atmega328p"));
    }

    #[test]
    fn vectors_per_chip() {
        let v = Chip::Atmega328p.vectors(0).unwrap();
        assert_eq!((v.timer0_compb, v.timer0_ovf, v.usart_rx, v.usart_udre, v.usart_tx), (15, 16, 18, 19, 20));
        assert_eq!(Chip::Atmega32u4.vectors(0), None);
        assert_eq!(Chip::Atmega32u4.vectors(1).unwrap().usart_rx, 25);
        assert_eq!(v.timer0_compa, 14);
        assert_eq!(Chip::Atmega2560.vectors(2).unwrap().timer0_compa, 21);
        assert_eq!(Chip::Atmega2560.vectors(3).unwrap().usart_tx, 56);
        assert_eq!(Chip::Atmega1280.vectors(2).unwrap().usart_udre, 52);
        assert_eq!(Chip::Atmega168.vectors(1), None);
        assert_eq!(Chip::Atmega32u4.default_usart(), 1);
        assert_eq!(Chip::Atmega2560.usarts(), [0, 1, 2, 3]);
    }

    #[test]
    fn usart_blocks() {
        assert_eq!(Chip::Atmega2560.usart_regs(3).unwrap().udr, 0x136);
        assert_eq!(Chip::Atmega32u4.usart_regs(1).unwrap().ucsra, 0xC8);
        assert_eq!(Chip::Atmega328p.usart_regs(2), None);
        assert_eq!(UsartRegs::usart(4), None);
    }

    #[test]
    fn response_times() {
        assert_eq!(Chip::Atmega328p.interrupt_response_cycles(), 4);
        assert_eq!(Chip::Atmega1280.interrupt_response_cycles(), 4);
        assert_eq!(Chip::Atmega2560.interrupt_response_cycles(), 5);
    }
}
