//! The reply delay (feature `reply-delay`, `Config::with_reply_delay`) on the simulated Uno:
//! `examples/slow_master.rs` answers 3 ms after T3.5 of silence, to within the slave's own
//! turnaround (`examples/minimal.rs`, the same map without a delay, is the reference), at
//! every phase of Timer0; a frame for another slave still gets no answer.

mod sim;

use sim::{cycles_to_us, read_request, us_to_cycles, with_crc, Line, Rtu, ID};

const LINE: Line = Line::B19200_8E1;
const DELAY_US: f64 = 3000.0;

/// Reply start − (request end + T3.5) in µs, for `n` reads at different moments.
fn past_t35(name: &str, n: u64) -> Vec<f64> {
    let mut rtu = Rtu::boot(name, LINE);
    let t35 = LINE.t35();
    (0..n)
        .map(|i| {
            // Move the request against Timer0: 0–1020 µs of extra silence in 4.3 µs steps.
            rtu.run_us(100 + (i * 43 / 10) % 1021);
            let exchange = rtu.exchange(&read_request(ID, 0x03, 0, 2));
            assert_eq!(exchange.bytes().len(), 9, "no reply to read {i}");
            let turnaround = exchange.turnaround().expect("a reply");
            cycles_to_us(turnaround) - cycles_to_us(t35)
        })
        .collect()
}

fn summary(values: &mut [f64]) -> (f64, f64, f64) {
    values.sort_by(f64::total_cmp);
    (values[0], values[values.len() / 2], values[values.len() - 1])
}

#[test]
fn the_reply_waits_its_delay_after_t35_at_every_phase_of_timer0() {
    let (min, p50, max) = summary(&mut past_t35("minimal", 240));
    println!("no delay: reply start - T3.5: min {min:.1} µs, p50 {p50:.1}, max {max:.1}");
    let (dmin, dp50, dmax) = summary(&mut past_t35("slow_master", 240));
    println!("3 ms delay: reply start - T3.5: min {dmin:.1} µs, p50 {dp50:.1}, max {dmax:.1}");
    println!(
        "  less the delay: min {:.1} µs, p50 {:.1}, max {:.1} (Timer0's tick: 4 µs)",
        dmin - DELAY_US,
        dp50 - DELAY_US,
        dmax - DELAY_US
    );
    // Never before T3.5 + the delay; after it, no later than the slave answers without one
    // plus a tick.
    assert!(dmin >= DELAY_US, "a reply came {:.1} µs before T3.5 + the delay", DELAY_US - dmin);
    assert!(dmax <= DELAY_US + max + 4.0, "a reply came {:.1} µs after T3.5 + the delay", dmax - DELAY_US);
    // Counted from T3.5's compare value, the delay itself adds no jitter beyond a tick.
    assert!(dmax - dmin <= 4.0, "replies spread over {:.1} µs", dmax - dmin);
}

#[test]
fn a_frame_for_another_slave_is_still_not_answered() {
    let mut rtu = Rtu::boot("slow_master", LINE);
    let exchange = rtu.exchange(&read_request(ID + 1, 0x03, 0, 2));
    assert!(exchange.reply.is_empty(), "answered {:02X?}", exchange.bytes());
    // And the next one for this slave is, after its delay.
    rtu.run_us(5_000);
    let request = with_crc(&[ID, 0x06, 0x00, 0x01, 0x00, 0x2A]);
    let exchange = rtu.exchange(&request);
    assert_eq!(exchange.bytes(), request);
    assert!(exchange.turnaround().unwrap() >= LINE.t35() + us_to_cycles(3_000));
}
