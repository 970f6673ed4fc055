//! Commands that change the Uno's inputs while it runs, one per line (stdin or `--control`):
//!
//! ```text
//! pin 6 0        drive pin 6 low (a closed switch to GND)
//! pin 6 1        drive pin 6 high
//! pin 6 z        release pin 6 (reads its pull-up, or low)
//! adc A0 2500    put 2500 mV on A0 (also `adc 0 2500`)
//! pins           print the watched output pins now
//! reset          press the reset button (the board restarts, through its bootloader if it has one)
//! link down      pull the shield's cable (--wiznet): nothing arrives, nothing sent arrives
//! link up        plug it back
//! chip reset     reset the shield's chip alone (a brown-out): its registers to their defaults
//! chip hang ff   the chip answers nothing: MISO stuck at 0xFF (or 00), writes ignored
//! chip unhang    the chip answers again, as it was
//! ```
//!
//! The start-up options use the same values: `--pin 6=0`, `--adc A0=2500`.

use uno_sim::{Error, Uno, A0};

/// One command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// Drive an Arduino pin (0-19) high, low, or release it (`None`).
    Pin(u8, Option<bool>),
    /// Millivolts on an ADC channel (0-7).
    Adc(u8, u32),
    /// Print the watched pins.
    ShowPins,
    /// Press the reset button.
    Reset,
    /// A fault of the shield's chip (`--wiznet`).
    Chip(Fault),
}

/// A fault of the simulated Ethernet chip, while the board runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The link goes down (`true`) or comes back.
    Link(bool),
    /// The chip resets by itself: registers to their defaults, sockets closed.
    Reset,
    /// The chip hangs, MISO stuck at this value.
    Hang(u8),
    /// The chip answers again.
    Unhang,
}

/// Usage of the commands, for error messages.
pub const USAGE: &str =
    "commands: pin N 0|1|z, adc A0..A5 MV, pins, reset, link down|up, chip reset|hang [00|ff]|unhang";

impl Command {
    /// Parses one command line; `Ok(None)` for a blank line or a `#` comment.
    pub fn parse(line: &str) -> Result<Option<Command>, String> {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [] => Ok(None),
            [first, ..] if first.starts_with('#') => Ok(None),
            ["pin", pin, level] => Ok(Some(Command::Pin(parse_pin(pin)?, parse_level(level)?))),
            ["adc", channel, mv] => Ok(Some(Command::Adc(parse_channel(channel)?, parse_mv(mv)?))),
            ["pins"] => Ok(Some(Command::ShowPins)),
            ["reset"] => Ok(Some(Command::Reset)),
            ["link", "down"] => Ok(Some(Command::Chip(Fault::Link(false)))),
            ["link", "up"] => Ok(Some(Command::Chip(Fault::Link(true)))),
            ["chip", "reset"] => Ok(Some(Command::Chip(Fault::Reset))),
            ["chip", "hang"] => Ok(Some(Command::Chip(Fault::Hang(0xFF)))),
            ["chip", "hang", miso] => Ok(Some(Command::Chip(Fault::Hang(parse_miso(miso)?)))),
            ["chip", "unhang"] => Ok(Some(Command::Chip(Fault::Unhang))),
            _ => Err(format!("cannot understand `{}` ({USAGE})", line.trim())),
        }
    }

    /// Parses the value of `--pin N=LEVEL`.
    pub fn parse_pin_option(value: &str) -> Result<Command, String> {
        let (pin, level) = value.split_once('=').ok_or_else(|| format!("--pin {value}: expected N=0|1|z"))?;
        Ok(Command::Pin(parse_pin(pin)?, parse_level(level)?))
    }

    /// Parses the value of `--adc CHANNEL=MILLIVOLTS`.
    pub fn parse_adc_option(value: &str) -> Result<Command, String> {
        let (channel, mv) = value.split_once('=').ok_or_else(|| format!("--adc {value}: expected A0=2500 (mV)"))?;
        Ok(Command::Adc(parse_channel(channel)?, parse_mv(mv)?))
    }

    /// Applies an input command to the simulated board (`ShowPins` does nothing here).
    pub fn apply(self, uno: &mut Uno) -> Result<(), Error> {
        match self {
            Command::Pin(pin, level) => uno.drive_pin(pin, level),
            Command::Adc(channel, mv) => uno.set_analog_mv(channel, mv),
            Command::Reset => {
                uno.hard_reset(uno_sim::ResetCause::External);
                Ok(())
            }
            Command::ShowPins => Ok(()),
            Command::Chip(fault) => {
                if let Some(chip) = uno.wiznet_mut() {
                    match fault {
                        Fault::Link(up) => chip.set_link(up),
                        Fault::Reset => chip.reset(),
                        Fault::Hang(miso) => chip.hang(miso),
                        Fault::Unhang => chip.unhang(),
                    }
                }
                Ok(())
            }
        }
    }
}

