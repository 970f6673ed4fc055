//! The slave the master talks to in the simulator: it waits for each request and answers
//! it as a slave would, T3.5 and a random turnaround later.

use uno_sim::{us_to_cycles, LineError, TxByte, Uno};

use crate::modbus::crc16;
use crate::random::Lcg;
use crate::Result;

/// Every this many requests, the slave answers with exception 2 (illegal data address).
pub(super) const EXCEPTION_EVERY: usize = 10;
/// The request whose reply has a parity error in its 4th character: the master drops the
/// reply at T3.5 and sends the request again at once (its one retry).
pub(super) const DAMAGED_REPLY: usize = 50;
/// A silence past T3.5 before a reply, drawn below this many µs: the slave's turnaround.
pub(super) const SLAVE_DELAY_US: u64 = 1500;

/// FC 3's reply with `values`, from slave 1.
fn fc3_reply(values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![3, (values.len() * 2) as u8];
    for v in values {
        pdu.extend_from_slice(&v.to_be_bytes());
    }
    frame(&pdu)
}

/// Slave 1's ADU around `pdu`.
fn frame(pdu: &[u8]) -> Vec<u8> {
    let mut f = vec![1];
    f.extend_from_slice(pdu);
    f.extend_from_slice(&crc16(&f).to_le_bytes());
    f
}

/// The line's character time and T3.5 (as the master counts them), cycles.
pub(super) fn line_times(uno: &Uno) -> std::result::Result<(u64, u64), uno_sim::Error> {
    let cfg = uno.serial_config().ok_or(uno_sim::Error::UartNotConfigured)?;
    let fixed = cfg.baud() > 19_200.0 * 1.05;
    Ok((cfg.char_cycles(), if fixed { us_to_cycles(1750) } else { cfg.char_cycles() * 7 / 2 }))
}

/// Runs until the master has sent a request (and the line is quiet again for two
/// characters), at most `wait` cycles: its characters.
pub(super) fn next_request(
    uno: &mut Uno,
    char_cycles: u64,
    wait: u64,
) -> std::result::Result<Vec<TxByte>, uno_sim::Error> {
    let deadline = uno.now() + wait;
    uno.run_until_tx_idle(2 * char_cycles, deadline)
}

/// Answers the request that ended at `request_end` as a slave would, T3.5 and a random
/// turnaround later: `n`'s registers, an exception now and then, one reply damaged.
/// Returns the reply's end on the line.
pub(super) fn answer(uno: &mut Uno, n: usize, request_end: u64, times: (u64, u64), rng: &mut Lcg) -> Result<u64> {
    let (char_cycles, t35) = times;
    let start = (request_end + t35 + us_to_cycles(rng.below(SLAVE_DELAY_US))).max(uno.now() + 1);
    let reply = if n % EXCEPTION_EVERY == EXCEPTION_EVERY - 1 {
        frame(&[0x83, 2])
    } else {
        let values: Vec<u16> = (0..10).map(|i| (n as u16).wrapping_mul(0x0101) ^ (i * 0x1111)).collect();
        fc3_reply(&values)
    };
    if n == DAMAGED_REPLY {
        let mut end = start;
        for (i, &byte) in reply.iter().enumerate() {
            end += char_cycles;
            if i == 3 {
                uno.send_byte_with_error(byte, end, LineError::Parity)?;
            } else {
                uno.send_byte(byte, end)?;
            }
        }
        return Ok(end);
    }
    Ok(uno.send_frame(&reply, start + char_cycles, 0)?)
}
