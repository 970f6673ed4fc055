//! `master_boards` on every chip and USART, against the simulated slave: its requests, the
//! replies it takes, and its interrupts' cycles.

use std::path::{Path, PathBuf};

use uno_sim::{us_to_cycles, Chip, Options, Uno};

use crate::bus::IsrTotal;
use crate::elf::{avr_size, chip_build_path};
use crate::log::Log;
use crate::modbus::{Expect, Request};
use crate::random::Lcg;
use crate::Result;

use super::slave::{answer, line_times, next_request};

/// Requests `master_boards` sends per chip and USART, each answered as a slave would.
pub(super) const BOARD_REQUESTS: usize = 100;
/// The target of the master's interrupts, as the slave's: cycles per run, mean and max.
pub(crate) const MASTER_ISR_TARGET_CYCLES: u64 = 100;

/// The master's interrupts, in the order of [`MasterRun::isr`].
/// (The master sends each character from TX complete: it binds no UDRE handler.)
pub(super) const MASTER_VECTORS: [&str; 4] = ["USART_RX", "TIMER0_COMPA", "USART_TX", "TIMER0_OVF (millis)"];

/// `master_boards` on one chip and USART.
pub(crate) struct MasterRun {
    pub(super) chip: Chip,
    pub(super) usart: u8,
    pub(super) flash: u64,
    pub(super) ram: u64,
    /// Interrupt cycles per entry of [`MASTER_VECTORS`], from the first request on.
    pub(super) isr: [IsrTotal; MASTER_VECTORS.len()],
    /// Requests seen on the wire (retries included), and those byte for byte right.
    pub(super) requests: usize,
    pub(super) right: usize,
    /// Replies the master was done with at once: the next request (or the retry of a
    /// damaged one) came within 100 ms of the reply's end, not after a response timeout.
    pub(super) taken: usize,
    pub(super) replies: usize,
    /// The reply's end to the next request's first start bit, cycles: min, max (replies taken).
    pub(super) next_after: (u64, u64),
    /// T3.5 on this line, cycles.
    pub(super) t35: u64,
}

/// Where `master_boards` is for `chip` and `usart`.
pub(super) fn master_board_path(root: &Path, chip: Chip, usart: u8) -> PathBuf {
    let dir = if usart == chip.default_usart() {
        format!("{}-master", chip.name())
    } else {
        format!("{}-usart{usart}-master", chip.name())
    };
    chip_build_path(root, &dir, "master_boards")
}

/// `master_boards` on one chip and USART against a simulated slave 1.
pub(super) fn master_run(elf: &Path, chip: Chip, usart: u8, log: &mut Log) -> Result<MasterRun> {
    let (flash, ram) = avr_size(elf)?;
    let mut uno = Uno::load_with(elf, Options::new().chip(chip).usart(usart))?;
    uno.run_until(us_to_cycles(1000))?;
    let times = line_times(&uno)?;
    let (char_cycles, t35) = times;
    let v = uno.vectors();
    let vectors = [v.usart_rx, v.timer0_compa, v.usart_tx, v.timer0_ovf];
    let expected = Request::read(1, 3, 0, 10, Expect::Normal).frame;
    let what = format!("master_boards ({chip}, USART{usart})");
    let mut rng = Lcg(0x3A57E2);
    let mut run = MasterRun {
        chip,
        usart,
        flash,
        ram,
        isr: [IsrTotal::default(); MASTER_VECTORS.len()],
        requests: 0,
        right: 0,
        taken: 0,
        replies: 0,
        next_after: (u64::MAX, 0),
        t35,
    };
    // The first request, after the power-up silence: the statistics count from here.
    let mut request = next_request(&mut uno, char_cycles, us_to_cycles(100_000))?;
    uno.reset_isr_stats();
    let mut reply_end: Option<u64> = None;
    for n in 0..=BOARD_REQUESTS {
        let Some(first) = request.first() else {
            log.problems.push(format!("{what}: no request after reply {n} (2.5 s)"));
            break;
        };
        if let Some(end) = reply_end {
            let after = first.start_cycle.saturating_sub(end);
            if after < us_to_cycles(100_000) {
                run.taken += 1;
                run.next_after = (run.next_after.0.min(after), run.next_after.1.max(after));
            }
        }
        run.requests += 1;
        let bytes: Vec<u8> = request.iter().map(|b| b.byte).collect();
        if bytes == expected {
            run.right += 1;
        } else {
            log.problems.push(format!("{what}: request {n} was {bytes:02X?}, not {expected:02X?}"));
        }
        if n == BOARD_REQUESTS {
            break;
        }
        let end = request.last().map_or(first.end_cycle, |b| b.end_cycle);
        reply_end = Some(answer(&mut uno, n, end, times, &mut rng)?);
        run.replies += 1;
        request = next_request(&mut uno, char_cycles, us_to_cycles(2_500_000))?;
    }
    for (total, &vector) in run.isr.iter_mut().zip(&vectors) {
        let s = uno.isr_stats(vector);
        *total = IsrTotal { entries: s.entries, cycles: s.cycles, max: s.max_cycles };
    }
    // Every reply is done with at once, the damaged one by a retry.
    if run.taken != run.replies {
        log.problems.push(format!("{what}: the master took {} of {} replies at once", run.taken, run.replies));
    }
    Ok(run)
}
