//! `examples/ascii.rs` (feature `ascii`, 9600 bps 7E1) on the simulated Uno: every function
//! code answered in ASCII byte for byte, the reply starting at the request's LF, and every
//! class of bad frame dropped in silence and counted (the example publishes its counters as
//! input registers 30003–30009), the next frame answered.

mod ascii_frames;
mod sim;

use ascii_frames::ascii;
use sim::{cycles_to_us, us_to_cycles, Line, Rtu, ID};
use uno_sim::{LineError, Parity};

/// Time for the main loop to copy inputs and counters into the registers.
const MAIN_LOOP_US: u64 = 2_000;

fn boot() -> Rtu {
    Rtu::boot("ascii", Line::B9600_7E1)
}

/// Sends `chars` and returns the reply's characters (empty: none).
fn ask(rtu: &mut Rtu, chars: &[u8]) -> Vec<u8> {
    rtu.ask(chars)
}

/// The example's counters, 30003–30009: frames, LRC errors, parity/framing errors,
/// overruns, malformed, exceptions, replies (read with FC 4, which itself counts a frame
/// and a reply once it is over).
fn counters(rtu: &mut Rtu) -> [u16; 7] {
    rtu.run_us(MAIN_LOOP_US);
    let reply = ask(rtu, &ascii(&[ID, 0x04, 0x00, 0x02, 0x00, 0x07]));
    let text = std::str::from_utf8(&reply).expect("ASCII reply");
    let hex = text.trim_start_matches(':').trim_end();
    let bytes: Vec<u8> = (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap()).collect();
    assert_eq!(&bytes[..3], &[ID, 0x04, 14], "{text:?}");
    let mut out = [0; 7];
    for (k, value) in out.iter_mut().enumerate() {
        *value = u16::from_be_bytes([bytes[3 + 2 * k], bytes[4 + 2 * k]]);
    }
    out
}

/// What `counters` reads for the counter at `index` after one more frame (`delta` 1) of
/// the kind it counts, knowing that each reading is itself a good frame and a reply.
fn counted(before: [u16; 7], after: [u16; 7], index: usize) {
    for (k, (b, a)) in before.iter().zip(after).enumerate() {
        // The reading before this one: one frame and one reply more (counted before it
        // was answered: the frame, not yet its reply).
        let reading = match k {
            0 => 1,
            6 => 1,
            _ => 0,
        };
        let expected = b + reading + u16::from(k == index || k == 0);
        assert_eq!(a, expected, "counter {k} (0 frames, 1 LRC errors, 2 UART, 3 overruns, 4 malformed, 5 exceptions, 6 replies): {before:?} -> {after:?}");
    }
}

#[test]
fn the_firmware_runs_9600_7e1() {
    let rtu = boot();
    let cfg = rtu.uno.serial_config().expect("USART0 configured");
    assert!(cfg.matches(9600, 7, Parity::Even, 1), "{cfg:?}");
}

