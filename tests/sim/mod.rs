//! Helpers shared by the simulator tests (`tests/sim_*.rs`): the release firmware run in
//! simavr through `uno-sim`, a bus master that schedules every character on simulated
//! time, and a CRC-16/MODBUS written from Serial Line v1.02 §6.2.2 (not the crate's).
//!
//! All times are CPU cycles at 16 MHz; wall time is never looked at.
//!
//! The Uno's firmware (`firmware`, `Rtu::boot`) runs on an ATmega328P with the wire on USART0.
//! A firmware built for another chip (`chip_firmware`) boots with `Rtu::boot_chip` or
//! `Rtu::boot_elf_on`: the chip comes from the ELF file, the wire goes on the USART asked for;
//! its vector numbers are `rtu.uno.vectors()`, its pins `rtu.uno.port_pin` (Arduino pin
//! numbers, `watch` included, are the Uno's: `watch_ports` names port and bit instead).
//!
//! Each test crate uses a different subset of these helpers.
#![allow(dead_code)]

use std::fmt::Debug;
use std::path::{Path, PathBuf};

use uno_sim::{Chip, Options, Parity, PinState, TxByte, Uno, F_CPU};

#[allow(unused_imports)] // not every test crate needs each
pub use uno_sim::{
    built::{built, target_dir},
    cycles_to_us, us_to_cycles,
};

/// The slave id every example answers to.
pub const ID: u8 = 1;

/// Path of the release ELF of example `name`: `$CARGO_TARGET_DIR` (else `target/` of the
/// workspace), then `avr-atmega328p/release/examples/NAME.elf`. Built by `make firmware`;
/// missing, it skips the test binary or fails it under `make` and in CI ([`built`]).
pub fn firmware(name: &str) -> PathBuf {
    built(target_dir().join("avr-atmega328p/release/examples").join(format!("{name}.elf")), "make firmware")
}

/// Where the build puts example `name` for `chip` with the wire on USART`usart`, whether or
/// not it is there: under the target directory, `chips/CHIP/avr-none/release/examples/NAME.elf`
/// for the chip's default USART (USART0, or the 32U4's only one, USART1), else
/// `chips/CHIP-usartN/avr-none/release/examples/NAME.elf`; the Uno's own build
/// (`avr-atmega328p/release/examples/NAME.elf`, as [`firmware`]) for the ATmega328P's USART0.
pub fn chip_firmware_path(chip: Chip, usart: u8, name: &str) -> PathBuf {
    let elf = format!("{name}.elf");
    if chip == Chip::Atmega328p && usart == 0 {
        return target_dir().join("avr-atmega328p/release/examples").join(elf);
    }
    chip_examples_dir(chip, usart, "").join(elf)
}

/// The folder of the examples built for `chip` with the wire on USART`usart`, with
/// `variant` after the build's name (`-settings`: `make chips`' build with the line
/// settings): `chips/CHIP[-usartN]VARIANT/avr-none/release/examples`.
pub fn chip_examples_dir(chip: Chip, usart: u8, variant: &str) -> PathBuf {
    let build = if usart == chip.default_usart() { chip.name().to_owned() } else { format!("{chip}-usart{usart}") };
    target_dir().join("chips").join(format!("{build}{variant}")).join("avr-none/release/examples")
}

/// [`chip_firmware_path`], built by `make chips` (the Uno's by `make firmware`), as [`firmware`].
pub fn chip_firmware(chip: Chip, usart: u8, name: &str) -> PathBuf {
    let uno = chip == Chip::Atmega328p && usart == 0;
    built(chip_firmware_path(chip, usart, name), if uno { "make firmware" } else { "make chips" })
}

/// The ELF `name` in [`chip_examples_dir`]`(chip, usart, variant)`, built by `make chips`, as
/// [`firmware`].
pub fn chip_variant_firmware(chip: Chip, usart: u8, variant: &str, name: &str) -> PathBuf {
    built(chip_examples_dir(chip, usart, variant).join(format!("{name}.elf")), "make chips")
}

// ---------------------------------------------------------------------------------------
// Frames

