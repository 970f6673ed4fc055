//! The silence deadlines against the exact T1.5 and T3.5 of Modbus over Serial Line v1.02
//! §2.5.1.1, for every rate the crate accepts in 100 bps steps and every character format.
//!
//! A deadline counts from the receive interrupt's read of TCNT0 (at least
//! `RX_LATENCY_CYCLES` after the USART flagged the character, RXCn), the next tick edge
//! coming anywhere within a tick of it; `Deadline::expiry_cycles` gives the earliest and
//! latest cycle its compare flag can rise. Here both are checked against the exact times,
//! worked out independently as fractions of cycles: never early, and late by less than
//! `ACCURACY_CYCLES`, or `ACCURACY_CYCLES` and a tick for a deadline one edge later because
//! its compare value would have been the count read.
//!
//! The USART flags a character at the middle of its first stop bit, half a bit before the
//! character ends on the line (one and a half bits with two stop bits), at its real bit time
//! (UBRRn, U2Xn). The gap deadline counts from one flag to the next, which are as far apart
//! as the characters' ends; T3.5 counts from the character's end, so from the flag it is
//! T3.5 and that half bit (or bit and a half).

use avr_modbus::internal::timing::{Deadline, Passed, TimerPlan, CLOCK_HZ, RX_LATENCY_CYCLES, TIMER0_DIVISOR};
use avr_modbus::{Config, Parity, StopBits};

/// The documented accuracy: a deadline passes less than 130 cycles (8.1 µs) after the
/// exact time: the unknown phase of the prescaler (a tick and a cycle of slack), the
/// rounding up to whole ticks (less than a tick), and the rounding of the exact time up to
/// whole nanoseconds and cycles (less than two cycles).
const ACCURACY_CYCLES: u64 = 2 * TIMER0_DIVISOR as u64 + 2;

const FORMATS: [(Parity, StopBits); 6] = [
    (Parity::None, StopBits::One),
    (Parity::None, StopBits::Two),
    (Parity::Even, StopBits::One),
    (Parity::Even, StopBits::Two),
    (Parity::Odd, StopBits::One),
    (Parity::Odd, StopBits::Two),
];

/// An exact duration: `num / den` CPU cycles.
#[derive(Clone, Copy, Debug)]
struct Exact {
    num: u128,
    den: u128,
}

/// The end-of-character gap deadline (one character plus T1.5, see
/// `CharTimes::gap_deadline_ns`) and T3.5, exactly, for `bits` bits per character, both
/// from the end of a character.
fn exact_times(baud: u32, bits: u32) -> (Exact, Exact) {
    let (baud, bits, hz) = (u128::from(baud), u128::from(bits), u128::from(CLOCK_HZ));
    let char_num = bits * hz; // / baud
    if baud <= 19_200 {
        // 1 + 1.5 characters, and 3.5 characters.
        (Exact { num: 5 * char_num, den: 2 * baud }, Exact { num: 7 * char_num, den: 2 * baud })
    } else {
        // One character + 750 µs, and 1750 µs.
        let us = hz / 1_000_000;
        (Exact { num: char_num + 750 * us * baud, den: baud }, Exact { num: 1750 * us, den: 1 })
    }
}

/// Whether `deadline` is one edge later than the fewest that are never early, because
/// those would have made a compare value equal to the count read (`low` 0).
fn moved_off_the_count_read(deadline: Deadline, exact: Exact) -> bool {
    let fewer = deadline.edges() - 1;
    let earliest = u128::from(RX_LATENCY_CYCLES + (fewer - 1) * TIMER0_DIVISOR);
    fewer % 256 == 1 && earliest * exact.den >= exact.num
}

/// How late a deadline can expire, in cycles past the exact time, and whether it is one of
/// those moved one edge later.
#[derive(Clone, Copy)]
struct Late {
    cycles: f64,
    moved: bool,
}

