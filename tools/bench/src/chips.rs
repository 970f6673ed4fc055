//! `examples/boards.rs` on every chip and USART the crate serves: sizes, interrupt cycles
//! and the turnaround of mixed requests.

use std::path::{Path, PathBuf};

use uno_sim::Chip;

use crate::bus::{Bus, IsrTotal, VECTORS};
use crate::elf::{avr_size, chip_build_path, firmware_path};
use crate::firmware::BOARDS_MAP;
use crate::log::Log;
use crate::requests::{mixed, workload};
use crate::series::Series;
use crate::timing::MIX_MAX_DELAY_US;
use crate::Result;

/// Every chip and USART the crate serves, from the chip table (`chips/chips.txt`, through
/// the simulator's [`Chip`]): `examples/boards.rs` is built for each (`make chips`; the
/// ATmega328P's from `make firmware`), and `examples/master_boards.rs` too: (chip, USART).
pub(crate) fn boards() -> Vec<(Chip, u8)> {
    Chip::ALL.iter().flat_map(|&chip| chip.usarts().into_iter().map(move |usart| (chip, usart))).collect()
}

/// Mixed requests per chip and USART, each after a random silence (the turnaround's spread).
pub(crate) const BOARD_REQUESTS: usize = 200;

/// `boards` on one chip and USART: sizes, interrupt cycles over the workload and the mixed
/// requests, and the turnaround of the mixed requests.
pub(crate) struct ChipRun {
    pub(crate) chip: Chip,
    pub(crate) usart: u8,
    pub(crate) flash: u64,
    pub(crate) ram: u64,
    pub(crate) isr: [IsrTotal; VECTORS.len()],
    /// Workload requests answered right, of those sent.
    pub(crate) right: usize,
    pub(crate) sent: usize,
    pub(crate) mixed: Series,
}

/// Where `boards` is for `chip` and `usart`: as tests/sim/mod.rs's `chip_firmware_path`.
fn board_path(root: &Path, chip: Chip, usart: u8) -> PathBuf {
    if chip == Chip::Atmega328p && usart == 0 {
        return firmware_path(root, "boards");
    }
    let dir =
        if usart == chip.default_usart() { chip.name().to_owned() } else { format!("{}-usart{usart}", chip.name()) };
    chip_build_path(root, &dir, "boards")
}

/// `boards` on each of [`boards`]: the workload, then [`BOARD_REQUESTS`] mixed requests.
pub(crate) fn chip_runs(root: &Path, log: &mut Log) -> Result<Vec<ChipRun>> {
    let mut runs = Vec::new();
    for (chip, usart) in boards() {
        let elf = board_path(root, chip, usart);
        if !elf.is_file() {
            log.problems.push(format!("{} is missing: run `make firmware`", elf.display()));
            continue;
        }
        eprintln!("bench: boards on the {chip}, USART{usart} (workload, {BOARD_REQUESTS} mixed requests)");
        let (flash, ram) = avr_size(&elf)?;
        let mut bus = Bus::boot_on(&elf, usart)?;
        let mut model = BOARDS_MAP.model();
        let problems = log.problems.len();
        let requests = workload(&BOARDS_MAP);
        let what = format!("boards ({chip}, USART{usart})");
        for req in &requests {
            let t = bus.transact(req, 0)?;
            log.check(&what, req, &t, &mut model);
        }
        let right = requests.len() - (log.problems.len() - problems);
        let mixed_requests = mixed(&BOARDS_MAP, BOARD_REQUESTS, 0xB0A2D);
        let mixed = Series::run_all(&mut bus, "19200 8E1", &mixed_requests, "mix", MIX_MAX_DELAY_US, &mut model, log)?;
        runs.push(ChipRun { chip, usart, flash, ram, isr: bus.isr, right, sent: requests.len(), mixed });
    }
    Ok(runs)
}
