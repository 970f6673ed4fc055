/*!
 * One firmware for every board the crate runs on: the peers' size contract
 * (`sixteen_each`'s map), 30001 counting seconds, and the board's LED "L" lit while the
 * slave answers. The chip is the one the build is for (`-C target-cpu`); `make firmware`
 * builds it for the ATmega168, ATmega32U4, ATmega1280 and ATmega2560, on each USART they
 * have, and `make serve BOARD=mega2560 USART=1` runs it.
 *
 * Wiring: the USART's pins to the TTL side of a MAX3232 board (or an RS-485 transceiver),
 * GND to GND:
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
 * On a Mega with the slave on USART1–3, USART0 (pins 0/1, the USB serial) stays the
 * application's: this firmware prints `writes N` there at 9600 8N1 each time the master
 * has written. So it does on an Uno or a Mega with the slave on the timer's capture line
 * (feature `capture-line`, as `make chips` builds it with AVR_MODBUS_EXAMPLE_USART=capture):
 * RX on pin 8, TX on pin 9 (the Mega's 48 and 46; the Leonardo's 13 and 5, without the LED
 * and the console).
 *
 * Serial line: slave id 1, 19200 bps, 8 data bits, even parity, 1 stop bit (8E1). With
 * feature `eeprom-settings` (and `ascii`), as `make firmware` builds it once more for the
 * Mega's USART1 and the Leonardo: the master sets the line at 40101–40105 as in
 * `configurable` (id, baud/100, parity, stop bits, mode), kept in EEPROM bytes 0–21 and
 * used from the next start-up on.
 *
 * | reference   | address | meaning                                          | QModMaster               |
 * |-------------|---------|--------------------------------------------------|--------------------------|
 * | 00001–00016 | 0–15    | coils, written by the master                     | Coils, start 0, 16       |
 * | 10001–10016 | 0–15    | discrete inputs (0 until the firmware sets them) | Discrete Inputs, 0, 16   |
 * | 30001       | 0       | seconds since start-up                           | Input Registers, 0, 1    |
 * | 30002–30008 | 1–7     | input registers (0)                              | Input Registers, 1, 7    |
 * | 40001–40016 | 0–15    | holding registers, written by the master         | Holding Registers, 0, 16 |
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::{board, millis, Config, NoPin, Parity, StopBits};
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

const CONFIG: Config = Config::new(1, 19_200, Parity::Even, StopBits::One);

avr_modbus::register_map! {
    /// The contract's map: 16 coils, 16 discrete inputs, 8 input and 16 holding registers.
    struct Registers {
        1..=16,
        10001..=10016,
        30001..=30008,
        40001..=40016,
    }
}

/// The map, and with feature `eeprom-settings` the line settings at 40101–40105 beside it.
#[cfg(not(feature = "eeprom-settings"))]
type Model = Registers;
#[cfg(feature = "eeprom-settings")]
type Model = avr_modbus::Configurable<Registers>;

/// Where the settings live: EEPROM bytes 0–21 (feature `eeprom-settings`).
#[cfg(feature = "eeprom-settings")]
const SETTINGS_AT: u16 = 0;

// The USART `make firmware` builds this for (AVR_MODBUS_EXAMPLE_USART, see build.rs);
// in a firmware of your own, one line: `slave!(SLAVE on USART1: …)` or `slave!(SLAVE: …)`.
#[cfg(not(any(example_usart = "1", example_usart = "2", example_usart = "3", example_usart = "capture")))]
avr_modbus::slave!(SLAVE: Model, NoPin, board::Pin);
#[cfg(example_usart = "1")]
avr_modbus::slave!(SLAVE on USART1: Model, NoPin, board::Pin);
#[cfg(example_usart = "2")]
avr_modbus::slave!(SLAVE on USART2: Model, NoPin, board::Pin);
#[cfg(example_usart = "3")]
avr_modbus::slave!(SLAVE on USART3: Model, NoPin, board::Pin);
// The timer's capture line (feature `capture-line`): pins 8/9 on the Uno, 48/46 on the Mega,
// 13/5 on the Leonardo, whose LED is on pin 13 and stays dark.
#[cfg(all(example_usart = "capture", any(avr_chip = "atmega328p", avr_chip = "atmega168")))]
avr_modbus::slave!(SLAVE on TIMER1: Model, NoPin, board::Pin);
#[cfg(all(example_usart = "capture", avr_chip = "atmega32u4"))]
avr_modbus::slave!(SLAVE on TIMER3: Model, NoPin, NoPin);
#[cfg(all(example_usart = "capture", any(avr_chip = "atmega2560", avr_chip = "atmega1280")))]
avr_modbus::slave!(SLAVE on TIMER5: Model, NoPin, board::Pin);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted) };
    #[cfg(not(avr_chip = "atmega32u4"))]
    let led_port = dp.PORTB;
    #[cfg(avr_chip = "atmega32u4")]
    let led_port = dp.PORTC;
    #[cfg(not(all(example_usart = "capture", avr_chip = "atmega32u4")))]
    let led = match board::led(led_port) {
        Ok(led) => led,
        Err(error) => board::halt(error),
    };
    #[cfg(all(example_usart = "capture", avr_chip = "atmega32u4"))]
    let (led, _) = (NoPin, led_port);
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
    #[cfg(not(feature = "eeprom-settings"))]
    let (config, model) = (CONFIG, Registers::new());
    #[cfg(feature = "eeprom-settings")]
    let (config, model, mut eeprom) = match settings(dp.EEPROM) {
        Ok(started) => started,
        Err(error) => board::halt(error),
    };
    if let Err(error) = SLAVE.start_with_pins(config, usart, dp.TC0, model, NoPin, led) {
        board::halt(error);
    }
    #[cfg(any(
        example_usart = "1",
        example_usart = "2",
        example_usart = "3",
        all(example_usart = "capture", not(avr_chip = "atmega32u4"))
    ))]
    let console = Console::new(dp.USART0);
    let mut seen = 0;
    loop {
        SLAVE.set(30001, (millis() / 1000) as u16).ok();
        #[cfg(feature = "eeprom-settings")]
        SLAVE.poll_settings(&mut eeprom, SETTINGS_AT);
        let writes = SLAVE.master_writes();
        if writes != seen {
            seen = writes;
            #[cfg(any(
                example_usart = "1",
                example_usart = "2",
                example_usart = "3",
                all(example_usart = "capture", not(avr_chip = "atmega32u4"))
            ))]
            console.print_writes(writes);
        }
    }
}

/// The stored line settings (the default where there are none) and the map with them.
#[cfg(feature = "eeprom-settings")]
fn settings(eeprom: pac::EEPROM) -> Result<(Config, Model, board::Eeprom), avr_modbus::Error> {
    let eeprom = board::Eeprom::new(eeprom)?;
    let config = eeprom.load_config(SETTINGS_AT).unwrap_or(CONFIG);
    Ok((config, Model::new(Registers::new(), 40101, config)?, eeprom))
}

/// USART0 as the application's own output, beside a slave on another USART: polled, 9600
/// 8N1, transmit only.
#[cfg(any(
    example_usart = "1",
    example_usart = "2",
    example_usart = "3",
    all(example_usart = "capture", not(avr_chip = "atmega32u4"))
))]
struct Console(pac::USART0);

#[cfg(any(
    example_usart = "1",
    example_usart = "2",
    example_usart = "3",
    all(example_usart = "capture", not(avr_chip = "atmega32u4"))
))]
impl Console {
    fn new(usart: pac::USART0) -> Self {
        // 9600 bps at 16 MHz: UBRR0 = 103; 8 data bits, no parity, 1 stop bit (reset value).
        usart.ubrr0().write(|w| w.set(103));
        usart.ucsr0b().write(|w| w.txen0().set_bit());
        Console(usart)
    }

    fn write(&self, byte: u8) {
        while self.0.ucsr0a().read().udre0().bit_is_clear() {}
        self.0.udr0().write(|w| w.set(byte));
    }

    /// `writes N` and CR LF.
    fn print_writes(&self, writes: u16) {
        b"writes ".iter().for_each(|&b| self.write(b));
        let mut digits = [b'0'; 5];
        let mut n = writes;
        for digit in digits.iter_mut().rev() {
            *digit = b'0' + (n % 10) as u8;
            n /= 10;
        }
        let first = digits.iter().position(|&d| d != b'0').unwrap_or(4);
        digits.iter().skip(first).for_each(|&b| self.write(b));
        self.write(b'\r');
        self.write(b'\n');
    }
}
