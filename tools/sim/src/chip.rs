//! The chips the simulator runs and what differs between them, as data: one table row per chip
//! (USART register blocks, interrupt vector numbers, the interrupt response time), read from
//! the firmware's own description of its chips, `chips/chips.txt` (sources there).

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

#[allow(dead_code)] // the firmware's build reads the rest of each chip's facts
#[path = "../../../chips/table.rs"]
mod table;

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

    /// USARTn's block at its address on every chip here that has it, whether or not a given
    /// chip has it: USART0 0xC0, USART1 0xC8, USART2 0xD0, USART3 0x130.
    pub fn usart(n: u8) -> Option<UsartRegs> {
        table()
            .iter()
            .flat_map(|info| &info.facts.usarts)
            .find(|usart| usart.number == n)
            .map(|u| UsartRegs::at(u.block))
    }
}

/// One chip's facts.
struct Info {
    chip: Chip,
    /// Its block of `chips/chips.txt`.
    facts: table::Facts,
}

/// Every chip, in the order of [`Chip::ALL`], which is the order of `chips/chips.txt`.
fn table() -> &'static [Info] {
    static TABLE: OnceLock<Vec<Info>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let chips = table::parse(include_str!("../../../chips/chips.txt")).unwrap_or_else(|error| panic!("{error}"));
        assert_eq!(chips.len(), Chip::ALL.len(), "chips/chips.txt describes a chip Chip::ALL lacks, or the reverse");
        Chip::ALL.into_iter().zip(chips).map(|(chip, facts)| Info { chip, facts }).collect()
    })
}

impl Chip {
    /// Every supported chip.
    pub const ALL: [Chip; 5] =
        [Chip::Atmega328p, Chip::Atmega168, Chip::Atmega32u4, Chip::Atmega1280, Chip::Atmega2560];

    fn info(self) -> &'static table::Facts {
        // The table is in the order of ALL, and ALL lists every variant.
        &table()[Chip::ALL.iter().position(|&c| c == self).unwrap_or(0)].facts
    }

    /// avr-gcc's name for it (`-mmcu`), also simavr's core name: `"atmega2560"`.
    pub fn name(self) -> &'static str {
        &self.info().cpu
    }

    /// The chip avr-gcc calls `name` (any case), if supported.
    pub fn from_name(name: &str) -> Option<Chip> {
        table().iter().find(|i| i.facts.cpu.eq_ignore_ascii_case(name)).map(|i| i.chip)
    }

    /// Its USARTs' numbers, the default one first: `[0]`, `[1]` (32U4), `[0, 1, 2, 3]` (Megas).
    pub fn usarts(self) -> Vec<u8> {
        let default = self.default_usart();
        let others = self.info().usarts.iter().map(|u| u.number).filter(|&n| n != default);
        std::iter::once(default).chain(others).collect()
    }

    /// The USART a board's serial pins use unless told otherwise: USART0, or USART1 on the 32U4.
    pub fn default_usart(self) -> u8 {
        self.info().pins_0_1().number
    }

    /// Whether it has USARTn.
    pub fn has_usart(self, n: u8) -> bool {
        self.info().usarts.iter().any(|u| u.number == n)
    }

    /// USARTn's register addresses, if the chip has it.
    pub fn usart_regs(self, n: u8) -> Option<UsartRegs> {
        self.info().usarts.iter().find(|u| u.number == n).map(|u| UsartRegs::at(u.block))
    }

    /// Timer0's and USARTn's vector numbers, if the chip has USARTn.
    pub fn vectors(self, usart: u8) -> Option<Vectors> {
        let info = self.info();
        let [rx, udre, tx] = info.usarts.iter().find(|u| u.number == usart)?.vectors;
        let [compa, compb, ovf] = info.timer0;
        Some(Vectors {
            timer0_compa: compa,
            timer0_compb: compb,
            timer0_ovf: ovf,
            usart_rx: rx,
            usart_udre: udre,
            usart_tx: tx,
        })
    }

    /// Bytes a CALL or an interrupt pushes: 2, or 3 with the 2560's 22-bit program counter.
    pub fn return_address_bytes(self) -> u8 {
        self.info().return_address_bytes
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
        2 + u64::from(self.info().return_address_bytes)
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
            let names: Vec<&str> = table().iter().map(|i| i.facts.cpu.as_str()).collect();
            format!("unsupported chip `{s}` (supported: {})", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_all() {
        for (info, chip) in table().iter().zip(Chip::ALL) {
            assert_eq!(info.chip, chip);
            // chips/chips.txt names each chip as its variant does: Atmega2560 is atmega2560.
            assert_eq!(format!("{chip:?}").to_lowercase(), info.facts.cpu);
            assert_eq!(Chip::from_name(&info.facts.cpu), Some(chip));
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
