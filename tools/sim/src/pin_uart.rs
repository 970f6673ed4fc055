//! A serial line on any pin, for a UART the firmware builds from a timer (AltSoftSerial's
//! design: input capture on RX, output compare on TX): characters turned into levels scheduled
//! on an input ([`Uno::send_pin_uart`], [`Uno::send_pin_bits`] for malformed ones), and an
//! output's logged levels turned back into characters ([`Uno::take_pin_uart`]) as a UART
//! receiver reads them.

use crate::pins::PinId;
use crate::{Error, Parity, Uno, F_CPU};

/// The format of a serial line on a pin. Bit times are `F_CPU / baud` cycles, not rounded
/// each: bit `k` of a character starts `k * F_CPU / baud` cycles (to the nearest cycle) after
/// its start edge, as a host's serial adapter with its own clock sends them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinUart {
    /// Bits per second.
    pub baud: u32,
    /// Data bits, 5-8, sent least significant first.
    pub data_bits: u8,
    /// The parity bit after the data bits, if any.
    pub parity: Parity,
    /// Stop bits, 1 or 2.
    pub stop_bits: u8,
}

/// A character read from an output pin's logged levels ([`Uno::take_pin_uart`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodedByte {
    /// The data bits (with fewer than 8, in the low bits).
    pub byte: u8,
    /// Cycle of the start bit's falling edge.
    pub start_cycle: u64,
    /// Cycle at which the last stop bit ends: `start_cycle` + a character time.
    pub end_cycle: u64,
    /// The parity bit matched the data (always with no parity).
    pub parity_ok: bool,
    /// Every stop bit was high at its middle (the megaAVR's receiver checks only the first).
    pub stop_ok: bool,
}

impl PinUart {
    /// `baud` with 8 data bits, no parity, 1 stop bit.
    pub const fn new(baud: u32) -> PinUart {
        PinUart { baud, data_bits: 8, parity: Parity::None, stop_bits: 1 }
    }

    /// The same with `parity`.
    pub const fn parity(self, parity: Parity) -> PinUart {
        PinUart { parity, ..self }
    }

    /// The same with `n` stop bits.
    pub const fn stop_bits(self, n: u8) -> PinUart {
        PinUart { stop_bits: n, ..self }
    }

    /// The same with `n` data bits.
    pub const fn data_bits(self, n: u8) -> PinUart {
        PinUart { data_bits: n, ..self }
    }

    fn check(self) -> Result<PinUart, Error> {
        if self.baud > 0 && (5..=8).contains(&self.data_bits) && (1..=2).contains(&self.stop_bits) {
            Ok(self)
        } else {
            Err(Error::BadPinUart(self))
        }
    }

    /// Bits per character: start + data + parity + stop.
    pub fn char_bits(&self) -> u32 {
        1 + u32::from(self.data_bits) + u32::from(self.parity != Parity::None) + u32::from(self.stop_bits)
    }

    /// Cycles from a character's start edge to the start of its bit `k` (bit 0 is the start
    /// bit; [`PinUart::char_bits`] gives the character's end), to the nearest cycle.
    pub fn bit_start(&self, k: u32) -> u64 {
        (2 * u64::from(k) * F_CPU + u64::from(self.baud)) / (2 * u64::from(self.baud))
    }

    /// Cycles from the start edge to the middle of bit `k`, where a receiver samples it.
    fn bit_middle(&self, k: u32) -> u64 {
        ((2 * u64::from(k) + 1) * F_CPU + u64::from(self.baud)) / (2 * u64::from(self.baud))
    }

    /// The line's level during each bit of a character carrying `byte`: the start bit (low),
    /// the data bits least significant first, the parity bit, the stop bits (high). Change
    /// one to make a malformed character for [`Uno::send_pin_bits`].
    pub fn frame(&self, byte: u8) -> Vec<bool> {
        let data: Vec<bool> = (0..self.data_bits).map(|b| byte >> b & 1 != 0).collect();
        let odd_ones = data.iter().filter(|&&bit| bit).count() % 2 == 1;
        let parity = match self.parity {
            Parity::None => None,
            Parity::Even => Some(odd_ones),
            Parity::Odd => Some(!odd_ones),
        };
        let stop = std::iter::repeat_n(true, usize::from(self.stop_bits));
        std::iter::once(false).chain(data).chain(parity).chain(stop).collect()
    }

