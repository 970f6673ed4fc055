/*!
 * A Mega 2560 (or 1280) as a gateway: a Modbus slave on Serial (USART0, pins 0/1, the USB
 * port) for QModMaster or a SCADA, and a Modbus master on Serial1 (USART1, pins 19 RX / 18
 * TX) polling a field device, slave 1 of the field line. Both roles run in interrupts on
 * Timer0 (the slave's silences on compare B, the master's on compare A); the loop only
 * copies values between them.
 *
 * On an Uno (feature `capture-line`) the master is on pins 8 (RX) and 9 (TX), Timer1's
 * capture line, and the slave on pins 0/1 (USART0, the USB port): the same gateway with one
 * USART.
 *
 * Wiring: the USB port (or pins 0/1 to a MAX3232) to the SCADA; pins 18/19 to an RS-485
 * transceiver's DI/RO with DE and /RE joined on pin 13 (the LED "L" then shows the field
 * line's requests), A/B to the field line, GND to GND. On the Uno: pins 8/9 to the field
 * line's transceiver (DI on 9, RO on 8), DE and /RE on pin 13.
 *
 * Serial lines: both 19200 8E1; the gateway is slave 1 toward the SCADA.
 *
 * | gateway's reference | what it holds                                                     |
 * |---------------------|-------------------------------------------------------------------|
 * | 40001–40010         | the field device's holding registers 0–9, read every 100 ms (FC 3) |
 * | 00001–00008         | written by the SCADA, sent on to the field device's coils 0–7 (FC 15) |
 * | 30001               | the field device's answers so far (wraps)                          |
 * | 30002               | its failures: timeouts, exceptions, bad replies (wraps)            |
 * | 30003               | the last failure: 0 none, 0x01–0xFF exception code, 0x100 timeout, 0x200 bad reply |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin};
use avr_modbus::master::{Failure, Request};
use avr_modbus::{millis, Config, Line, NoPin, Parity, SlaveId, StopBits};
use panic_halt as _;

#[cfg(avr_chip = "atmega1280")]
use avr_device::atmega1280 as pac;
#[cfg(avr_chip = "atmega2560")]
use avr_device::atmega2560 as pac;
#[cfg(all(avr_chip = "atmega328p", feature = "capture-line"))]
use avr_device::atmega328p as pac;
#[cfg(not(any(
    avr_chip = "atmega2560",
    avr_chip = "atmega1280",
    all(avr_chip = "atmega328p", feature = "capture-line")
)))]
compile_error!(
    "the gateway needs two serial lines: build it for the Mega (-C target-cpu=atmega2560 or atmega1280), \
     or for the Uno with feature capture-line (pins 8/9)"
);

const SCADA_SIDE: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const FIELD_LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);
const FIELD_DEVICE: SlaveId = SlaveId::new(1);

avr_modbus::register_map! {
    /// What the SCADA sees.
    struct Gateway {
        1..=8,
        30001..=30003,
        40001..=40010,
    }
}

avr_modbus::slave!(SLAVE: Gateway);
// FC 3 × 10 is answered in 25 bytes; FC 15 × 8 takes 10.
#[cfg(not(avr_chip = "atmega328p"))]
avr_modbus::master!(MASTER on USART1: 25, Pin, NoPin);
#[cfg(avr_chip = "atmega328p")]
avr_modbus::master!(MASTER on TIMER1: 25, Pin, NoPin);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted) };
    // The Mega's pin 13 (PB7, the LED "L", which then shows the field line's requests):
    // the transceiver's DE and /RE.
    let driver_enable = match board::led(dp.PORTB) {
        Ok(pin) => pin,
        Err(error) => board::halt(error),
    };
    // The field line's USART; on the Uno the timer of pins 8/9.
    #[cfg(not(avr_chip = "atmega328p"))]
    let field_line = dp.USART1;
    #[cfg(avr_chip = "atmega328p")]
    let field_line = dp.TC1;
    // The master first, with Timer0 lent (`&*dp.TC0`); the slave takes it for good.
    let started = MASTER
        .start_with_pins(FIELD_LINE, field_line, &*dp.TC0, driver_enable, NoPin)
        .and_then(|()| SLAVE.start(SCADA_SIDE, dp.USART0, dp.TC0, Gateway::new()));
    if let Err(error) = started {
        board::halt(error);
    }

    let (mut answers, mut failures) = (0u16, 0u16);
    let mut last_poll = 0u32;
    let mut coils_sent: Option<u8> = None;
    let mut writing = false;
    loop {
        let done = MASTER.poll(|outcome| match outcome {
            Ok(reply) => {
                for (i, value) in reply.registers().enumerate() {
                    let _ = SLAVE.set(40001 + i as u16, value);
                }
                Ok(())
            }
            Err(failure) => Err(failure),
        });
        match done {
            Some(Ok(())) => answers = answers.wrapping_add(1),
            Some(Err(failure)) => {
                failures = failures.wrapping_add(1);
                let code = match failure {
                    Failure::Exception(code) => u16::from(code.code()),
                    Failure::Timeout => 0x100,
                    Failure::BadReply => 0x200,
                };
                let _ = SLAVE.set(30003, code);
                if writing {
                    // Send the coils again.
                    coils_sent = None;
                }
            }
            None => {}
        }
        let _ = SLAVE.set(30001, answers);
        let _ = SLAVE.set(30002, failures);
        if MASTER.is_busy() {
            continue;
        }
        // The eight coils read together: never half of a SCADA write.
        let coils = SLAVE.with(|map| (0..8).fold(0u8, |bits, i| bits | u8::from(map.get(1 + i) == Ok(1)) << i));
        let Some(coils) = coils else { continue };
        let now = millis();
        if coils_sent != Some(coils) {
            let values = [0, 1, 2, 3, 4, 5, 6, 7].map(|i| coils >> i & 1 == 1);
            writing = MASTER.send(FIELD_DEVICE, &Request::WriteMultipleCoils { address: 0, values: &values }).is_ok();
            if writing {
                coils_sent = Some(coils);
            }
        } else if now.wrapping_sub(last_poll) >= 100 {
            last_poll = now;
            writing = false;
            let _ = MASTER.send(FIELD_DEVICE, &Request::ReadHoldingRegisters { address: 0, quantity: 10 });
        }
    }
}
