//! Every supported function code (Application Protocol v1.1b3 §6.1–6.6, §6.11, §6.12) and
//! exceptions 01–03 (§7) end to end: the release `uno_slave` and `minimal` firmware in
//! simavr, requests sent on the wire at 19200 8E1, replies compared byte for byte with
//! frames whose CRC the test computes itself; and the Uno demo's I/O (LEDs follow coils,
//! switches are discrete inputs, potentiometers are input registers).

mod sim;

use sim::{crc16, with_crc, Line, Rtu, ID};
use uno_sim::{A0, A1, A2};

fn uno_slave() -> Rtu {
    Rtu::boot("uno_slave", Line::B19200_8E1)
}

fn minimal() -> Rtu {
    Rtu::boot("minimal", Line::B19200_8E1)
}

/// The main loop of `uno_slave` copies coils to LEDs, switches and ADC readings to the
/// bank; one pass takes well under a millisecond (three ADC conversions).
const MAIN_LOOP_US: u64 = 5_000;

// ---------------------------------------------------------------------------------------
// uno_slave: reads

#[test]
fn uno_slave_fc1_reads_five_coils_all_off_after_reset() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x01, // function: read coils
        0x00, // starting address hi
        0x00, // starting address lo: coil 00001
        0x00, // quantity hi
        0x05, // quantity lo: 5
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x01, // byte count
        0x00, // coils 00005..00001, unused high bits zero
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn uno_slave_fc2_reads_closed_switches_on_pins_6_and_8_as_ones() {
    let mut rtu = uno_slave();
    rtu.uno.drive_pin(6, Some(false)).unwrap();
    rtu.uno.drive_pin(8, Some(false)).unwrap();
    rtu.run_us(MAIN_LOOP_US);
    let request = with_crc(&[
        ID,   // slave address
        0x02, // function: read discrete inputs
        0x00, // starting address hi
        0x00, // starting address lo: input 10001
        0x00, // quantity hi
        0x04, // quantity lo: 4
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x02, // function
        0x01, // byte count
        0x05, // 10004..10001 = 0101: pins 8 and 6 closed, 9 and 7 open
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn uno_slave_fc2_follows_a_switch_that_opens_again() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x02, // function: read discrete inputs
        0x00, // starting address hi
        0x03, // starting address lo: input 10004 (pin 9)
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    let closed = with_crc(&[ID, 0x02, 0x01, 0x01]);
    let open = with_crc(&[ID, 0x02, 0x01, 0x00]);

    rtu.uno.drive_pin(9, Some(false)).unwrap();
    rtu.run_us(MAIN_LOOP_US);
    assert_eq!(rtu.ask(&request), closed);

    rtu.uno.drive_pin(9, None).unwrap(); // released: the pull-up reads high
    rtu.run_us(MAIN_LOOP_US);
    assert_eq!(rtu.ask(&request), open);
}

#[test]
fn uno_slave_fc3_reads_the_ten_holding_registers_with_their_defaults() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo: 40001
        0x00, // quantity hi
        0x0A, // quantity lo: 10
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x14, // byte count: 20
        0x01, 0xF4, // 40001: blink half-period 500 ms
        0x02, 0x00, // 40002: A0 threshold 512
        0x00, 0x00, // 40003
        0x00, 0x00, // 40004
        0x00, 0x00, // 40005
        0x00, 0x00, // 40006
        0x00, 0x00, // 40007
        0x00, 0x00, // 40008
        0x00, 0x00, // 40009
        0x00, 0x00, // 40010
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

/// What `uno-sim` documents the ADC reads for `mv` with the 5 V reference.
fn adc_counts(mv: u32) -> u16 {
    (mv * 1023 / 5000) as u16
}

#[test]
fn uno_slave_fc4_reads_the_three_potentiometers_in_adc_counts() {
    let mut rtu = uno_slave();
    let millivolts = [1000, 2500, 4000];
    for (channel, mv) in [A0, A1, A2].into_iter().zip(millivolts) {
        rtu.uno.set_analog_mv(channel - A0, mv).unwrap();
    }
    rtu.run_us(MAIN_LOOP_US);
    let request = with_crc(&[
        ID,   // slave address
        0x04, // function: read input registers
        0x00, // starting address hi
        0x00, // starting address lo: 30001
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    let reply = rtu.ask(&request);
    assert_eq!(reply.len(), 11, "address, function, byte count, 3 registers, CRC: {reply:02X?}");
    assert_eq!(reply[..3], [ID, 0x04, 0x06], "{reply:02X?}");
    assert_eq!(crc16(&reply), 0, "reply CRC: {reply:02X?}");
    for (i, mv) in millivolts.into_iter().enumerate() {
        let value = u16::from_be_bytes([reply[3 + 2 * i], reply[4 + 2 * i]]);
        let expected = adc_counts(mv);
        assert!(value.abs_diff(expected) <= 1, "3000{}: {value}, expected {expected} ± 1 for {mv} mV", i + 1);
    }
}

// ---------------------------------------------------------------------------------------
// uno_slave: writes and what the main loop makes of them

/// Makes pin 13 steady (no blinking) so that it shows coil 00001 alone.
fn steady_pin_13(rtu: &mut Rtu) {
    let request = with_crc(&[ID, 0x06, 0x00, 0x00, 0x00, 0x00]); // 40001 = 0
    assert_eq!(rtu.ask(&request), request);
}

#[test]
fn uno_slave_fc5_coil_1_on_lights_pin_13_and_off_darkens_it() {
    let mut rtu = uno_slave();
    steady_pin_13(&mut rtu);
    let on = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0x00, // output address hi
        0x00, // output address lo: coil 00001
        0xFF, // value hi: ON
        0x00, // value lo
    ]);
    let off = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0x00, // output address hi
        0x00, // output address lo: coil 00001
        0x00, // value hi: OFF
        0x00, // value lo
    ]);
    assert!(!rtu.uno.pin(13).unwrap().level, "pin 13 lit before any write");

    assert_eq!(rtu.ask(&on), on, "the reply echoes the request");
    rtu.run_us(MAIN_LOOP_US);
    let pin = rtu.uno.pin(13).unwrap();
    assert!(pin.output && pin.level, "pin 13 after coil 00001 ON: {pin:?}");

    assert_eq!(rtu.ask(&off), off, "the reply echoes the request");
    rtu.run_us(MAIN_LOOP_US);
    assert!(!rtu.uno.pin(13).unwrap().level, "pin 13 after coil 00001 OFF");
}