    /// Reads the characters a line carries that have ended by `now`: `level` before the first
    /// of `edges` (cycle, new level). As a UART receiver: a falling edge while idle starts a
    /// character; the start bit must still be low at its middle (else it was a glitch, and the
    /// search goes on after that sample); each further bit is sampled at its middle; after the
    /// last stop bit's sample the receiver waits for the next falling edge (a line held low
    /// gives none). Returns the characters and how many edges they used up (those of a
    /// character not ended by `now` are left).
    fn decode(&self, level: bool, edges: &[(u64, bool)], now: u64) -> (Vec<DecodedByte>, usize) {
        let level_at = |cycle: u64| match edges.partition_point(|&(at, _)| at <= cycle) {
            0 => level,
            n => edges[n - 1].1,
        };
        let mut bytes = Vec::new();
        let (mut scan, mut not_until) = (0, None::<u64>);
        loop {
            // each edge is a change: a low one falls
            let start = loop {
                let Some(&(at, high)) = edges.get(scan) else {
                    return (bytes, scan);
                };
                if !high && not_until.is_none_or(|sample| at > sample) {
                    break scan;
                }
                scan += 1;
            };
            let start_cycle = edges[start].0;
            let end_cycle = start_cycle + self.bit_start(self.char_bits());
            if end_cycle > now {
                return (bytes, start);
            }
            scan = start + 1;
            let sample = |k: u32| level_at(start_cycle + self.bit_middle(k));
            if sample(0) {
                not_until = Some(start_cycle + self.bit_middle(0));
                continue;
            }
            let data_bits = u32::from(self.data_bits);
            let byte = (0..data_bits).filter(|&b| sample(1 + b)).fold(0u8, |byte, b| byte | 1 << b);
            let odd_ones = byte.count_ones() % 2 == 1;
            let parity_ok = match self.parity {
                Parity::None => true,
                Parity::Even => sample(1 + data_bits) == odd_ones,
                Parity::Odd => sample(1 + data_bits) != odd_ones,
            };
            let first_stop = self.char_bits() - u32::from(self.stop_bits);
            let stop_ok = (first_stop..self.char_bits()).all(sample);
            bytes.push(DecodedByte { byte, start_cycle, end_cycle, parity_ok, stop_ok });
            not_until = Some(start_cycle + self.bit_middle(self.char_bits() - 1));
        }
    }
}

impl Uno {
    /// Drives input `pin` from outside with `bits`, one level per bit time of `uart`'s baud
    /// rate, the first from `start_cycle` ([`Uno::schedule_pin`] at each change). The line
    /// keeps the last level afterwards. Returns the cycle at which the last bit ends.
    ///
    /// With [`PinUart::frame`] this makes any character, well formed or not: a wrong parity
    /// bit, a missing stop bit (then the line stays low: end it with a high bit), characters
    /// run together. A glitch or a break is two [`Uno::schedule_pin`] calls.
    pub fn send_pin_bits(
        &mut self,
        pin: impl PinId,
        uart: PinUart,
        start_cycle: u64,
        bits: &[bool],
    ) -> Result<u64, Error> {
        self.schedule_bits(pin, uart.check()?, start_cycle, 0, bits)
    }

    /// Schedules `bits` as bits `first_bit`.. of a bit clock running from `origin` (only the
    /// changes, and the first); returns the cycle at which the last one ends.
    fn schedule_bits(
        &mut self,
        pin: impl PinId,
        uart: PinUart,
        origin: u64,
        first_bit: u32,
        bits: &[bool],
    ) -> Result<u64, Error> {
        let mut last = None;
        let mut bit = first_bit;
        for &level in bits {
            if last != Some(level) {
                self.schedule_pin(pin, origin + uart.bit_start(bit), level)?;
                last = Some(level);
            }
            bit += 1;
        }
        Ok(origin + uart.bit_start(bit))
    }

    /// Sends `bytes` on input `pin` as a serial line in `uart`'s format: the first start bit at
    /// `first_start_cycle`, each next one `gap_cycles` of idle (high) line after the previous
    /// character's last stop bit (0: back to back). One bit clock times them all, as a serial
    /// adapter's does: character `k` starts `k * gap_cycles` plus `k` character times (to the
    /// nearest cycle, [`PinUart::bit_start`]) after the first. The line must be high (idle)
    /// before; it is high after. Returns the cycle at which the last stop bit ends.
    pub fn send_pin_uart(
        &mut self,
        pin: impl PinId,
        bytes: &[u8],
        uart: PinUart,
        first_start_cycle: u64,
        gap_cycles: u64,
    ) -> Result<u64, Error> {
        let uart = uart.check()?;
        let mut end = first_start_cycle;
        for (k, &byte) in (0u32..).zip(bytes) {
            let origin = first_start_cycle + u64::from(k) * gap_cycles;
            end = self.schedule_bits(pin, uart, origin, k * uart.char_bits(), &uart.frame(byte))?;
        }
        Ok(end)
    }