#[test]
fn every_function_code_is_answered_in_ascii() {
    let mut rtu = boot();
    rtu.uno.drive_pin(6, Some(false)).unwrap();
    rtu.uno.set_analog_mv(0, 2500).unwrap();
    rtu.run_us(MAIN_LOOP_US);
    // FC 6, FC 16 and FC 3: write 40001, then 40002-40003, read 40001-40003.
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x06, 0x00, 0x00, 0x12, 0x34])), ascii(&[ID, 0x06, 0x00, 0x00, 0x12, 0x34]));
    let fc16 = [ID, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0xAB, 0xCD, 0x00, 0x07];
    assert_eq!(ask(&mut rtu, &ascii(&fc16)), ascii(&[ID, 0x10, 0x00, 0x01, 0x00, 0x02]));
    assert_eq!(
        ask(&mut rtu, &ascii(&[ID, 0x03, 0x00, 0x00, 0x00, 0x03])),
        ascii(&[ID, 0x03, 0x06, 0x12, 0x34, 0xAB, 0xCD, 0x00, 0x07])
    );
    // FC 5 and FC 15 switch the LEDs on pins 2-5 (coils 00001-00004); FC 1 reads them back.
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x05, 0x00, 0x00, 0xFF, 0x00])), ascii(&[ID, 0x05, 0x00, 0x00, 0xFF, 0x00]));
    let fc15 = [ID, 0x0F, 0x00, 0x01, 0x00, 0x03, 0x01, 0b101];
    assert_eq!(ask(&mut rtu, &ascii(&fc15)), ascii(&[ID, 0x0F, 0x00, 0x01, 0x00, 0x03]));
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x01, 0x00, 0x00, 0x00, 0x04])), ascii(&[ID, 0x01, 0x01, 0b1011]));
    rtu.run_us(MAIN_LOOP_US);
    let leds = [2, 3, 4, 5].map(|pin| rtu.uno.pin(pin).unwrap().level);
    assert_eq!(leds, [true, true, false, true]);
    // FC 2: the switch on pin 6 is closed; FC 4: A0 at 2.5 V reads 511.
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x02, 0x00, 0x00, 0x00, 0x04])), ascii(&[ID, 0x02, 0x01, 0b0001]));
    let a0 = u16::try_from(2500 * 1023 / 5000).unwrap();
    assert_eq!(
        ask(&mut rtu, &ascii(&[ID, 0x04, 0x00, 0x00, 0x00, 0x01])),
        ascii(&[ID, 0x04, 0x02, (a0 >> 8) as u8, a0 as u8])
    );
    // Exceptions 01, 02 (40009 does not exist) and 03 (quantity 0), as in RTU.
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x41])), ascii(&[ID, 0xC1, 0x01]));
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x03, 0x00, 0x08, 0x00, 0x01])), ascii(&[ID, 0x83, 0x02]));
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x03, 0x00, 0x00, 0x00, 0x00])), ascii(&[ID, 0x83, 0x03]));
}

#[test]
fn lower_case_requests_are_answered_in_upper_case() {
    let mut rtu = boot();
    let request = String::from_utf8(ascii(&[ID, 0x06, 0x00, 0x05, 0xBE, 0xEF])).unwrap().to_ascii_lowercase();
    assert_eq!(ask(&mut rtu, request.as_bytes()), ascii(&[ID, 0x06, 0x00, 0x05, 0xBE, 0xEF]));
}

/// ASCII waits for no silence: the reply comes within the character that follows the LF
/// (RTU would wait 3.5 characters first), but never before the LF has left the line: the
/// USART flags it half a bit before its stop bit ends, and the reply's `:` waits for that end.
#[test]
fn the_reply_starts_at_the_requests_lf() {
    let mut rtu = boot();
    let lead = rtu.uno.rx_flag_lead().expect("USART0 enabled");
    let request = ascii(&[ID, 0x03, 0x00, 0x00, 0x00, 0x08]);
    let (mut least, mut most) = (u64::MAX, 0);
    for i in 0..20 {
        // Each request a few cycles later against Timer0's ticks.
        let first_end = rtu.first_end_after_silence(us_to_cycles(8) + i * 37);
        let end = rtu.send_at(&request, first_end, 0);
        let exchange = rtu.receive(end);
        assert_eq!(exchange.bytes().first(), Some(&b':'), "request {i}");
        // Panics if the reply started before the LF's last stop bit ended.
        let turnaround = exchange.turnaround().expect("a reply");
        assert!(turnaround < rtu.char_cycles, "request {i}: reply {turnaround} cycles after the LF");
        least = least.min(turnaround);
        most = most.max(turnaround);
    }
    eprintln!(
        "ascii 9600 7E1: the reply's `:` starts {:.1}..{:.1} us after the LF's stop bit ends, RXC0 {:.1} us \
         before it ({} characters of request, 20 requests)",
        cycles_to_us(least),
        cycles_to_us(most),
        cycles_to_us(lead),
        request.len()
    );
}

#[test]
fn a_broadcast_is_executed_and_another_slaves_frame_ignored_in_silence() {
    let mut rtu = boot();
    assert_eq!(ask(&mut rtu, &ascii(&[0x00, 0x06, 0x00, 0x07, 0x55, 0xAA])), b"");
    assert_eq!(ask(&mut rtu, &ascii(&[0x02, 0x06, 0x00, 0x07, 0x11, 0x11])), b"");
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x03, 0x00, 0x07, 0x00, 0x01])), ascii(&[ID, 0x03, 0x02, 0x55, 0xAA]));
}

