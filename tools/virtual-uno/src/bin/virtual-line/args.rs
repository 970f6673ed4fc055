//! Command-line options of `virtual-line`.

use std::fmt;
use std::path::{Path, PathBuf};

use uno_sim::wiznet::Mapping;
use uno_sim::{Chip, Wiznet, F_CPU};

use crate::control::Command;
use crate::line::{Parity, Settings};

/// Usage text for `--help` and errors.
pub const USAGE: &str = "\
usage: virtual-line [OPTIONS] --board NAME=FIRMWARE.elf [BOARD-OPTIONS...] [--board ...] [--pty NAME[=PATH]]

Several simulated boards (simavr) and outside programs on ONE half-duplex RS-485 line, in
lockstep on simulated time: every board and pty hears every character any other puts on
the line; a board with de=PIN reaches the line only while that pin is high; two
transmitters at once garble both, and so does a board holding its DE high while another
sends. Every frame on the line is printed with its sender once 3.5 character times of
silence have ended it (`frame from master: 01 02 00 00 00 02 F9 CB`, remarks in
parentheses: COLLISION, bad CRC, characters cut by DE, a short silence); pin changes as
`tower pins: 4=on 5=off ...`. Lines start with the simulated time in seconds,
[   1.234567] (a frame's: when its first start bit began). At the end (--until, Ctrl-C,
SIGTERM): a summary line, each DE pin's timing, and the speed against real time.

options:
  --board NAME=ELF [OPT...]  a simulated board; the chip is the one the ELF names. Its
                   options follow as separate words:
                     de=PIN          the pin gating its transmitter (RS-485 DE, high =
                                     drive): an Uno pin (13), or by port and bit (PB7,
                                     a Mega's pin 13) on any chip
                     usart=N         the USART on the line (default: the chip's)
                     usartN=pty:PATH USART N (another than the line's) on a pty of its
                                     own, off the line, PATH a symlink to it: a Mega
                                     gateway's other side for a master (one a board)
                     chip=NAME       override the chip the ELF names
                     pinN=low|high|z drive input pin N from the start (e.g. pin12=low)
                     watch=LIST      pins printed when they change: 4,5,6,7 or none
                                     (default 2,3,4,5,6,7)
                     wiznet=CHIP     an Ethernet shield on its SPI port: w5100 or
                                     w5500, chip select on the board's pin 10
                     cs=PORTBIT      the shield's chip select on another pin (PB4)
                     tcp=CHIP:HOST   bridge the shield's TCP port CHIP to
                                     127.0.0.1:HOST (repeatable; e.g. 502:1502):
                                     `NAME tcp: 127.0.0.1:HOST` once the firmware
                                     listens, then each connection and each Modbus
                                     TCP request and answer (`NAME conn 127.0.0.1:PORT
                                     (socket N) request tid 0x0001 unit 1 fc 0x02 …`)
                     connect=CHIP:HOST  bridge the firmware's own connections to
                                     port CHIP (any address) to 127.0.0.1:HOST, a
                                     server on the host (repeatable; a TCP client:
                                     `NAME dialed …`, then its requests and answers)
                     udp=CHIP:HOST   bridge the shield's UDP port CHIP to
                                     127.0.0.1:HOST (repeatable): each datagram to
                                     the firmware's UDP socket on CHIP, its answers
                                     back to the sender (`NAME udp: 127.0.0.1:HOST`
                                     once the socket opens)
  --pty NAME[=PATH]  a pseudo-terminal on the line for an outside program (mbpoll,
                   pymodbus); PATH becomes a symlink to it (removed on exit)
  --baud N         the line's baud rate (default 19200), for ptys and the frame silence
  --format 8E1     the line's frame format (default 8E1)
  --at SECONDS CMD run CMD (a command, below) at that simulated time (repeatable)
  --until SECONDS  stop at that simulated time, print the summary and exit 0
  --no-pace        run as fast as the CPU allows (default: paced to the wall clock,
                   never faster than real time)
  --control PATH   read commands from PATH, a FIFO (created if missing, then removed)
  --no-stdin       do not read commands from standard input
  -h, --help       this text

commands (stdin, --control or --at), one per line:
  set NAME pinN low|high|z    drive or release an input pin of board NAME (also 0|1)
  NAME pin N low|high|z       the same
  NAME adc A0 MV              put MV millivolts on an analog input
  NAME reset                  press the board's reset button
  pins                        print every board's watched pins
  at SECONDS COMMAND          run COMMAND at that simulated time
";

/// The pin a board's `de=` names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DePin {
    /// An Arduino Uno pin number (0-19), on the chips wired like the Uno.
    Uno(u8),
    /// A port and bit, `('B', 7)` for PB7, on any chip.
    Port(char, u8),
}

impl DePin {
    /// Its direction and level.
    pub fn state(self, uno: &uno_sim::Uno) -> Result<uno_sim::PinState, uno_sim::Error> {
        match self {
            DePin::Uno(pin) => uno.pin(pin),
            DePin::Port(port, bit) => uno.port_pin(port, bit),
        }
    }
}

impl fmt::Display for DePin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DePin::Uno(pin) => write!(f, "pin {pin}"),
            DePin::Port(port, bit) => write!(f, "P{port}{bit}"),
        }
    }
}