    /// Reads the characters output `pin` ([`Uno::watch_pin`]) has sent in `uart`'s format
    /// since the last call, each sampled at the middle of its bits from its start edge as a
    /// receiver does ([`DecodedByte`]). A character still under way is left for the next call,
    /// with the level changes after it; the changes read are used up (they no longer come from
    /// [`Uno::take_pin_edges`]).
    pub fn take_pin_uart(&mut self, pin: impl PinId, uart: PinUart) -> Result<Vec<DecodedByte>, Error> {
        let uart = uart.check()?;
        let index = self.drain_pin_log(pin)?;
        let now = self.now();
        let line = &mut self.logged[index];
        let (bytes, used) = uart.decode(line.level, &line.edges, now);
        if used > 0 {
            line.level = line.edges[used - 1].1;
            line.edges.drain(..used);
        }
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EVEN_19200: PinUart = PinUart::new(19200).parity(Parity::Even);

    /// The edges `bits` make on a line idle high, from `start`.
    fn edges(uart: PinUart, start: u64, bits: &[bool]) -> Vec<(u64, bool)> {
        let mut level = true;
        let mut out = Vec::new();
        for (k, &bit) in (0u32..).zip(bits) {
            if bit != level {
                out.push((start + uart.bit_start(k), bit));
                level = bit;
            }
        }
        out
    }

    #[test]
    fn bit_times_are_not_rounded_each() {
        // 16 MHz / 19200 = 833.33 cycles: 11 bits are 9167, not 11 * 833
        assert_eq!(EVEN_19200.bit_start(1), 833);
        assert_eq!(EVEN_19200.bit_start(11), 9167);
        assert_eq!(EVEN_19200.bit_middle(0), 417);
        assert_eq!(PinUart::new(38400).bit_start(3), 1250);
    }

    #[test]
    fn frame_is_start_data_lsb_first_parity_stop() {
        // 0x31 = 0b0011_0001: three ones, even parity bit 1
        let frame = EVEN_19200.frame(0x31);
        assert_eq!(frame, [false, true, false, false, false, true, true, false, false, true, true]);
        assert_eq!(PinUart::new(9600).stop_bits(2).frame(0).len(), 11);
        assert!(!PinUart::new(9600).parity(Parity::Odd).frame(0x31)[9], "odd parity of three ones is 0");
    }

    #[test]
    fn decodes_what_it_encodes_and_keeps_a_character_under_way() {
        let uart = PinUart::new(38400).stop_bits(2);
        let mut line = edges(uart, 1000, &uart.frame(0xA5));
        let second = 1000 + uart.bit_start(11);
        line.extend(edges(uart, second, &uart.frame(0x00)));
        let (bytes, used) = uart.decode(true, &line, second + 100);
        assert_eq!(bytes.len(), 1);
        assert_eq!((bytes[0].byte, bytes[0].start_cycle, bytes[0].end_cycle), (0xA5, 1000, second));
        assert!(bytes[0].parity_ok && bytes[0].stop_ok);
        assert_eq!(line[used], (second, false), "the second character is left whole");
        let (rest, all) = uart.decode(true, &line[used..], second + uart.bit_start(11));
        assert_eq!((rest[0].byte, all), (0x00, line.len() - used));
    }

    #[test]
    fn a_short_low_pulse_is_no_start_bit() {
        let line = [(1000, false), (1000 + 300, true)];
        assert_eq!(EVEN_19200.decode(true, &line, 1_000_000), (vec![], 2));
    }

    #[test]
    fn wrong_parity_and_missing_stop_bit_are_flagged() {
        let mut bad_parity = EVEN_19200.frame(0x31);
        bad_parity[9] = !bad_parity[9];
        let (bytes, _) = EVEN_19200.decode(true, &edges(EVEN_19200, 0, &bad_parity), 20_000);
        assert!(!bytes[0].parity_ok && bytes[0].stop_ok);

        let mut no_stop = EVEN_19200.frame(0x31);
        no_stop[10] = false;
        let mut line = edges(EVEN_19200, 0, &no_stop);
        line.push((EVEN_19200.bit_start(12), true));
        let (bytes, _) = EVEN_19200.decode(true, &line, 20_000);
        assert_eq!(bytes.len(), 1);
        assert!(bytes[0].parity_ok && !bytes[0].stop_ok);
    }

    #[test]
    fn a_break_is_one_zero_character_until_the_line_rises() {
        let line = [(0, false), (100_000, true)];
        let (bytes, _) = EVEN_19200.decode(true, &line, 200_000);
        assert_eq!(bytes.len(), 1);
        assert_eq!(bytes[0].byte, 0);
        assert!(!bytes[0].stop_ok && bytes[0].parity_ok);
    }

    #[test]
    fn formats_out_of_range_are_refused() {
        assert!(PinUart::new(0).check().is_err());
        assert!(PinUart::new(9600).data_bits(9).check().is_err());
        assert!(PinUart::new(9600).stop_bits(3).check().is_err());
        assert!(PinUart::new(9600).data_bits(5).check().is_ok());
    }
}
