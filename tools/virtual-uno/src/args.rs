//! Command-line options.

use std::path::PathBuf;

use uno_sim::wiznet::Mapping;
use uno_sim::{Chip, Wiznet};

use crate::control::Command;
use crate::pin_wire::{HiddenFrame, PinName};

/// Usage text for `--help` and errors.
pub const USAGE: &str = "\
usage: virtual-uno [OPTIONS] FIRMWARE.elf
       virtual-uno --bootloader FILE.hex --state DIR [OPTIONS] [FIRMWARE.elf]

Runs the firmware on a simulated Arduino Uno (simavr, 16 MHz) paced to real time, with
USART0 on a pseudo-terminal: open the printed /dev/pts/N (or the --link) with any Modbus
master, at the firmware's baud rate and frame format. A firmware built for another chip
(ATmega168, 32U4, 1280, 2560) runs on that chip, its serial line on --usart.

With --bootloader it is a whole board: the chip starts the bootloader at every reset, and
a program opening the port resets it, as DTR does on a real Uno or Mega, so avrdude (and
ravedude, `cargo run`) flash it through the port. --state keeps its flash and EEPROM in a
directory, as a chip keeps them unplugged; without a FIRMWARE.elf it runs what DIR holds.

options:
  --link PATH      make PATH a symlink to the pty (removed on exit), e.g. /tmp/ttyUNO
  --chip NAME      the chip: atmega328p, atmega168, atmega32u4, atmega1280, atmega2560
                   (default: the one the ELF file names, else atmega328p)
  --usart N        the USART on the pty (default: USART0, on the ATmega32U4 USART1)
  --bootloader F   program the bootloader in Intel HEX file F into its boot section and
                   start it at every reset (BOOTRST); opening the port resets the board
  --no-auto-reset  opening the port does not reset the board (a real board with a 10 uF
                   capacitor from RESET to GND); the default without --bootloader
  --state DIR      keep the flash (DIR/flash.bin) and EEPROM (DIR/eeprom.bin) across resets
                   and restarts; a FIRMWARE.elf given replaces the program, as a programmer
  --pin N=0|1|z    drive input pin N low, high, or release it, from the start (repeatable)
  --adc A0=MV      put MV millivolts (0-5000) on an analog input from the start (repeatable)
  --control PATH   read commands from PATH, a FIFO (created if missing, then removed)
  --no-stdin       do not read commands from standard input
  --watch LIST     output pins to print when they change, with the simulated time
                   (`pins: 13=on 2=off ... (at 12.345 s)`; default 13,2,3,4,5 on the
                   Uno's chips, none on the others; `none`)
  --wiznet CHIP    an Ethernet shield on the SPI port: w5100 or w5500, its chip select on
                   the board's pin 10 (PB2 on the Uno, PB4 on the Megas)
  --cs PORTBIT     the shield's chip select on another pin, e.g. PB4
  --tcp CHIP:HOST  bridge the chip's TCP port CHIP to 127.0.0.1:HOST (repeatable; e.g.
                   502:1502); printed as `tcp: 127.0.0.1:HOST` once the firmware listens
  --connect CHIP:HOST  bridge the firmware's connections to port CHIP (any address) to
                   127.0.0.1:HOST, a server on the host (repeatable; e.g. 502:1502)
  --udp CHIP:HOST  bridge the chip's UDP port CHIP to 127.0.0.1:HOST (repeatable): each
                   datagram to HOST goes to the firmware's UDP socket on CHIP, its answers
                   back to the sender; printed as `udp: 127.0.0.1:HOST` once the socket opens
  --dhcp LEASE     play the network's DHCP server: a DHCP firmware (feature `dhcp`) gets
                   192.168.50.23/24 for LEASE seconds, renewed as it asks; printed as
                   `dhcp: DISCOVER to 255.255.255.255:67, answered OFFER 192.168.50.23`
  --pins RX,TX     a serial line on two pins, on a pty of its own (printed as `pin line:`):
                   a UART the firmware builds from a timer (feature capture-line: 8,9 on
                   the Uno, PL1,PL3 on the Mega, PC7,PC6 on the Leonardo). Pins are Uno
                   numbers or port pins (PB0). The master's bytes reach RX at its termios
                   rate, stop bits and odd parity; TX is read at the same settings
  --pins-link PATH make PATH a symlink to the pins' pty, e.g. /tmp/ttyPINS
  --pins-frame F   what a pty hides of the master's frame, its data bits and even parity
                   (it shows 8N1 for 8E1 and 7E1): 8E (default, Modbus RTU), 8N, 7E or 7N
  --messages       print each Modbus TCP (and UDP) request and answer through the bridge (connection,
                   transaction id, unit id, function code, the bytes)
  -h, --help       this text

Pin numbers (--pin, --watch, `pin`) are the Uno's (0-13, A0-A5) and work on the ATmega328P
and ATmega168 only.

