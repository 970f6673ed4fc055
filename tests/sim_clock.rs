//! Timer0 as the application's clock, on the release firmware: `millis()` against
//! simulated time while the slave is polled, and the receive interrupt's latency that the
//! silence deadlines assume (`timing::RX_LATENCY_CYCLES`).
//!
//! The clock is read from the firmware's RAM (the overflow interrupt's `CLOCK`) and TIFR0,
//! at random moments; what `millis()` would return there follows from it and from TCNT0,
//! which runs at clk/64 from the cycle the firmware started Timer0. All times are
//! simulated cycles: the runs are unpaced, as fast as simavr goes.

mod sim;

use std::time::Instant;

use avr_modbus::internal::timing::{Uptime, RX_LATENCY_CYCLES, TICKS_PER_MS, TIMER0_DIVISOR};
use sim::{read_request, registers_reply, Line, Rng, Rtu, ID};
use uno_sim::{vector, Uno, F_CPU};

/// Data-space address of TIFR0 (TOV0 is bit 0).
const TIFR0: u16 = 0x35;
/// Cycles in one turn of Timer0 (256 ticks).
const TURN: u64 = 256 * TIMER0_DIVISOR as u64;
/// Cycles in a millisecond.
const MS: u64 = F_CPU / 1000;

/// Where the overflow interrupt keeps its clock: `avr::clock::CLOCK` (an `Uptime`; feature `millis`), or its
/// two fields when the optimiser split the static (`CLOCK.0` = the milliseconds, `.1` the
/// fraction).
struct ClockInRam {
    millis: u16,
    fract: u16,
}

impl ClockInRam {
    fn find(uno: &Uno) -> ClockInRam {
        let find = |suffix: &str| {
            uno.symbols()
                .iter()
                .find(|s| s.name.ends_with(suffix) && s.name.contains("avr_modbus"))
                .map(|s| (s.addr as u16, s.size))
        };
        if let Some((addr, size)) = find("5clock5CLOCK") {
            assert_eq!(size, 5, "CLOCK is an Uptime (5 bytes)");
            return ClockInRam { millis: addr, fract: addr + 4 };
        }
        match (find("5clock5CLOCK.0"), find("5clock5CLOCK.1")) {
            (Some((millis, 4)), Some((fract, 1))) => ClockInRam { millis, fract },
            other => panic!("no Timer0 clock in {}: {other:?}", uno.path().display()),
        }
    }

    /// The overflow interrupt's clock, and whether an overflow is pending.
    fn read(&self, uno: &Uno) -> (Uptime, bool) {
        let millis = uno.read_ram(self.millis, 4).expect("RAM");
        let fract = uno.read_ram(self.fract, 1).expect("RAM")[0];
        let pending = uno.read_ram(TIFR0, 1).expect("TIFR0")[0] & 1 != 0;
        (Uptime { millis: u32::from_le_bytes(millis.try_into().unwrap()), fract }, pending)
    }
}

/// Checks the clock at the current cycle and returns how far `millis()` is behind the time
/// since Timer0 started, in cycles.
fn check_clock(uno: &mut Uno, clock: &ClockInRam, started: u64) -> u64 {
    // The overflow handler's stores are not one instruction: let it finish. An overflow due
    // at this very cycle is not raised yet (simavr handles it before the next instruction).
    while uno.in_isr() == Some(vector::TIMER0_OVF) || (uno.now() - started) % TURN == 0 {
        uno.step().expect("firmware runs");
    }
    let elapsed = uno.now() - started;
    let (uptime, pending) = clock.read(uno);
    // Every turn completed has been counted, but one whose interrupt is still pending.
    let counted = elapsed / TURN - u64::from(pending);
    assert_eq!(
        u64::from(uptime.millis) * u64::from(TICKS_PER_MS) + u64::from(uptime.fract),
        counted * 256,
        "{elapsed} cycles after the start: {uptime:?} is not {counted} turns"
    );
    // What millis() returns at this cycle: TCNT0 is the tick within the turn.
    let tcnt = ((elapsed % TURN) / u64::from(TIMER0_DIVISOR)) as u8;
    let millis = u64::from(uptime.millis_at(tcnt, pending));
    assert!(millis * MS <= elapsed, "millis() = {millis} is ahead of {elapsed} cycles");
    let behind = elapsed - millis * MS;
    assert!(behind < MS, "millis() = {millis} is {behind} cycles behind {elapsed} cycles");
    behind
}

