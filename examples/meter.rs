/*!
 * 32-bit values as a meter holds them: a counter, a float computed from a setpoint, a
 * float the master writes and a counter the master writes in the other word order, each
 * in a pair of registers declared `as u32` or `as f32`, so that a master never reads a
 * pair half old, half new and never writes half of one.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485 transceiver, GND to
 * GND. Pin 12 to GND at start-up: the counter is updated register by register instead of
 * as one value (a demonstration of the torn reads `set_wide` prevents; never do this).
 *
 * Serial line: slave id 1, 19200 bps, 8E1.
 *
 * | references  | what                                                                    |
 * |-------------|-------------------------------------------------------------------------|
 * | 30001–30002 | u32, high word first: a counter of equal words (0x0001_0001, 0x0002_0002, …) stepped as fast as the loop runs |
 * | 30003–30004 | f32, high word first: 40001–40002 × 2                                    |
 * | 30005–30006 | u32, low word first: 40003–40004 + 1                                     |
 * | 40001–40002 | f32, high word first: a setpoint for the master (starts at 1.5)          |
 * | 40003–40004 | u32, low word first ("CDAB"): for the master                             |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pins};
use avr_modbus::{Config, Parity, StopBits, WordOrder};
use panic_halt as _;

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const ABCD: WordOrder = WordOrder::HighFirst;
const CDAB: WordOrder = WordOrder::LowFirst;

avr_modbus::register_map! {
    /// Pairs only.
    struct Meter {
        30001..=30002 as u32,
        30003..=30004 as f32,
        30005..=30006 as u32,
        40001..=40002 as f32,
        40003..=40004 as u32,
    }
}

avr_modbus::slave!(SLAVE: Meter);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let pins = match Pins::new(dp.PORTB, dp.PORTC, dp.PORTD) {
        Ok(pins) => pins,
        Err(error) => board::halt(error),
    };
    let jumper = pins.d12.into_pull_up_input();
    avr_device::asm::delay_cycles(1_000);
    let torn = !jumper.is_high();
    let mut meter = Meter::new();
    if let Err(error) = meter.set_wide(40001, 1.5f32, ABCD) {
        board::halt(error);
    }
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, meter) {
        board::halt(error);
    }

    let mut step = 0u16;
    let mut seen = u16::MAX;
    loop {
        // Both words the same, whatever the step: a pair read half old, half new shows.
        step = step.wrapping_add(1);
        let counter = u32::from(step) << 16 | u32::from(step);
        if torn {
            // Two critical sections: the slave may answer between them.
            let [high, low] = ABCD.split(counter);
            let _ = SLAVE.set(30001, high);
            let _ = SLAVE.set(30002, low);
        } else {
            let _ = SLAVE.set_wide(30001, counter, ABCD);
        }
        let writes = SLAVE.master_writes();
        if writes != seen {
            seen = writes;
            let setpoint = SLAVE.get_wide::<f32>(40001, ABCD).unwrap_or(0.0);
            let _ = SLAVE.set_wide(30003, setpoint * 2.0, ABCD);
            let count = SLAVE.get_wide::<u32>(40003, CDAB).unwrap_or(0);
            let _ = SLAVE.set_wide(30005, count.wrapping_add(1), CDAB);
        }
    }
}