commands (stdin or --control), one per line:
  pin 6 0 | pin 6 1 | pin 6 z    drive or release an input pin
  adc A0 2500                    set an analog input, in mV
  pins                           print the watched pins now
  reset                          press the reset button
  link down | link up            pull the shield's cable, plug it back (--wiznet)
  chip reset                     reset the shield's chip alone (its defaults, sockets closed)
  chip hang [ff|00] | chip unhang  the chip answers nothing (MISO stuck), then again
";

/// What the command line asked for.
#[derive(Debug)]
pub struct Args {
    /// The firmware; `None`: what `--state` holds, else erased flash.
    pub elf: Option<PathBuf>,
    /// `--bootloader`.
    pub bootloader: Option<PathBuf>,
    /// Reset when a program opens the port: with `--bootloader`, unless `--no-auto-reset`.
    pub auto_reset: bool,
    /// `--state`.
    pub state: Option<PathBuf>,
    /// `--link`.
    pub link: Option<PathBuf>,
    /// `--chip`.
    pub chip: Option<Chip>,
    /// `--usart`.
    pub usart: Option<u8>,
    /// `--pin` and `--adc`, in order.
    pub initial: Vec<Command>,
    /// `--control`.
    pub control: Option<PathBuf>,
    /// Not `--no-stdin`.
    pub stdin: bool,
    /// `--watch`; `None`: the default for the chip.
    pub watch: Option<Vec<u8>>,
    /// `--wiznet`.
    pub wiznet: Option<Wiznet>,
    /// `--cs`.
    pub cs: Option<(char, u8)>,
    /// `--tcp`, in order.
    pub tcp: Vec<Mapping>,
    /// `--connect`, in order.
    pub connect: Vec<Mapping>,
    /// `--udp`, in order.
    pub udp: Vec<Mapping>,
    /// `--messages`.
    pub messages: bool,
    /// `--dhcp`: the lease, seconds.
    pub dhcp: Option<u32>,
    /// `--pins`: RX and TX.
    pub pins: Option<(PinName, PinName)>,
    /// `--pins-link`.
    pub pins_link: Option<PathBuf>,
    /// `--pins-frame`, else Modbus RTU's 8E.
    pub pins_frame: HiddenFrame,
}

/// The pins watched when `--watch` is not given: the Uno's LED and pins 2-5, on the chips
/// wired like the Uno.
pub fn default_watch(chip: Chip) -> Vec<u8> {
    if chip.has_uno_pinout() {
        vec![13, 2, 3, 4, 5]
    } else {
        Vec::new()
    }
}

/// `Err(None)` for `--help`, `Err(Some(message))` for a mistake.
pub fn parse(mut words: impl Iterator<Item = String>) -> Result<Args, Option<String>> {
    let mut args = Args {
        elf: None,
        bootloader: None,
        auto_reset: true,
        state: None,
        link: None,
        chip: None,
        usart: None,
        initial: Vec::new(),
        control: None,
        stdin: true,
        watch: None,
        wiznet: None,
        cs: None,
        tcp: Vec::new(),
        connect: Vec::new(),
        udp: Vec::new(),
        messages: false,
        dhcp: None,
        pins: None,
        pins_link: None,
        pins_frame: HiddenFrame::RTU,
    };
    let mut pins_frame = None;
    let mut elf = None;
    while let Some(word) = words.next() {
        let mut value = || words.next().ok_or_else(|| Some(format!("{word} needs a value")));
        match word.as_str() {
            "-h" | "--help" => return Err(None),
            "--link" => args.link = Some(value()?.into()),
            "--chip" => args.chip = Some(value()?.parse::<Chip>().map_err(|e| Some(format!("--chip: {e}")))?),
            "--usart" => args.usart = Some(parse_usart(&value()?).map_err(Some)?),
            "--pin" => args.initial.push(Command::parse_pin_option(&value()?).map_err(Some)?),
            "--adc" => args.initial.push(Command::parse_adc_option(&value()?).map_err(Some)?),
            "--control" => args.control = Some(value()?.into()),
            "--no-stdin" => args.stdin = false,
            "--bootloader" => args.bootloader = Some(value()?.into()),
            "--no-auto-reset" => args.auto_reset = false,
            "--state" => args.state = Some(value()?.into()),
            "--watch" => args.watch = Some(parse_watch(&value()?).map_err(Some)?),
            "--wiznet" => args.wiznet = Some(value()?.parse::<Wiznet>().map_err(|e| Some(format!("--wiznet: {e}")))?),
            "--cs" => {
                let text = value()?;
                args.cs =
                    Some(parse_port_pin(&text).ok_or_else(|| Some(format!("--cs: `{text}` is no pin such as PB2")))?);
            }
            "--pins" => args.pins = Some(parse_pins(&value()?).map_err(Some)?),
            "--pins-link" => args.pins_link = Some(value()?.into()),
            "--pins-frame" => pins_frame = Some(value()?.parse::<HiddenFrame>().map_err(Some)?),
            "--messages" => args.messages = true,
            "--tcp" => args.tcp.push(value()?.parse::<Mapping>().map_err(|e| Some(format!("--tcp: {e}")))?),
            "--connect" => args.connect.push(value()?.parse::<Mapping>().map_err(|e| Some(format!("--connect: {e}")))?),
            "--dhcp" => args.dhcp = Some(value()?.parse::<u32>().map_err(|e| Some(format!("--dhcp: {e}")))?),
            "--udp" => args.udp.push(value()?.parse::<Mapping>().map_err(|e| Some(format!("--udp: {e}")))?),
            w if w.starts_with('-') => return Err(Some(format!("unknown option {w}"))),
            _ if elf.is_some() => return Err(Some(format!("one firmware file only (got {word} too)"))),
            _ => elf = Some(PathBuf::from(word)),
        }
    }
    if elf.is_none() && args.bootloader.is_none() && args.state.is_none() {
        return Err(Some("no firmware file given".to_owned()));
    }
    let bridged = !args.tcp.is_empty() || !args.connect.is_empty() || !args.udp.is_empty();
    if args.wiznet.is_none() && (bridged || args.cs.is_some() || args.dhcp.is_some()) {
        return Err(Some("--tcp, --connect, --udp, --dhcp and --cs need a shield: --wiznet w5100 or w5500".to_owned()));
    }
    if args.messages && !bridged {
        return Err(Some("--messages needs a bridge: --tcp 502:1502, --connect 502:1502 or --udp 502:1502".to_owned()));
    }
    if args.pins.is_none() && (args.pins_link.is_some() || pins_frame.is_some()) {
        return Err(Some("--pins-link and --pins-frame need a line on two pins: --pins 8,9".to_owned()));
    }
    args.pins_frame = pins_frame.unwrap_or(HiddenFrame::RTU);
    args.elf = elf;
    args.auto_reset &= args.bootloader.is_some();
    Ok(args)
}

