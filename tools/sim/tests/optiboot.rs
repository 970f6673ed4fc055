//! A board with a bootloader: the chip starts the boot section at every reset (BOOTRST),
//! resets keep the clock and the flash, MCUSR says why, and the watchdog resets as the chip
//! does; an erased chip under optiboot stays quiet until programmed. With the Uno's optiboot,
//! built by `make bootloaders` (target/bootloaders/): without it these tests are skipped, or
//! fail under `make` and in CI (`uno_sim::built`).

mod common;

use std::path::PathBuf;

use common::*;
use uno_sim::built::{built, workspace};
use uno_sim::{us_to_cycles, Options, ResetCause, Uno};

fn optiboot() -> PathBuf {
    built(workspace().join("target/bootloaders/optiboot_atmega328.hex"), "make bootloaders")
}

#[test]
fn optiboot_leaves_a_power_on_to_the_program_and_takes_the_line_after_an_external_reset() {
    let mut uno = Uno::load(echo_elf()).unwrap();
    assert_eq!(uno.install_bootloader(&optiboot()).unwrap(), 0x7E00);
    uno.hard_reset(ResetCause::PowerOn);
    assert_eq!(uno.resets(), (1, Some(ResetCause::PowerOn)));
    uno.run_for(us_to_cycles(10_000)).unwrap();
    assert_eq!(uno.read_symbol("ready").unwrap(), [1], "the program runs after a power-on");
    assert_eq!(baud(&uno), Some(19_231));

    let before = uno.now();
    uno.hard_reset(ResetCause::External);
    assert_eq!(uno.now(), before, "a reset keeps the clock");
    assert_eq!(uno.resets(), (2, Some(ResetCause::External)));
    assert_eq!(uno.pc(), 0x7E00, "BOOTRST: the boot section first");
    uno.run_for(us_to_cycles(10_000)).unwrap();
    assert_eq!(baud(&uno), Some(117_647), "optiboot listens at 115200 (U2X, UBRR 16)");
    assert!(uno.pc() >= 0x7E00);

    // Nothing from avrdude: after its LED's three flashes (0.375 s) optiboot's 1 s watchdog
    // resets the chip into the program.
    uno.run_for(us_to_cycles(1_300_000)).unwrap();
    assert_eq!(uno.resets(), (2, Some(ResetCause::External)), "not before 1.375 s");
    uno.run_for(us_to_cycles(200_000)).unwrap();
    assert_eq!(uno.resets(), (3, Some(ResetCause::Watchdog)));
    uno.run_for(us_to_cycles(10_000)).unwrap();
    assert_eq!(baud(&uno), Some(19_231));
    assert_eq!(uno.read_symbol("ready").unwrap(), [1]);
    // and it answers on the line again: the wire survived both resets
    let end = uno.now() + us_to_cycles(2_000);
    uno.send_byte(0x5A, end).unwrap();
    uno.run_until(end + us_to_cycles(3_000)).unwrap();
    assert_eq!(uno.take_tx().iter().map(|t| t.byte).collect::<Vec<_>>(), [0x5A]);
}

/// A board fresh from the factory with its bootloader: erased flash under optiboot. A
/// power-on reaches optiboot, which leaves at once for the program (`rcall appStart`, then
/// `ijmp` to 0 with r31 clear); the erased words (0xFFFF, `sbrs r31, 7`: never a skip
/// here) run up to the boot section, into optiboot again, and so on, about once a
/// millisecond. Each pass leaves optiboot's return address (0x3F05) on the stack, so after
/// some 1.1 s the stack runs down through the I/O registers, then wraps and comes down
/// again. On the chip none of that resets it or sets its USART up: MCUSR's flags are set by
/// resets alone (its pushed 0x3F fakes no external reset), UCSR0B gets 0x05 (no RXEN0 nor
/// TXEN0), and optiboot turns off any watchdog the stack turns on before its next pass. A
/// program written then runs after a reset.
#[test]
fn erased_flash_under_optiboot_neither_resets_nor_sets_up_the_usart_until_programmed() {
    let mut program = Uno::load(echo_elf()).unwrap().flash();
    program.truncate(program.iter().rposition(|&b| b != 0xFF).unwrap() + 1);
    let mut uno = Uno::erased(Options::new()).unwrap();
    uno.install_bootloader(&optiboot()).unwrap();
    uno.hard_reset(ResetCause::PowerOn);
    for _ in 0..50 {
        uno.run_for(us_to_cycles(100_000)).unwrap();
        assert_eq!(uno.resets(), (1, Some(ResetCause::PowerOn)), "a reset by {} cycles", uno.now());
        assert_eq!(baud(&uno), None, "the USART set up by {} cycles", uno.now());
    }
    // The stack went through USART0's registers (UBRR0L, UBRR0H): 5 s cover the case.
    assert_eq!(uno.read_ram(0xC4, 2).unwrap(), [0x3F, 0x05]);

    uno.write_flash(0, &program).unwrap();
    uno.hard_reset(ResetCause::PowerOn);
    uno.run_for(us_to_cycles(10_000)).unwrap();
    assert_eq!(baud(&uno), Some(19_231), "the program configures its line");
    let end = uno.now() + us_to_cycles(2_000);
    uno.send_byte(0x5A, end).unwrap();
    uno.run_until(end + us_to_cycles(3_000)).unwrap();
    assert_eq!(uno.take_tx().iter().map(|t| t.byte).collect::<Vec<_>>(), [0x5A]);
}
