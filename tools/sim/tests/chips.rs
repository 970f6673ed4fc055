//! Every chip and every USART: the chip comes from the ELF file, the wire goes on the USART
//! asked for with the same exact character timing as the Uno's USART0, interrupt responses
//! take as long as the chip's data sheet says, and the other USARTs still transmit.

mod common;

use common::*;
use uno_sim::{us_to_cycles, Chip, Error, Options, Uno};

/// Upper bound on the echo firmware's latency from RXCn to the echo's start bit.
const LATENCY: u64 = 300;

#[test]
fn the_chip_comes_from_the_elf_file() {
    for chip in Chip::ALL {
        let usart = chip.default_usart();
        let uno = Uno::load(echo_elf_for(chip, usart, None)).unwrap();
        assert_eq!((uno.chip(), uno.usart()), (chip, usart));
        assert_eq!(uno.vectors(), chip.vectors(usart).unwrap());
        assert_eq!(uno.usart_regs(), chip.usart_regs(usart).unwrap());
    }
    assert_eq!(Uno::load(echo_elf()).unwrap().vectors().usart_rx, uno_sim::vector::USART_RX);
}

#[test]
fn a_file_without_the_device_note_is_a_328p_unless_told() {
    let elf = echo_elf_for(Chip::Atmega1280, 0, None);
    let stripped = scratch("stripped.elf");
    let status = std::process::Command::new("avr-objcopy")
        .args(["--remove-section", ".note.gnu.avr.deviceinfo"])
        .arg(&elf)
        .arg(&stripped)
        .status()
        .expect("avr-objcopy (binutils-avr)");
    assert!(status.success());
    assert_eq!(Uno::load(&stripped).unwrap().chip(), Chip::Atmega328p);
    let told = Uno::load_with(&stripped, Options::new().chip(Chip::Atmega1280)).unwrap();
    assert_eq!(told.chip(), Chip::Atmega1280);
    // and it runs there: the echo answers
    let mut uno = ready(told, MODE_SLEEP);
    let at = uno.now() + CHAR;
    uno.send_byte(0x5A, at).unwrap();
    let echo = uno.run_until_tx_idle(CHAR, at + 5 * CHAR).unwrap();
    assert_eq!(echo.iter().map(|t| t.byte).collect::<Vec<_>>(), [0x5A]);
}

#[test]
fn unsupported_chips_and_missing_usarts_are_errors() {
    let source = scratch("spin.c");
    std::fs::write(&source, "int main(void) { for (;;) ; }\n").unwrap();
    let elf = scratch("spin-644p.elf");
    compile(&source, "atmega644p", &[], &elf);
    let err = Uno::load(&elf).unwrap_err();
    assert!(matches!(&err, Error::UnsupportedChip { name, .. } if name == "atmega644p"), "{err}");
    assert!(err.to_string().contains("atmega644p") && err.to_string().contains("atmega2560"), "{err}");
    // told which chip to be, it loads
    assert_eq!(Uno::load_with(&elf, Options::new().chip(Chip::Atmega328p)).unwrap().chip(), Chip::Atmega328p);

    let err = Uno::load_with(echo_elf(), Options::new().usart(1)).unwrap_err();
    assert!(matches!(err, Error::NoSuchUsart { chip: Chip::Atmega328p, usart: 1 }), "{err}");
    assert_eq!(err.to_string(), "the atmega328p has no USART1 (it has USART0)");
    let leonardo = echo_elf_for(Chip::Atmega32u4, 1, None);
    let err = Uno::load_with(&leonardo, Options::new().usart(0)).unwrap_err();
    assert!(matches!(err, Error::NoSuchUsart { chip: Chip::Atmega32u4, usart: 0 }), "{err}");
    let mega = echo_elf_for(Chip::Atmega2560, 0, None);
    assert!(matches!(Uno::load_with(&mega, Options::new().usart(4)), Err(Error::NoSuchUsart { usart: 4, .. })));
}