/// Sends `bad` (which must get no reply), then checks the counter at `index` moved by one
/// and that the next request is answered.
fn dropped(bad: &[u8], index: usize) {
    let mut rtu = boot();
    let before = counters(&mut rtu);
    assert_eq!(ask(&mut rtu, bad), b"", "{:?}", String::from_utf8_lossy(bad));
    let after = counters(&mut rtu);
    counted(before, after, index);
    assert_eq!(ask(&mut rtu, &ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x01])), ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x01]));
}

#[test]
fn a_bad_lrc_is_dropped_and_counted_as_an_lrc_error() {
    let mut bad = ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x09]);
    let n = bad.len();
    bad[n - 3] = if bad[n - 3] == b'0' { b'1' } else { b'0' };
    dropped(&bad, 1);
}

#[test]
fn a_character_that_is_not_hex_is_dropped_as_malformed() {
    dropped(b":0106000X0009F0\r\n", 4);
}

#[test]
fn an_odd_number_of_hex_digits_is_dropped_as_malformed() {
    let mut bad = ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x09]);
    bad.remove(5);
    dropped(&bad, 4);
}

#[test]
fn a_frame_over_513_characters_is_dropped_as_an_overrun() {
    // Address, FC 16 header, 250 bytes of data: 257 bytes with the LRC, 517 characters.
    let mut frame = vec![ID, 0x10, 0x00, 0x00, 0x00, 0x7D, 0xFA];
    frame.extend(std::iter::repeat(0x11).take(250));
    let bad = ascii(&frame);
    assert!(bad.len() > 513);
    dropped(&bad, 3);
}

#[test]
fn a_parity_error_drops_its_frame() {
    let mut rtu = boot();
    let before = counters(&mut rtu);
    let request = ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x09]);
    let first_end = rtu.first_end_after_silence(0);
    let mut end = first_end;
    for (i, &c) in request.iter().enumerate() {
        if i == 5 {
            rtu.uno.send_byte_with_error(c, end, LineError::Parity).unwrap();
        } else {
            rtu.uno.send_byte(c, end).unwrap();
        }
        end += rtu.char_cycles;
    }
    rtu.quiet_since = end;
    assert!(rtu.receive(end - rtu.char_cycles).bytes().is_empty());
    let after = counters(&mut rtu);
    counted(before, after, 2);
}

#[test]
fn a_silence_of_a_second_inside_a_frame_drops_it_as_malformed() {
    let mut rtu = boot();
    let before = counters(&mut rtu);
    let request = ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x09]);
    let end = rtu.send(&request[..7]);
    rtu.uno.run_until(end + us_to_cycles(1_100_000)).unwrap();
    // The rest alone is no frame (no `:`): ignored.
    rtu.quiet_since = rtu.uno.now();
    assert_eq!(ask(&mut rtu, &request[7..]), b"");
    let after = counters(&mut rtu);
    counted(before, after, 4);
}

#[test]
fn a_silence_under_a_second_inside_a_frame_is_fine() {
    let mut rtu = boot();
    let request = ascii(&[ID, 0x06, 0x00, 0x00, 0x00, 0x09]);
    let end = rtu.send(&request[..7]);
    rtu.uno.run_until(end + us_to_cycles(900_000)).unwrap();
    let first_end = rtu.uno.now() + rtu.char_cycles;
    let end = rtu.send_at(&request[7..], first_end, 0);
    assert_eq!(rtu.receive(end).bytes(), request);
}

#[test]
fn a_colon_restarts_the_frame() {
    let mut rtu = boot();
    let before = counters(&mut rtu);
    let mut chars = b":0106000".to_vec();
    chars.extend(ascii(&[ID, 0x06, 0x00, 0x02, 0x00, 0x2A]));
    assert_eq!(ask(&mut rtu, &chars), ascii(&[ID, 0x06, 0x00, 0x02, 0x00, 0x2A]));
    let after = counters(&mut rtu);
    // The dropped start counts as a malformed frame, the restarted one as a frame and a
    // reply: two frames and a reply more than the readings alone.
    assert_eq!(after[0], before[0] + 1 + 2, "frames {before:?} -> {after:?}");
    assert_eq!(after[4], before[4] + 1, "malformed {before:?} -> {after:?}");
    assert_eq!(after[6], before[6] + 1 + 1, "replies {before:?} -> {after:?}");
}
