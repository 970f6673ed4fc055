//! The TCP server's addresses as a record for the EEPROM (features `tcp` and
//! `eeprom-settings`): MAC, IP, subnet mask, gateway, port and unit id, with a sequence
//! number and a CRC, in two slots, so that a reset during a store leaves the old record or
//! the new one, never half of each.
//!
//! A record: sequence (1), the addresses in the chips' order (18), port (2, big-endian), unit
//! id (1: 0 for every unit), CRC-16/MODBUS of the 22 bytes before it (2, low byte first).

use super::network::{Network, ADDRESSES};
use crate::link::crc::crc16;

/// One record's bytes.
pub const RECORD_LEN: usize = 24;
/// Two slots: what a store needs in the EEPROM.
pub const NETWORK_SLOTS_LEN: usize = 2 * RECORD_LEN;

/// `network`'s addresses, port and unit id as a record numbered `sequence`.
pub fn encode(network: &Network, sequence: u8) -> [u8; RECORD_LEN] {
    let mut record = [0; RECORD_LEN];
    record[0] = sequence;
    record[1..1 + ADDRESSES].copy_from_slice(&network.addresses);
    record[19..21].copy_from_slice(&network.port.to_be_bytes());
    record[21] = network.unit;
    let crc = crc16(&record[..22]);
    record[22..].copy_from_slice(&crc.to_le_bytes());
    record
}

/// The record's sequence and `default` with the record's addresses, port and unit id (the
/// rest, the allow-list and the timeouts, stays the firmware's); `None` for bytes that are
/// no record (erased, torn, a port of 0, a unit id outside 0–247).
pub fn decode(record: &[u8; RECORD_LEN], default: Network) -> Option<(u8, Network)> {
    if crc16(&record[..22]).to_le_bytes() != [record[22], record[23]] {
        return None;
    }
    let port = u16::from_be_bytes([record[19], record[20]]);
    let unit = record[21];
    if port == 0 || unit > 247 {
        return None;
    }
    let mut addresses = [0; ADDRESSES];
    addresses.copy_from_slice(&record[1..1 + ADDRESSES]);
    Some((record[0], Network { addresses, port, unit, ..default }))
}

/// The newer of the two slots' records (sequence numbers compared as they wrap), `default`
/// changed by it; `None` when neither holds one.
pub fn newest(slots: &[u8; NETWORK_SLOTS_LEN], default: Network) -> Option<(usize, u8, Network)> {
    let slot = |i: usize| {
        let mut record = [0; RECORD_LEN];
        record.copy_from_slice(&slots[i * RECORD_LEN..(i + 1) * RECORD_LEN]);
        decode(&record, default).map(|(sequence, network)| (i, sequence, network))
    };
    match (slot(0), slot(1)) {
        (Some(a), Some(b)) => Some(if b.1.wrapping_sub(a.1) < 128 { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// Where and what to write to store `network` in the slots: the slot that does not hold the
/// newest record, its record with the next sequence number. `None` when the newest record
/// already holds it.
pub fn store(slots: &[u8; NETWORK_SLOTS_LEN], network: &Network) -> Option<(usize, [u8; RECORD_LEN])> {
    match newest(slots, *network) {
        Some((_, _, stored))
            if stored.addresses == network.addresses && stored.port == network.port && stored.unit == network.unit =>
        {
            None
        }
        Some((slot, sequence, _)) => Some(((1 - slot) * RECORD_LEN, encode(network, sequence.wrapping_add(1)))),
        None => Some((0, encode(network, 0))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEFAULT: Network = Network::new([2, 0, 0, 0, 0, 1], [192, 168, 1, 177]);

    fn erased() -> [u8; NETWORK_SLOTS_LEN] {
        [0xFF; NETWORK_SLOTS_LEN]
    }

    fn written(slots: &mut [u8; NETWORK_SLOTS_LEN], network: &Network) {
        if let Some((at, record)) = store(slots, network) {
            slots[at..at + RECORD_LEN].copy_from_slice(&record);
        }
    }

    #[test]
    fn an_erased_eeprom_holds_no_network() {
        assert!(newest(&erased(), DEFAULT).is_none());
    }

    #[test]
    fn a_stored_network_comes_back_with_the_firmwares_allow_list() {
        let mut slots = erased();
        let stored = DEFAULT.gateway([10, 0, 0, 1]).with_port(1502).only_unit(7);
        written(&mut slots, &stored);
        let default = DEFAULT.allow(&[[10, 0, 0, 9]]);
        let (_, _, loaded) = newest(&slots, default).unwrap();
        assert_eq!((loaded.addresses, loaded.port, loaded.unit), (stored.addresses, 1502, 7));
        assert_eq!(loaded.allow, default.allow);
    }

    #[test]
    fn a_store_goes_to_the_other_slot_and_the_newest_wins() {
        let mut slots = erased();
        written(&mut slots, &DEFAULT.with_port(1000));
        written(&mut slots, &DEFAULT.with_port(2000));
        written(&mut slots, &DEFAULT.with_port(3000));
        assert_eq!(newest(&slots, DEFAULT).unwrap().2.port, 3000);
        assert_eq!(newest(&slots, DEFAULT).unwrap().0, 0, "slots 0, 1, 0");
    }

    #[test]
    fn a_store_torn_at_any_byte_leaves_the_old_network_or_the_new() {
        let mut slots = erased();
        written(&mut slots, &DEFAULT.with_port(1000));
        let new = DEFAULT.with_port(2000);
        let (at, record) = store(&slots, &new).unwrap();
        for torn in 0..RECORD_LEN {
            let mut partial = slots;
            partial[at..at + torn].copy_from_slice(&record[..torn]);
            let port = newest(&partial, DEFAULT).unwrap().2.port;
            assert!(port == 1000 || (port == 2000 && torn == RECORD_LEN), "torn after {torn} bytes: {port}");
        }
    }

    #[test]
    fn storing_what_is_stored_writes_nothing() {
        let mut slots = erased();
        written(&mut slots, &DEFAULT);
        assert!(store(&slots, &DEFAULT).is_none());
    }

    #[test]
    fn sequence_numbers_wrap() {
        let a = encode(&DEFAULT.with_port(1), 255);
        let b = encode(&DEFAULT.with_port(2), 0);
        let mut slots = [0; NETWORK_SLOTS_LEN];
        slots[..RECORD_LEN].copy_from_slice(&a);
        slots[RECORD_LEN..].copy_from_slice(&b);
        assert_eq!(newest(&slots, DEFAULT).unwrap().2.port, 2);
    }
}
