//! Loading, memory, symbols, GPIO and ADC.

mod common;

use common::*;
use std::io::Write;
use uno_sim::{us_to_cycles, Error, Space, Uno, A0, A1, A5};

#[test]
fn gpio_round_trip() {
    let mut uno = boot(MODE_POLL);
    uno.run_for(us_to_cycles(500)).unwrap();
    let led = uno.pin(13).unwrap();
    assert!(led.output && !led.level);
    let pin8 = uno.pin(8).unwrap();
    assert!(pin8.output && pin8.level);
    let button = uno.pin(2).unwrap();
    assert!(!button.output && button.pull_up && button.level);
    let a1 = uno.pin(A1).unwrap();
    assert!(!a1.output && !a1.pull_up);

    // press: pin 2 to ground, the firmware lights pin 13
    uno.drive_pin(2, Some(false)).unwrap();
    assert!(!uno.pin(2).unwrap().level);
    uno.run_for(us_to_cycles(500)).unwrap();
    assert!(uno.pin(13).unwrap().level);
    // the firmware rewrites PORTB/PORTD meanwhile: the external level must hold
    assert!(!uno.pin(2).unwrap().level);

    // release: the pull-up takes over again
    uno.drive_pin(2, None).unwrap();
    uno.run_for(us_to_cycles(500)).unwrap();
    assert!(uno.pin(2).unwrap().level);
    assert!(!uno.pin(13).unwrap().level);

    uno.drive_pin(A1, Some(true)).unwrap();
    assert!(uno.pin(A1).unwrap().level);
    assert!(matches!(uno.pin(20), Err(Error::BadPin(20))));
    assert!(matches!(uno.drive_pin(200, Some(true)), Err(Error::BadPin(200))));
}

#[test]
fn adc_round_trip() {
    let mut uno = boot(MODE_POLL);
    let millivolts = [2500u32, 0, 5000, 1234, 4999, 7000];
    for (ch, &mv) in millivolts.iter().enumerate() {
        uno.set_analog_mv(ch as u8, mv).unwrap();
    }
    // 6 conversions of 13 ADC clocks at 125 kHz: ~10 ms is plenty
    uno.run_for(us_to_cycles(10_000)).unwrap();
    let expected: Vec<u16> = millivolts.iter().map(|&mv| (mv * 1023 / 5000).min(1023) as u16).collect();
    assert_eq!(read_u16s(&uno, "adc_values"), expected);
    assert_eq!(expected[0], 511);
    assert!(matches!(uno.set_analog_mv(8, 1), Err(Error::BadAdcChannel(8))));
    assert_eq!(A5 - A0, 5);
}

#[test]
fn memory_and_symbols() {
    let mut uno = boot(MODE_SLEEP);
    let log = uno.symbol("rx_log").unwrap().clone();
    assert_eq!((log.space, log.addr, log.size), (Space::Ram, 0x100, 128));
    assert_eq!(uno.symbol("main").unwrap().space, Space::Flash);
    assert!(matches!(uno.read_symbol("main"), Err(Error::NotInRam(_))));
    assert!(matches!(uno.read_symbol("no_such_thing"), Err(Error::UnknownSymbol(_))));
    assert!(matches!(uno.write_symbol("mode", &[1, 2]), Err(Error::SymbolTooSmall { size: 1, len: 2, .. })));

    // stack painting: the top of SRAM below the stack is free
    let sp = uno.sp();
    assert!(sp > 0x300 && sp <= 0x8ff, "sp {sp:#x}");
    uno.write_ram(0x600, &[0xAA; 16]).unwrap();
    assert_eq!(uno.read_ram(0x600, 16).unwrap(), [0xAA; 16]);
    assert_eq!(uno.read_ram(0x8ff, 1).unwrap().len(), 1);
    assert!(matches!(uno.read_ram(0x8ff, 2), Err(Error::OutOfRange { size: 0x900, .. })));
    assert!(uno.write_ram(0xffff, &[0]).is_err());
    assert_eq!(uno.sreg() & 0x80, 0x80, "interrupts enabled");
    assert_eq!(uno.in_isr(), None);
}

fn temp_file(name: &str, contents: &[u8]) -> std::path::PathBuf {
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{name}", std::process::id()));
    std::fs::File::create(&path).unwrap().write_all(contents).unwrap();
    path
}

#[test]
fn load_errors_are_one_line_messages() {
    let missing = Uno::load("/nonexistent/firmware.elf").unwrap_err();
    assert!(matches!(missing, Error::Io { .. }));
    assert!(missing.to_string().contains("/nonexistent/firmware.elf"), "{missing}");

    let text = Uno::load(temp_file("text.elf", b"hello, world\n")).unwrap_err();
    assert!(text.to_string().contains("not an ELF file"), "{text}");
    let empty = Uno::load(temp_file("empty.elf", b"")).unwrap_err();
    assert!(matches!(empty, Error::BadElf { .. }), "{empty}");

    // this test binary: an ELF file, but not for the AVR
    let host = Uno::load(std::env::current_exe().unwrap()).unwrap_err();
    assert!(host.to_string().contains("not AVR"), "{host}");

    // a truncated AVR executable must fail cleanly, not take the process down
    let elf = std::fs::read(echo_elf()).unwrap();
    for len in [60, 200, elf.len() / 2] {
        let err = Uno::load(temp_file(&format!("cut{len}.elf"), &elf[..len])).unwrap_err();
        assert!(matches!(err, Error::Load { .. } | Error::BadElf { .. }), "{err}");
        assert!(!err.to_string().contains('\n'), "{err}");
    }

    for err in [missing, text, host] {
        assert!(!err.to_string().contains('\n'), "{err}");
    }
}

#[test]
fn instances_are_independent_and_send() {
    let handles: Vec<_> = (0..4)
        .map(|k| {
            std::thread::spawn(move || {
                let mut uno = boot(MODE_SLEEP);
                let at = uno.now() + 1000;
                uno.send_byte(k, at).unwrap();
                let echo = uno.run_until_tx_idle(CHAR, at + 5 * CHAR).unwrap();
                echo[0].byte
            })
        })
        .collect();
    let bytes: Vec<u8> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    assert_eq!(bytes, [0, 1, 2, 3]);
}
