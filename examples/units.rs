/*!
 * One board standing in for four sensors: slave ids 1–4 on one line, each with a register
 * map of its own ([`avr_modbus::Units`]). A broadcast's write reaches all four; the line's
 * counters are one set for the four.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to the TTL side of a MAX3232 board (or an RS-485
 * transceiver), GND to GND.
 *
 * Serial line: slave ids 1–4 (the model's; the configuration's id is unused), 19200 bps,
 * 8 data bits, even parity, 1 stop bit (8E1).
 *
 * Each sensor (slave id `n`, 1–4):
 *
 * | reference | address | meaning                                            |
 * |-----------|---------|----------------------------------------------------|
 * | 30001     | 0       | reading: 100 × `n`, set by the firmware at start   |
 * | 30002     | 1       | copy of 40001 made by the main loop                |
 * | 40001     | 0       | threshold, written by the master                   |
 * | 40002     | 1       | free for the master                                |
 *
 * In QModMaster set Slave Addr to 1–4 (Start Address counts from 0):
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 30001–30002 | Read Input Registers (0x04)                        | 0             | 2      |
 * | 40001–40002 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 2      |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::{board, Config, Parity, StopBits, Units};
use panic_halt as _;

/// The slave id here is unused: the model's ids (1–4) are the slave's.
const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// The first sensor's slave id.
const FIRST: u8 = 1;

avr_modbus::register_map! {
    /// One sensor: its reading and a copy of its threshold, the threshold and a free register.
    struct Sensor { 30001..=30002, 40001..=40002 }
}

/// Four sensors, slave ids 1–4.
type Sensors = Units<Sensor, 4>;

avr_modbus::slave!(SLAVE: Sensors);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let mut sensors = Units::new(FIRST, [Sensor::new(), Sensor::new(), Sensor::new(), Sensor::new()]);
    for id in FIRST..FIRST + 4 {
        let _ = sensors.set(id, 30001, 100 * u16::from(id));
    }
    if let Err(error) = SLAVE.start(CONFIG, dp.USART0, dp.TC0, sensors) {
        board::halt(error);
    }

    let mut seen = 0;
    loop {
        let writes = SLAVE.master_writes();
        if writes != seen {
            seen = writes;
            SLAVE.with(|sensors| {
                for id in FIRST..FIRST + 4 {
                    let threshold = sensors.get(id, 40001).unwrap_or(0);
                    let _ = sensors.set(id, 30002, threshold);
                }
            });
        }
    }
}