/// Polls `dip_switch` at `preset` for 60 s of simulated time with FC 03 requests and
/// random pauses, checking the clock after every reply and at random moments between.
fn millis_keeps_simulated_time_for_60_s(preset: usize) {
    let wall = Instant::now();
    let mut rtu = Rtu::boot_dip(preset);
    let started = rtu.timer0_started;
    let clock = ClockInRam::find(&rtu.uno);
    let request = read_request(ID, 0x03, 0, 4);
    let reply = registers_reply(ID, 0x03, &[0; 4]);
    let mut rng = Rng(0xC10C_0000 + preset as u64);
    let (mut least, mut most, mut samples, mut replies) = (u64::MAX, 0, 0, 0);
    let end = started + 60 * F_CPU;
    while rtu.uno.now() < end {
        assert_eq!(rtu.ask(&request), reply, "{}: request {replies}", rtu.line.name());
        replies += 1;
        let pause_until = rtu.uno.now() + rng.below(20 * MS);
        loop {
            let behind = check_clock(&mut rtu.uno, &clock, started);
            (least, most, samples) = (least.min(behind), most.max(behind), samples + 1);
            let next = rtu.uno.now() + 1 + rng.below(3 * MS);
            if next >= pause_until {
                break;
            }
            rtu.uno.run_until(next).expect("firmware runs");
        }
        rtu.uno.run_until(pause_until).expect("firmware runs");
    }
    let seconds = (rtu.uno.now() - started) as f64 / F_CPU as f64;
    let overflow = rtu.uno.isr_stats(vector::TIMER0_OVF);
    eprintln!(
        "{}: {seconds:.1} s simulated, {replies} requests answered, {samples} samples: millis() \
         {:.1}..{:.1} µs behind the time since Timer0 started; TIMER0_OVF {} entries, max {} \
         cycles ({:.1} s wall)",
        rtu.line.name(),
        least as f64 * 1000.0 / MS as f64,
        most as f64 * 1000.0 / MS as f64,
        overflow.entries,
        overflow.max_cycles,
        wall.elapsed().as_secs_f64()
    );
    assert_eq!(overflow.entries, (rtu.uno.now() - started) / TURN, "one overflow interrupt per turn");
}

#[test]
fn at_1200_millis_keeps_simulated_time_for_60_s() {
    millis_keeps_simulated_time_for_60_s(7);
}

#[test]
fn at_19200_millis_keeps_simulated_time_for_60_s() {
    millis_keeps_simulated_time_for_60_s(0);
}

#[test]
fn at_115200_millis_keeps_simulated_time_for_60_s() {
    millis_keeps_simulated_time_for_60_s(4);
}

/// The overflow handler (written in assembly) against `Uptime::after_overflow` where its
/// carries go furthest: the milliseconds just below each byte's wrap and 2³², the fraction
/// on either side of a whole millisecond. Each clock is written into RAM just after an
/// overflow interrupt, and read back after the next.
#[test]
fn the_overflow_handler_carries_through_every_byte_of_the_milliseconds() {
    let mut rtu = Rtu::boot_dip(0);
    let clock = ClockInRam::find(&rtu.uno);
    let uno = &mut rtu.uno;
    // Runs until an overflow interrupt has come and gone.
    let next_overflow = |uno: &mut Uno| {
        let entries = uno.isr_stats(vector::TIMER0_OVF).entries;
        while uno.isr_stats(vector::TIMER0_OVF).entries == entries || uno.in_isr() == Some(vector::TIMER0_OVF) {
            uno.step().expect("firmware runs");
        }
    };
    let t = TICKS_PER_MS as u8;
    for millis in [0xFF, 0xFFFF, 0xFF_FFFF, 0xFFFF_FFFE, 0xFFFF_FFFF] {
        for fract in [0, t - 7, t - 6, t - 1] {
            let before = Uptime { millis, fract };
            next_overflow(uno);
            uno.write_ram(clock.millis, &millis.to_le_bytes()).expect("RAM");
            uno.write_ram(clock.fract, &[fract]).expect("RAM");
            next_overflow(uno);
            assert_eq!(clock.read(uno).0, before.after_overflow(), "one turn after {before:?}");
        }
    }
}

/// `uno_slave` publishes `millis() / 1000` as input register 30004.
#[test]
fn uno_slave_counts_its_uptime_in_seconds() {
    let mut rtu = Rtu::boot("uno_slave", Line::B19200_8E1);
    let started = rtu.timer0_started;
    rtu.uno.run_until(started + 5 * F_CPU / 2).expect("firmware runs");
    let request = read_request(ID, 0x04, 3, 1);
    assert_eq!(rtu.ask(&request), registers_reply(ID, 0x04, &[2]), "30004 at 2.5 s");
}