/// Checks `deadline` against `exact`.
fn check(deadline: Deadline, exact: Exact, what: &str) -> Late {
    assert_ne!(deadline.low, 0, "{what}: compare value equal to the count read");
    let (earliest, latest) = deadline.expiry_cycles();
    let (earliest, latest) = (u128::from(earliest), u128::from(latest));
    assert!(
        earliest * exact.den >= exact.num,
        "{what}: expires {earliest} cycles after the character, before {:.2}",
        exact.num as f64 / exact.den as f64
    );
    let moved = moved_off_the_count_read(deadline, exact);
    let allowed = if moved { ACCURACY_CYCLES + TIMER0_DIVISOR as u64 } else { ACCURACY_CYCLES };
    // The fewest edges that are never early: one fewer (besides the moved one) would be,
    // but for the rounding of the exact time up to whole nanoseconds and cycles.
    let fewest = deadline.edges() - u32::from(moved);
    let sooner = u128::from(RX_LATENCY_CYCLES + (fewest - 2) * TIMER0_DIVISOR);
    assert!(sooner * exact.den < exact.num + 2 * exact.den, "{what}: {} edges would do", fewest - 1);
    assert!(
        latest * exact.den < exact.num + u128::from(allowed) * exact.den,
        "{what}: expires up to {latest} cycles after the character, {:.2} late",
        latest as f64 - exact.num as f64 / exact.den as f64
    );
    Late { cycles: latest as f64 - exact.num as f64 / exact.den as f64, moved }
}

/// Cycles from the USART's receive flag, at the middle of the first stop bit, to the end of
/// the character: (stop bits − ½) bits of the rate `config`'s UBRRn and U2Xn make.
fn flag_to_end_cycles(config: &Config) -> u128 {
    let divisor = config.line().divisor();
    let bit = (u128::from(divisor.ubrr) + 1) * if divisor.double_speed { 8 } else { 16 };
    let stop = match config.stop_bits() {
        StopBits::One => 1,
        StopBits::Two => 2,
    };
    bit * (2 * stop - 1) / 2
}

fn check_config(baud: u32, parity: Parity, stop_bits: StopBits) -> Option<[Late; 2]> {
    let config = Config::try_new(1, baud, parity, stop_bits).ok()?;
    let what = format!("{baud} {parity:?} {stop_bits:?}");
    let plan = config.line().timer_plan();
    let (gap, t35) = exact_times(baud, config.line().bits_per_char());
    // From the flag: the gap deadline as it is, T3.5 after the character's end.
    let t35 = Exact { num: t35.num + flag_to_end_cycles(&config) * t35.den, den: t35.den };
    let late = [check(plan.gap, gap, &format!("{what} gap")), check(plan.end, t35, &format!("{what} T3.5"))];
    assert!(plan.gap.edges() < plan.end.edges(), "{what}: the gap deadline comes after T3.5");
    Some(late)
}

#[test]
fn every_accepted_rate_and_format_meets_t15_and_t35_within_the_documented_accuracy() {
    let (mut configs, mut refused, mut moved) = (0, 0, 0);
    // Latest expiry past the exact time: gap deadline and T3.5, and the moved ones.
    let (mut worst, mut worst_moved) = ([0.0_f64; 2], 0.0_f64);
    for baud in (Config::MIN_BAUD..=Config::MAX_BAUD).step_by(100) {
        for (parity, stop_bits) in FORMATS {
            let Some(late) = check_config(baud, parity, stop_bits) else {
                refused += 1;
                continue;
            };
            configs += 1;
            for (i, late) in late.into_iter().enumerate() {
                if late.moved {
                    moved += 1;
                    worst_moved = worst_moved.max(late.cycles);
                } else {
                    worst[i] = worst[i].max(late.cycles);
                }
            }
        }
    }
    eprintln!(
        "{configs} configurations ({refused} refused: rate error over 2.5 %); latest expiry past the exact \
         time: gap deadline {:.2} cycles, T3.5 {:.2} cycles ({ACCURACY_CYCLES} allowed); {moved} deadlines \
         one edge later, {worst_moved:.2} cycles ({} allowed)",
        worst[0],
        worst[1],
        ACCURACY_CYCLES + TIMER0_DIVISOR as u64
    );
    // From 1200 to 115200 every 100 bps is accepted.
    assert!(configs >= 6 * ((115_200 - 1200) / 100 + 1), "{configs}");
    // The moved deadlines are exercised too.
    assert!(moved > 0);
}

