//! What the run found besides the figures: wrong or missing replies.

use crate::bus::Transaction;
use crate::modbus::{Model, Request};

/// Every reply checked, and those wrong or missing.
#[derive(Default)]
pub(crate) struct Log {
    pub(crate) problems: Vec<String>,
    /// (where, function code) of each wrong or missing reply.
    failed: Vec<(String, u8)>,
    pub(crate) replies: usize,
}

impl Log {
    /// Function codes that got a wrong or missing reply from `firmware`, in order.
    pub(crate) fn failed_fcs(&self, firmware: &str) -> Vec<String> {
        let mut fcs: Vec<u8> = self
            .failed
            .iter()
            .filter(|(what, _)| what.split(' ').next() == Some(firmware))
            .map(|&(_, fc)| fc)
            .collect();
        fcs.sort_unstable();
        fcs.dedup();
        fcs.iter().map(|fc| format!("FC {fc}")).collect()
    }

    /// Checks a reply against `model` and counts it; returns its turnaround in cycles if
    /// the reply is right.
    pub(crate) fn check(&mut self, what: &str, req: &Request, t: &Transaction, model: &mut Model) -> Option<i64> {
        if let Err(e) = req.check(&t.reply, model) {
            let problem = if t.reply.is_empty() { format!("{}: no reply", req.label) } else { e };
            self.problems.push(format!("{what}: {problem}"));
            self.failed.push((what.to_owned(), req.frame[1]));
            return None;
        }
        let cycles = t.turnaround?;
        self.replies += 1;
        Some(cycles)
    }
}
