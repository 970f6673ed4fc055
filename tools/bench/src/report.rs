//! Everything one run measures, in the order it is measured.

use std::path::Path;

use crate::calls::{self, Calls};
use crate::chips::{chip_runs, ChipRun};
use crate::features::{feature_costs, FeatureCost};
use crate::firmware::FIRMWARE;
use crate::log::Log;
use crate::master;
use crate::profile::{profile, Profile};
use crate::timing::Timing;
use crate::Result;

/// Everything measured in one run.
pub(crate) struct Report {
    /// Each of [`FIRMWARE`] under the workload.
    pub(crate) profiles: Vec<Profile>,
    /// The replies' timing on the Uno.
    pub(crate) timing: Timing,
    /// `call_loop`: the main loop's critical sections, if built.
    pub(crate) calls: Option<Calls>,
    /// Feature costs on `minimal`, then `configurable`'s total.
    pub(crate) features: Vec<FeatureCost>,
    /// `boards` on every chip and USART.
    pub(crate) chips: Vec<ChipRun>,
    /// The master: `master_boards` on every chip and USART, `poll_holding`'s send latency.
    pub(crate) master: master::Measured,
    /// Modbus TCP, if built.
    pub(crate) tcp: Option<crate::tcp::Measured>,
    /// The TCP to RTU gateway, if built.
    pub(crate) gateway: Option<crate::gateway::Measured>,
    /// The serial line on pins 8/9, if built.
    pub(crate) capture: Option<crate::capture::Measured>,
}

impl Report {
    /// Runs every measurement; wrong or missing replies go to `log`.
    pub(crate) fn measure(root: &Path, log: &mut Log) -> Result<Report> {
        let mut profiles = Vec::new();
        for fw in &FIRMWARE {
            eprintln!("bench: {} (workload, stack)", fw.name);
            profiles.push(profile(root, fw, log)?);
        }
        Ok(Report {
            profiles,
            timing: Timing::measure(root, log)?,
            calls: calls::measure(root, log)?,
            features: feature_costs(root),
            chips: chip_runs(root, log)?,
            master: master::measure(root, log)?,
            tcp: crate::tcp::measure(root, log)?,
            gateway: crate::gateway::measure(root, log)?,
            capture: crate::capture::measure(root, log)?,
        })
    }

    /// The profile of firmware `name`, if measured.
    pub(crate) fn profile(&self, name: &str) -> Option<&Profile> {
        self.profiles.iter().find(|p| p.name == name)
    }
}
