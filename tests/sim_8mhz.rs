//! The slave built for an 8 MHz board (`AVR_CPU_FREQUENCY_HZ=8000000`: the SparkFun Pro Mini
//! and Pro Micro 3.3 V): `examples/boards.rs` for an 8 MHz ATmega328P and ATmega32U4 (`make chips`),
//! slave 1 at 19200 8E1 on the board's pins 0/1, run in simavr; and the master
//! (`examples/master_boards.rs`, feature `master` too) for the same two chips.
//!
//! The simulated chip runs at 16 MHz. A chip does everything in cycles of its own clock, so
//! the 8 MHz firmware on it behaves as on an 8 MHz board with time running twice as fast:
//! every check here is in cycles, worked out at 8 MHz. The master sends at the firmware's
//! own bit time (416 cycles: 19 231 bps at 8 MHz); the silences are 19200 8E1's T1.5 and
//! T3.5 (Serial Line v1.02 §2.5.1.1) at 8 MHz; a second is 8 000 000 cycles. The 16 MHz build
//! fails each check: its bit is 832 cycles, its T3.5 32 084 cycles, its second twice as long.

mod sim;

use sim::{
    chip_variant_firmware, read_request, registers_reply, with_crc, write_register_request, Exchange, Line, Rtu, ID,
};
use uno_sim::{Chip, Options, Uno};

/// Cycles of the board's clock per microsecond.
const CYCLES_PER_US: u64 = 8;

/// 19200 8E1: bits per character.
const CHAR_BITS: u64 = 11;

/// `n` halves of a nominal 19200 bps character at 8 MHz, in cycles, rounded up.
fn half_chars(n: u64) -> u64 {
    (n * CHAR_BITS * 8_000_000).div_ceil(2 * 19_200)
}

/// T1.5 and T3.5 of 19200 8E1 at 8 MHz, in cycles: 6875 and 16 042.
fn t15() -> u64 {
    half_chars(3)
}

fn t35() -> u64 {
    half_chars(7)
}

/// The 8 MHz boards: the Pro Mini's chip (USART0) and the Pro Micro's (USART1).
const BOARDS: [(Chip, u8); 2] = [(Chip::Atmega328p, 0), (Chip::Atmega32u4, 1)];

fn boot(chip: Chip, usart: u8) -> Rtu {
    let elf = chip_variant_firmware(chip, usart, "-8mhz", "boards");
    // The master's own waits (T3.5 before each request, the time it gives a reply) are those
    // of 19200 8E1 at 16 MHz: twice the 8 MHz board's, so never too short.
    let rtu = Rtu::boot_elf_on(&elf, usart, Line::B19200_8E1, |_| {});
    assert_eq!(rtu.uno.chip(), chip, "{} names another chip", elf.display());
    rtu
}

/// Sends `request` with `gap` idle cycles before its last character and collects what comes
/// back.
fn send_with_last_gap(rtu: &mut Rtu, request: &[u8], gap: u64) -> Exchange {
    let end = rtu.send_with_gap(request, request.len() - 1, gap);
    rtu.receive(end)
}

#[test]
fn the_line_is_19200_8e1_at_8_mhz() {
    for (chip, usart) in BOARDS {
        let rtu = boot(chip, usart);
        // UBRRn 25, normal speed: 16 · 26 = 416 cycles a bit, 19 231 bps at 8 MHz (+0.16 %).
        assert_eq!(rtu.char_cycles, CHAR_BITS * 416, "{chip}: the firmware's character");
        assert_eq!(rtu.tick, 64, "{chip}: Timer0 at clk/64");
    }
}

#[test]
fn replies_start_t35_after_the_request_and_within_50_us_of_it() {
    for (chip, usart) in BOARDS {
        let mut rtu = boot(chip, usart);
        let fc6 = write_register_request(ID, 0, 0xBEEF);
        assert_eq!(rtu.ask(&fc6), fc6, "{chip}: FC 6 echoes");
        let request = read_request(ID, 0x03, 0, 2);
        let reply = registers_reply(ID, 0x03, &[0xBEEF, 0]);
        let mut turnarounds = Vec::new();
        for offset in 0..32 {
            // Each request ends at another phase of Timer0's 64-cycle tick.
            let first_end = rtu.first_end_after_silence(offset * 7 + offset * offset * 131);
            let end = rtu.send_at(&request, first_end, 0);
            let exchange = rtu.receive(end);
            assert_eq!(exchange.bytes(), reply, "{chip}: FC 3");
            turnarounds.push(exchange.turnaround().expect("a reply"));
        }
        let (earliest, latest) = (turnarounds.iter().min().unwrap(), turnarounds.iter().max().unwrap());
        assert!(*earliest >= t35(), "{chip}: a reply started {earliest} cycles after the request, T3.5 is {}", t35());
        // Within 400 cycles of T3.5, as at 16 MHz (25 µs there: Timer0's ticks are 64 cycles
        // and the interrupts take the same cycles at any clock): 50 µs at 8 MHz.
        assert!(
            *latest <= t35() + 50 * CYCLES_PER_US,
            "{chip}: a reply started {latest} cycles after the request, T3.5 is {}",
            t35()
        );
        eprintln!("{chip} at 8 MHz: reply − T3.5 from {} to {} cycles", earliest - t35(), latest - t35());
    }
}