/// A board's `usartN=pty:PATH`: a USART off the line, on a pty of its own.
#[derive(Debug, Clone, PartialEq)]
pub struct SideArgs {
    /// The USART.
    pub usart: u8,
    /// The symlink to the pty.
    pub link: PathBuf,
}

/// One `--board`.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardArgs {
    /// Its name in frames and commands.
    pub name: String,
    /// The firmware.
    pub elf: PathBuf,
    /// `chip=`.
    pub chip: Option<Chip>,
    /// `usart=`.
    pub usart: Option<u8>,
    /// `de=`.
    pub de: Option<DePin>,
    /// `usartN=pty:PATH`.
    pub side: Option<SideArgs>,
    /// `pinN=` presets, in order.
    pub initial: Vec<Command>,
    /// `watch=`.
    pub watch: Vec<u8>,
    /// `wiznet=`.
    pub wiznet: Option<Wiznet>,
    /// `cs=`.
    pub cs: Option<(char, u8)>,
    /// `tcp=`, in order.
    pub tcp: Vec<Mapping>,
    /// `connect=`, in order.
    pub connect: Vec<Mapping>,
    /// `udp=`, in order.
    pub udp: Vec<Mapping>,
}

/// One `--pty`.
#[derive(Debug, Clone, PartialEq)]
pub struct PtyArgs {
    /// Its name in frames.
    pub name: String,
    /// The symlink to create.
    pub link: Option<PathBuf>,
}

/// What the command line asked for.
#[derive(Debug)]
pub struct Args {
    /// The boards.
    pub boards: Vec<BoardArgs>,
    /// The ptys.
    pub ptys: Vec<PtyArgs>,
    /// The line's settings.
    pub line: Settings,
    /// `--at`: (cycle, command line).
    pub at: Vec<(u64, String)>,
    /// `--until`, in cycles.
    pub until: Option<u64>,
    /// Not `--no-pace`.
    pub pace: bool,
    /// `--control`.
    pub control: Option<PathBuf>,
    /// Not `--no-stdin`.
    pub stdin: bool,
}

/// Default watched pins: the Uno's pins 2-7 (buttons and lamps; not the LED on 13, which
/// flashes with every frame).
pub const DEFAULT_WATCH: [u8; 6] = [2, 3, 4, 5, 6, 7];

/// Seconds (decimal) to cycles.
pub fn seconds_to_cycles(text: &str) -> Result<u64, String> {
    let s: f64 = text.trim_end_matches('s').parse().map_err(|_| format!("`{text}` is not a time in seconds"))?;
    if !(0.0..1e6).contains(&s) {
        return Err(format!("`{text}` is not a time in seconds"));
    }
    Ok((s * F_CPU as f64).round() as u64)
}

