//! USART0 timing: received bytes reach the firmware exactly when the chip's receiver flags
//! them, at the middle of the first stop bit (or, asked by name, at the character's end),
//! transmitted bytes are timestamped with the real character time.

mod common;

use common::*;
use uno_sim::{reg, vector, Error, LineError, Options, Parity, RxFlag, SerialConfig, TxByte, Uno};

const RXC0: u8 = 0x80;
const TXC0: u8 = 0x40;
const DOR0: u8 = 0x08;
const FE0: u8 = 0x10;
const UPE0: u8 = 0x04;
/// Upper bound on the echo firmware's latency from RXC0 to the echo's start bit
/// (interrupt responses, register saves, the RX and UDRE handlers).
const LATENCY: u64 = 300;

fn ucsr0a(uno: &Uno) -> u8 {
    uno.read_ram(reg::UCSR0A, 1).unwrap()[0]
}

/// Steps until the RX handler is entered; returns the cycle after the entering step.
fn step_to_rx_isr(uno: &mut Uno, give_up: u64) -> u64 {
    loop {
        let step = uno.step().unwrap();
        if step.entered == Some(vector::USART_RX) {
            assert_eq!(uno.pc(), RX_VECTOR_ADDR);
            return uno.now();
        }
        assert!(uno.now() < give_up, "RX interrupt never taken");
    }
}

#[test]
fn serial_config_is_decoded_from_registers() {
    let uno = boot(MODE_SLEEP);
    let cfg = uno.serial_config().expect("USART0 enabled");
    assert_eq!((cfg.ubrr, cfg.double_speed, cfg.bit_cycles), (51, false, 832));
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, Parity::Even, 1));
    assert!(cfg.rx_enabled && cfg.tx_enabled);
    assert_eq!(cfg.char_bits(), 11);
    assert_eq!(uno.wire_char_cycles(), Some(CHAR));
    assert!((cfg.baud() - 19230.77).abs() < 0.01);
    assert!(cfg.matches(19200, 8, Parity::Even, 1));
    assert!(!cfg.matches(19200, 8, Parity::None, 2));
    assert!(!cfg.matches(9600, 8, Parity::Even, 1));
    // simavr's usleep() on UCSR0A polling is off
    assert_eq!(uno.uart_sim_flags() & 1, 0);
}

#[test]
fn usart_off_until_the_firmware_enables_it() {
    let mut uno = Uno::load(echo_elf()).unwrap();
    assert_eq!(uno.serial_config(), None);
    assert!(matches!(uno.send_frame(&[1, 2], 100_000, 0), Err(Error::UartNotConfigured)));
    // a byte that arrives before RXEN0 is set is lost
    uno.send_byte(0x42, 10).unwrap();
    uno.run_until(1000).unwrap();
    assert_eq!(uno.uart_counters().rx_dropped, 1);
}

#[test]
fn rx_is_seen_exactly_at_the_middle_of_the_stop_bit_when_sleeping() {
    let mut uno = boot(MODE_SLEEP);
    assert_eq!(uno.rx_flag(), RxFlag::FirstStopBit);
    assert_eq!(uno.rx_flag_lead(), Some(HALF_BIT));
    for k in 0..8u64 {
        let end = uno.now() + 20_000 + 97 * k;
        let at = end - HALF_BIT;
        uno.send_byte(0x30 + k as u8, end).unwrap();
        uno.run_until(at - 1).unwrap();
        assert_eq!(rx_log(&uno).len() as u64, k, "byte delivered early");
        assert_eq!(ucsr0a(&uno) & RXC0, 0, "RXC0 set early");
        assert_eq!(uno.isr_stats(vector::USART_RX).entries, k);
        // wake-up at the middle of the stop bit plus the 8-cycle interrupt response from sleep
        assert_eq!(step_to_rx_isr(&mut uno, at + 1000), at + 8);
        let echo = uno.run_until_tx_idle(CHAR, end + 10 * CHAR).unwrap();
        assert_eq!(echo.len(), 1);
        assert_eq!(echo[0].byte, 0x30 + k as u8);
        assert!(echo[0].start_cycle > at && echo[0].start_cycle < at + LATENCY, "echo at {echo:?}, byte at {at}");
    }
}

#[test]
fn with_two_stop_bits_rx_is_flagged_a_bit_and_a_half_before_the_end() {
    let mut uno = boot(MODE_SLEEP);
    // 8E2: UPM01, USBS0, UCSZ01:0 (written raw: the simulator times from the registers).
    uno.write_ram(reg::UCSR0C, &[0x20 | 0x08 | 0x06]).unwrap();
    assert_eq!(uno.serial_config().unwrap().stop_bits, 2);
    assert_eq!(uno.rx_flag_lead(), Some(3 * HALF_BIT));
    let end = uno.now() + 20_000;
    let at = end - 3 * HALF_BIT;
    uno.send_byte(0x5A, end).unwrap();
    uno.run_until(at - 1).unwrap();
    assert_eq!(ucsr0a(&uno) & RXC0, 0, "RXC0 set early");
    assert_eq!(step_to_rx_isr(&mut uno, at + 1000), at + 8);
    uno.run_for(LATENCY).unwrap();
    assert_eq!(rx_log(&uno), [(0x5A, 0)]);
}

