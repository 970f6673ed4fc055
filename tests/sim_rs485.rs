//! The RS-485 driver-enable pin and the communication LED on the real firmware, Modbus
//! over Serial Line v1.02 §3.3.1 (two-wire bus: the driver is on only while the slave
//! transmits) and §3.1.2 (the communication LED). `lab_lights` drives DE/RE on pin 10 and
//! the LED on pin 13.

mod sim;

use sim::{read_request, with_crc, Line, Rtu, ID};

const DRIVER_ENABLE: u8 = 10;
const LED: u8 = 13;

fn lab_lights() -> Rtu {
    Rtu::boot("lab_lights", Line::B19200_8E1)
}

#[test]
fn driver_enable_rises_before_the_first_reply_bit_and_falls_after_the_last() {
    let mut rtu = lab_lights();
    let window = 40 * rtu.char_cycles;
    let watched = rtu.exchange_watching(&read_request(ID, 0x02, 0, 2), &[DRIVER_ENABLE], window);
    let (edges, reply) = (watched.pin(DRIVER_ENABLE), &watched.exchange.reply);
    assert_eq!(watched.exchange.bytes(), with_crc(&[ID, 0x02, 0x01, 0x00]));
    let (first, last) = (reply.first().unwrap().start_cycle, reply.last().unwrap().end_cycle);
    let (rose, fell) = (edges.rose.expect("DE rose"), edges.fell.expect("DE fell"));
    assert!(rose <= first, "DE rose at {rose}, after the first start bit at {first}");
    // The driver comes on only once the request has left the line and T3.5 has passed.
    let t35_end = watched.exchange.request_end + rtu.line.t35();
    assert!(rose >= t35_end, "DE rose at {rose}, before T3.5 after the request's end at {t35_end}");
    assert!(fell >= last, "DE fell at {fell}, before the last stop bit ended at {last}");
    // Released promptly: within a tenth of a character after transmit complete.
    assert!(fell - last < rtu.char_cycles / 10, "DE held {} cycles past the reply", fell - last);
}

#[test]
fn driver_enable_stays_low_for_frames_not_answered() {
    let mut rtu = lab_lights();
    let window = 40 * rtu.char_cycles;
    for request in [read_request(0x22, 0x02, 0, 2), read_request(0, 0x02, 0, 2)] {
        let watched = rtu.exchange_watching(&request, &[DRIVER_ENABLE], window);
        assert!(
            watched.exchange.reply.is_empty() && watched.pin(DRIVER_ENABLE).rose.is_none(),
            "request {request:02X?}"
        );
    }
}

#[test]
fn the_communication_led_flashes_for_each_frame_addressed_to_the_slave() {
    let mut rtu = lab_lights();
    let window = 40 * rtu.char_cycles;
    let watched = rtu.exchange_watching(&read_request(ID, 0x02, 0, 2), &[LED], window);
    assert!(!watched.exchange.reply.is_empty());
    let edges = watched.pin(LED);
    assert!(edges.rose.is_some() && edges.fell.is_some(), "LED flashed");
    let watched = rtu.exchange_watching(&read_request(0x22, 0x02, 0, 2), &[LED], window);
    assert!(watched.pin(LED).rose.is_none(), "LED stays dark for another slave's frame");
}