fn is_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// `Err(None)` for `--help`, `Err(Some(message))` for a mistake.
pub fn parse(words: impl Iterator<Item = String>) -> Result<Args, Option<String>> {
    let mut args = Args {
        boards: Vec::new(),
        ptys: Vec::new(),
        line: Settings { baud: 19200, data_bits: 8, parity: Parity::Even, stop_bits: 1 },
        at: Vec::new(),
        until: None,
        pace: true,
        control: None,
        stdin: true,
    };
    let mut words = words.peekable();
    while let Some(word) = words.next() {
        let mut value = || words.next().ok_or_else(|| Some(format!("{word} needs a value")));
        match word.as_str() {
            "-h" | "--help" => return Err(None),
            "--board" => {
                let spec = value()?;
                let mut board = parse_board(&spec).map_err(Some)?;
                while let Some(opt) = words.next_if(|w| !w.starts_with('-')) {
                    board_option(&mut board, &opt).map_err(Some)?;
                }
                let bridged = !board.tcp.is_empty() || !board.connect.is_empty() || !board.udp.is_empty();
                if board.wiznet.is_none() && (bridged || board.cs.is_some()) {
                    return Err(Some(format!(
                        "--board {}: tcp=, connect=, udp= and cs= need a shield: wiznet=w5100 or w5500",
                        board.name
                    )));
                }
                args.boards.push(board);
            }
            "--pty" => {
                let spec = value()?;
                let (name, link) = match spec.split_once('=') {
                    Some((n, p)) => (n.to_owned(), Some(PathBuf::from(p))),
                    None => (spec.clone(), None),
                };
                if !is_name(&name) {
                    return Err(Some(format!("--pty {spec}: bad name `{name}`")));
                }
                args.ptys.push(PtyArgs { name, link });
            }
            "--baud" => {
                let v = value()?;
                args.line.baud = v.parse().ok().filter(|&b| b > 0).ok_or_else(|| Some(format!("--baud: `{v}`")))?;
            }
            "--format" => {
                let v = value()?;
                let (d, p, s) = parse_format(&v).ok_or_else(|| Some(format!("--format: `{v}` (e.g. 8E1, 8N2)")))?;
                (args.line.data_bits, args.line.parity, args.line.stop_bits) = (d, p, s);
            }
            "--at" => {
                let t = seconds_to_cycles(&value()?).map_err(|e| Some(format!("--at: {e}")))?;
                let cmd = value()?;
                args.at.push((t, cmd));
            }
            "--until" => args.until = Some(seconds_to_cycles(&value()?).map_err(|e| Some(format!("--until: {e}")))?),
            "--no-pace" => args.pace = false,
            "--control" => args.control = Some(value()?.into()),
            "--no-stdin" => args.stdin = false,
            w => return Err(Some(format!("unknown option or stray word `{w}`"))),
        }
    }
    if args.boards.is_empty() && args.ptys.is_empty() {
        return Err(Some("nothing on the line: give --board (and --pty)".to_owned()));
    }
    let mut names: Vec<&str> =
        args.boards.iter().map(|b| b.name.as_str()).chain(args.ptys.iter().map(|p| p.name.as_str())).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(Some(format!("two participants are named `{}`", w[0])));
    }
    args.at.sort_by_key(|(t, _)| *t);
    Ok(args)
}

fn parse_board(spec: &str) -> Result<BoardArgs, String> {
    let (name, elf) = spec.split_once('=').ok_or_else(|| format!("--board {spec}: expected NAME=FIRMWARE.elf"))?;
    if !is_name(name) {
        return Err(format!("--board {spec}: bad name `{name}` (letters, digits, - and _)"));
    }
    Ok(BoardArgs {
        name: name.to_owned(),
        elf: PathBuf::from(elf),
        chip: None,
        usart: None,
        de: None,
        side: None,
        initial: Vec::new(),
        watch: DEFAULT_WATCH.to_vec(),
        wiznet: None,
        cs: None,
        tcp: Vec::new(),
        connect: Vec::new(),
        udp: Vec::new(),
    })
}

