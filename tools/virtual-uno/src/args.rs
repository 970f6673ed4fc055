//! Command-line options.

use std::path::PathBuf;

use crate::control::Command;

/// Usage text for `--help` and errors.
pub const USAGE: &str = "\
usage: virtual-uno [OPTIONS] FIRMWARE.elf

Runs the firmware on a simulated Arduino Uno (simavr, 16 MHz) paced to real time, with
USART0 on a pseudo-terminal: open the printed /dev/pts/N (or the --link) with any Modbus
master, at the firmware's baud rate and frame format.

options:
  --link PATH      make PATH a symlink to the pty (removed on exit), e.g. /tmp/ttyUNO
  --pin N=0|1|z    drive input pin N low, high, or release it, from the start (repeatable)
  --adc A0=MV      put MV millivolts (0-5000) on an analog input from the start (repeatable)
  --control PATH   read commands from PATH, a FIFO (created if missing, then removed)
  --no-stdin       do not read commands from standard input
  --watch LIST     output pins to print when they change (default 13,2,3,4,5; `none`)
  -h, --help       this text

commands (stdin or --control), one per line:
  pin 6 0 | pin 6 1 | pin 6 z    drive or release an input pin
  adc A0 2500                    set an analog input, in mV
  pins                           print the watched pins now
";

/// What the command line asked for.
#[derive(Debug)]
pub struct Args {
    /// The firmware.
    pub elf: PathBuf,
    /// `--link`.
    pub link: Option<PathBuf>,
    /// `--pin` and `--adc`, in order.
    pub initial: Vec<Command>,
    /// `--control`.
    pub control: Option<PathBuf>,
    /// Not `--no-stdin`.
    pub stdin: bool,
    /// `--watch`.
    pub watch: Vec<u8>,
}

/// `Err(None)` for `--help`, `Err(Some(message))` for a mistake.
pub fn parse(mut words: impl Iterator<Item = String>) -> Result<Args, Option<String>> {
    let mut args = Args {
        elf: PathBuf::new(),
        link: None,
        initial: Vec::new(),
        control: None,
        stdin: true,
        watch: vec![13, 2, 3, 4, 5],
    };
    let mut elf = None;
    while let Some(word) = words.next() {
        let mut value = || words.next().ok_or_else(|| Some(format!("{word} needs a value")));
        match word.as_str() {
            "-h" | "--help" => return Err(None),
            "--link" => args.link = Some(value()?.into()),
            "--pin" => args.initial.push(Command::parse_pin_option(&value()?).map_err(Some)?),
            "--adc" => args.initial.push(Command::parse_adc_option(&value()?).map_err(Some)?),
            "--control" => args.control = Some(value()?.into()),
            "--no-stdin" => args.stdin = false,
            "--watch" => args.watch = parse_watch(&value()?).map_err(Some)?,
            w if w.starts_with('-') => return Err(Some(format!("unknown option {w}"))),
            _ if elf.is_some() => return Err(Some(format!("one firmware file only (got {word} too)"))),
            _ => elf = Some(PathBuf::from(word)),
        }
    }
    args.elf = elf.ok_or_else(|| Some("no firmware file given".to_owned()))?;
    Ok(args)
}

fn parse_watch(list: &str) -> Result<Vec<u8>, String> {
    if list == "none" || list.is_empty() {
        return Ok(Vec::new());
    }
    list.split(',')
        .map(|p| p.trim().parse::<u8>().ok().filter(|&p| p <= 19).ok_or_else(|| format!("--watch: bad pin `{p}`")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> impl Iterator<Item = String> + '_ {
        s.split_whitespace().map(str::to_owned)
    }

    #[test]
    fn options_and_firmware() {
        let a = parse(words("--link /tmp/ttyUNO --pin 10=0 --adc A0=2500 fw.elf --watch 13,2")).unwrap();
        assert_eq!(a.elf, PathBuf::from("fw.elf"));
        assert_eq!(a.link, Some(PathBuf::from("/tmp/ttyUNO")));
        assert_eq!(a.initial, vec![Command::Pin(10, Some(false)), Command::Adc(0, 2500)]);
        assert_eq!(a.watch, vec![13, 2]);
        assert!(a.stdin);
    }

    #[test]
    fn mistakes_are_reported() {
        assert_eq!(parse(words("")).unwrap_err(), Some("no firmware file given".into()));
        assert_eq!(parse(words("fw.elf --link")).unwrap_err(), Some("--link needs a value".into()));
        assert!(parse(words("--frobnicate fw.elf")).is_err());
        assert!(parse(words("--help")).unwrap_err().is_none());
    }
}
