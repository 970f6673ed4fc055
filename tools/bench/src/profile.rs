//! One firmware under the workload: its sizes, stack high-water mark, interrupt cycles and
//! the compare interrupt's runs per request.

use std::path::Path;

use crate::bus::{Bus, IsrTotal, VECTORS};
use crate::elf::{avr_size, firmware_path, template_size};
use crate::firmware::Firmware;
use crate::log::Log;
use crate::requests::{label, workload};
use crate::Result;

/// Measurements of one firmware under the workload.
pub(crate) struct Profile {
    pub(crate) name: &'static str,
    /// Flash and static RAM as the avr-hal template builds it (`make chips`), if built.
    pub(crate) template: Option<(u64, u64)>,
    /// Flash and static RAM as `make firmware` builds it: the ELF file measured in the
    /// simulator.
    pub(crate) flash: u64,
    pub(crate) ram: u64,
    /// Bytes of register and bit values in the example's data model.
    pub(crate) values: u64,
    pub(crate) stack: u16,
    pub(crate) isr: [IsrTotal; VECTORS.len()],
    /// (request label, gap deadline and T3.5 interrupt cycles) per workload request.
    pub(crate) t35: Vec<(String, u64, u64)>,
    /// Workload requests answered right, of those sent.
    pub(crate) right: usize,
    pub(crate) sent: usize,
}

/// Sizes, stack high-water mark, interrupt cycles and per-request T3.5 cycles of one firmware.
pub(crate) fn profile(root: &Path, fw: &Firmware, log: &mut Log) -> Result<Profile> {
    let elf = firmware_path(root, fw.name);
    let (flash, ram) = avr_size(&elf)?;
    let requests = workload(fw);
    let mut stack = 0;
    let mut isr = [IsrTotal::default(); VECTORS.len()];
    let mut t35 = Vec::new();
    // Two passes with complementary patterns: a stack byte that happens to equal the
    // pattern cannot hide the high-water mark in both.
    let problems = log.problems.len();
    for (pass, pattern) in [0xA5u8, 0x5A].into_iter().enumerate() {
        let mut bus = Bus::boot(&elf, &[], Some(pattern))?;
        let mut model = fw.model();
        for req in &requests {
            let t = bus.transact(req, 0)?;
            if pass == 0 {
                log.check(fw.name, req, &t, &mut model);
                t35.push((label(req), t.gap_isr, t.t35_isr));
            }
        }
        stack = stack.max(bus.stack_used(pattern)?);
        if pass == 0 {
            isr = bus.isr;
        }
    }
    let sent = requests.len();
    let right = sent - (log.problems.len() - problems);
    let template = template_size(root, fw.name);
    Ok(Profile { name: fw.name, template, flash, ram, values: fw.values(), stack, isr, t35, right, sent })
}
