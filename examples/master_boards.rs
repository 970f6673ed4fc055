/*!
 * The master on every board the crate runs on: `poll_holding`'s request, holding registers
 * 40001–40010 (addresses 0–9) of slave 1 with FC 03, sent again as soon as the last one's
 * outcome is in (the master itself waits T3.5 of silence first), with the values kept in
 * `values`. The chip is the one the build is for (`-C target-cpu`); `make chips` builds it
 * for the ATmega328P, ATmega168, ATmega32U4, ATmega1280 and ATmega2560, on each USART they
 * have, and `make bench` times its interrupts there against a simulated slave.
 *
 * Wiring: the USART's pins to the TTL side of a MAX3232 board (or an RS-485 transceiver),
 * GND to GND, as for `boards`:
 *
 * | board (chip)                      | USART  | RX pin | TX pin |
 * |-----------------------------------|--------|--------|--------|
 * | Uno, Nano, Pro Mini, Nano168      | USART0 | 0      | 1      |
 * | Leonardo, Micro, Pro Micro (32U4) | USART1 | 0      | 1      |
 * | Mega 2560, Mega 1280              | USART0 | 0      | 1      |
 * |                                   | USART1 | 19     | 18     |
 * |                                   | USART2 | 17     | 16     |
 * |                                   | USART3 | 15     | 14     |
 *
 * Serial line: 19200 bps, 8E1; response timeout 1000 ms, one retry (the defaults).
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::master::Request;
use avr_modbus::{board, Line, Parity, SlaveId, StopBits};
use panic_halt as _;

// The chip's peripherals, as the build's `-C target-cpu` chose the chip (build.rs).
#[cfg(avr_chip = "atmega1280")]
use avr_device::atmega1280 as pac;
#[cfg(avr_chip = "atmega168")]
use avr_device::atmega168 as pac;
#[cfg(avr_chip = "atmega2560")]
use avr_device::atmega2560 as pac;
#[cfg(avr_chip = "atmega328p")]
use avr_device::atmega328p as pac;
#[cfg(avr_chip = "atmega32u4")]
use avr_device::atmega32u4 as pac;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);

// The USART `make chips` builds this for (AVR_MODBUS_EXAMPLE_USART, see build.rs); in a
// firmware of your own, one line: `master!(MASTER on USART1: 25)` or `master!(MASTER: 25)`.
// FC 3 × 10 is answered in 25 bytes.
#[cfg(not(any(example_usart = "1", example_usart = "2", example_usart = "3", example_usart = "capture")))]
avr_modbus::master!(MASTER: 25);
#[cfg(example_usart = "1")]
avr_modbus::master!(MASTER on USART1: 25);
#[cfg(example_usart = "2")]
avr_modbus::master!(MASTER on USART2: 25);
#[cfg(example_usart = "3")]
avr_modbus::master!(MASTER on USART3: 25);
// The timer's capture line (feature `capture-line`): pins 8/9 on the Uno, 48/46 on the Mega,
// 13/5 on the Leonardo.
#[cfg(all(example_usart = "capture", any(avr_chip = "atmega328p", avr_chip = "atmega168")))]
avr_modbus::master!(MASTER on TIMER1: 25);
#[cfg(all(example_usart = "capture", avr_chip = "atmega32u4"))]
avr_modbus::master!(MASTER on TIMER3: 25);
#[cfg(all(example_usart = "capture", any(avr_chip = "atmega2560", avr_chip = "atmega1280")))]
avr_modbus::master!(MASTER on TIMER5: 25);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted) };
    #[cfg(not(any(example_usart = "1", example_usart = "2", example_usart = "3", example_usart = "capture")))]
    let usart = {
        #[cfg(not(avr_chip = "atmega32u4"))]
        let usart = dp.USART0;
        #[cfg(avr_chip = "atmega32u4")]
        let usart = dp.USART1;
        usart
    };
    #[cfg(example_usart = "1")]
    let usart = dp.USART1;
    #[cfg(example_usart = "2")]
    let usart = dp.USART2;
    #[cfg(example_usart = "3")]
    let usart = dp.USART3;
    #[cfg(all(example_usart = "capture", any(avr_chip = "atmega328p", avr_chip = "atmega168")))]
    let usart = dp.TC1;
    #[cfg(all(example_usart = "capture", avr_chip = "atmega32u4"))]
    let usart = dp.TC3;
    #[cfg(all(example_usart = "capture", any(avr_chip = "atmega2560", avr_chip = "atmega1280")))]
    let usart = dp.TC5;
    if let Err(error) = MASTER.start(LINE, usart, dp.TC0) {
        board::halt(error);
    }
    let request = Request::ReadHoldingRegisters { address: 0, quantity: 10 };
    let mut values = [0u16; 10];
    loop {
        MASTER.poll(|outcome| {
            if let Ok(reply) = outcome {
                for (slot, value) in values.iter_mut().zip(reply.registers()) {
                    *slot = value;
                }
            }
        });
        // Busy while the last request is under way: it goes on, and this one waits.
        let _ = MASTER.send(SlaveId::new(1), &request);
        core::hint::black_box(&values);
    }
}