#[test]
fn uno_slave_fc15_sets_the_leds_on_pins_2_to_5_bit_by_bit() {
    let mut rtu = uno_slave();
    let write = |pattern: u8| {
        with_crc(&[
            ID,      // slave address
            0x0F,    // function: write multiple coils
            0x00,    // starting address hi
            0x01,    // starting address lo: coil 00002 (pin 2)
            0x00,    // quantity hi
            0x04,    // quantity lo: 4
            0x01,    // byte count
            pattern, // coils 00005..00002
        ])
    };
    let reply = with_crc(&[
        ID,   // slave address
        0x0F, // function
        0x00, // starting address hi
        0x01, // starting address lo
        0x00, // quantity hi
        0x04, // quantity lo
    ]);
    let leds = |rtu: &Rtu| [2, 3, 4, 5].map(|pin| rtu.uno.pin(pin).unwrap().level);

    assert_eq!(rtu.ask(&write(0b1010)), reply);
    rtu.run_us(MAIN_LOOP_US);
    assert_eq!(leds(&rtu), [false, true, false, true], "pins 2, 3, 4, 5 after 0b1010");

    assert_eq!(rtu.ask(&write(0b0101)), reply);
    rtu.run_us(MAIN_LOOP_US);
    assert_eq!(leds(&rtu), [true, false, true, false], "pins 2, 3, 4, 5 after 0b0101");
}

