//! `poll_holding` on the Uno: the time from the application's call of `Master::send` to
//! the request's first start bit.

use std::path::Path;

use uno_sim::{us_to_cycles, Space, Uno};

use crate::elf::firmware_path;
use crate::log::Log;
use crate::random::Lcg;
use crate::Result;

use super::slave::{answer, line_times, next_request, EXCEPTION_EVERY};

/// Requests timed on `poll_holding` for the send latency.
pub(super) const LATENCY_REQUESTS: usize = 50;
/// The target: the request's first start bit at most this long after `Master::send` is
/// called, on a line idle for T3.5.
pub(crate) const LATENCY_TARGET_US: f64 = 25.0;

/// `poll_holding`: from the call of its `ask` (which calls `Master::send`) to the request's
/// first start bit.
pub(crate) struct Latency {
    /// Cycles, sorted.
    pub(super) samples: Vec<u64>,
    /// Shortest silence on the line before a call (from the last reply's end), cycles.
    pub(super) idle_min: u64,
    pub(super) t35: u64,
}

/// The entry of `poll_holding`'s `ask` (`#[inline(never)]`), which calls `Master::send`: the
/// moment the application asks.
fn send_entry(uno: &Uno) -> Option<u32> {
    uno.symbols()
        .iter()
        .find(|s| s.space == Space::Flash && s.name.contains("12poll_holding") && s.name.ends_with("3ask"))
        .map(|s| s.addr)
}

/// `poll_holding` on the Uno: each call of its `ask` (reached by stepping to its entry)
/// to the request's first start bit, the line idle since the last reply.
pub(super) fn latency(root: &Path, log: &mut Log) -> Result<Option<Latency>> {
    let elf = firmware_path(root, "poll_holding");
    if !elf.is_file() {
        log.problems.push(format!("{} is missing: run `make firmware`", elf.display()));
        return Ok(None);
    }
    let mut uno = Uno::load(&elf)?;
    let Some(entry) = send_entry(&uno) else {
        log.problems.push(format!("{}: no symbol for poll_holding's ask (is it #[inline(never)]?)", elf.display()));
        return Ok(None);
    };
    uno.run_until(us_to_cycles(1000))?;
    let times = line_times(&uno)?;
    let (char_cycles, t35) = times;
    let mut rng = Lcg(0x1A7E);
    let mut samples = Vec::with_capacity(LATENCY_REQUESTS);
    let mut idle_min = u64::MAX;
    let mut quiet_from = 0;
    let mut called = None;
    for n in 0..LATENCY_REQUESTS {
        // A request every 100 ms of millis(): run to just before the next, then step.
        if let Some(at) = called {
            uno.run_until(at + us_to_cycles(95_000))?;
        }
        let limit = uno.now() + us_to_cycles(300_000);
        while uno.pc() != entry {
            uno.step()?;
            if uno.now() > limit {
                return Err(format!("poll_holding: ask not called within 300 ms (request {n})").into());
            }
        }
        let at = uno.now();
        called = Some(at);
        idle_min = idle_min.min(at - quiet_from);
        let request = next_request(&mut uno, char_cycles, us_to_cycles(20_000))?;
        let (Some(first), Some(last)) = (request.first(), request.last()) else {
            log.problems.push(format!("poll_holding: no request after Master::send (request {n})"));
            return Ok(None);
        };
        if first.start_cycle < at {
            log.problems.push(format!("poll_holding: a request went out before ask (request {n})"));
            return Ok(None);
        }
        samples.push(first.start_cycle - at);
        // Answered normally: the next call finds the master idle.
        quiet_from = answer(&mut uno, n % (EXCEPTION_EVERY - 1), last.end_cycle, times, &mut rng)?;
    }
    samples.sort_unstable();
    Ok(Some(Latency { samples, idle_min, t35 }))
}
