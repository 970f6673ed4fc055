//! Pacing a simulation to the wall clock: which cycle the simulated chips should have
//! reached by now, and cycles as wall time.

use std::time::{Duration, Instant};

use uno_sim::CYCLES_PER_US;

/// Maps wall-clock time to simulated cycles.
pub(crate) struct Clock {
    start: Instant,
    base_cycle: u64,
}

impl Clock {
    pub(crate) fn new(now_cycle: u64) -> Clock {
        Clock { start: Instant::now(), base_cycle: now_cycle }
    }

    /// The cycle the simulation should have reached by now.
    pub(crate) fn due(&self) -> u64 {
        let ns = self.start.elapsed().as_nanos();
        self.base_cycle + u64::try_from(ns * u128::from(CYCLES_PER_US) / 1_000).unwrap_or(u64::MAX)
    }
}

/// Simulated cycles as wall time.
pub(crate) fn cycles_to_duration(cycles: u64) -> Duration {
    Duration::from_nanos(cycles.saturating_mul(1_000) / CYCLES_PER_US)
}