fn board_option(board: &mut BoardArgs, opt: &str) -> Result<(), String> {
    let bad = |why: &str| format!("--board {}: option `{opt}`: {why}", board.name);
    let (key, value) = opt.split_once('=').ok_or_else(|| bad("expected KEY=VALUE"))?;
    match key {
        "de" => board.de = Some(parse_de(value).ok_or_else(|| bad("not an Uno pin (0-19) nor a port pin (PB7)"))?),
        "usart" => board.usart = Some(value.parse().ok().filter(|&n| n <= 3).ok_or_else(|| bad("0-3"))?),
        "chip" => board.chip = Some(value.parse::<Chip>().map_err(|e| bad(&e.to_string()))?),
        "watch" if value == "none" || value.is_empty() => board.watch.clear(),
        "watch" => {
            board.watch = value
                .split([',', '+', ':'])
                .map(|p| parse_pin(p).ok_or_else(|| bad(&format!("bad pin `{p}`"))))
                .collect::<Result<_, _>>()?;
        }
        "wiznet" => board.wiznet = Some(value.parse::<Wiznet>().map_err(|e| bad(&e.to_string()))?),
        "cs" => match parse_de(value) {
            Some(DePin::Port(port, bit)) => board.cs = Some((port, bit)),
            _ => return Err(bad("not a port pin such as PB2")),
        },
        "tcp" => board.tcp.push(value.parse::<Mapping>().map_err(|e| bad(&e))?),
        "connect" => board.connect.push(value.parse::<Mapping>().map_err(|e| bad(&e))?),
        "udp" => board.udp.push(value.parse::<Mapping>().map_err(|e| bad(&e))?),
        k if k.starts_with("pin") => {
            board.initial.push(Command::parse_pin_option(&format!("{}={value}", &k[3..])).map_err(|e| bad(&e))?);
        }
        k if k.starts_with("usart") => {
            let usart = k[5..].parse().ok().filter(|&n: &u8| n <= 3).ok_or_else(|| bad("usart0-usart3"))?;
            let path = value.strip_prefix("pty:").filter(|p| !p.is_empty()).ok_or_else(|| bad("expected pty:PATH"))?;
            if board.side.is_some() {
                return Err(bad("one USART on a pty of its own per board"));
            }
            board.side = Some(SideArgs { usart, link: Path::new(path).to_owned() });
        }
        _ => return Err(bad("unknown (de, usart, usartN, chip, pinN, watch, wiznet, cs, tcp, connect, udp)")),
    }
    Ok(())
}

fn parse_pin(text: &str) -> Option<u8> {
    match text.strip_prefix(['A', 'a']) {
        Some(n) => n.parse::<u8>().ok().filter(|&n| n <= 5).map(|n| uno_sim::A0 + n),
        None => text.parse::<u8>().ok().filter(|&n| n <= 19),
    }
}

fn parse_de(text: &str) -> Option<DePin> {
    match text.as_bytes() {
        [b'P' | b'p', port, bit] if port.is_ascii_alphabetic() && (b'0'..=b'7').contains(bit) => {
            Some(DePin::Port(port.to_ascii_uppercase() as char, bit - b'0'))
        }
        _ => parse_pin(text).map(DePin::Uno),
    }
}

fn parse_format(text: &str) -> Option<(u8, Parity, u8)> {
    let b = text.as_bytes();
    if b.len() != 3 {
        return None;
    }
    let data = (b[0] as char).to_digit(10).filter(|d| (5..=8).contains(d))? as u8;
    let parity = match b[1].to_ascii_uppercase() {
        b'N' => Parity::None,
        b'E' => Parity::Even,
        b'O' => Parity::Odd,
        _ => return None,
    };
    let stop = (b[2] as char).to_digit(10).filter(|d| (1..=2).contains(d))? as u8;
    Some((data, parity, stop))
}