#[test]
fn rx_flag_lead_is_half_a_bit_or_one_and_a_half_from_ubrr_and_u2x() {
    // (UCSR0A, UCSR0C, UBRR0L, UBRR0H) -> cycles before the character's end
    let cases = [
        (0x00, 0x06, 51, 0, 416),         // 19200 8N1: 832-cycle bits
        (0x00, 0x0E, 103, 0, 2496),       // 9600 8N2: 1.5 × 1664
        (0x02, 0x06, 16, 0, 68),          // 115200 with U2X0: 136-cycle bits
        (0x02, 0x2E, 34, 0, 420),         // 57600 8E2 with U2X0: 1.5 × 280
        (0x00, 0x0E, 0x40, 0x03, 19_992), // 1200 8N2: UBRR0 832, 1.5 × 13 328
    ];
    for (a, c, l, h, lead) in cases {
        let cfg = SerialConfig::from_registers(a, 0x18, c, l, h);
        assert_eq!(cfg.rx_flag_lead_cycles(), lead, "{cfg:?}");
    }
}

/// The old behaviour, by name: RXC0 at the end of the whole character, as simavr's own USART.
#[test]
fn rx_flag_at_char_end_is_seen_exactly_when_the_stop_bit_ends() {
    let mut uno = ready(Uno::load_with(echo_elf(), Options::new().rx_flag(RxFlag::CharEnd)).unwrap(), MODE_SLEEP);
    assert_eq!(uno.rx_flag_lead(), Some(0));
    let at = uno.now() + 20_000;
    uno.send_byte(0x42, at).unwrap();
    uno.run_until(at - 1).unwrap();
    assert_eq!(ucsr0a(&uno) & RXC0, 0, "RXC0 set early");
    assert_eq!(step_to_rx_isr(&mut uno, at + 1000), at + 8);
    // a reset keeps the choice
    uno.reset().unwrap();
    assert_eq!(uno.rx_flag(), RxFlag::CharEnd);
}

#[test]
fn rx_is_seen_within_an_instruction_when_running() {
    let mut uno = boot(MODE_POLL);
    let mut seen = Vec::new();
    for k in 0..40u64 {
        let at = uno.now() + 30_000 + 13 * k;
        uno.send_byte(k as u8, at + HALF_BIT).unwrap();
        uno.run_until(at - 20).unwrap();
        // RXC0 shows at the end of the instruction running at `at` (+0..3), then 4 cycles response
        let entered = loop {
            let step = uno.step().unwrap();
            if step.entered == Some(vector::USART_RX) {
                break uno.now();
            }
            if uno.now() < at {
                assert_eq!(ucsr0a(&uno) & RXC0, 0, "RXC0 set at {} for a byte at {at}", uno.now());
            }
            assert!(uno.now() < at + 1000, "RX interrupt never taken");
        };
        assert!((at + 4..=at + 7).contains(&entered), "entered at {entered}, byte at {at}");
        seen.push(entered - at - 4);
        uno.run_until_tx_idle(CHAR, at + 10 * CHAR).unwrap();
    }
    assert_eq!(rx_log(&uno).len(), 40);
    assert!(seen.contains(&0), "latencies {seen:?}");
}

#[test]
fn back_to_back_frame_is_echoed_with_char_time_spacing() {
    let mut uno = boot(MODE_SLEEP);
    let request = [0x01, 0x03, 0x00, 0x10, 0x00, 0x02, 0xC5, 0xCE];
    let first_end = uno.now() + CHAR;
    let last_end = uno.send_frame(&request, first_end, 0).unwrap();
    assert_eq!(last_end, first_end + 7 * CHAR);
    assert_eq!(uno.pending_rx(), 8);
    let echo = uno.run_until_tx_idle(2 * CHAR, last_end + 20 * CHAR).unwrap();
    assert_eq!(uno.pending_rx(), 0);
    assert_eq!(echo.iter().map(|t| t.byte).collect::<Vec<_>>(), request);
    for (i, t) in echo.iter().enumerate() {
        let rx_flag = first_end + i as u64 * CHAR - HALF_BIT;
        assert_eq!(t.end_cycle - t.start_cycle, CHAR);
        assert!(t.start_cycle > rx_flag && t.start_cycle < rx_flag + LATENCY, "byte {i}: {t:?}, RXC0 at {rx_flag}");
        if i > 0 {
            assert!(t.start_cycle >= echo[i - 1].end_cycle, "frames overlap: {echo:?}");
        }
    }
    assert!(uno.now() >= echo[7].end_cycle + 2 * CHAR);
    assert_eq!(rx_log(&uno).iter().map(|r| r.0).collect::<Vec<_>>(), request);
}

