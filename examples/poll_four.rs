/*!
 * The Arduino masters' benchmark sketch (`make bench` sets its size beside theirs): every
 * 100 ms one request to slave 1, in turn FC 03 (holding registers 0–9), FC 16 (registers
 * 10–11 = the first two values read), FC 01 (coils 0–7) and FC 05 (coil 8 = coil 0 read),
 * the loop never waiting for the line.
 *
 * Wiring: Uno pins 0 (RX) and 1 (TX) to a MAX3232 board or an RS-485 transceiver, GND to GND.
 *
 * Serial line: 19200 bps, 8E1; response timeout 1000 ms, one retry (the defaults).
 */
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]

use avr_modbus::master::Request;
use avr_modbus::{board, millis, FunctionCode, Line, Parity, SlaveId, StopBits};
use panic_halt as _;

const LINE: Line = Line::new(19_200, Parity::Even, StopBits::One);

// FC 3 × 10 is answered in 25 bytes; FC 16 × 2 takes 13.
avr_modbus::master!(MASTER: 25);

#[avr_device::entry]
fn main() -> ! {
    let Some(dp) = avr_device::atmega328p::Peripherals::take() else {
        avr_modbus::board::halt(avr_modbus::Error::AlreadyStarted)
    };
    if let Err(error) = MASTER.start(LINE, dp.USART0, dp.TC0) {
        board::halt(error);
    }
    let mut registers = [0u16; 10];
    let mut coils = [false; 8];
    let mut step = 0u8;
    let mut last = 0;
    loop {
        MASTER.poll(|outcome| match outcome {
            Ok(reply) if reply.function() == FunctionCode::ReadHoldingRegisters => {
                for (slot, value) in registers.iter_mut().zip(reply.registers()) {
                    *slot = value;
                }
            }
            Ok(reply) if reply.function() == FunctionCode::ReadCoils => {
                for (i, coil) in coils.iter_mut().enumerate() {
                    *coil = reply.bit(i) == Some(true);
                }
            }
            _ => {}
        });
        let now = millis();
        if now.wrapping_sub(last) >= 100 {
            last = now;
            let pair = [registers[0], registers[1]];
            let request = match step {
                0 => Request::ReadHoldingRegisters { address: 0, quantity: 10 },
                1 => Request::WriteMultipleRegisters { address: 10, values: &pair },
                2 => Request::ReadCoils { address: 0, quantity: 8 },
                _ => Request::WriteSingleCoil { address: 8, value: coils[0] },
            };
            if MASTER.send(SlaveId::new(1), &request).is_ok() {
                step = (step + 1) % 4;
            }
        }
    }
}