/// CRC-16/MODBUS, Serial Line v1.02 §6.2.2: start at 0xFFFF; for each byte xor it into the
/// low byte, then eight times shift right and xor 0xA001 when a 1 fell out.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            let lsb = crc & 1;
            crc >>= 1;
            if lsb == 1 {
                crc ^= 0xA001;
            }
        }
    }
    crc
}

/// `frame` with its CRC appended, low byte first.
pub fn with_crc(frame: &[u8]) -> Vec<u8> {
    let crc = crc16(frame);
    let mut out = frame.to_vec();
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// A read request (FC 01–04) to `id`: function, start address, quantity, CRC.
pub fn read_request(id: u8, function: u8, start: u16, qty: u16) -> Vec<u8> {
    let [s_hi, s_lo] = start.to_be_bytes();
    let [q_hi, q_lo] = qty.to_be_bytes();
    with_crc(&[id, function, s_hi, s_lo, q_hi, q_lo])
}

/// An FC 03 reply from `id` carrying `values`.
pub fn registers_reply(id: u8, function: u8, values: &[u16]) -> Vec<u8> {
    let mut frame = vec![id, function, (2 * values.len()) as u8];
    for value in values {
        frame.extend_from_slice(&value.to_be_bytes());
    }
    with_crc(&frame)
}

/// An FC 06 request to `id` (its reply is the same frame).
pub fn write_register_request(id: u8, address: u16, value: u16) -> Vec<u8> {
    let [a_hi, a_lo] = address.to_be_bytes();
    let [v_hi, v_lo] = value.to_be_bytes();
    with_crc(&[id, 0x06, a_hi, a_lo, v_hi, v_lo])
}

/// An exception reply from `id`.
pub fn exception_reply(id: u8, function: u8, code: u8) -> Vec<u8> {
    with_crc(&[id, function | 0x80, code])
}

// ---------------------------------------------------------------------------------------
// Line settings and the silences derived from them

/// A line setting, as the master sees it: nominal rate and frame format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line {
    /// Nominal bits per second.
    pub baud: u32,
    /// Parity bit.
    pub parity: Parity,
    /// Stop bits.
    pub stop_bits: u8,
    /// Data bits: 8, or 7 for ASCII.
    pub data_bits: u8,
}

impl Line {
    /// 1200 bps, 8E1.
    pub const B1200_8E1: Line = Line { baud: 1200, parity: Parity::Even, stop_bits: 1, data_bits: 8 };
    /// 9600 bps, 8E1.
    pub const B9600_8E1: Line = Line { baud: 9600, parity: Parity::Even, stop_bits: 1, data_bits: 8 };
    /// 9600 bps, 8N1.
    pub const B9600_8N1: Line = Line { baud: 9600, parity: Parity::None, stop_bits: 1, data_bits: 8 };
    /// 19200 bps, 8E1: the spec's default.
    pub const B19200_8E1: Line = Line { baud: 19200, parity: Parity::Even, stop_bits: 1, data_bits: 8 };
    /// 19200 bps, 8N2.
    pub const B19200_8N2: Line = Line { baud: 19200, parity: Parity::None, stop_bits: 2, data_bits: 8 };
    /// 19200 bps, 8O1.
    pub const B19200_8O1: Line = Line { baud: 19200, parity: Parity::Odd, stop_bits: 1, data_bits: 8 };
    /// 115200 bps, 8N1 (fixed T1.5/T3.5).
    pub const B115200_8N1: Line = Line { baud: 115200, parity: Parity::None, stop_bits: 1, data_bits: 8 };
    /// 9600 bps, 7E1: ASCII's default character format.
    pub const B9600_7E1: Line = Line { baud: 9600, parity: Parity::Even, stop_bits: 1, data_bits: 7 };
    /// 115200 bps, 8E1 (fixed T1.5/T3.5).
    pub const B115200_8E1: Line = Line { baud: 115200, parity: Parity::Even, stop_bits: 1, data_bits: 8 };

    /// Bits per character: start, data, parity, stop.
    pub fn char_bits(&self) -> u64 {
        1 + u64::from(self.data_bits) + u64::from(self.parity != Parity::None) + u64::from(self.stop_bits)
    }

