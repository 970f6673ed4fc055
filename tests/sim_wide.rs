//! 32-bit values on the simulated Uno (`examples/meter.rs`): a u32 counter of two equal
//! words the loop steps as fast as it runs, read thousands of times by a master with FC 4 — the
//! two words always equal, never a torn pair (and torn pairs seen when the firmware updates
//! the words one by one, its pin-12 mode, so the check can fail); floats and word orders
//! written and read through the map; a master's write of half a pair refused with 02.

mod sim;

use sim::{read_request, with_crc, Line, Rtu, ID};

const LINE: Line = Line::B19200_8E1;

/// The two registers of a FC 3/4 reply of two registers.
fn pair(reply: &[u8]) -> (u16, u16) {
    assert_eq!(reply.len(), 9, "reply {reply:02X?}");
    (u16::from_be_bytes([reply[3], reply[4]]), u16::from_be_bytes([reply[5], reply[6]]))
}

/// Reads the counter `reads` times, each at another moment of the loop, and returns how many
/// reads were torn (high word ≠ low word).
fn hammer(rtu: &mut Rtu, reads: usize) -> usize {
    let request = read_request(ID, 0x04, 0, 2);
    let mut torn = 0;
    let mut last = None;
    for i in 0..reads {
        // A silence that moves the request against the loop: 0–97 µs more each time.
        rtu.run_us(50 + (i as u64 * 7) % 97);
        let (high, low) = pair(&rtu.ask(&request));
        if high != low {
            torn += 1;
        }
        assert_ne!(last, Some(high), "the counter did not move between two reads");
        last = Some(high);
    }
    torn
}

#[test]
fn a_counter_updated_with_set_wide_is_never_read_torn() {
    let mut rtu = Rtu::boot("meter", LINE);
    let torn = hammer(&mut rtu, 2000);
    println!("set_wide: {torn} torn reads of 2000");
    assert_eq!(torn, 0);
}

#[test]
fn a_counter_updated_word_by_word_is_read_torn() {
    let mut rtu = Rtu::boot_with("meter", LINE, |uno| uno.drive_pin(12, Some(false)).unwrap());
    let torn = hammer(&mut rtu, 2000);
    println!("two set calls: {torn} torn reads of 2000");
    assert!(torn > 0, "no torn read: the hammer would not see one either");
}

#[test]
fn floats_and_word_orders_as_the_map_declares_them() {
    let mut rtu = Rtu::boot("meter", LINE);
    // 40001–40002: 1.5 = 0x3FC0_0000, high word first; 30003–30004 = 3.0 = 0x4040_0000.
    assert_eq!(pair(&rtu.ask(&read_request(ID, 0x03, 0, 2))), (0x3FC0, 0x0000));
    // Write −2.25 (0xC010_0000) to 40001–40002; 30003–30004 becomes −4.5 (0xC090_0000).
    let write = with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0xC0, 0x10, 0x00, 0x00]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x02]));
    rtu.run_us(2_000);
    assert_eq!(pair(&rtu.ask(&read_request(ID, 0x04, 2, 2))), (0xC090, 0x0000));
    // 40003–40004 low word first: 0x0001_FFFF written as FFFF 0001; 30005–30006 = 0x0002_0000
    // low word first: 0000 0002.
    let write = with_crc(&[ID, 0x10, 0x00, 0x02, 0x00, 0x02, 0x04, 0xFF, 0xFF, 0x00, 0x01]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x02, 0x00, 0x02]));
    rtu.run_us(2_000);
    assert_eq!(pair(&rtu.ask(&read_request(ID, 0x04, 4, 2))), (0x0000, 0x0002));
}

#[test]
fn a_write_of_half_a_pair_is_exception_02_and_changes_nothing() {
    let mut rtu = Rtu::boot("meter", LINE);
    // FC 6 to 40002, the float's second half; FC 16 of 40002–40003, across two pairs.
    let fc6 = with_crc(&[ID, 0x06, 0x00, 0x01, 0x12, 0x34]);
    assert_eq!(rtu.ask(&fc6), with_crc(&[ID, 0x86, 0x02]));
    let fc16 = with_crc(&[ID, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x12, 0x34, 0x56, 0x78]);
    assert_eq!(rtu.ask(&fc16), with_crc(&[ID, 0x90, 0x02]));
    assert_eq!(pair(&rtu.ask(&read_request(ID, 0x03, 0, 2))), (0x3FC0, 0x0000));
}