#[test]
fn a_gap_over_t15_drops_the_frame_and_one_under_it_does_not() {
    for (chip, usart) in BOARDS {
        let mut rtu = boot(chip, usart);
        let request = read_request(ID, 0x03, 1, 1);
        let answer = registers_reply(ID, 0x03, &[0]);
        // Before the last character: T1.5 less 300 cycles (two ticks and more of the detector's
        // slack), then T1.5 and half a character, still short of T3.5.
        let under = send_with_last_gap(&mut rtu, &request, t15() - 300);
        assert_eq!(under.bytes(), answer, "{chip}: a gap under T1.5");
        assert!(t15() + half_chars(1) < t35());
        let exchange = send_with_last_gap(&mut rtu, &request, t15() + half_chars(1));
        assert!(exchange.reply.is_empty(), "{chip}: a gap over T1.5: the slave answered {:02X?}", exchange.bytes());
        assert_eq!(rtu.ask(&request), answer, "{chip}: the next request");
        assert_eq!(rtu.ask(&with_crc(&[ID, 0x07])), with_crc(&[ID, 0x87, 0x01]), "{chip}: exception 01");
    }
}

#[test]
fn the_clock_counts_8_000_000_cycles_a_second() {
    for (chip, usart) in BOARDS {
        let mut rtu = boot(chip, usart);
        // 2.1 s of the board's time, then 30001 (`millis() / 1000`) says 2; at 16 MHz it would
        // say 1.
        rtu.uno.run_for(21 * 800_000).expect("firmware runs");
        let read_at = rtu.uno.now();
        let reply = rtu.ask(&read_request(ID, 0x04, 0, 1));
        let seconds = read_at / 8_000_000;
        assert_eq!(seconds, 2, "{chip}: ran {read_at} cycles");
        assert_eq!(reply, registers_reply(ID, 0x04, &[seconds as u16]), "{chip}: 30001 after {read_at} cycles");
    }
}

/// The master built for an 8 MHz board (`master_boards`, feature `master`, at 8 MHz,
/// `make chips`) against a scripted slave 1: its FC 3 request at the firmware's bit time
/// (416 cycles, as the slave's), its response timeout of 1000 ms as 8 000 000 cycles
/// (then its one retry), and a reply taken: the next request after T3.5 of silence at 8 MHz,
/// long before a timeout. The 16 MHz build sends 832-cycle bits and waits twice as long.
#[test]
fn the_master_sends_at_19200_8e1_and_times_out_after_1000_ms_at_8_mhz() {
    for (chip, usart) in BOARDS {
        let elf = chip_variant_firmware(chip, usart, "-8mhz-master", "master_boards");
        let mut uno = Uno::load_with(&elf, Options::new().usart(usart)).expect("master_boards loads");
        assert_eq!(uno.chip(), chip, "{} names another chip", elf.display());
        let char_cycles = CHAR_BITS * 416;
        let request = read_request(ID, 0x03, 0, 10);

        // The first request: 40001-40010 of slave 1, 11 bits of 416 cycles a character, each
        // written by the transmit-complete interrupt once the one before has left: the gap
        // between two is that interrupt's latency, and when a character ends while Timer0's
        // compare handler runs (the master's deadlines and millisecond tick: 291 cycles seen)
        // that handler's rest too. Under MAX_GAP cycles (50 µs), where T1.5 is 6 864 cycles
        // (858 µs): a character sent from the loop, or one the handler forgot, is far later.
        const MAX_GAP: u64 = 400;
        let first = uno.run_until_tx_idle(2 * char_cycles, 8_000_000).expect("firmware runs");
        assert_eq!(first.iter().map(|t| t.byte).collect::<Vec<u8>>(), request, "{chip}: the request");
        assert_eq!(uno.wire_char_cycles(), Some(char_cycles), "{chip}: UBRRn 25 at 8 MHz");
        for (i, t) in first.iter().enumerate() {
            assert_eq!(t.end_cycle - t.start_cycle, char_cycles, "{chip}: character {i}'s length");
            if i > 0 {
                let gap = t.start_cycle - first[i - 1].end_cycle;
                assert!(gap <= MAX_GAP, "{chip}: a gap of {gap} cycles before character {i}");
            }
        }

        // No answer: the same request again 1000 ms (8 000 000 cycles) after the first one ended.
        let first_end = first.last().unwrap().end_cycle;
        let retry = uno.run_until_tx_idle(2 * char_cycles, first_end + 10_000_000).expect("firmware runs");
        assert_eq!(retry.iter().map(|t| t.byte).collect::<Vec<u8>>(), request, "{chip}: the retry");
        let waited = retry[0].start_cycle - first_end;
        assert!(
            (8_000_000 - 8 * 1000..=8_000_000 + 8 * 2000 + t35()).contains(&waited),
            "{chip}: the retry came {waited} cycles after the request, the timeout is 8 000 000 (1000 ms)"
        );

        // Answered: the next request T3.5 (at 8 MHz) after the reply, not a timeout later.
        let values: Vec<u16> = (0..10).map(|i| 0x1000 + i).collect();
        let reply_end = uno
            .send_frame(&registers_reply(ID, 0x03, &values), retry.last().unwrap().end_cycle + t35(), 0)
            .expect("the reply is scheduled");
        let next = uno.run_until_tx_idle(2 * char_cycles, reply_end + 8_000_000).expect("firmware runs");
        assert_eq!(next.iter().map(|t| t.byte).collect::<Vec<u8>>(), request, "{chip}: the next request");
        let silence = next[0].start_cycle - reply_end;
        assert!(
            (t35()..t35() + 8 * 2000).contains(&silence),
            "{chip}: the next request came {silence} cycles after the reply, T3.5 is {}",
            t35()
        );
        eprintln!("{chip} at 8 MHz: retry after {waited} cycles, next request {silence} cycles after a reply");
    }
}