#[test]
fn uno_slave_fc15_written_coils_read_back_with_fc1() {
    let mut rtu = uno_slave();
    let write = with_crc(&[
        ID,   // slave address
        0x0F, // function: write multiple coils
        0x00, // starting address hi
        0x00, // starting address lo: coil 00001
        0x00, // quantity hi
        0x05, // quantity lo: 5
        0x01, // byte count
        0x16, // coils 00005..00001 = 10110
    ]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x0F, 0x00, 0x00, 0x00, 0x05]));
    let read = with_crc(&[ID, 0x01, 0x00, 0x00, 0x00, 0x05]);
    let reply = with_crc(&[
        ID,   // slave address
        0x01, // function
        0x01, // byte count
        0x16, // coils 00005..00001
    ]);
    assert_eq!(rtu.ask(&read), reply);
}

#[test]
fn uno_slave_fc6_writes_a_setpoint_that_fc3_reads_back() {
    let mut rtu = uno_slave();
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x02, // register address lo: 40003
        0x12, // value hi
        0x34, // value lo
    ]);
    assert_eq!(rtu.ask(&write), write, "the reply echoes the request");
    let read = with_crc(&[ID, 0x03, 0x00, 0x02, 0x00, 0x01]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x02, // byte count
        0x12, 0x34, // 40003
    ]);
    assert_eq!(rtu.ask(&read), reply);
}

#[test]
fn uno_slave_fc16_writes_three_setpoints_that_fc3_reads_back() {
    let mut rtu = uno_slave();
    let write = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x07, // starting address lo: 40008
        0x00, // quantity hi
        0x03, // quantity lo: 3
        0x06, // byte count
        0xAB, 0xCD, // 40008
        0x00, 0x01, // 40009
        0xFF, 0xFF, // 40010
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x10, // function
        0x00, // starting address hi
        0x07, // starting address lo
        0x00, // quantity hi
        0x03, // quantity lo
    ]);
    assert_eq!(rtu.ask(&write), reply);
    let read = with_crc(&[ID, 0x03, 0x00, 0x07, 0x00, 0x03]);
    let values = with_crc(&[ID, 0x03, 0x06, 0xAB, 0xCD, 0x00, 0x01, 0xFF, 0xFF]);
    assert_eq!(rtu.ask(&read), values);
}

// ---------------------------------------------------------------------------------------
// uno_slave: exceptions

#[test]
fn uno_slave_unsupported_fc7_is_exception_01_illegal_function() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x07, // function: read exception status (not supported)
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x87, // function | 0x80
        0x01, // exception: illegal function
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn uno_slave_fc3_past_40010_is_exception_02_illegal_data_address() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x09, // starting address lo: 40010
        0x00, // quantity hi
        0x02, // quantity lo: 2 (40011 does not exist)
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x83, // function | 0x80
        0x02, // exception: illegal data address
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn uno_slave_fc3_quantity_126_is_exception_03_illegal_data_value() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo
        0x00, // quantity hi
        0x7E, // quantity lo: 126, one more than allowed
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x83, // function | 0x80
        0x03, // exception: illegal data value
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn uno_slave_fc5_value_other_than_ff00_or_0000_is_exception_03_and_changes_nothing() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x05, // function: write single coil
        0x00, // output address hi
        0x01, // output address lo: coil 00002
        0x00, // value hi
        0x01, // value lo: 0x0001 is not a coil value
    ]);
    assert_eq!(rtu.ask(&request), with_crc(&[ID, 0x85, 0x03]));
    let read = with_crc(&[ID, 0x01, 0x00, 0x01, 0x00, 0x01]);
    assert_eq!(rtu.ask(&read), with_crc(&[ID, 0x01, 0x01, 0x00]), "coil 00002 still off");
}

#[test]
fn uno_slave_fc16_running_past_40010_is_exception_02_and_writes_nothing() {
    let mut rtu = uno_slave();
    let request = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x09, // starting address lo: 40010
        0x00, // quantity hi
        0x02, // quantity lo: 2 (40011 does not exist)
        0x04, // byte count
        0x11, 0x11, // 40010
        0x22, 0x22, // 40011
    ]);
    assert_eq!(rtu.ask(&request), with_crc(&[ID, 0x90, 0x02]));
    let read = with_crc(&[ID, 0x03, 0x00, 0x09, 0x00, 0x01]);
    assert_eq!(rtu.ask(&read), with_crc(&[ID, 0x03, 0x02, 0x00, 0x00]), "40010 unchanged");
}