fn parse_usart(text: &str) -> Result<u8, String> {
    text.parse::<u8>().ok().filter(|&n| n <= 3).ok_or_else(|| format!("--usart: `{text}` is not 0, 1, 2 or 3"))
}

/// `PB4` (or `B4`): port letter and bit.
fn parse_port_pin(text: &str) -> Option<(char, u8)> {
    let t = text.trim().to_ascii_uppercase();
    let t = t.strip_prefix('P').unwrap_or(&t);
    let mut chars = t.chars();
    match (chars.next(), chars.as_str().parse::<u8>()) {
        (Some(port @ 'A'..='L'), Ok(bit)) if bit < 8 => Some((port, bit)),
        _ => None,
    }
}

/// `8,9` or `PL1,PL3`: the RX and TX pins of `--pins`.
fn parse_pins(text: &str) -> Result<(PinName, PinName), String> {
    let pin = |p: &str| match p.trim().parse::<u8>() {
        Ok(n) if n <= 19 => Some(PinName::Uno(n)),
        Ok(_) => None,
        Err(_) => parse_port_pin(p).map(|(port, bit)| PinName::Port(port, bit)),
    };
    match text.split_once(',') {
        Some((rx, tx)) => match (pin(rx), pin(tx)) {
            (Some(rx), Some(tx)) if rx != tx => Ok((rx, tx)),
            _ => Err(format!("--pins: `{text}` is not two pins RX,TX such as 8,9 or PL1,PL3")),
        },
        None => Err(format!("--pins: `{text}` is not two pins RX,TX such as 8,9 or PL1,PL3")),
    }
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
        assert_eq!(a.elf, Some(PathBuf::from("fw.elf")));
        assert!(!a.auto_reset, "no auto-reset without a bootloader");
        assert_eq!(a.link, Some(PathBuf::from("/tmp/ttyUNO")));
        assert_eq!(a.initial, vec![Command::Pin(10, Some(false)), Command::Adc(0, 2500)]);
        assert_eq!(a.watch, Some(vec![13, 2]));
        assert_eq!((a.chip, a.usart), (None, None));
        assert!(a.stdin);
    }

    #[test]
    fn chip_and_usart() {
        let a = parse(words("--chip atmega2560 --usart 1 fw.elf")).unwrap();
        assert_eq!((a.chip, a.usart, a.watch), (Some(Chip::Atmega2560), Some(1), None));
        assert!(parse(words("--chip atmega4809 fw.elf")).unwrap_err().unwrap().contains("unsupported chip"));
        assert_eq!(parse(words("--usart 4 fw.elf")).unwrap_err(), Some("--usart: `4` is not 0, 1, 2 or 3".into()));
        assert_eq!(default_watch(Chip::Atmega168), [13, 2, 3, 4, 5]);
        assert!(default_watch(Chip::Atmega32u4).is_empty());
    }

    #[test]
    fn a_board_with_a_bootloader_resets_when_the_port_opens() {
        let a = parse(words("--bootloader boot.hex --state dir")).unwrap();
        assert_eq!((a.elf, a.auto_reset), (None, true));
        assert_eq!(a.state, Some(PathBuf::from("dir")));
        let a = parse(words("--bootloader boot.hex --no-auto-reset fw.elf")).unwrap();
        assert_eq!((a.elf, a.auto_reset), (Some(PathBuf::from("fw.elf")), false));
    }

    #[test]
    fn a_shield_with_bridged_ports() {
        let a = parse(words("--wiznet w5500 --tcp 502:1502 --tcp 80 --cs PB4 fw.elf")).unwrap();
        assert_eq!(a.wiznet, Some(Wiznet::W5500));
        assert_eq!(a.cs, Some(('B', 4)));
        assert_eq!(a.tcp, [Mapping { chip_port: 502, host_port: 1502 }, Mapping { chip_port: 80, host_port: 80 }]);
        assert!(parse(words("--tcp 502:1502 fw.elf")).unwrap_err().unwrap().contains("need a shield"));
        let a = parse(words("--wiznet w5100 --connect 502:1502 fw.elf")).unwrap();
        assert_eq!(a.connect, [Mapping { chip_port: 502, host_port: 1502 }]);
        assert!(parse(words("--connect 502:1502 fw.elf")).unwrap_err().unwrap().contains("need a shield"));
        assert!(parse(words("--wiznet w5100 --connect 502:1502 --messages fw.elf")).unwrap().messages);
        assert!(parse(words("--wiznet w5300 fw.elf")).unwrap_err().unwrap().contains("w5300"));
        assert!(parse(words("--wiznet w5100 --cs PB9 fw.elf")).unwrap_err().unwrap().contains("PB9"));
        assert!(parse(words("--wiznet w5100 --tcp 0:1 fw.elf")).is_err());
        assert_eq!(parse(words("fw.elf")).unwrap().wiznet, None);
        assert!(parse(words("--wiznet w5100 --tcp 502:1502 --messages fw.elf")).unwrap().messages);
        assert!(parse(words("--wiznet w5100 --messages fw.elf")).unwrap_err().unwrap().contains("needs a bridge"));
        let a = parse(words("--wiznet w5100 --udp 502:1502 --messages fw.elf")).unwrap();
        assert_eq!((a.udp[0], a.messages), (Mapping { chip_port: 502, host_port: 1502 }, true));
        assert!(parse(words("--udp 502:1502 fw.elf")).unwrap_err().unwrap().contains("need a shield"));
    }

    #[test]
    fn a_line_on_two_pins_with_its_own_pty() {
        let a = parse(words("--link /tmp/ttyUNO --pins 8,9 --pins-link /tmp/ttyPINS gateway.elf")).unwrap();
        assert_eq!(a.pins, Some((PinName::Uno(8), PinName::Uno(9))));
        assert_eq!(a.pins_link, Some(PathBuf::from("/tmp/ttyPINS")));
        assert_eq!(a.pins_frame, HiddenFrame::RTU);
        let a = parse(words("--pins PL1,pl3 --pins-frame 7E fw.elf")).unwrap();
        assert_eq!(a.pins, Some((PinName::Port('L', 1), PinName::Port('L', 3))));
        assert_eq!(a.pins_frame, HiddenFrame { data_bits: 7, parity: uno_sim::Parity::Even });
        assert_eq!(parse(words("fw.elf")).unwrap().pins, None);
        for bad in ["8", "8,8", "8,20", "8,PM0", "8,9,10"] {
            let msg = parse(words(&format!("--pins {bad} fw.elf"))).unwrap_err().unwrap();
            assert!(msg.contains(&format!("`{bad}`")), "{bad}: {msg}");
        }
        assert!(parse(words("--pins-link /tmp/ttyPINS fw.elf")).unwrap_err().unwrap().contains("--pins 8,9"));
        assert!(parse(words("--pins-frame 8N fw.elf")).unwrap_err().unwrap().contains("--pins 8,9"));
        assert!(parse(words("--pins 8,9 --pins-frame 8O fw.elf")).unwrap_err().unwrap().contains("8O"));
    }

    #[test]
    fn mistakes_are_reported() {
        assert_eq!(parse(words("")).unwrap_err(), Some("no firmware file given".into()));
        assert_eq!(parse(words("fw.elf --link")).unwrap_err(), Some("--link needs a value".into()));
        assert!(parse(words("--frobnicate fw.elf")).is_err());
        assert!(parse(words("--help")).unwrap_err().is_none());
    }
}
