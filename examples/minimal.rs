//! placeholder
#![no_std]
#![no_main]
#![allow(unsafe_code)]
use panic_halt as _;
#[avr_device::entry]
fn main() -> ! {
    let dp = avr_device::atmega328p::Peripherals::take().unwrap();
    let mut x = 0u8;
    loop { x = avr_modbus_slave::add(x, 1); dp.PORTB.portb().write(|w| unsafe { w.bits(x) }); }
}
