/*!
 * The Modbus TCP client under test: a firmware the simulator tests command through two
 * arrays in RAM (`tests/sim_tcp_client.rs`, `tools/virtual-uno/tests/interop_tcp_client.rs`
 * read and write them by their symbols). It connects to 192.168.1.10, port 502, and for each
 * new command reads holding registers with the timeouts the command gives, then writes the
 * outcome. The chip is the one the build is for: the W5100, or with this repository's
 * `AVR_MODBUS_EXAMPLE_SHIELD=w5500` the W5500.
 *
 * `TCP_COMMAND`, written by the test: sequence number (a new one starts a request), address
 * (2 bytes, high first), quantity (1–8), response timeout in ms (2 bytes, high first),
 * retries, unit id, then milliseconds to hold the SPI (`with_spi`) right after `send`.
 *
 * `TCP_OUTCOME`, written by the firmware: the sequence number of the outcome, its kind (1
 * the registers, 2 timeout, 3 bad reply, 4 exception, 5 refused by `send`), the exception
 * code or `Error` as a number, whether connected, connections made, then the counters'
 * requests, replies, timeouts, retries and unexpected (low bytes), then the registers, high
 * byte first.
 */
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU8, Ordering::Relaxed};

use avr_modbus::master::{Failure, Request, Timeouts};
use avr_modbus::tcp::Network;
use avr_modbus::{board, millis, Error};
use panic_halt as _;

const NETWORK: Network = Network::new([0xDE, 0xAD, 0xBE, 0xEF, 0xFE, 0x03], [192, 168, 1, 177]);
const SERVER: [u8; 4] = [192, 168, 1, 10];

#[cfg(not(example_shield = "w5500"))]
avr_modbus::tcp_client!(CLIENT: avr_modbus::tcp::W5100, 32);
#[cfg(example_shield = "w5500")]
avr_modbus::tcp_client!(CLIENT: avr_modbus::tcp::W5500, 32);

#[allow(clippy::declare_interior_mutable_const)]
const ZERO: AtomicU8 = AtomicU8::new(0);
/// The test's command (see the header). Exported by name (`no_mangle`, which the lint
/// counts as unsafe: no other symbol of the firmware has these names) for the tests.
#[allow(unsafe_code)]
#[no_mangle]
static TCP_COMMAND: [AtomicU8; 9] = [ZERO; 9];
/// The firmware's outcome (see the header).
#[allow(unsafe_code)]
#[no_mangle]
static TCP_OUTCOME: [AtomicU8; 32] = [ZERO; 32];

/// Where the registers start in `TCP_OUTCOME`.
const VALUES: usize = 11;

fn put(at: usize, byte: u8) {
    TCP_OUTCOME[at].store(byte, Relaxed);
}

fn get(at: usize) -> u8 {
    TCP_COMMAND[at].load(Relaxed)
}

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else { board::halt(Error::AlreadyStarted) };
    if let Err(error) = CLIENT.start(NETWORK, SERVER, 502, dp.SPI, dp.TC0) {
        board::halt(error);
    }
    let mut started = 0u8;
    loop {
        let seq = get(0);
        if seq != started && !CLIENT.is_busy() {
            let word = |at: usize| u16::from_be_bytes([get(at), get(at + 1)]);
            CLIENT.set_timeouts(Timeouts { response_ms: word(4), turnaround_ms: 0, retries: get(6) });
            let request = Request::ReadHoldingRegisters { address: word(1), quantity: u16::from(get(3)) };
            match CLIENT.send(get(7), &request) {
                Ok(()) => {
                    started = seq;
                    let hold = u32::from(get(8));
                    if hold != 0 {
                        // The SPI is the application's meanwhile: nothing goes out.
                        CLIENT.with_spi(|| {
                            let since = millis();
                            while millis().wrapping_sub(since) < hold {}
                        });
                    }
                }
                // Not connected yet: asked again at the next turn.
                Err(Error::NotConnected) => {}
                Err(error) => {
                    started = seq;
                    put(1, 5);
                    put(2, error as u8);
                    put(0, seq);
                }
            }
        }
        CLIENT.poll(|outcome| {
            let (kind, code) = match outcome {
                Ok(reply) => {
                    for (i, value) in reply.registers().take(8).enumerate() {
                        let [high, low] = value.to_be_bytes();
                        put(VALUES + 2 * i, high);
                        put(VALUES + 2 * i + 1, low);
                    }
                    (1, 0)
                }
                Err(Failure::Timeout) => (2, 0),
                Err(Failure::BadReply) => (3, 0),
                Err(Failure::Exception(exception)) => (4, exception.code()),
            };
            put(1, kind);
            put(2, code);
            put(0, started);
        });
        let counters = CLIENT.counters();
        put(3, u8::from(CLIENT.is_connected()));
        put(4, CLIENT.connections() as u8);
        for (i, count) in
            [counters.requests, counters.replies, counters.timeouts, counters.retries, counters.unexpected]
                .into_iter()
                .enumerate()
        {
            put(5 + i, count as u8);
        }
    }
}
