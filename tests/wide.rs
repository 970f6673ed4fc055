//! 32-bit values in two registers: both word orders against values whose bytes are known,
//! NaN and infinities bit for bit, the maps' and the bank's pairs read and written whole,
//! and the rule for a master's write of half a pair (exception 02, nothing written).

mod common;

use avr_modbus::{Bank, Error, Reference, WordOrder};
use common::{exchange, with_crc, write_multiple_pdu, ID};

#[test]
fn one_as_f32_is_3f80_0000_high_word_first_and_0000_3f80_low_word_first() {
    assert_eq!(WordOrder::HighFirst.split(1.0f32), [0x3F80, 0x0000]);
    assert_eq!(WordOrder::LowFirst.split(1.0f32), [0x0000, 0x3F80]);
    assert_eq!(WordOrder::HighFirst.join::<f32>([0x3F80, 0x0000]), 1.0);
    assert_eq!(WordOrder::LowFirst.join::<f32>([0x0000, 0x3F80]), 1.0);
    assert_eq!(WordOrder::default(), WordOrder::HighFirst);
}

#[test]
fn minus_two_as_i32_and_0x12345678_as_u32_in_both_orders() {
    assert_eq!(WordOrder::HighFirst.split(-2i32), [0xFFFF, 0xFFFE]);
    assert_eq!(WordOrder::LowFirst.split(-2i32), [0xFFFE, 0xFFFF]);
    assert_eq!(WordOrder::HighFirst.join::<i32>([0xFFFF, 0xFFFE]), -2);
    assert_eq!(WordOrder::HighFirst.split(0x1234_5678u32), [0x1234, 0x5678]);
    assert_eq!(WordOrder::LowFirst.split(0x1234_5678u32), [0x5678, 0x1234]);
    assert_eq!(WordOrder::LowFirst.join::<u32>([0x5678, 0x1234]), 0x1234_5678);
}

#[test]
fn nan_and_infinities_pass_through_bit_for_bit() {
    for bits in [0x7FC0_0000u32, 0x7FC0_1234, 0xFFC0_0001, 0x7F80_0001, 0x7F80_0000, 0xFF80_0000, 0x8000_0000] {
        for order in [WordOrder::HighFirst, WordOrder::LowFirst] {
            let words = order.split(f32::from_bits(bits));
            assert_eq!(order.join::<f32>(words).to_bits(), bits, "{bits:#010X} {order:?}");
        }
    }
}

avr_modbus::register_map! {
    /// Plain registers, a float pair and two counters.
    struct Meter { 40001..=40004, 40005..=40006 as f32, 40007..=40010 as u32, 30001..=30002 as i32 }
}

#[test]
fn a_map_reads_and_writes_its_pairs_whole() {
    let mut map = Meter::new();
    map.set_wide(40005, -1.5f32, WordOrder::HighFirst).unwrap();
    assert_eq!((map.get(40005), map.get(40006)), (Ok(0xBFC0), Ok(0x0000)));
    map.set_wide(40009, 70_000u32, WordOrder::LowFirst).unwrap();
    assert_eq!((map.get(40009), map.get(40010)), (Ok((70_000u32 & 0xFFFF) as u16), Ok(1)));
    assert_eq!(map.get_wide::<u32>(40009, WordOrder::LowFirst), Ok(70_000));
    map.set_wide(30001, -2i32, WordOrder::HighFirst).unwrap();
    assert_eq!(map.get_wide::<i32>(30001, WordOrder::HighFirst), Ok(-2));
    // A pair whose second register is missing changes nothing.
    assert_eq!(map.set_wide(40010, 1u32, WordOrder::HighFirst), Err(Error::NotFound));
    assert_eq!(map.get(40010), Ok(1));
    // Bits hold no pairs.
    assert_eq!(map.set_wide(1, 1u32, WordOrder::HighFirst), Err(Error::BadReference));
}

/// FC 16 of `values` from `start`, as the slave engine answers it.
fn fc16(map: &mut Meter, start: u16, values: &[u16]) -> Vec<u8> {
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    exchange(map, &write_multiple_pdu(0x10, start, values.len() as u16, &data))
}

#[test]
fn a_write_of_half_a_pair_is_exception_02_and_writes_nothing() {
    let mut map = Meter::new();
    map.set_wide(40005, 2.5f32, WordOrder::HighFirst).unwrap();
    map.set_wide(40007, 0xAAAA_BBBBu32, WordOrder::HighFirst).unwrap();
    let illegal_address = with_crc(&[ID, 0x90, 0x02]);
    // Only the second register of the float; only the first; across the float's middle.
    assert_eq!(fc16(&mut map, 5, &[1]), illegal_address);
    assert_eq!(fc16(&mut map, 4, &[1]), illegal_address);
    assert_eq!(fc16(&mut map, 3, &[1, 2]), illegal_address, "40004 and the float's first half");
    assert_eq!(fc16(&mut map, 5, &[1, 2]), illegal_address, "the float's second half and 40007");
    // FC 6 to one register of a pair: 02 as well.
    let fc6 = exchange(&mut map, &[0x06, 0x00, 0x06, 0x12, 0x34]);
    assert_eq!(fc6, with_crc(&[ID, 0x86, 0x02]));
    assert_eq!(map.get_wide::<f32>(40005, WordOrder::HighFirst), Ok(2.5));
    assert_eq!(map.get_wide::<u32>(40007, WordOrder::HighFirst), Ok(0xAAAA_BBBB));
    // Whole pairs, alone or with plain registers before them: written.
    let ok = fc16(&mut map, 3, &[9, 0x4000, 0x0000, 0x1111, 0x2222]);
    assert_eq!(ok, with_crc(&[ID, 0x10, 0x00, 0x03, 0x00, 0x05]));
    assert_eq!(map.get_wide::<f32>(40005, WordOrder::HighFirst), Ok(2.0));
    assert_eq!(map.get_wide::<u32>(40007, WordOrder::HighFirst), Ok(0x1111_2222));
    // A read of half a pair is answered.
    let read = exchange(&mut map, &[0x03, 0x00, 0x05, 0x00, 0x01]);
    assert_eq!(read, with_crc(&[ID, 0x03, 0x02, 0x00, 0x00]));
}