    /// `tenths` tenths of a nominal character time, in cycles, rounded up.
    fn char_tenths(&self, tenths: u64) -> u64 {
        (tenths * self.char_bits() * F_CPU).div_ceil(10 * u64::from(self.baud))
    }

    /// T1.5 in cycles: 1.5 characters, or 750 µs above 19200 bps.
    pub fn t15(&self) -> u64 {
        if self.baud > 19200 {
            us_to_cycles(750)
        } else {
            self.char_tenths(15)
        }
    }

    /// T3.5 in cycles: 3.5 characters, or 1750 µs above 19200 bps.
    pub fn t35(&self) -> u64 {
        if self.baud > 19200 {
            us_to_cycles(1750)
        } else {
            self.char_tenths(35)
        }
    }

    /// "115200 8N1".
    pub fn name(&self) -> String {
        let parity = match self.parity {
            Parity::None => 'N',
            Parity::Even => 'E',
            Parity::Odd => 'O',
        };
        format!("{} {}{}{}", self.baud, self.data_bits, parity, self.stop_bits)
    }
}

/// The `dip_switch` presets, in switch order (pin 10 = bit 0, closed = 1).
pub const DIP_PRESETS: [Line; 8] = [
    Line::B19200_8E1,
    Line::B9600_8E1,
    Line::B19200_8N2,
    Line::B19200_8O1,
    Line::B115200_8N1,
    Line::B9600_8N1,
    Line::B115200_8E1,
    Line::B1200_8E1,
];

// ---------------------------------------------------------------------------------------
// The simulated slave and its master

/// What one request got back.
#[derive(Clone, Debug)]
pub struct Exchange {
    /// Cycle at which the request's last stop bit ended: the true end of its last character
    /// on the line (the chip's receiver flagged it half a bit earlier, or one and a half bits
    /// with two stop bits; see `uno_sim::RxFlag`).
    pub request_end: u64,
    /// The reply's characters with their times on the wire (empty: no reply).
    pub reply: Vec<TxByte>,
}

impl Exchange {
    /// The reply's bytes.
    pub fn bytes(&self) -> Vec<u8> {
        self.reply.iter().map(|t| t.byte).collect()
    }

    /// Cycles from the request's end to the reply's first start bit. Panics if the reply
    /// started before the request's last stop bit had ended.
    pub fn turnaround(&self) -> Option<u64> {
        self.reply.first().map(|t| {
            t.start_cycle.checked_sub(self.request_end).unwrap_or_else(|| {
                panic!(
                    "the reply started {} cycles before the request's last stop bit ended",
                    self.request_end - t.start_cycle
                )
            })
        })
    }

    /// Longest idle time between two characters of the reply, in cycles.
    pub fn max_reply_gap(&self) -> u64 {
        self.reply.windows(2).map(|w| w[1].start_cycle - w[0].end_cycle).max().unwrap_or(0)
    }
}

/// A firmware running on a simulated Uno (or another chip), with a master on its serial line.
pub struct Rtu {
    /// The simulated board (`uno.chip()`, `uno.usart()`: which chip, which USART is the wire).
    pub uno: Uno,
    /// The line setting the master uses.
    pub line: Line,
    /// One character on the wire, in cycles (from the firmware's UBRRn and format).
    pub char_cycles: u64,
    /// One tick of Timer0 (the silence detector), in cycles, from the clock select the
    /// firmware wrote when it started the timer.
    pub tick: u64,
    /// Cycle at which the firmware started Timer0 (the clock of `millis()`).
    pub timer0_started: u64,
    /// The line has been idle since this cycle (end of the last character either way).
    pub quiet_since: u64,
}

/// Simulated time the firmware gets to start up before the master's first T3.5 wait.
const BOOT_CYCLES: u64 = us_to_cycles(2_000);

/// How long a firmware may take to start Timer0: `configurable` with a stored record first
/// computes its configuration (≈3 ms); the master then gives it 1 ms more.
const TIMER0_START_CYCLES: u64 = us_to_cycles(20_000);

/// Data-space address of TCCR0B (clock select CS02:0 in bits 2:0).
const TCCR0B: u16 = 0x45;

