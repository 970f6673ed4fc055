//! One request repeated (or a list of requests) on one line setting: the replies'
//! turnarounds against T3.5, the silences inside them, the compare interrupt's runs.

use uno_sim::{us_to_cycles, CYCLES_PER_US};

use crate::bus::Bus;
use crate::firmware::firmware_model;
use crate::log::Log;
use crate::modbus::{Model, Request};
use crate::random::Lcg;
use crate::Result;

/// The percentile of the turnaround the tables and targets give beside p50 and max.
pub(crate) const TURNAROUND_PERCENTILE: usize = 99;

/// `cycles` in µs, one decimal.
pub(crate) fn us(cycles: i64) -> String {
    format!("{:.1}", cycles as f64 / CYCLES_PER_US as f64)
}

/// One request repeated on one line setting, and how the replies came.
pub(crate) struct Series {
    /// Firmware name.
    pub(crate) firmware: String,
    /// Line setting, e.g. "19200 8E1".
    pub(crate) line: String,
    /// Request label.
    pub(crate) request: String,
    /// The Uno's actual bit rate and bits per character.
    pub(crate) baud: f64,
    pub(crate) char_bits: u32,
    /// Character time, cycles.
    pub(crate) char_cycles: u64,
    /// The master's T3.5 and T1.5, cycles.
    pub(crate) t35: u64,
    pub(crate) t15: u64,
    /// Requests sent.
    pub(crate) sent: usize,
    /// Turnarounds of the right replies, cycles, sorted.
    turnarounds: Vec<i64>,
    /// Longest silence inside a reply, cycles.
    pub(crate) max_gap: u64,
    /// Longest gap deadline and T3.5 interrupt runs, cycles.
    pub(crate) gap_isr: u64,
    pub(crate) t35_isr: u64,
    /// Length of the last reply, bytes.
    pub(crate) reply_len: usize,
    /// From the first request's start bit to T3.5 after the last reply, cycles.
    pub(crate) span: u64,
}

impl Series {
    /// Sends `req` `count` times on `bus`, each after a pseudo-random extra silence below
    /// `max_delay_us` (0: back to back, T3.5 after the previous reply).
    pub(crate) fn run(
        bus: &mut Bus,
        line: &str,
        req: &Request,
        count: usize,
        max_delay_us: u64,
        log: &mut Log,
    ) -> Result<Series> {
        let mut model = firmware_model(bus.name());
        Series::run_all(bus, line, &vec![req.clone(); count], &req.label, max_delay_us, &mut model, log)
    }

    /// Sends `requests` in order on `bus` (labelled `label` in the tables), each after a
    /// pseudo-random extra silence below `max_delay_us`, checking the replies against `model`.
    pub(crate) fn run_all(
        bus: &mut Bus,
        line: &str,
        requests: &[Request],
        label: &str,
        max_delay_us: u64,
        model: &mut Model,
        log: &mut Log,
    ) -> Result<Series> {
        let mut rng = Lcg(0x5EED);
        let first = bus.idle_from();
        let count = requests.len();
        let mut s = Series {
            firmware: bus.name().to_owned(),
            line: line.to_owned(),
            request: label.to_owned(),
            baud: bus.baud,
            char_bits: bus.char_bits,
            char_cycles: bus.char_cycles,
            t35: bus.t35,
            t15: bus.t15,
            sent: count,
            turnarounds: Vec::with_capacity(count),
            max_gap: 0,
            gap_isr: 0,
            t35_isr: 0,
            reply_len: 0,
            span: 0,
        };
        for req in requests {
            let delay = if max_delay_us == 0 { 0 } else { us_to_cycles(rng.below(max_delay_us)) };
            let t = bus.transact(req, delay)?;
            s.max_gap = s.max_gap.max(t.max_gap);
            s.gap_isr = s.gap_isr.max(t.gap_isr);
            s.t35_isr = s.t35_isr.max(t.t35_isr);
            s.reply_len = t.reply.len();
            s.turnarounds.extend(log.check(&format!("{} {line}", bus.name()), req, &t, model));
        }
        s.turnarounds.sort_unstable();
        s.span = bus.idle_from() - first;
        Ok(s)
    }

    /// Requests answered right.
    pub(crate) fn answered(&self) -> usize {
        self.turnarounds.len()
    }

    fn median(&self) -> i64 {
        self.percentile(50).unwrap_or(0)
    }

    /// The latest turnaround, cycles.
    pub(crate) fn max(&self) -> i64 {
        self.turnarounds.last().copied().unwrap_or(0)
    }

    /// The earliest turnaround (negative: a reply that started before T3.5 had passed).
    pub(crate) fn min(&self) -> Option<i64> {
        self.turnarounds.first().copied()
    }

    /// "p50 / p99 / max" in µs.
    pub(crate) fn spread(&self) -> String {
        format!(
            "{} / {} / {}",
            us(self.median()),
            self.percentile(TURNAROUND_PERCENTILE).map_or("–".into(), us),
            us(self.max())
        )
    }

    /// The turnaround `pct` % of the requests sent came within; `None` if that many were
    /// not answered right.
    pub(crate) fn percentile(&self, pct: usize) -> Option<i64> {
        let rank = (self.sent * pct).div_ceil(100).max(1);
        self.turnarounds.get(rank - 1).copied()
    }
}
