// libmodbus 3.1.6's unit-test map (its `tests/unit-test.h`, as `tests/unit-test-server.c`
// serves it), for `libmodbus_map.rs` (over TCP) and `libmodbus_map_rtu.rs` (over RTU, slave
// 17): each example `include!`s it, so that the two serve the same map with the same values.

avr_modbus::register_map! {
    /// libmodbus's unit-test map, at its addresses.
    struct UnitTest {
        305..=341,
        10453..=10474,
        30265,
        40353..=40384,
    }
}

/// UT_INPUT_BITS_TAB: the discrete inputs from 0x1C4 on, LSB first.
const INPUT_BITS: [u8; 3] = [0xAC, 0xDB, 0x35];
/// UT_INPUT_BITS_NB.
const INPUT_BITS_NB: u16 = 0x16;

/// libmodbus's values in `map`: its discrete inputs and its one input register (0x000A);
/// coils and holding registers stay 0, as libmodbus's server's.
fn set_unit_test_values(map: &mut UnitTest) {
    for i in 0..INPUT_BITS_NB {
        let bit = INPUT_BITS[usize::from(i / 8)] >> (i % 8) & 1;
        if let Err(error) = map.set(10453 + u32::from(i), u16::from(bit)) {
            board::halt(error);
        }
    }
    if let Err(error) = map.set(30265, 0x000A) {
        board::halt(error);
    }
}