/// Rates where the Timer0 restart of earlier versions expired more than a tick late (their
/// deadline was a whole number of counter turns, which it could not set).
#[test]
fn rates_reported_late_before_are_within_the_accuracy() {
    for (baud, parity, stop_bits) in [
        (36_000, Parity::None, StopBits::One),
        (6100, Parity::None, StopBits::One),
        (4700, Parity::Even, StopBits::One),
    ] {
        check_config(baud, parity, stop_bits).expect("accepted");
    }
}

/// Tick edges from the receive interrupt's read of TCNT0 (`t0`) to the compare matches at
/// which the one compare unit reports the gap deadline and T3.5, when the interrupt that
/// moves the compare value at the gap deadline reads TCNT0 `late` edges after the match:
/// the arithmetic of `TimerPlan` played against a counter, as `avr::timer` runs it.
fn one_compare_edges(plan: TimerPlan, t0: u8, late: u32) -> (u32, u32) {
    let schedule = plan.schedule();
    let tcnt = |edge: u32| t0.wrapping_add(edge as u8);
    // A match of `value` is the edge that takes TCNT0 from `value` to `value + 1`.
    let next_match = |value: u8, after: u32| (after + 1..).find(|&e| tcnt(e) == value.wrapping_add(1)).unwrap();
    let mut value = t0.wrapping_add(plan.gap.low);
    let (mut matches, mut edge, mut gap) = (0, 0, None);
    loop {
        edge = next_match(value, edge);
        let (passed, count) = schedule.on_match(matches);
        matches = count;
        match passed {
            Passed::Nothing => {}
            Passed::Gap => {
                gap = Some(edge);
                // The interrupt reads TCNT0 `late` edges on; if that is T3.5's value, it
                // waits for the next edge before it writes.
                let mut write = edge + late;
                let mut elapsed = tcnt(write).wrapping_sub(value);
                if plan.to_end() != 0 && elapsed == plan.to_end() {
                    write += 1;
                    elapsed = elapsed.wrapping_add(1);
                }
                value = value.wrapping_add(plan.to_end());
                matches = schedule.count_after_gap(elapsed);
                // Matches of the new value come after the write: an edge to it that came
                // before is not seen.
                edge = write;
            }
            Passed::End => return (gap.expect("the gap deadline passes first"), edge),
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => unreachable!("the schedule knows nothing of reply delays"),
        }
    }
}

#[test]
fn one_compare_unit_reports_both_deadlines_at_their_edges_however_late_the_move() {
    let (mut configs, mut waits, mut seen_late) = (0, 0, 0);
    for baud in (Config::MIN_BAUD..=Config::MAX_BAUD).step_by(100) {
        for (parity, stop_bits) in FORMATS {
            let Ok(config) = Config::try_new(1, baud, parity, stop_bits) else { continue };
            let plan = config.line().timer_plan();
            configs += 1;
            for t0 in [0, 1, 127, 254, 255] {
                // Up to 16 edges late (1024 cycles): the longest interrupt or critical section.
                for late in 0..=16 {
                    let (gap, end) = one_compare_edges(plan, t0, late);
                    assert_eq!(
                        gap,
                        plan.gap.edges(),
                        "{baud} {parity:?} {stop_bits:?} t0 {t0} late {late}: gap deadline"
                    );
                    assert_eq!(end, plan.end.edges(), "{baud} {parity:?} {stop_bits:?} t0 {t0} late {late}: T3.5");
                    let to_end = u32::from(plan.to_end());
                    waits += u32::from(to_end != 0 && late + 1 == to_end);
                    seen_late += u32::from(to_end != 0 && late + 1 > to_end);
                }
            }
        }
    }
    eprintln!(
        "{configs} configurations: the move waited for an edge {waits} times, found T3.5's value gone by \
         {seen_late} times"
    );
    // Both corner cases of the move are exercised.
    assert!(waits > 0 && seen_late > 0);
}