/// Runs the firmware one instruction at a time until it starts Timer0 and returns the
/// timer's tick in cycles and the cycle at which the instruction that started it began
/// (simavr counts the timer from there).
fn timer0_tick(uno: &mut Uno) -> (u64, u64) {
    while uno.now() < TIMER0_START_CYCLES {
        let before = uno.now();
        uno.step().expect("firmware runs");
        let divisor = match uno.read_ram(TCCR0B, 1).expect("TCCR0B")[0] & 0b111 {
            0 => continue,
            1 => 1,
            2 => 8,
            3 => 64,
            4 => 256,
            5 => 1024,
            external => panic!("Timer0 clocked from pin T0 (CS0 = {external:#05b})"),
        };
        return (divisor, before);
    }
    panic!("the firmware did not start Timer0 within {TIMER0_START_CYCLES} cycles");
}

impl Rtu {
    /// Boots example `name`, which must use `line`.
    pub fn boot(name: &str, line: Line) -> Rtu {
        Rtu::boot_with(name, line, |_| {})
    }

    /// Boots example `name` after `before_reset` set up the board (pins, voltages).
    pub fn boot_with(name: &str, line: Line, before_reset: impl FnOnce(&mut Uno)) -> Rtu {
        Rtu::boot_elf(&firmware(name), line, before_reset)
    }

    /// Boots the firmware at `elf`, which must use `line`, with the wire on its chip's default
    /// USART (USART0 on the Uno).
    pub fn boot_elf(elf: &Path, line: Line, before_reset: impl FnOnce(&mut Uno)) -> Rtu {
        Rtu::boot_elf_with(elf, Options::new(), line, before_reset)
    }

    /// Boots the firmware at `elf` on the chip it was built for, with the wire on USART`usart`.
    pub fn boot_elf_on(elf: &Path, usart: u8, line: Line, before_reset: impl FnOnce(&mut Uno)) -> Rtu {
        Rtu::boot_elf_with(elf, Options::new().usart(usart), line, before_reset)
    }

    /// Boots example `name` built for `chip` with the wire on USART`usart` (see
    /// [`chip_firmware`]); the file must name that chip.
    pub fn boot_chip(chip: Chip, usart: u8, name: &str, line: Line) -> Rtu {
        let rtu = Rtu::boot_elf_on(&chip_firmware(chip, usart, name), usart, line, |_| {});
        assert_eq!(rtu.uno.chip(), chip, "{name} for the {chip} names another chip");
        rtu
    }

    /// Boots the firmware at `elf` on the chip and USART `options` pick.
    pub fn boot_elf_with(elf: &Path, options: Options, line: Line, before_reset: impl FnOnce(&mut Uno)) -> Rtu {
        let mut uno = Uno::load_with(elf, options).expect("firmware loads");
        before_reset(&mut uno);
        let (tick, timer0_started) = timer0_tick(&mut uno);
        let booted = if uno.now() < BOOT_CYCLES { BOOT_CYCLES } else { uno.now() + us_to_cycles(1_000) };
        uno.run_until(booted).expect("firmware runs");
        let usart = uno.usart();
        let char_cycles = uno.wire_char_cycles().unwrap_or_else(|| panic!("the firmware enabled USART{usart}"));
        // The slave's own power-up wait counts from its start; the master waits T3.5 from here.
        let quiet_since = uno.now();
        Rtu { uno, line, char_cycles, tick, timer0_started, quiet_since }
    }

    /// Boots `dip_switch` with its switches set to `preset` (0-7).
    pub fn boot_dip(preset: usize) -> Rtu {
        Rtu::boot_with("dip_switch", DIP_PRESETS[preset], |uno| {
            for (bit, pin) in [10u8, 11, 12].into_iter().enumerate() {
                let closed = preset & (1 << bit) != 0;
                // Closed switches pull the pin to GND; open ones leave it to the pull-up.
                uno.drive_pin(pin, if closed { Some(false) } else { None }).unwrap();
            }
        })
    }

