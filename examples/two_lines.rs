/*!
 * One device on two serial lines: a Mega 2560 (or 1280) serves the contract's map on Serial
 * (USART0, pins 0/1, the USB port) and on Serial1 (USART1, pins 19 RX / 18 TX) at once, one
 * model without copies (`shared_model!`), each line with its own settings, slave id and
 * counters. Two slaves run in interrupts on Timer0: the first keeps its silences on compare
 * B, the second on compare A (`with TIMER0_COMPA`), so no master may run beside them.
 *
 * Wiring: the USB port (or pins 0/1 to a MAX3232) to one master; pins 18/19 to an RS-485
 * transceiver's DI/RO (DE and /RE to a pin of your choice), A/B to the other line, GND to
 * GND.
 *
 * Serial: slave id 1, 19200 8E1. Serial1: slave id 2, 9600 8N1. On both, the references of
 * `sixteen_each`; the main loop keeps input register 30001 at the number of master writes
 * so far, 30002 at the last writer's line (0 none yet, 1 Serial, 2 Serial1), 30003 at the
 * seconds since start, and each line's counters: 30004/30005 the frames addressed to
 * Serial's slave / Serial1's (or broadcast), 30006/30007 the frames each dropped for a bad
 * CRC.
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board;
use avr_modbus::{millis, Config, Parity, Port, StopBits};
use panic_halt as _;

#[cfg(avr_chip = "atmega1280")]
use avr_device::atmega1280 as pac;
#[cfg(avr_chip = "atmega2560")]
use avr_device::atmega2560 as pac;
#[cfg(not(any(avr_chip = "atmega2560", avr_chip = "atmega1280")))]
compile_error!("two lines need two USARTs: build it for the Mega (-C target-cpu=atmega2560 or atmega1280)");

const SERIAL: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const SERIAL1: Config = Config::new(2, 9_600, Parity::None, StopBits::One);

avr_modbus::register_map! {
    /// The contract's map: 16 coils, 16 discrete inputs, 8 input and 16 holding registers.
    struct Registers {
        1..=16,
        10001..=10016,
        30001..=30008,
        40001..=40016,
    }
}

avr_modbus::shared_model!(MODEL: Registers);
avr_modbus::slave!(SLAVE: MODEL);
avr_modbus::slave!(SLAVE1 on USART1 with TIMER0_COMPA: MODEL);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    // The first one started borrows Timer0 (`&*dp.TC0`), the second takes it.
    let started =
        SLAVE1.start(SERIAL1, dp.USART1, &*dp.TC0, MODEL).and_then(|()| SLAVE.start(SERIAL, dp.USART0, dp.TC0, MODEL));
    if let Err(error) = started {
        board::halt(error);
    }
    let (mut second, mut seconds) = (0u32, 0u16);
    loop {
        if millis().wrapping_sub(second) >= 1000 {
            second = second.wrapping_add(1000);
            seconds = seconds.wrapping_add(1);
            let _ = MODEL.set(30003, seconds);
        }
        let _ = MODEL.set(30001, MODEL.master_writes());
        let (serial, serial1) = (SLAVE.counters(), SLAVE1.counters());
        let _ = MODEL.set(30004, serial.messages);
        let _ = MODEL.set(30005, serial1.messages);
        let _ = MODEL.set(30006, serial.crc_errors);
        let _ = MODEL.set(30007, serial1.crc_errors);
        if let Some(write) = MODEL.take_write() {
            let _ = MODEL.set(30002, if write.by == Port::Serial(0) { 1 } else { 2 });
        }
    }
}