// ---------------------------------------------------------------------------------------
// minimal: four holding registers, nothing else

#[test]
fn minimal_fc3_reads_four_zero_registers_after_reset() {
    let mut rtu = minimal();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo: 40001
        0x00, // quantity hi
        0x04, // quantity lo: 4
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x08, // byte count
        0x00, 0x00, // 40001
        0x00, 0x00, // 40002
        0x00, 0x00, // 40003
        0x00, 0x00, // 40004
    ]);
    assert_eq!(rtu.ask(&request), reply);
}

#[test]
fn minimal_fc6_setpoint_is_copied_to_40002_and_counted_in_40003_by_the_main_loop() {
    let mut rtu = minimal();
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x00, // register address lo: 40001
        0x05, // value hi
        0xDC, // value lo: 1500
    ]);
    assert_eq!(rtu.ask(&write), write, "the reply echoes the request");
    rtu.run_us(1_000);
    let read = with_crc(&[ID, 0x03, 0x00, 0x00, 0x00, 0x04]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x08, // byte count
        0x05, 0xDC, // 40001: the setpoint
        0x05, 0xDC, // 40002: its copy
        0x00, 0x01, // 40003: one master write seen
        0x00, 0x00, // 40004
    ]);
    assert_eq!(rtu.ask(&read), reply);
}

#[test]
fn minimal_fc16_writes_all_four_registers() {
    let mut rtu = minimal();
    let write = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x02, // starting address lo: 40003
        0x00, // quantity hi
        0x02, // quantity lo: 2
        0x04, // byte count
        0x00, 0x0A, // 40003
        0x01, 0x02, // 40004
    ]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x02, 0x00, 0x02]));
    let read = with_crc(&[ID, 0x03, 0x00, 0x03, 0x00, 0x01]);
    assert_eq!(rtu.ask(&read), with_crc(&[ID, 0x03, 0x02, 0x01, 0x02]), "40004");
}

/// FC 01, 02, 04, 05 and 15 are supported, but `minimal` has no coils, discrete inputs or
/// input registers: each is answered with exception 02.
fn minimal_answers_02(request: &[u8]) {
    let mut rtu = minimal();
    let request = with_crc(request);
    let reply = with_crc(&[ID, request[1] | 0x80, 0x02]);
    assert_eq!(rtu.ask(&request), reply, "request {request:02X?}");
}

#[test]
fn minimal_fc1_without_coils_is_exception_02() {
    minimal_answers_02(&[ID, 0x01, 0x00, 0x00, 0x00, 0x01]);
}

#[test]
fn minimal_fc2_without_discrete_inputs_is_exception_02() {
    minimal_answers_02(&[ID, 0x02, 0x00, 0x00, 0x00, 0x01]);
}

#[test]
fn minimal_fc4_without_input_registers_is_exception_02() {
    minimal_answers_02(&[ID, 0x04, 0x00, 0x00, 0x00, 0x01]);
}

#[test]
fn minimal_fc5_without_coils_is_exception_02() {
    minimal_answers_02(&[ID, 0x05, 0x00, 0x00, 0xFF, 0x00]);
}

#[test]
fn minimal_fc15_without_coils_is_exception_02() {
    minimal_answers_02(&[ID, 0x0F, 0x00, 0x00, 0x00, 0x01, 0x01, 0x01]);
}

#[test]
fn minimal_fc3_quantity_0_is_exception_03() {
    let mut rtu = minimal();
    let request = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo
        0x00, // quantity hi
        0x00, // quantity lo: 0
    ]);
    assert_eq!(rtu.ask(&request), with_crc(&[ID, 0x83, 0x03]));
}

#[test]
fn minimal_unsupported_fc43_is_exception_01() {
    let mut rtu = minimal();
    let request = with_crc(&[
        ID,   // slave address
        0x2B, // function: encapsulated interface transport (not supported)
        0x0E, // MEI type: read device identification
        0x01, // read device id code
        0x00, // object id
    ]);
    assert_eq!(rtu.ask(&request), with_crc(&[ID, 0xAB, 0x01]));
}
