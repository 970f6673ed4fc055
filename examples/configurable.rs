/*!
 * Line settings the master can change, kept in EEPROM: the master writes the slave id,
 * baud rate, parity, stop bits, the transmission mode (RTU or ASCII, feature `ascii`) and
 * the reply delay (feature `reply-delay`) to holding registers 40101–40106; the slave
 * answers that
 * write at the old settings and switches once the reply has left the wire and the main
 * loop (`SLAVE.poll_settings`) has computed the new USART and Timer0 settings, under 4 ms
 * after the request (3.7 ms measured at 115200). The main loop then stores them in EEPROM (≈3.4 ms per changed byte), where
 * the next start-up finds them.
 *
 * EEPROM: bytes 0–21, two slots of 11 bytes for the settings record; a store writes the
 * slot without the newest record and completes it with its last byte, so a reset or power
 * cut during a store leaves the old settings or the new ones. Only when neither slot holds
 * a valid record (blank or damaged EEPROM) does the device start at the compiled-in
 * default, 19200 8E1, slave id 1. A record left at byte 0 by earlier firmware is read.
 *
 * Recovery: a jumper from pin 12 to GND at start-up (power-up or reset) ignores the EEPROM
 * and starts at the default, whatever a master stored. Settings written with the jumper on
 * are stored as usual; remove it and reset to start with them.
 *
 * Wiring: on an RS-485 bus, Uno pin 1 (TX) to the transceiver's DI, pin 0 (RX) to RO, pin 10
 * to DE and /RE tied together (high only while the slave answers), GND to GND; A/B to the
 * bus. Or pins 0 and 1 to the TTL side of a MAX3232 board for a point-to-point line (pin 10
 * then unused). The on-board LED (pin 13) is lit while the slave answers a frame addressed
 * to it; it stays dark for broadcasts, other slaves' frames, damaged frames and in
 * listen-only mode (FC 8 sub-function 04). The recovery jumper between pin 12 and GND
 * (open in normal use).
 *
 * | reference   | address | meaning                                              |
 * |-------------|---------|------------------------------------------------------|
 * | 00001–00008 | 0–7     | coils kept for the master                            |
 * | 30001       | 0       | settings used at start-up: 0 default (no valid record in EEPROM), 1 EEPROM, 2 default forced by the jumper |
 * | 30002       | 1       | EEPROM bytes written by the last save (0–12)         |
 * | 30003       | 2       | saves since start-up                                 |
 * | 40001–40004 | 0–3     | holding registers kept for the master                |
 * | 40101       | 100     | slave id, 1–247                                      |
 * | 40102       | 101     | baud rate / 100: 12–10000 (96 = 9600, 1152 = 115200) |
 * | 40103       | 102     | parity: 0 none, 1 odd, 2 even                        |
 * | 40104       | 103     | stop bits: 1 or 2                                    |
 * | 40105       | 104     | mode: 0 RTU, 1 ASCII (7 data bits), 2 ASCII with 8   |
 * | 40106       | 105     | reply delay after T3.5 in ms, 0–255 (RTU)            |
 *
 * In QModMaster (Start Address counts from 0; Options › Settings › Base Addr stays 0), one
 * read per row: 40005–40100 don't exist, so a read from 40001 to 40101 gets exception 02.
 *
 * | references  | Function Code                                      | Start Address | Number |
 * |-------------|----------------------------------------------------|---------------|--------|
 * | 00001–00008 | Read Coils (0x01); write: 0x05, 0x0f               | 0             | 8      |
 * | 30001–30003 | Read Input Registers (0x04)                        | 0             | 3      |
 * | 40001–40004 | Read Holding Registers (0x03); write: 0x06, 0x10   | 0             | 4      |
 * | 40101–40106 | Read Holding Registers (0x03); write: 0x06, 0x10   | 100           | 6      |
 *
 * A write to 40101–40106 that the slave can't run (id 0 or over 247, a rate the 16 MHz
 * USART can't make within 2.5 %, another code) gets exception 03 and changes nothing. In
 * ASCII the line keeps its rate, parity and stop bits (19200 7E1 after writing 1 to 40105
 * at the default), and a frame inside which it stays silent for 1 s is dropped.
 * Also answers FC 7, 8, 11, 17 (feature `diagnostics`), FC 22, 23 (`extra-fc`) and FC 43 /
 * MEI 14, Read Device Identification (`device-id`), with these objects, kept in flash:
 *
 * | id   | object             | value                                  |
 * |------|--------------------|----------------------------------------|
 * | 0x00 | VendorName         | avr-modbus                       |
 * | 0x01 | ProductCode        | configurable                           |
 * | 0x02 | MajorMinorRevision | the crate's version (0.1.0)            |
 * | 0x04 | ProductName        | Uno Modbus slave with stored settings  |
 * | 0x05 | ModelName          | Arduino Uno (ATmega328P)               |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::board::{self, Eeprom, Pin, Pins};
use avr_modbus::{Config, Configurable, Error, Parity, StopBits};
use panic_halt as _;

/// The compiled-in default, and what the jumper forces.
const DEFAULT: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

/// EEPROM address of the two settings slots (22 bytes).
const SETTINGS_AT: u16 = 0;

/// Where the settings block starts.
const SETTINGS_BLOCK: u32 = 40101;

/// Start-up settings as reported in 30001.
const FROM_DEFAULT: u16 = 0;
const FROM_EEPROM: u16 = 1;
const FROM_JUMPER: u16 = 2;

avr_modbus::identification! {
    /// What FC 43 / MEI 14 tells a master: the objects in the table above.
    static IDENTITY = {
        vendor_name: "avr-modbus",
        product_code: "configurable",
        major_minor_revision: env!("CARGO_PKG_VERSION"),
        product_name: "Uno Modbus slave with stored settings",
        model_name: "Arduino Uno (ATmega328P)",
    };
}

avr_modbus::register_map! {
    /// The table above, without the settings block (`Configurable` adds it).
    struct Map { 1..=8, 30001..=30003, 40001..=40004 }
}

type Registers = Configurable<Map>;

avr_modbus::slave!(SLAVE: Registers, Pin, Pin);

/// Reads the jumper and the EEPROM, builds the register map and starts the slave.
fn start(dp: avr_device::atmega328p::Peripherals) -> Result<Eeprom, Error> {
    let pins = Pins::new(dp.PORTB, dp.PORTC, dp.PORTD)?;
    let jumper = pins.d12.into_pull_up_input();
    // Let the pull-up charge the pin before reading it.
    avr_device::asm::delay_cycles(1_000);
    let forced = !jumper.is_high();

    let eeprom = Eeprom::new(dp.EEPROM)?;
    let (config, source) = match (forced, eeprom.load_config(SETTINGS_AT)) {
        (true, _) => (DEFAULT, FROM_JUMPER),
        (false, Some(stored)) => (stored, FROM_EEPROM),
        (false, None) => (DEFAULT, FROM_DEFAULT),
    };

    let mut bank = Map::new();
    bank.set(30001, source)?;
    bank.set_device_info(b"avr-modbus configurable");
    bank.set_identification(&IDENTITY);
    let model = Configurable::new(bank, SETTINGS_BLOCK, config)?;
    let driver_enable = pins.d10.into_output();
    let led = pins.d13.into_output();
    SLAVE.start_with_pins(config, dp.USART0, dp.TC0, model, driver_enable, led)?;
    Ok(eeprom)
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    let mut eeprom = match start(dp) {
        Ok(eeprom) => eeprom,
        Err(error) => board::halt(error),
    };

    let mut saves: u16 = 0;
    loop {
        if let Some(written) = SLAVE.poll_settings(&mut eeprom, SETTINGS_AT) {
            saves = saves.wrapping_add(1);
            let _ = SLAVE.set(30002, written as u16);
            let _ = SLAVE.set(30003, saves);
        }
    }
}