/// What a hung chip's MISO reads: `00` or `ff` (`0x` before it allowed).
fn parse_miso(text: &str) -> Result<u8, String> {
    match text.trim_start_matches("0x").to_ascii_lowercase().as_str() {
        "00" | "0" => Ok(0x00),
        "ff" => Ok(0xFF),
        _ => Err(format!("`{text}`: a hung chip reads 00 or ff")),
    }
}

/// `13`, or `A0`-`A5` for pins 14-19.
fn parse_pin(text: &str) -> Result<u8, String> {
    let pin = match text.strip_prefix(['A', 'a']) {
        Some(n) => n.parse::<u8>().ok().filter(|&n| n <= 5).map(|n| A0 + n),
        None => text.parse::<u8>().ok().filter(|&n| n <= 19),
    };
    pin.ok_or_else(|| format!("`{text}` is not an Uno pin (0-13, A0-A5)"))
}

fn parse_level(text: &str) -> Result<Option<bool>, String> {
    match text {
        "0" | "low" => Ok(Some(false)),
        "1" | "high" => Ok(Some(true)),
        "z" | "Z" | "release" => Ok(None),
        _ => Err(format!("`{text}` is not a level (0, 1 or z)")),
    }
}

/// `A0`-`A5` or `0`-`7`.
fn parse_channel(text: &str) -> Result<u8, String> {
    let channel = match text.strip_prefix(['A', 'a']) {
        Some(n) => n.parse::<u8>().ok().filter(|&n| n <= 5),
        None => text.parse::<u8>().ok().filter(|&n| n <= 7),
    };
    channel.ok_or_else(|| format!("`{text}` is not an analog input (A0-A5)"))
}

fn parse_mv(text: &str) -> Result<u32, String> {
    text.trim_end_matches("mV")
        .parse::<u32>()
        .ok()
        .filter(|&mv| mv <= 5000)
        .ok_or_else(|| format!("`{text}` is not a voltage in mV (0-5000)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse() {
        assert_eq!(Command::parse("pin 6 0"), Ok(Some(Command::Pin(6, Some(false)))));
        assert_eq!(Command::parse("  pin A1 z "), Ok(Some(Command::Pin(15, None))));
        assert_eq!(Command::parse("adc A0 2500"), Ok(Some(Command::Adc(0, 2500))));
        assert_eq!(Command::parse("adc 2 5000"), Ok(Some(Command::Adc(2, 5000))));
        assert_eq!(Command::parse("pins"), Ok(Some(Command::ShowPins)));
        assert_eq!(Command::parse("link down"), Ok(Some(Command::Chip(Fault::Link(false)))));
        assert_eq!(Command::parse("link up"), Ok(Some(Command::Chip(Fault::Link(true)))));
        assert_eq!(Command::parse("chip reset"), Ok(Some(Command::Chip(Fault::Reset))));
        assert_eq!(Command::parse("chip hang"), Ok(Some(Command::Chip(Fault::Hang(0xFF)))));
        assert_eq!(Command::parse("chip hang 00"), Ok(Some(Command::Chip(Fault::Hang(0x00)))));
        assert_eq!(Command::parse("chip hang 0xFF"), Ok(Some(Command::Chip(Fault::Hang(0xFF)))));
        assert_eq!(Command::parse("chip unhang"), Ok(Some(Command::Chip(Fault::Unhang))));
        assert_eq!(Command::parse("# a comment"), Ok(None));
        assert_eq!(Command::parse(""), Ok(None));
    }

    #[test]
    fn bad_commands_say_why() {
        assert!(Command::parse("pin 20 0").unwrap_err().contains("not an Uno pin"));
        assert!(Command::parse("adc A6 100").unwrap_err().contains("not an analog input"));
        assert!(Command::parse("adc A0 6000").unwrap_err().contains("0-5000"));
        assert!(Command::parse("led 13").unwrap_err().contains("commands:"));
        assert!(Command::parse("chip hang 7f").unwrap_err().contains("00 or ff"));
        assert!(Command::parse("link sideways").unwrap_err().contains("commands:"));
    }

    #[test]
    fn options_parse() {
        assert_eq!(Command::parse_pin_option("10=0"), Ok(Command::Pin(10, Some(false))));
        assert_eq!(Command::parse_adc_option("A0=2500"), Ok(Command::Adc(0, 2500)));
        assert!(Command::parse_pin_option("10").is_err());
    }
}