/// The program's code from the ELF file: (address, bytes) of each executable section.
fn code_sections(elf: &std::path::Path) -> Vec<(u32, Vec<u8>)> {
    let b = std::fs::read(elf).expect("ELF");
    let u16_at = |o: usize| u16::from_le_bytes([b[o], b[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let (shoff, shentsize, shnum) = (u32_at(0x20) as usize, u16_at(0x2E), u16_at(0x30));
    (0..shnum)
        .map(|i| shoff + i * shentsize)
        .filter(|&h| u32_at(h + 4) == 1 && u32_at(h + 8) & 0x4 != 0) // PROGBITS, executable
        .map(|h| {
            let (addr, offset, size) = (u32_at(h + 0x0C), u32_at(h + 0x10) as usize, u32_at(h + 0x14) as usize);
            (addr, b[offset..offset + size].to_vec())
        })
        .collect()
}

/// Whether the instruction at `pc` is `in Rd, TCNT0` (I/O address 0x26): 1011 0AAd dddd AAAA.
fn reads_tcnt0(code: &[(u32, Vec<u8>)], pc: u32) -> bool {
    code.iter().any(|(addr, bytes)| {
        let Some(at) = pc.checked_sub(*addr).map(|o| o as usize).filter(|&o| o + 1 < bytes.len()) else {
            return false;
        };
        let word = u16::from_le_bytes([bytes[at], bytes[at + 1]]);
        word & 0xF800 == 0xB000 && ((word >> 5) & 0x30) | (word & 0x0F) == 0x26
    })
}

/// Cycles from RXC0 to the receive interrupt's read of TCNT0, for a byte flagged (RXC0) at
/// `arrival`: the handler is stepped through up to its `in` from TCNT0.
fn rx_latency(rtu: &mut Rtu, code: &[(u32, Vec<u8>)], arrival: u64) -> Option<u64> {
    let lead = rtu.uno.rx_flag_lead().expect("USART0 enabled");
    rtu.uno.send_byte(0x00, arrival + lead).expect("byte scheduled");
    rtu.uno.run_until(arrival.saturating_sub(200)).expect("firmware runs");
    let mut entered = false;
    for _ in 0..2000 {
        let before = rtu.uno.now();
        let step = rtu.uno.step().expect("firmware runs");
        if step.vector != Some(vector::USART_RX) {
            if entered {
                return None;
            }
            continue;
        }
        entered = true;
        if reads_tcnt0(code, step.pc) {
            return Some(before - arrival);
        }
    }
    None
}

/// The receive interrupt's latency over arrivals at 64 phases of Timer0 and of the main
/// loop: never below what the deadlines assume.
fn rx_latency_is_at_least_the_assumed(mut rtu: Rtu, what: &str) {
    let code = code_sections(rtu.uno.path());
    let mut latencies = Vec::new();
    for i in 0..64 {
        let arrival = rtu.uno.now() + rtu.line.t35() + 1000 + i * 97;
        if let Some(latency) = rx_latency(&mut rtu, &code, arrival) {
            latencies.push(latency);
        }
        // Let the one-byte frame end.
        rtu.uno.run_for(2 * rtu.line.t35()).expect("firmware runs");
    }
    assert!(latencies.len() >= 32, "{what}: the read of TCNT0 was found {} times out of 64", latencies.len());
    let (least, most) = (latencies.iter().min().unwrap(), latencies.iter().max().unwrap());
    eprintln!(
        "{what}: RXC0 to the first read of TCNT0 {least}..{most} cycles ({} arrivals), deadlines assume {}",
        latencies.len(),
        RX_LATENCY_CYCLES
    );
    assert!(*least >= u64::from(RX_LATENCY_CYCLES), "{what}: TCNT0 read {least} cycles after RXC0");
}

#[test]
fn receive_interrupt_reads_timer0_no_sooner_than_the_deadlines_assume() {
    for name in ["minimal", "uno_slave", "busy_loop", "lab_lights", "max_frame", "configurable"] {
        rx_latency_is_at_least_the_assumed(Rtu::boot(name, Line::B19200_8E1), name);
    }
    for preset in [0, 4, 7] {
        rx_latency_is_at_least_the_assumed(Rtu::boot_dip(preset), &format!("dip_switch preset {preset}"));
    }
}