/// A command line, in the terms of one board or of all: what `execute` carries out.
#[derive(Debug, PartialEq)]
pub enum LineCommand {
    /// A blank line or a comment.
    Nothing,
    /// A command for board NAME.
    Board(String, Command),
    /// Print every board's pins.
    ShowPins,
    /// Run the command at that cycle.
    At(u64, String),
}

/// Parses `set NAME pinN low`, `NAME pin N 0`, `NAME reset`, `pins`, `at T ...`.
pub fn parse_command(line: &str) -> Result<LineCommand, String> {
    let words: Vec<&str> = line.split_whitespace().collect();
    match words.as_slice() {
        [] => Ok(LineCommand::Nothing),
        [first, ..] if first.starts_with('#') => Ok(LineCommand::Nothing),
        ["pins"] => Ok(LineCommand::ShowPins),
        ["at", t, rest @ ..] if !rest.is_empty() => Ok(LineCommand::At(seconds_to_cycles(t)?, rest.join(" "))),
        ["set", name, rest @ ..] | [name, rest @ ..] if !rest.is_empty() => {
            let mut rest: Vec<String> = rest.iter().map(|s| (*s).to_owned()).collect();
            // pin2 -> pin 2
            if let Some(n) = rest[0].strip_prefix("pin").filter(|n| !n.is_empty()).map(str::to_owned) {
                rest.splice(0..1, ["pin".to_owned(), n]);
            }
            match Command::parse(&rest.join(" "))? {
                Some(Command::ShowPins) | None => Err(format!("cannot understand `{}`", line.trim())),
                Some(cmd) => Ok(LineCommand::Board((*name).to_owned(), cmd)),
            }
        }
        _ => Err(format!(
            "cannot understand `{}` (set NAME pinN low|high|z, NAME pin N 0|1|z, NAME adc A0 MV, NAME reset, pins, at SECONDS ...)",
            line.trim()
        )),
    }
}

