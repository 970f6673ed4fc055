//! `virtual-line`: several simulated boards (and outside programs on ptys) on one RS-485
//! half-duplex line, in lockstep on simulated time. See `bus` for the line's model and
//! `args::USAGE` for the command line.
//!
//! ```text
//! virtual-line --board master=lab_control.elf de=10 \
//!              --board box=lab_lights.elf de=10 \
//!              --board tower=lab_lights.elf de=10 pin12=low watch=4,5,6,7 \
//!              --at 2 'set box pin2 low' --at 2.3 'set box pin2 z'
//! ```
//!
//! A TCP gateway: an Uno with an Ethernet shield, its port 502 on 127.0.0.1:1502, the
//! line's slaves behind it (one of them pymodbus on a pty), every Modbus TCP request and
//! answer printed with its connection beside the frames on the line:
//!
//! ```text
//! virtual-line --board gw=tcp_gateway.elf de=3 wiznet=w5100 tcp=502:1502 \
//!              --board box=lab_lights.elf de=10 --pty pymodbus=/tmp/ttyPLANT
//! ```
//!
//! A TCP client (`tcp_client!`) on the line's board: its connections to port 502 go to a
//! server on 127.0.0.1:1502 (`connect=`), their requests and answers printed:
//!
//! ```text
//! virtual-line --board client=tcp_poll.elf wiznet=w5100 connect=502:1502 --pty slave=/tmp/ttyS
//! ```
//!
//! A Mega gateway: its master's USART1 on the line (DE on PB7, the Mega's pin 13), its
//! slave's USART0 on a pty of its own for an outside master, a field device on a pty:
//!
//! ```text
//! virtual-line --board gw=gateway.elf usart=1 de=PB7 usart0=pty:/tmp/ttyGW \
//!              --pty field=/tmp/ttyFIELD
//! ```

#[allow(dead_code)]
mod args;
mod bus;
#[path = "../../commands.rs"]
mod commands;
#[allow(dead_code)]
#[path = "../../control.rs"]
mod control;
#[allow(dead_code)]
#[path = "../../line.rs"]
mod line;
#[path = "../../mbap.rs"]
mod mbap;
#[path = "../../net.rs"]
mod net;
#[path = "../../pace.rs"]
mod pace;
#[allow(dead_code)]
#[path = "../../pty.rs"]
mod pty;
mod side;
#[allow(dead_code)]
#[path = "../../wire.rs"]
mod wire;

use std::fs::File;
use std::io;
use std::os::fd::AsFd;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::signal::{SigSet, Signal};
use nix::sys::signalfd::{SfdFlags, SignalFd};
use uno_sim::{Options, Uno};

use args::LineCommand;
use bus::{stamp, Board, Bus, PtyPort};
use commands::{CommandSource, ControlFifo};
use net::Net;
use pace::{cycles_to_duration, Clock};
use pty::{Link, Pty};
use side::Side;

/// Falling behind the wall clock by more than this is reported, and the pacing clock starts
/// again from the simulation's time. Kept short: a pty's bytes go on the line no sooner than
/// the clock's cycle (`Bus::pty_sent`), so a clock far ahead of a slow simulation makes an
/// outside program (pymodbus) answer that much later in simulated time, past a master's
/// timeout.
const LAG_WARN: Duration = Duration::from_millis(10);
/// How often falling behind is reported, at most.
const LAG_REPORT_EVERY: Duration = Duration::from_secs(5);
/// Wall time spent simulating before looking at the ptys and commands again.
const TURN: Duration = Duration::from_millis(5);

