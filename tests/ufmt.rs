//! Feature `ufmt`: the types a firmware prints over arduino-hal's serial implement
//! `ufmt::uDebug` and print like `core::fmt::Debug` would.

use avr_modbus::{Config, Error, Exception, FunctionCode, Parity, Reference, SlaveCounters, SlaveId, StopBits, Table};
use ufmt::{uDebug, uWrite};

/// A `uWrite` into a `String`, standing in for a serial port.
struct Text(String);

impl uWrite for Text {
    type Error = core::convert::Infallible;

    fn write_str(&mut self, s: &str) -> Result<(), Self::Error> {
        self.0.push_str(s);
        Ok(())
    }
}

fn printed(value: &impl uDebug) -> String {
    let mut out = Text(String::new());
    ufmt::uwrite!(out, "{:?}", value).unwrap();
    out.0
}

#[test]
fn counters_print_every_field() {
    let counters = SlaveCounters { frames: 3, crc_errors: 1, ..SlaveCounters::new() };
    let text = printed(&counters);
    assert!(text.starts_with("SlaveCounters { frames: 3, crc_errors: 1, uart_errors: 0,"), "{text}");
    assert!(text.ends_with('}'), "{text}");
}

#[test]
fn config_prints_the_line_settings() {
    let config = Config::new(7, 9600, Parity::None, StopBits::Two);
    assert_eq!(printed(&config), "Config { slave_id: 7, baud: 9600, parity: None, stop_bits: Two }");
}

#[test]
fn errors_and_exceptions_print_their_variant() {
    assert_eq!(printed(&Error::RegistersFull), "RegistersFull");
    assert_eq!(printed(&Exception::IllegalDataAddress), "IllegalDataAddress");
    assert_eq!(printed(&Exception::from_code(7).unwrap()), "Exception(7)");
    assert_eq!(printed(&FunctionCode::custom(65)), "FunctionCode(65)");
}

#[test]
fn references_print_table_and_address() {
    assert_eq!(printed(&Reference::holding_register(4)), "Reference { table: HoldingRegisters, address: 4 }");
    assert_eq!(printed(&Table::Coils), "Coils");
    assert_eq!(printed(&SlaveId::new(9)), "SlaveId(9)");
}

#[test]
fn an_error_displays_its_message_with_ufmt_and_core_fmt() {
    let mut out = Text(String::new());
    ufmt::uwrite!(out, "{}", Error::Quantity).unwrap();
    assert_eq!(out.0, "quantity outside the spec's limits");
    assert_eq!(format!("{}", Error::SlaveId), "slave id must be 1-247");
    assert_eq!(Error::Busy.to_string(), Error::Busy.message());
}