    /// The earliest cycle at which the end of a request's first character may be
    /// scheduled so that T3.5 plus `margin` cycles of silence precede its start bit.
    pub fn first_end_after_silence(&self, margin: u64) -> u64 {
        let start = (self.quiet_since + self.line.t35() + margin).max(self.uno.now());
        start + self.char_cycles
    }

    /// Schedules `bytes` from the master: the first character ends at `first_end`, the
    /// others follow after `gap` idle cycles each. Returns the last character's end.
    pub fn send_at(&mut self, bytes: &[u8], first_end: u64, gap: u64) -> u64 {
        let end = self.uno.send_frame(bytes, first_end, gap).expect("bytes scheduled");
        self.quiet_since = self.quiet_since.max(end);
        end
    }

    /// Schedules `bytes` back to back after T3.5 (+ two ticks) of silence; returns the end
    /// of the last character.
    pub fn send(&mut self, bytes: &[u8]) -> u64 {
        let first_end = self.first_end_after_silence(2 * self.tick);
        self.send_at(bytes, first_end, 0)
    }

    /// Schedules `frame` after T3.5 (+ two ticks) of silence, its first `split` bytes back to
    /// back, then `gap` idle cycles, then the rest back to back; returns the end of the last
    /// character.
    pub fn send_with_gap(&mut self, frame: &[u8], split: usize, gap: u64) -> u64 {
        let first_end = self.first_end_after_silence(2 * self.tick);
        let head_end = self.send_at(&frame[..split], first_end, 0);
        self.send_at(&frame[split..], head_end + gap + self.char_cycles, 0)
    }

    /// Sends `request` after T3.5 of silence and collects the reply (see [`Rtu::receive`]).
    pub fn exchange(&mut self, request: &[u8]) -> Exchange {
        let end = self.send(request);
        self.receive(end)
    }

    /// Sends `request` and returns the reply's bytes.
    pub fn ask(&mut self, request: &[u8]) -> Vec<u8> {
        self.exchange(request).bytes()
    }

    /// Runs until the reply to a request that ended at `request_end` is complete, or, if
    /// none has started by then, until T3.5 plus ten characters after it.
    pub fn receive(&mut self, request_end: u64) -> Exchange {
        let reply = collect_reply(&mut self.uno, request_end, self.char_cycles, self.line.t35());
        if let Some(last) = reply.last() {
            self.quiet_since = self.quiet_since.max(last.end_cycle);
        }
        Exchange { request_end, reply }
    }

    /// Lets the firmware run for `us` microseconds of simulated time.
    pub fn run_us(&mut self, us: u64) {
        self.uno.run_for(us_to_cycles(us)).expect("firmware runs");
    }

    /// Asserts that the firmware has transmitted nothing that was not collected yet.
    pub fn assert_silent(&mut self, what: &str) {
        let tx = self.uno.take_tx();
        assert!(tx.is_empty(), "{what}: the slave sent {:02X?}", tx.iter().map(|t| t.byte).collect::<Vec<_>>());
    }
}

// ---------------------------------------------------------------------------------------
// Output pins watched while the slave works (RS-485 driver enable, communication LED)

/// When a watched pin first went high and first went low.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Edges {
    /// Cycle of the first rising edge.
    pub rose: Option<u64>,
    /// Cycle of the first falling edge.
    pub fell: Option<u64>,
}

/// What the slave did while [`Rtu::watch`] (pins by Arduino Uno number) or
/// [`Rtu::watch_ports`] (pins by port letter and bit) ran.
#[derive(Clone, Debug)]
pub struct Watched<P = u8> {
    /// The characters it sent (empty: none).
    pub exchange: Exchange,
    /// The edges of each watched pin, in the order asked for.
    pub edges: Vec<(P, Edges)>,
}

impl<P: Copy + PartialEq> Watched<P> {
    /// The edges of `pin`, which must have been watched.
    pub fn pin(&self, pin: P) -> Edges {
        self.edges.iter().find(|(p, _)| *p == pin).map(|&(_, e)| e).expect("pin watched")
    }
}