#[test]
fn gap_between_bytes_shows_in_the_echo() {
    let mut uno = boot(MODE_SLEEP);
    let gap = 3 * CHAR / 2 + 17;
    let first_end = uno.now() + CHAR;
    uno.send_frame(&[0xAA, 0x55, 0x0F], first_end, gap).unwrap();
    let echo = uno.run_until_tx_idle(5 * CHAR, first_end + 30 * CHAR).unwrap();
    assert_eq!(echo.len(), 3);
    // sleeping firmware: identical path for every byte, so the echo keeps the spacing exactly
    assert_eq!(echo[1].start_cycle - echo[0].start_cycle, CHAR + gap);
    assert_eq!(echo[2].start_cycle - echo[1].start_cycle, CHAR + gap);
}

#[test]
fn transmit_buffer_queues_one_byte_behind_the_shift_register() {
    let mut uno = boot(MODE_DOUBLE);
    let first_end = uno.now() + CHAR;
    uno.send_frame(&[1, 2, 3, 4], first_end, 0).unwrap();
    uno.run_until(first_end - 1).unwrap();
    assert_eq!(ucsr0a(&uno) & TXC0, 0);
    // 8 bytes to send at the rate of 4 received: one continuous burst
    let mut tx: Vec<TxByte> = Vec::new();
    while tx.len() < 8 {
        assert!(uno.now() < first_end + 20 * CHAR, "only {tx:?}");
        uno.run_for(CHAR / 4).unwrap();
        tx.extend(uno.take_tx());
    }
    assert_eq!(tx.iter().map(|t| t.byte).collect::<Vec<_>>(), [1, 1, 2, 2, 3, 3, 4, 4]);
    let rx_flag = first_end - HALF_BIT;
    assert!(tx[0].start_cycle > rx_flag && tx[0].start_cycle < rx_flag + LATENCY);
    for pair in tx.windows(2) {
        assert_eq!(pair[1].start_cycle, pair[0].end_cycle, "{tx:?}");
        assert_eq!(pair[1].end_cycle - pair[1].start_cycle, CHAR);
    }
    let last_end = tx[7].end_cycle;
    assert_eq!(uno.tx_busy_until(), Some(last_end));
    uno.run_until(last_end - 1).unwrap();
    assert_eq!(ucsr0a(&uno) & TXC0, 0, "TXC0 before the last stop bit ended");
    uno.run_until(last_end + 1).unwrap();
    uno.step().unwrap();
    assert_ne!(ucsr0a(&uno) & TXC0, 0, "TXC0 not set after the last stop bit");
    assert_eq!(uno.tx_busy_until(), None);
    assert_eq!(uno.uart_counters().tx_ignored, 0);
}

#[test]
fn frame_format_written_after_the_baud_rate_is_used() {
    // simavr 1.6 reads the format only on UBRR0L writes, and always counts a parity bit
    let mut uno = boot(MODE_8N1_LATE);
    let cfg = uno.serial_config().unwrap();
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, Parity::None, 1));
    let char_8n1 = 832 * 10;
    assert_eq!(uno.wire_char_cycles(), Some(char_8n1));
    let first_end = uno.now() + char_8n1;
    let last_end = uno.send_frame(&[7, 8, 9], first_end, 0).unwrap();
    assert_eq!(last_end, first_end + 2 * char_8n1);
    let tx = uno.run_until_tx_idle(char_8n1, last_end + 20 * char_8n1).unwrap();
    assert_eq!(tx.iter().map(|t| t.byte).collect::<Vec<_>>(), [7, 7, 8, 8, 9, 9]);
    for pair in tx.windows(2) {
        assert_eq!(pair[1].start_cycle, pair[0].end_cycle);
        assert_eq!(pair[1].end_cycle - pair[1].start_cycle, char_8n1);
    }
}

#[test]
fn framing_and_parity_errors_reach_the_firmware() {
    let mut uno = boot(MODE_SLEEP);
    let t = uno.now() + CHAR;
    uno.send_byte_with_error(0x11, t, LineError::Framing).unwrap();
    uno.send_byte_with_error(0x22, t + CHAR, LineError::Parity).unwrap();
    uno.send_byte(0x33, t + 2 * CHAR).unwrap();
    uno.run_until(t + 4 * CHAR).unwrap();
    assert_eq!(rx_log(&uno), [(0x11, FE0), (0x22, UPE0), (0x33, 0)]);
}

