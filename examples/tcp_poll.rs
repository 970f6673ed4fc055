/*!
 * A Modbus TCP client on an Arduino Ethernet Shield (W5100): every 100 ms, holding
 * registers 40001–40010 (addresses 0–9) of the server at 192.168.1.10, port 502, unit id
 * 0xFF, with FC 03; the values land in `values`, and the count of answers in `answered`. The
 * TCP masters' benchmark sketch in its read-only form (`make bench` sets its size beside
 * modbus-esp8266's and ArduinoModbus's). The connection is made at the start and made again
 * whenever it drops; while it is down, `send` is refused and the loop asks again 100 ms later.
 *
 * Wiring: the shield on an Uno; its chip select is pin 10, its SD card's pin 4 (leave that
 * high, or unplugged); pins 11–13 are the SPI. A W5500 module (Ethernet Shield 2):
 * `W5500` below, its MOSI, MISO, SCK to pins 11, 12, 13, CS to pin 10.
 *
 * Network: 192.168.1.177/24, MAC DE:AD:BE:EF:FE:02; the server's response timeout 1000 ms,
 * one retry (the defaults). On the virtual shield (`tools/virtual-uno --wiznet w5100
 * --connect 502:1502`) the server is whatever listens on 127.0.0.1:1502.
 */
#![no_std]
#![no_main]

use avr_modbus::master::Request;
use avr_modbus::tcp::Network;
use avr_modbus::{board, millis};
use panic_halt as _;

const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x02], [192, 168, 1, 177]);
const SERVER: [u8; 4] = [192, 168, 1, 10];

// FC 3 × 10 is answered in 25 bytes.
avr_modbus::tcp_client!(CLIENT: avr_modbus::tcp::W5100, 25);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(avr_modbus::Error::AlreadyStarted) };
    if let Err(error) = CLIENT.start(NETWORK, SERVER, 502, dp.SPI, dp.TC0) {
        board::halt(error);
    }
    let mut values = [0u16; 10];
    let mut answered: u16 = 0;
    let mut last = 0;
    loop {
        CLIENT.poll(|outcome| {
            if let Ok(reply) = outcome {
                for (slot, value) in values.iter_mut().zip(reply.registers()) {
                    *slot = value;
                }
                answered = answered.wrapping_add(1);
            }
        });
        let now = millis();
        if now.wrapping_sub(last) >= 100 {
            last = now;
            let _ = CLIENT.send(0xFF, &Request::ReadHoldingRegisters { address: 0, quantity: 10 });
        }
        core::hint::black_box((&values, answered));
    }
}