/// Character time of the line's settings, in cycles.
pub fn char_cycles(s: &Settings) -> u64 {
    let parity = u64::from(!matches!(s.parity, Parity::None | Parity::NoneOrEven));
    let bits = 1 + u64::from(s.data_bits) + parity + u64::from(s.stop_bits);
    bits * F_CPU / u64::from(s.baud.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> impl Iterator<Item = String> + '_ {
        s.split_whitespace().map(str::to_owned)
    }

    #[test]
    fn boards_with_options_and_ptys() {
        let a = parse(words(
            "--board m=m.elf de=10 --board t=l.elf pin12=low watch=4,5 usart=0 --pty mbpoll=/tmp/ttyX --until 2.5 --no-pace",
        ))
        .unwrap();
        assert_eq!(a.boards.len(), 2);
        assert_eq!(a.boards[0].de, Some(DePin::Uno(10)));
        assert_eq!(a.boards[0].watch, DEFAULT_WATCH);
        assert_eq!(a.boards[1].initial, vec![Command::Pin(12, Some(false))]);
        assert_eq!(a.boards[1].watch, vec![4, 5]);
        assert_eq!(a.ptys[0], PtyArgs { name: "mbpoll".into(), link: Some("/tmp/ttyX".into()) });
        assert_eq!(a.until, Some(40_000_000));
        assert!(!a.pace);
        assert_eq!(a.line.to_string(), "19200 8E1");
        assert!(parse(words("--board a=x.elf --board a=y.elf")).unwrap_err().unwrap().contains("two participants"));
        assert!(parse(words("--board a=x.elf frob=1")).is_err());
    }

    #[test]
    fn a_gateway_with_de_by_port_and_a_usart_on_a_pty_of_its_own() {
        let a = parse(words("--board gw=g.elf de=PB7 usart=1 usart0=pty:/tmp/ttyGW --pty field")).unwrap();
        let gw = &a.boards[0];
        assert_eq!((gw.de, gw.usart), (Some(DePin::Port('B', 7)), Some(1)));
        assert_eq!(gw.side, Some(SideArgs { usart: 0, link: "/tmp/ttyGW".into() }));
        assert_eq!(DePin::Port('B', 7).to_string(), "PB7");
        let err = |s: &str| parse(words(s)).unwrap_err().unwrap();
        assert!(err("--board gw=g.elf usart0=/tmp/x").contains("expected pty:PATH"));
        assert!(err("--board gw=g.elf usart4=pty:/tmp/x").contains("usart0-usart3"));
        assert!(err("--board gw=g.elf usart0=pty:/a usart2=pty:/b").contains("one USART"));
        assert!(err("--board gw=g.elf de=PB8").contains("port pin"));
    }

    #[test]
    fn a_tcp_gateway_with_its_shield_bridged_to_the_host() {
        let a = parse(words("--board gw=g.elf de=3 wiznet=w5100 tcp=502:1502 --pty slave=/tmp/ttyP")).unwrap();
        let gw = &a.boards[0];
        assert_eq!((gw.wiznet, gw.cs), (Some(Wiznet::W5100), None));
        assert_eq!(gw.tcp, [Mapping { chip_port: 502, host_port: 1502 }]);
        let a = parse(words("--board gw=g.elf wiznet=w5500 cs=PB4 tcp=502:0 tcp=80")).unwrap();
        assert_eq!((a.boards[0].cs, a.boards[0].tcp.len()), (Some(('B', 4)), 2));
        let err = |s: &str| parse(words(s)).unwrap_err().unwrap();
        assert!(err("--board gw=g.elf tcp=502:1502").contains("need a shield"));
        assert!(err("--board gw=g.elf wiznet=w5300").contains("w5300"));
        assert!(err("--board gw=g.elf wiznet=w5100 cs=10").contains("port pin"));
        assert!(err("--board gw=g.elf wiznet=w5100 tcp=0:1").contains("502:1502"));
        let a = parse(words("--board client=c.elf wiznet=w5100 connect=502:1502 --board gw=g.elf")).unwrap();
        assert_eq!(a.boards[0].connect, [Mapping { chip_port: 502, host_port: 1502 }]);
        assert!(a.boards[0].tcp.is_empty() && a.boards[1].connect.is_empty());
        let a = parse(words("--board gw=g.elf wiznet=w5500 udp=502:0")).unwrap();
        assert_eq!(a.boards[0].udp, [Mapping { chip_port: 502, host_port: 0 }]);
        assert!(err("--board gw=g.elf udp=502:1502").contains("need a shield"));
        assert!(err("--board client=c.elf connect=502:1502").contains("need a shield"));
        assert!(err("--board client=c.elf wiznet=w5100 connect=0:1").contains("502:1502"));
    }

    #[test]
    fn commands() {
        assert_eq!(
            parse_command("set lab1 pin2 low"),
            Ok(LineCommand::Board("lab1".into(), Command::Pin(2, Some(false))))
        );
        assert_eq!(parse_command("lab1 pin 2 z"), Ok(LineCommand::Board("lab1".into(), Command::Pin(2, None))));
        assert_eq!(parse_command("tower reset"), Ok(LineCommand::Board("tower".into(), Command::Reset)));
        assert_eq!(parse_command("pins"), Ok(LineCommand::ShowPins));
        assert_eq!(parse_command("at 1.5 set a pin3 high"), Ok(LineCommand::At(24_000_000, "set a pin3 high".into())));
        assert_eq!(parse_command("  # x"), Ok(LineCommand::Nothing));
        assert!(parse_command("set lab1 pin2").is_err());
    }

    #[test]
    fn line_character_time() {
        let s = Settings { baud: 19200, data_bits: 8, parity: Parity::Even, stop_bits: 1 };
        assert_eq!(char_cycles(&s), 11 * 16_000_000 / 19200);
    }
}