#[test]
fn receive_buffer_holds_three_bytes_then_overruns() {
    let mut uno = boot(MODE_DRAIN);
    let first_end = uno.now() + CHAR;
    let last_end = uno.send_frame(&[10, 11, 12, 13, 14], first_end, 0).unwrap();
    uno.run_until(last_end + 10).unwrap();
    assert_eq!(ucsr0a(&uno) & (RXC0 | DOR0), RXC0 | DOR0);
    assert_eq!(uno.uart_counters().rx_overruns, 2);
    // DOR0 is read-only: clearing TXC0 (a UCSR0A write) must not clear it
    uno.write_symbol("clear_txc", &[1]).unwrap();
    uno.run_for(2000).unwrap();
    assert_eq!(uno.read_symbol("clear_txc").unwrap(), [0]);
    assert_eq!(ucsr0a(&uno) & (RXC0 | DOR0), RXC0 | DOR0);
    uno.write_symbol("drain", &[1]).unwrap();
    uno.run_for(2000).unwrap();
    // 12 and 13 were overwritten in the shift register; DOR0 shows with the byte before the loss
    assert_eq!(rx_log(&uno), [(10, DOR0), (11, 0), (14, 0)]);
    assert_eq!(ucsr0a(&uno) & (RXC0 | DOR0), 0);
}

#[test]
fn scheduling_errors() {
    let mut uno = boot(MODE_SLEEP);
    let now = uno.now();
    assert!(matches!(uno.send_byte(1, now - 1), Err(Error::RxInPast { .. })));
    // a character ending within half a bit from now would have been flagged already
    assert!(matches!(uno.send_byte(1, now + HALF_BIT - 1), Err(Error::RxInPast { at, .. }) if at == now - 1));
    uno.send_byte(1, now + 5000).unwrap();
    assert!(matches!(uno.send_byte(2, now + 4000), Err(Error::RxOutOfOrder { at }) if at == now + 4000 - HALF_BIT));
    assert!(matches!(uno.send_frame(&[3, 4], now + 1000, 0), Err(Error::RxOutOfOrder { .. })));
    assert_eq!(uno.pending_rx(), 1);
    uno.cancel_rx();
    assert_eq!(uno.pending_rx(), 0);
    uno.run_for(10_000).unwrap();
    assert!(rx_log(&uno).is_empty());
}

#[test]
fn tx_idle_wait_times_out_quietly() {
    let mut uno = boot(MODE_SLEEP);
    let deadline = uno.now() + 50_000;
    let tx = uno.run_until_tx_idle(CHAR, deadline).unwrap();
    assert!(tx.is_empty());
    assert!(uno.now() >= deadline && uno.now() < deadline + 16);
}

#[test]
fn isr_cycles_are_accounted_per_vector() {
    let mut uno = boot(MODE_SLEEP);
    uno.reset_isr_stats();
    let at = uno.now() + 5000;
    uno.send_byte(0x77, at).unwrap();
    let mut by_vector = [0u64; 32];
    let mut main_cycles = 0;
    let mut tx = Vec::new();
    while uno.now() < at + 2 * CHAR {
        let step = uno.step().unwrap();
        if tx.is_empty() {
            tx = uno.take_tx();
            if let Some(first) = tx.first() {
                // the idle transmitter starts when the ST/STS to UDR0 completes
                assert_eq!(step.vector, Some(vector::USART_UDRE));
                assert_eq!((first.byte, first.start_cycle), (0x77, uno.now()));
            }
        }
        match step.vector {
            Some(v) => by_vector[v as usize] += step.cycles,
            None => main_cycles += step.cycles,
        }
        if let Some(v) = step.entered {
            by_vector[v as usize] += step.response_cycles;
        }
    }
    let rx = uno.isr_stats(vector::USART_RX);
    let udre = uno.isr_stats(vector::USART_UDRE);
    assert_eq!(rx.entries, 1);
    assert_eq!(udre.entries, 2); // one write, one to switch UDRIE0 off
    assert_eq!(rx.cycles, by_vector[vector::USART_RX as usize]);
    assert_eq!(udre.cycles, by_vector[vector::USART_UDRE as usize]);
    assert_eq!(rx.max_cycles, rx.cycles);
    assert!(rx.cycles > 30 && rx.cycles < 300, "{rx:?}");
    assert!(main_cycles > 0);
    assert_eq!(uno.isr_stats(vector::USART_TX).entries, 0);
    assert_eq!(tx.len(), 1);
}

#[test]
fn stopped_cpu_is_an_error() {
    let mut uno = Uno::load(echo_elf()).unwrap();
    uno.write_symbol("mode", &[MODE_STOP]).unwrap();
    let err = uno.run_for(100_000).unwrap_err();
    assert!(matches!(err, Error::Stopped { .. }), "{err}");
    assert!(uno.run_for(10).is_err());
}
