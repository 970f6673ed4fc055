//! Replies come from interrupts alone: the release `busy_loop` firmware, whose main loop
//! blocks for 500 ms at a time, answers 200 back-to-back requests at 19200 8E1, each
//! within a small bound past T3.5 (Modbus over Serial Line v1.02 §2.5.1.1).

mod sim;

use sim::{cycles_to_us, read_request, registers_reply, us_to_cycles, with_crc, Line, Rtu, ID};

/// How long past T3.5 a reply may start, whatever the main loop is doing.
const BOUND_US: u64 = 200;

#[test]
fn two_hundred_requests_are_answered_within_t35_plus_200_us_while_the_main_loop_blocks() {
    let mut rtu = Rtu::boot("busy_loop", Line::B19200_8E1);
    let values = [0x1111, 0x2222, 0x3333];
    let write = with_crc(&[
        ID,   // slave address
        0x10, // function: write multiple registers
        0x00, // starting address hi
        0x00, // starting address lo: 40001
        0x00, // quantity hi
        0x03, // quantity lo: 3
        0x06, // byte count
        0x11, 0x11, // 40001
        0x22, 0x22, // 40002
        0x33, 0x33, // 40003
    ]);
    assert_eq!(rtu.ask(&write), with_crc(&[ID, 0x10, 0x00, 0x00, 0x00, 0x03]));

    let t35 = rtu.line.t35();
    let mut worst = 0;
    for i in 0..200u16 {
        let start = i % 3;
        let request = read_request(ID, 0x03, start, 3 - start);
        let exchange = rtu.exchange(&request);
        let expected = registers_reply(ID, 0x03, &values[usize::from(start)..]);
        assert_eq!(exchange.bytes(), expected, "request {i}");
        let turnaround = exchange.turnaround().unwrap();
        assert!(turnaround >= t35, "request {i}: reply {turnaround} cycles after the request, T3.5 is {t35}");
        let past = turnaround - t35;
        assert!(past < us_to_cycles(BOUND_US), "request {i}: reply {:.1} µs past T3.5", cycles_to_us(past));
        worst = worst.max(past);
    }

    let passes = rtu.ask(&read_request(ID, 0x04, 0, 1));
    eprintln!(
        "busy_loop: 200 replies, latest T3.5 + {:.1} µs ({worst} cycles); {:.2} s simulated, {} main-loop passes",
        cycles_to_us(worst),
        rtu.uno.now() as f64 / 16e6,
        u16::from_be_bytes([passes[3], passes[4]])
    );
}

#[test]
fn the_main_loop_really_blocks_for_half_a_second() {
    let mut rtu = Rtu::boot("busy_loop", Line::B19200_8E1);
    let read_passes = read_request(ID, 0x04, 0, 1); // 30001: passes through the main loop
    assert_eq!(rtu.ask(&read_passes), registers_reply(ID, 0x04, &[1]), "first pass, then blocked");
    rtu.uno.run_until(us_to_cycles(1_200_000)).unwrap();
    assert_eq!(rtu.ask(&read_passes), registers_reply(ID, 0x04, &[3]), "passes at 0, 0.5 and 1 s");
}