/// The echo firmware on `chip`, wire on USART`usart`: RXCn exactly at the stop bit's middle, the
/// chip's wake-up response, a back-to-back frame echoed at the exact character time, and
/// nothing on the chip's other USARTs.
fn echo_is_exact(chip: Chip, usart: u8) {
    let what = format!("{chip} USART{usart}");
    let mut uno = boot_on(chip, usart, MODE_SLEEP);
    assert_eq!(uno.wire_char_cycles(), Some(CHAR), "{what}");
    let rx_vector = uno.vectors().usart_rx;
    let wake = 2 * chip.interrupt_response_cycles();

    let end = uno.now() + 20_000;
    let at = end - HALF_BIT;
    uno.send_byte(0x42, end).unwrap();
    uno.run_until(at - 1).unwrap();
    assert!(rx_log(&uno).is_empty(), "{what}: byte delivered early");
    let entered = loop {
        let step = uno.step().unwrap();
        if step.entered == Some(rx_vector) {
            assert_eq!(step.response_cycles, wake, "{what}");
            assert_eq!(uno.pc(), u32::from(rx_vector) * 4, "{what}");
            break uno.now();
        }
        assert!(uno.now() < at + 1000, "{what}: RX interrupt never taken");
    };
    assert_eq!(entered, at + wake, "{what}");
    let echo = uno.run_until_tx_idle(CHAR, at + 10 * CHAR).unwrap();
    assert_eq!(echo.len(), 1, "{what}");
    assert!(echo[0].start_cycle > at && echo[0].start_cycle < at + LATENCY, "{what}: {echo:?}, byte at {at}");

    let request = [0x01, 0x03, 0x00, 0x10, 0x00, 0x02, 0xC5, 0xCE];
    let first_end = uno.now() + CHAR;
    let last_end = uno.send_frame(&request, first_end, 0).unwrap();
    let echo = uno.run_until_tx_idle(2 * CHAR, last_end + 20 * CHAR).unwrap();
    assert_eq!(echo.iter().map(|t| t.byte).collect::<Vec<_>>(), request, "{what}");
    for (i, t) in echo.iter().enumerate() {
        let rx_flag = first_end + i as u64 * CHAR - HALF_BIT;
        assert_eq!(t.end_cycle - t.start_cycle, CHAR, "{what}");
        assert!(t.start_cycle > rx_flag && t.start_cycle < rx_flag + LATENCY, "{what}: byte {i}: {t:?}");
    }
    // sleeping firmware, identical path for every byte: the echo keeps the wire's spacing
    for pair in echo.windows(2) {
        assert_eq!(pair[1].start_cycle - pair[0].start_cycle, CHAR, "{what}: {echo:?}");
    }
    for other in chip.usarts().into_iter().filter(|&n| n != usart) {
        assert_eq!(uno.take_usart_output(other).unwrap(), b"", "{what}: USART{other} sent something");
    }
}

#[test]
fn echo_on_the_atmega168() {
    echo_is_exact(Chip::Atmega168, 0);
}

#[test]
fn echo_on_the_atmega32u4_usart1() {
    echo_is_exact(Chip::Atmega32u4, 1);
}

#[test]
fn echo_on_every_usart_of_the_atmega1280() {
    for usart in 0..4 {
        echo_is_exact(Chip::Atmega1280, usart);
    }
}

#[test]
fn echo_on_every_usart_of_the_atmega2560() {
    for usart in 0..4 {
        echo_is_exact(Chip::Atmega2560, usart);
    }
}

/// One received byte on `chip`'s USART`usart`, stepped through: the RX and UDRE handlers'
/// statistics against the steps, the interrupt responses (asleep and awake), the return address
/// pushed and RETI's cycles. Returns the RX handler's `IsrStats::cycles`.
fn isr_accounting(chip: Chip, usart: u8) -> u64 {
    let what = format!("{chip} USART{usart}");
    let mut uno = boot_on(chip, usart, MODE_SLEEP);
    let v = uno.vectors();
    let response = chip.interrupt_response_cycles();
    let reti_at = |uno: &Uno, vector: u8| {
        let sym = uno.symbol(&format!("__vector_{vector}")).expect("handler symbol").clone();
        sym.addr + sym.size - 2 // its last instruction
    };
    let (rx_reti, udre_reti) = (reti_at(&uno, v.usart_rx), reti_at(&uno, v.usart_udre));
    uno.reset_isr_stats();
    let at = uno.now() + 5000;
    uno.send_byte(0x77, at).unwrap();
    let mut by_vector = [0u64; 64];
    let mut responses = Vec::new();
    let mut retis = Vec::new();
    while uno.now() < at + 2 * CHAR {
        let sp = uno.sp();
        let step = uno.step().unwrap();
        if step.pc == rx_reti || step.pc == udre_reti {
            retis.push(step.cycles);
        }
        if let Some(vector) = step.vector {
            by_vector[vector as usize] += step.cycles;
        }
        if let Some(vector) = step.entered {
            by_vector[vector as usize] += step.response_cycles;
            responses.push((vector, step.response_cycles, sp - uno.sp()));
        }
    }
    let rx = uno.isr_stats(v.usart_rx);
    let udre = uno.isr_stats(v.usart_udre);
    assert_eq!((rx.entries, udre.entries), (1, 2), "{what}");
    assert_eq!(rx.cycles, by_vector[v.usart_rx as usize], "{what}");
    assert_eq!(udre.cycles, by_vector[v.usart_udre as usize], "{what}");
    assert_eq!(rx.max_cycles, rx.cycles, "{what}");
    let pushed = u16::from(chip.return_address_bytes());
    // RX wakes the CPU; the UDRE entries come while it is awake
    assert_eq!(
        responses,
        [(v.usart_rx, 2 * response, pushed), (v.usart_udre, response, pushed), (v.usart_udre, response, pushed)],
        "{what}"
    );
    assert_eq!(retis, [response; 3], "{what}: RETI cycles");
    rx.cycles
}

