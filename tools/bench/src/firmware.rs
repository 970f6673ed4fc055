//! The example firmware the bench runs, each with its data model at the default pin
//! settings (from the register table in the header of `examples/<name>.rs`).

use crate::modbus::Model;

/// Slave id of every example (lab_lights: button box, pin 12 open).
pub(crate) const ID: u8 = 1;

/// The contract's two firmware: its map fixed at build time, and from a run-time `Bank`.
pub(crate) const CONTRACTS: [&str; 2] = ["sixteen_each", "sixteen_each_bank"];

/// An example firmware and its data model; all tables start at address 0.
pub(crate) struct Firmware {
    pub(crate) name: &'static str,
    pub(crate) coils: u16,
    pub(crate) inputs: u16,
    pub(crate) input_regs: u16,
    pub(crate) holding: u16,
    /// Ranges (first reference, count) whose values the firmware sets itself: replies are
    /// not compared there.
    changing: &'static [(u32, u16)],
    /// References that start at a value other than 0.
    initial: &'static [(u32, u16)],
}

impl Firmware {
    const fn new(name: &'static str, [coils, inputs, input_regs, holding]: [u16; 4]) -> Firmware {
        Firmware { name, coils, inputs, input_regs, holding, changing: &[], initial: &[] }
    }

    /// The master's view of the registers just after start-up.
    pub(crate) fn model(&self) -> Model {
        Model::new([self.coils, self.inputs, self.input_regs, self.holding], self.changing, self.initial)
    }

    /// Bytes of register and bit values: 2 per register, 1 bit per coil or input.
    pub(crate) fn values(&self) -> u64 {
        2 * u64::from(self.input_regs + self.holding) + u64::from(self.coils + self.inputs).div_ceil(8)
    }
}

/// The Uno's examples the bench profiles, in the order of its tables.
pub(crate) const FIRMWARE: [Firmware; 7] = [
    Firmware { changing: &[(40002, 2)], ..Firmware::new("minimal", [0, 0, 0, 4]) },
    Firmware {
        changing: &[(10001, 4), (30001, 12)],
        initial: &[(40001, 500), (40002, 512)],
        ..Firmware::new("uno_slave", [5, 4, 12, 10])
    },
    Firmware { changing: &[(30001, 1), (40004, 1)], ..Firmware::new("busy_loop", [0, 0, 1, 4]) },
    Firmware { changing: &[(10001, 2)], ..Firmware::new("lab_lights", [0, 2, 0, 0]) },
    Firmware { changing: &[(10001, 3), (30001, 1)], ..Firmware::new("dip_switch", [16, 3, 1, 10]) },
    Firmware::new("sixteen_each", [16, 16, 8, 16]),
    Firmware::new("sixteen_each_bank", [16, 16, 8, 16]),
];

/// `examples/boards.rs`'s map: sixteen_each's, with 30001 counting seconds.
pub(crate) const BOARDS_MAP: Firmware =
    Firmware { changing: &[(30001, 1)], ..Firmware::new("boards", [16, 16, 8, 16]) };

/// The firmware of [`FIRMWARE`] called `name`.
pub(crate) fn firmware(name: &str) -> &'static Firmware {
    FIRMWARE.iter().find(|fw| fw.name == name).expect("firmware in the table")
}

/// The model of a firmware in [`FIRMWARE`] by name; one that knows nothing for others
/// (`max_frame`: 125 holding registers kept for the master, all 0 at start-up; `call_loop`).
pub(crate) fn firmware_model(name: &str) -> Model {
    match FIRMWARE.iter().find(|fw| fw.name == name) {
        Some(fw) => fw.model(),
        None if name == "max_frame" => Model::new([0, 0, 0, 125], &[], &[]),
        // examples/call_loop.rs: 30001–30006 the loop writes, 40001–40003 the master's.
        None if name == crate::calls::FIRMWARE => Model::new([0, 0, 6, 3], &[(30001, 6)], &[]),
        None => Model::new([0; 4], &[], &[]),
    }
}
