//! The requests sent to a firmware: the workload of every function code, and mixed
//! requests on random ranges of its tables.

use crate::firmware::{Firmware, ID};
use crate::modbus::{Expect, Request};
use crate::random::Lcg;

/// A request of every function code the examples serve, each answered normally where the
/// table exists and with exception 02 where it does not, plus FC 3 × 125 and an unsupported
/// function code.
pub(crate) fn workload(fw: &Firmware) -> Vec<Request> {
    let expect = |n: u16| if n > 0 { Expect::Normal } else { Expect::Exception(2) };
    let (c, i, h, r) = (fw.coils, fw.inputs, fw.holding, fw.input_regs);
    vec![
        Request::read(ID, 1, 0, c.max(1), expect(c)),
        Request::read(ID, 2, 0, i.max(1), expect(i)),
        Request::read(ID, 3, 0, h.max(1), expect(h)),
        Request::read(ID, 4, 0, r.max(1), expect(r)),
        Request::write_single(ID, 5, 0, 0xFF00, expect(c)),
        Request::write_single(ID, 6, 0, 1234, expect(h)),
        Request::write_coils(ID, 0, c.max(1), expect(c)),
        Request::write_registers(ID, 0, h.max(1), expect(h)),
        Request::read(ID, 3, 0, 125, if h >= 125 { Expect::Normal } else { Expect::Exception(2) }),
        Request::raw("FC 65 (unsupported)", ID, &[0x41, 0, 0, 0, 1], Expect::Exception(1)),
        // Read back what the writes left.
        Request::read(ID, 1, 0, c.max(1), expect(c)),
        Request::read(ID, 3, 0, h.max(1), expect(h)),
    ]
}

/// `count` requests, each of one of the eight function codes picked at random, on a
/// random range inside its table, with random values: all answered normally.
pub(crate) fn mixed(fw: &Firmware, count: usize, seed: u64) -> Vec<Request> {
    let mut rng = Lcg(seed);
    let mut requests = Vec::with_capacity(count);
    while requests.len() < count {
        let fc = [1u8, 2, 3, 4, 5, 6, 15, 16][rng.below(8) as usize];
        let size = match fc {
            1 | 5 | 15 => fw.coils,
            2 => fw.inputs,
            4 => fw.input_regs,
            _ => fw.holding,
        };
        if size == 0 {
            continue;
        }
        let start = rng.below(u64::from(size)) as u16;
        let qty = 1 + rng.below(u64::from(size - start)) as u16;
        let bit = |rng: &mut Lcg| rng.below(2) == 1;
        requests.push(match fc {
            5 => Request::write_single(ID, 5, start, if bit(&mut rng) { 0xFF00 } else { 0 }, Expect::Normal),
            6 => Request::write_single(ID, 6, start, rng.below(0x1_0000) as u16, Expect::Normal),
            15 => {
                let bits: Vec<bool> = (0..qty).map(|_| bit(&mut rng)).collect();
                Request::write_coil_values(ID, start, &bits, Expect::Normal)
            }
            16 => {
                let values: Vec<u16> = (0..qty).map(|_| rng.below(0x1_0000) as u16).collect();
                Request::write_register_values(ID, start, &values, Expect::Normal)
            }
            _ => Request::read(ID, fc, start, qty, Expect::Normal),
        });
    }
    requests
}

/// The request's label in the tables, with the exception it expects.
pub(crate) fn label(req: &Request) -> String {
    match req.expect {
        Expect::Normal => req.label.clone(),
        Expect::Exception(code) => format!("{} → exception {code:02}", req.label),
    }
}