#[test]
fn isr_cycles_on_the_atmega2560_count_its_3_byte_return_address() {
    let uno = isr_accounting(Chip::Atmega328p, 0);
    let mega = isr_accounting(Chip::Atmega2560, 1);
    let mega1280 = isr_accounting(Chip::Atmega1280, 1);
    assert_eq!(Chip::Atmega2560.interrupt_response_cycles(), 5);
    // same handler code: the 2560 pays one more cycle on entry, wake-up and RETI, plus what its
    // own code does differently (checked above instruction by instruction)
    assert!(mega >= uno + 3, "328P {uno}, 2560 {mega}");
    assert!(mega1280 < mega, "1280 {mega1280}, 2560 {mega}");
}

#[test]
fn other_usarts_transmit_as_simavr_models_them() {
    let elf = echo_elf_for(Chip::Atmega2560, 1, Some(0));
    let mut uno = ready(Uno::load_with(elf, Options::new().usart(1)).unwrap(), MODE_SLEEP);
    uno.run_for(100_000).unwrap();
    assert_eq!(uno.take_usart_output(0).unwrap(), b"boot\r\n");
    assert_eq!(uno.take_usart_output(0).unwrap(), b"", "taken once");
    assert_eq!(uno.take_usart_output(2).unwrap(), b"");
    assert!(matches!(uno.take_usart_output(1), Err(Error::WireUsart(1))));
    assert!(matches!(uno.take_usart_output(4), Err(Error::NoSuchUsart { usart: 4, .. })));
    // the debug print never reaches the wire, and the wire still echoes
    assert!(uno.take_tx().is_empty());
    let at = uno.now() + CHAR;
    uno.send_byte(0x31, at).unwrap();
    let echo = uno.run_until_tx_idle(CHAR, at + 5 * CHAR).unwrap();
    assert_eq!(echo.iter().map(|t| t.byte).collect::<Vec<_>>(), [0x31]);

    let mut leonardo = boot_on(Chip::Atmega32u4, 1, MODE_SLEEP);
    assert!(matches!(leonardo.take_usart_output(0), Err(Error::NoSuchUsart { usart: 0, .. })));
}

#[test]
fn pins_by_port_on_a_mega() {
    let mut uno = boot_on(Chip::Atmega2560, 0, MODE_POLL);
    uno.run_for(us_to_cycles(500)).unwrap();
    assert!(matches!(uno.pin(13), Err(Error::NoArduinoPins(Chip::Atmega2560))));
    assert!(matches!(uno.drive_pin(2, Some(false)), Err(Error::NoArduinoPins(_))));
    let pb5 = uno.port_pin('B', 5).unwrap();
    assert!(pb5.output && !pb5.level);
    let pd2 = uno.port_pin('D', 2).unwrap();
    assert!(!pd2.output && pd2.pull_up && pd2.level);
    // press PD2: the firmware lights PB5
    uno.drive_port_pin('D', 2, Some(false)).unwrap();
    uno.run_for(us_to_cycles(500)).unwrap();
    assert!(uno.port_pin('B', 5).unwrap().level);
    uno.drive_port_pin('D', 2, None).unwrap();
    uno.run_for(us_to_cycles(500)).unwrap();
    assert!(!uno.port_pin('B', 5).unwrap().level);
    // the Mega's extended ports are there; the LED is PB7
    assert!(uno.port_pin('L', 7).is_ok() && uno.port_pin('B', 7).is_ok());
    assert!(matches!(uno.port_pin('I', 0), Err(Error::NoSuchPortPin { port: 'I', .. })));
    assert!(matches!(uno.port_pin('B', 8), Err(Error::NoSuchPortPin { bit: 8, .. })));
    uno.set_analog_mv(15, 2500).unwrap();
    assert!(matches!(uno.set_analog_mv(16, 1), Err(Error::BadAdcChannel(16))));

    let uno = boot(MODE_POLL);
    assert_eq!(uno.port_pin('B', 5).unwrap(), uno.pin(13).unwrap());
    assert!(matches!(uno.port_pin('H', 0), Err(Error::NoSuchPortPin { chip: Chip::Atmega328p, .. })));
}