impl Rtu {
    /// Runs the firmware one instruction at a time until `window` cycles after
    /// `request_end` (a request already scheduled), recording every character it sends
    /// and the first rising and falling edge of each of `pins`. A pin level changes only
    /// by an instruction, so checking after each one misses no pulse, however short.
    /// Every pin must be a low output when the watch starts. Arduino Uno pin numbers: on
    /// other chips, [`Rtu::watch_ports`].
    pub fn watch(&mut self, request_end: u64, pins: &[u8], window: u64) -> Watched {
        self.watch_by(request_end, pins, window, |uno, pin| uno.pin(pin).expect("Uno pin"))
    }

    /// [`Rtu::watch`] with pins named by port letter and bit (`('B', 7)`: PB7, a Mega's LED),
    /// on any chip.
    pub fn watch_ports(&mut self, request_end: u64, pins: &[(char, u8)], window: u64) -> Watched<(char, u8)> {
        self.watch_by(request_end, pins, window, |uno, (port, bit)| uno.port_pin(port, bit).expect("port pin"))
    }

    fn watch_by<P: Copy + Debug>(
        &mut self,
        request_end: u64,
        pins: &[P],
        window: u64,
        state_of: impl Fn(&Uno, P) -> PinState,
    ) -> Watched<P> {
        let mut was_high = Vec::with_capacity(pins.len());
        for &pin in pins {
            let state = state_of(&self.uno, pin);
            assert!(state.output && !state.level, "pin {pin:?} is a low output while the slave listens: {state:?}");
            was_high.push(false);
        }
        let mut edges = vec![Edges::default(); pins.len()];
        // Collected at the end: what was sent before the watch started is not this reply's.
        self.assert_silent("before the watch");
        while self.uno.now() < request_end + window {
            self.uno.step().expect("firmware runs");
            let now = self.uno.now();
            for ((&pin, was), edge) in pins.iter().zip(was_high.iter_mut()).zip(edges.iter_mut()) {
                let high = state_of(&self.uno, pin).level;
                match (*was, high) {
                    (false, true) if edge.rose.is_none() => edge.rose = Some(now),
                    (true, false) if edge.fell.is_none() => edge.fell = Some(now),
                    _ => {}
                }
                *was = high;
            }
        }
        let reply = self.uno.take_tx();
        if let Some(last) = reply.last() {
            let busy = self.uno.tx_busy_until().unwrap_or(0).max(last.end_cycle);
            self.quiet_since = self.quiet_since.max(busy);
        }
        Watched { exchange: Exchange { request_end, reply }, edges: pins.iter().copied().zip(edges).collect() }
    }

    /// Sends `request` after T3.5 of silence and [watches](Rtu::watch) `pins` until
    /// `window` cycles after its last character.
    pub fn exchange_watching(&mut self, request: &[u8], pins: &[u8], window: u64) -> Watched {
        let end = self.send(request);
        self.watch(end, pins, window)
    }
}

/// Runs until the reply to a request that ended at `request_end` is complete (two
/// characters of idle line after its last one), or, if none has started by then, until
/// T3.5 plus ten characters after the request.
pub fn collect_reply(uno: &mut Uno, request_end: u64, char_cycles: u64, t35: u64) -> Vec<TxByte> {
    let idle = 2 * char_cycles;
    let no_reply_by = request_end + t35 + 10 * char_cycles;
    // Only stop early if a reply started (that is what `run_until_tx_idle` does).
    let mut reply = uno.run_until_tx_idle(idle, no_reply_by).expect("firmware runs");
    while let Some(last) = reply.last() {
        let busy = uno.tx_busy_until().unwrap_or(0).max(last.end_cycle);
        if uno.now() >= busy + idle {
            break;
        }
        uno.run_until(busy + idle).expect("firmware runs");
        reply.extend(uno.take_tx());
    }
    reply
}

/// A seeded generator (SplitMix64): the same seed gives the same run.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    /// Uniform in `lo..=hi`.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.below(hi - lo + 1)
    }

    /// True with probability `percent` / 100.
    pub fn chance(&mut self, percent: u64) -> bool {
        self.below(100) < percent
    }

    pub fn u16(&mut self) -> u16 {
        self.next_u64() as u16
    }

    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len() as u64) as usize]
    }
}
