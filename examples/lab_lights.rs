/*!
 * Two devices of a lab bench from one firmware: the jumper on pin 12 picks the role.
 *
 * - Pin 12 open (pulled up): slave id 1, the **button box**. START on pin 2 and STOP on
 *   pin 3, each a push button to GND, are discrete inputs 10001 and 10002 (1 = pressed).
 * - Pin 12 jumpered to GND at start-up: slave id 2, the **light tower**. RED, GREEN,
 *   YELLOW and BLUE lamps (LEDs with 220 Ω resistors to GND) on pins 4, 5, 6 and 7 follow
 *   coils 00001–00004.
 *
 * Wiring: both devices on one RS-485 bus: Uno pin 1 (TX) to the transceiver's DI, pin 0
 * (RX) to RO, pin 10 to DE and /RE tied together (high while the Uno answers), GND to GND;
 * A/B to the bus. The on-board LED (pin 13) flashes for every frame addressed to the
 * device (the serial-line spec's communication LED). Pin 10 stays low with a MAX3232 board
 * instead of a transceiver, which works too for one device.
 *
 * Serial line: 19200 bps, 8E1.
 *
 * | id | reference | address | meaning        |
 * |----|-----------|---------|----------------|
 * | 1  | 10001     | 0       | START pressed  |
 * | 1  | 10002     | 1       | STOP pressed   |
 * | 2  | 00001     | 0       | RED lamp       |
 * | 2  | 00002     | 1       | GREEN lamp     |
 * | 2  | 00003     | 2       | YELLOW lamp    |
 * | 2  | 00004     | 3       | BLUE lamp      |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0):
 *
 * | Slave Addr | references  | Function Code                        | Start Address | Number |
 * |------------|-------------|--------------------------------------|---------------|--------|
 * | 1          | 10001–10002 | Read Discrete Inputs (0x02)          | 0             | 2      |
 * | 2          | 00001–00004 | Read Coils (0x01); write: 0x05, 0x0f | 0             | 4      |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Pin, Pins};
use avr_modbus::{bit_bytes, Bank, Config, Error, Parity, SlaveId, StopBits};
use panic_halt as _;

const BUTTON_BOX: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);
const LIGHT_TOWER: SlaveId = SlaveId::new(2);

type Bits = Bank<1, 0, { bit_bytes(4) }>;

avr_modbus::slave!(SLAVE: Bits, Pin, Pin);

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
    // Let the pull-up charge the pin before reading it.
    avr_device::asm::delay_cycles(1_000);
    let tower = !jumper.is_high();

    let mut bank = Bits::new();
    let (config, map) = if tower {
        (BUTTON_BOX.with_slave_id(LIGHT_TOWER), bank.add_range(1, 4))
    } else {
        (BUTTON_BOX, bank.add_range(10001, 2))
    };
    let driver_enable = pins.d10.into_output();
    let led = pins.d13.into_output();
    let started: Result<(), Error> =
        map.and_then(|()| SLAVE.start_with_pins(config, dp.USART0, dp.TC0, bank, driver_enable, led));
    if let Err(error) = started {
        board::halt(error);
    }

    if tower {
        let mut lamps = [pins.d4.into_output(), pins.d5.into_output(), pins.d6.into_output(), pins.d7.into_output()];
        loop {
            for (coil, lamp) in (1..).zip(lamps.iter_mut()) {
                lamp.set(SLAVE.get(coil).unwrap_or(0) != 0);
            }
        }
    } else {
        let buttons = [pins.d2.into_pull_up_input(), pins.d3.into_pull_up_input()];
        loop {
            for (input, button) in (10001..).zip(buttons.iter()) {
                let _ = SLAVE.set(input, u16::from(!button.is_high()));
            }
        }
    }
}