fn main() -> ExitCode {
    let args = match args::parse(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(None) => {
            print!("{}", args::USAGE);
            return ExitCode::SUCCESS;
        }
        Err(Some(msg)) => {
            eprintln!("virtual-line: {msg}\n\n{}", args::USAGE);
            return ExitCode::from(2);
        }
    };
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("virtual-line: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// Carries out a command line now, or schedules it.
fn execute(bus: &mut Bus, scheduled: &mut Vec<(u64, String)>, line: &str) {
    match args::parse_command(line) {
        Ok(LineCommand::Nothing) => {}
        Ok(LineCommand::ShowPins) => bus.show_pins(),
        Ok(LineCommand::At(t, cmd)) => {
            if let Err(e) = args::parse_command(&cmd) {
                eprintln!("virtual-line: {e}");
                return;
            }
            bus.say(&format!("scheduled at {}: {cmd}", stamp(t)));
            scheduled.push((t, cmd));
            scheduled.sort_by_key(|(t, _)| *t);
        }
        Ok(LineCommand::Board(name, cmd)) => {
            if let Err(e) = bus.command(&name, cmd, line) {
                eprintln!("virtual-line: {}: {e}", line.trim());
            }
        }
        Err(msg) => eprintln!("virtual-line: {msg}"),
    }
}

fn run(args: args::Args) -> Result<(), String> {
    let mut boards = Vec::new();
    for b in &args.boards {
        let second_usart = b.side.as_ref().map(|s| s.usart);
        let options =
            Options { chip: b.chip, usart: b.usart, second_usart, wiznet: b.wiznet, wiznet_cs: b.cs, ..Options::new() };
        let mut uno = Uno::load_with(&b.elf, options).map_err(|e| format!("{}: {e}", b.name))?;
        if second_usart == Some(uno.usart()) {
            return Err(format!("{}: USART{} is on the line; its pty needs another", b.name, uno.usart()));
        }
        let has_pins = uno.chip().has_uno_pinout();
        let uno_de = matches!(b.de, Some(args::DePin::Uno(_)));
        if !has_pins && (uno_de || !b.initial.is_empty() || b.watch != args::DEFAULT_WATCH && !b.watch.is_empty()) {
            return Err(format!("{}: pin numbers are the Uno's; the {} has none of them", b.name, uno.chip()));
        }
        for cmd in &b.initial {
            cmd.apply(&mut uno).map_err(|e| format!("{}: {e}", b.name))?;
        }
        let watch = if has_pins { b.watch.clone() } else { Vec::new() };
        println!(
            "{} board {}: {}, {}, USART{} on the line{}",
            stamp(0),
            b.name,
            b.elf.display(),
            uno.chip(),
            uno.usart(),
            b.de.map_or(String::new(), |p| format!(", DE on {p}"))
        );
        let side = match &b.side {
            Some(s) => {
                let pty = Pty::open().map_err(|e| format!("cannot open a pseudo-terminal: {e}"))?;
                let link =
                    Link::create(&s.link, pty.path()).map_err(|e| format!("cannot link {}: {e}", s.link.display()))?;
                println!(
                    "{} board {}: USART{} on {} (link {}), off the line",
                    stamp(0),
                    b.name,
                    s.usart,
                    pty.path().display(),
                    s.link.display()
                );
                Some(Side::new(s.usart, pty, s.link.clone(), link))
            }
            None => None,
        };
        if let (Some(model), Some((port, bit))) = (b.wiznet, uno.wiznet_cs()) {
            println!("{} board {}: shield {model} on the SPI port, chip select P{port}{bit}", stamp(0), b.name);
        }
        let mut board = Board::new(b.name.clone(), uno, b.de, side, watch);
        if !b.tcp.is_empty() || !b.connect.is_empty() || !b.udp.is_empty() {
            let net = Net::bind(&b.tcp, true).map_err(|e| format!("{}: tcp=: {e}", b.name))?;
            let net = net.with_outgoing(&b.connect).with_udp(&b.udp).map_err(|e| format!("{}: udp=: {e}", b.name))?;
            board.net = Some(net);
        }
        boards.push(board);
    }
    let mut ptys = Vec::new();
    for p in &args.ptys {
        let pty = Pty::open().map_err(|e| format!("cannot open a pseudo-terminal: {e}"))?;
        let link = match &p.link {
            Some(path) => {
                Some(Link::create(path, pty.path()).map_err(|e| format!("cannot link {}: {e}", path.display()))?)
            }
            None => None,
        };
        println!(
            "{} pty {}: {}{}",
            stamp(0),
            p.name,
            pty.path().display(),
            p.link.as_ref().map_or(String::new(), |l| format!(" (link {})", l.display()))
        );
        ptys.push(PtyPort::new(p.name.clone(), pty, link));
    }
    println!("{} line: {}{}", stamp(0), args.line, if args.pace { "" } else { ", not paced" });
    let mut bus = Bus::new(args.line, boards, ptys);
    let mut scheduled = args.at.clone();
    for (_, cmd) in &scheduled {
        args::parse_command(cmd).map_err(|e| format!("--at: {e}"))?;
    }

    let mut signals = SigSet::empty();
    for sig in [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP] {
        signals.add(sig);
    }
    signals.thread_block().map_err(|e| format!("cannot block signals: {e}"))?;
    let signal_fd = SignalFd::with_flags(&signals, SfdFlags::SFD_NONBLOCK).map_err(|e| format!("signalfd: {e}"))?;
    let (_fifo, control) = match &args.control {
        Some(path) => {
            let (fifo, source) = ControlFifo::open(path)?;
            (Some(fifo), Some(source))
        }
        None => (None, None),
    };
    let mut sources: Vec<CommandSource> = control.into_iter().collect();
    if args.stdin {
        let fd = io::stdin().as_fd().try_clone_to_owned().map_err(|e| format!("stdin: {e}"))?;
        sources.push(CommandSource::new("stdin", File::from(fd)));
    }

    let wall_start = Instant::now();
    let mut clock = Clock::new(0);
    let (mut lag_total, mut lag_window, mut lag_reported) = (Duration::ZERO, Duration::ZERO, None::<Instant>);
    let mut buf = [0u8; 1024];
    let until = args.until.unwrap_or(u64::MAX);
    'run: loop {
        let behind = clock.due().saturating_sub(bus.now);
        let timeout = if !args.pace || behind > 0 { PollTimeout::ZERO } else { PollTimeout::from(1u8) };
        let mut fds = vec![PollFd::new(signal_fd.as_fd(), PollFlags::POLLIN)];
        fds.extend(bus.ptys.iter().map(|p| PollFd::new(p.pty.fd(), PollFlags::POLLIN)));
        let first_side = fds.len();
        let sides: Vec<usize> = (0..bus.boards.len()).filter(|&i| bus.boards[i].side.is_some()).collect();
        fds.extend(
            sides
                .iter()
                .filter_map(|&i| bus.boards[i].side.as_ref())
                .map(|s| PollFd::new(s.pty.fd(), PollFlags::POLLIN)),
        );
        let first_source = fds.len();
        fds.extend(sources.iter().filter(|s| s.open).map(|s| PollFd::new(s.file.as_fd(), PollFlags::POLLIN)));
        match poll(&mut fds, timeout) {
            Ok(_) | Err(nix::errno::Errno::EINTR) => {}
            Err(e) => return Err(format!("poll: {e}")),
        }
        let ready: Vec<bool> = fds.iter().map(|fd| fd.any().unwrap_or(false)).collect();
        drop(fds);
        if ready[0] {
            if let Ok(Some(info)) = signal_fd.read_signal() {
                let name = Signal::try_from(info.ssi_signo as i32).map_or("signal", |s| s.as_str());
                eprintln!("virtual-line: {name}, stopping");
            }
            break;
        }
        for k in 0..bus.ptys.len() {
            if ready[1 + k] {
                let n = bus.ptys[k].pty.read(&mut buf).map_err(|e| format!("reading the pty: {e}"))?;
                if n > 0 {
                    // Paced: when the wall clock says, or its reaction to what it heard.
                    let at =
                        if args.pace { bus.reaction(k).map_or(clock.due(), |r| r.max(clock.due())) } else { bus.now };
                    bus.pty_sent(k, &buf[..n], at)?;
                }
            }
        }
        for (k, &i) in sides.iter().enumerate() {
            if ready[first_side + k] {
                let Some(side) = &mut bus.boards[i].side else { continue };
                let n = side.pty.read(&mut buf).map_err(|e| format!("reading the pty: {e}"))?;
                if n > 0 {
                    bus.side_sent(i, &buf[..n])?;
                }
            }
        }
        let open: Vec<usize> = (0..sources.len()).filter(|&i| sources[i].open).collect();
        for (k, i) in open.into_iter().enumerate() {
            if ready[first_source + k] {
                for line in sources[i].read_lines() {
                    execute(&mut bus, &mut scheduled, &line);
                }
            }
        }

        // Run up to the wall clock (or flat out), a few milliseconds of wall time at most.
        let turn = Instant::now();
        let due = if args.pace { clock.due() } else { u64::MAX };
        while bus.now < due.min(until) && turn.elapsed() < TURN {
            let next_cmd = scheduled.first().map_or(u64::MAX, |(t, _)| *t);
            if next_cmd <= bus.now {
                let (_, cmd) = scheduled.remove(0);
                execute(&mut bus, &mut scheduled, &cmd);
                continue;
            }
            bus.step(due.min(until).min(next_cmd))?;
        }
        if bus.now >= until {
            while scheduled.first().is_some_and(|(t, _)| *t <= bus.now) {
                let (_, cmd) = scheduled.remove(0);
                execute(&mut bus, &mut scheduled, &cmd);
            }
            break 'run;
        }

        if args.pace {
            let lag = cycles_to_duration(clock.due().saturating_sub(bus.now));
            if lag > LAG_WARN {
                lag_total += lag;
                lag_window += lag;
                clock = Clock::new(bus.now);
                let since = lag_reported.map(|t| t.elapsed());
                if since.is_none_or(|d| d >= LAG_REPORT_EVERY) {
                    let msg = match since {
                        None => format!("behind: the simulation is {} ms behind real time", lag.as_millis()),
                        Some(d) => format!(
                            "behind: the simulation fell {} ms behind real time in {:.1} s ({:.0} % speed)",
                            lag_window.as_millis(),
                            d.as_secs_f64(),
                            100.0 * (1.0 - lag_window.as_secs_f64() / d.as_secs_f64()).max(0.0)
                        ),
                    };
                    bus.say(&msg);
                    lag_window = Duration::ZERO;
                    lag_reported = Some(Instant::now());
                }
            }
        }
    }
    bus.finish();
    let wall = wall_start.elapsed().as_secs_f64();
    println!("{} {}", stamp(bus.now), bus.summary());
    for line in bus.de_report().into_iter().chain(bus.side_report()) {
        println!("{} {line}", stamp(bus.now));
    }
    println!(
        "{} speed: {:.3} s simulated in {wall:.1} s of wall time ({:.0} % of real time){}",
        stamp(bus.now),
        bus.now as f64 / uno_sim::F_CPU as f64,
        100.0 * bus.now as f64 / uno_sim::F_CPU as f64 / wall.max(1e-9),
        if args.pace { format!(", {} ms behind in all", lag_total.as_millis()) } else { String::new() }
    );
    Ok(())
}