#[test]
fn a_bank_reads_and_writes_pairs_whole() {
    let mut bank: Bank<2, 8, 0> = Bank::new();
    bank.add_range(40001, 4).unwrap();
    bank.set_wide(40002, 0x0102_0304u32, WordOrder::HighFirst).unwrap();
    assert_eq!((bank.get(40002), bank.get(40003)), (Ok(0x0102), Ok(0x0304)));
    assert_eq!(bank.get_wide::<u32>(40002, WordOrder::HighFirst), Ok(0x0102_0304));
    assert_eq!(bank.set_wide(40004, 1u32, WordOrder::HighFirst), Err(Error::NotFound));
    assert_eq!(bank.get(40004), Ok(0));
    assert_eq!(
        bank.get_wide::<u32>(Reference::holding_register(65535), WordOrder::HighFirst),
        Err(Error::BadReference)
    );
}

/// A bank with room for one range of pairs: holding registers 40001–40002 plain,
/// 40003–40006 two pairs.
fn paired_bank() -> Bank<4, 8, 0, 0, 1> {
    let mut bank = Bank::new();
    bank.add_range(40001, 2).unwrap();
    bank.add_pairs(40003, 2).unwrap();
    bank
}

/// FC 16 of `values` from `start` to a bank, as the slave engine answers it.
fn bank_fc16<const P: usize>(bank: &mut Bank<4, 8, 0, 0, P>, start: u16, values: &[u16]) -> Vec<u8> {
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    exchange(bank, &write_multiple_pdu(0x10, start, values.len() as u16, &data))
}

#[test]
fn a_bank_refuses_a_write_of_half_a_pair_with_02_and_takes_whole_pairs() {
    let mut bank = paired_bank();
    bank.set_wide(40003, 0x1111_2222u32, WordOrder::HighFirst).unwrap();
    bank.set_wide(40005, 0x3333_4444u32, WordOrder::HighFirst).unwrap();
    let illegal_address = with_crc(&[ID, 0x90, 0x02]);
    assert_eq!(bank_fc16(&mut bank, 1, &[9, 9]), illegal_address, "40002 and the first pair's first half");
    assert_eq!(bank_fc16(&mut bank, 3, &[9, 9]), illegal_address, "across the two pairs");
    assert_eq!(exchange(&mut bank, &[0x06, 0x00, 0x05, 0x00, 0x09]), with_crc(&[ID, 0x86, 0x02]));
    assert_eq!(bank.get_wide::<u32>(40003, WordOrder::HighFirst), Ok(0x1111_2222));
    assert_eq!(bank.get_wide::<u32>(40005, WordOrder::HighFirst), Ok(0x3333_4444));
    // Whole pairs, with a plain register before them: written.
    assert_eq!(bank_fc16(&mut bank, 1, &[7, 0xAAAA, 0xBBBB]), with_crc(&[ID, 0x10, 0x00, 0x01, 0x00, 0x03]));
    assert_eq!(bank.get_wide::<u32>(40003, WordOrder::HighFirst), Ok(0xAAAA_BBBB));
    // The plain registers are written one at a time as before.
    let fc6 = [0x06, 0x00, 0x00, 0x00, 0x05];
    assert_eq!(exchange(&mut bank, &fc6), with_crc(&[ID, 0x06, 0x00, 0x00, 0x00, 0x05]));
}

#[test]
fn a_bank_has_room_for_as_many_ranges_of_pairs_as_it_was_given() {
    let mut bank = paired_bank();
    assert_eq!(bank.add_pairs(40011, 1), Err(Error::PairsFull));
    assert!(!bank.contains(40011), "a refused range is not added");
    // Input registers take no slot: no master writes them.
    assert_eq!(bank.add_pairs(30001, 1), Ok(()));
    assert_eq!(bank.add_pairs(1, 1), Err(Error::BadReference));
    // Without room for pairs, a half write is applied as any write is.
    let mut plain: Bank<4, 8, 0> = Bank::new();
    plain.add_range(40001, 2).unwrap();
    assert_eq!(bank_fc16(&mut plain, 1, &[9]), with_crc(&[ID, 0x10, 0x00, 0x01, 0x00, 0x01]));
}
