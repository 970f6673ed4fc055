//! `virtual-uno`: runs Uno firmware in simavr, paced to real time, with USART0 on a
//! pseudo-terminal, so that any Modbus master (mbpoll, pymodbus, QModMaster) can poll it; or a
//! firmware built for another board's chip (`--chip`, else the one the ELF file names) with
//! any of its USARTs on the pseudo-terminal (`--usart`).
//!
//! The loop, once a millisecond: wait for bytes from the master (or commands), hand each byte to
//! the simulated USART with real-wire timing, run the CPU up to the wall clock, write the bytes
//! the firmware has finished sending to the pty, and print what changed (line settings, LEDs).
//!
//! ```text
//! virtual-uno --link /tmp/ttyUNO target/avr-atmega328p/release/examples/uno_slave.elf
//! mbpoll -m rtu -b 19200 -P even -a 1 -t 3 -c 5 -1 /tmp/ttyUNO
//! ```
//!
//! With `--pins 8,9` a second pty carries a serial line on two pins (see `pin_wire`): a
//! firmware's timer UART (feature `capture-line`), beside USART0 on the first, as the Uno
//! gateway has them:
//!
//! ```text
//! virtual-uno --link /tmp/ttyUNO --pins 8,9 --pins-link /tmp/ttyFIELD gateway.elf
//! ```
//!
//! With `--bootloader` it is a whole board, flashed through its port like a real one (see
//! `dtr` for the auto-reset and `state` for the flash and EEPROM kept in files):
//!
//! ```text
//! virtual-uno --link /tmp/ttyUNO --bootloader optiboot_atmega328.hex --state target/board/uno
//! RAVEDUDE_PORT=/tmp/ttyUNO cargo run --release
//! ```

mod args;
mod commands;
mod control;
mod dtr;
mod line;
mod mbap;
mod net;
mod pace;
mod pin_wire;
mod pty;
mod state;
mod wire;

use std::fs::File;
use std::io;
use std::os::fd::AsFd;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::signal::{SigSet, Signal};
use nix::sys::signalfd::{SfdFlags, SignalFd};
use uno_sim::{Options, ResetCause, Uno, CYCLES_PER_US};

use commands::{CommandSource, ControlFifo};
use control::Command;
use dtr::Dtr;
use line::Settings;
use net::Net;
use pace::{cycles_to_duration, Clock};
use pin_wire::PinWire;
use pty::{Link, Pty};
use state::State;
use wire::Wire;

/// Simulated time run per loop turn, at most (1 ms).
const SLICE_CYCLES: u64 = 1_000 * CYCLES_PER_US;
/// Falling behind the wall clock by more than this is reported.
const LAG_WARN: Duration = Duration::from_millis(20);
/// How often falling behind is reported, at most.
const LAG_REPORT_EVERY: Duration = Duration::from_secs(5);
/// How often `--state` is written back if it changed (and at every reset and on exit).
const SAVE_EVERY: Duration = Duration::from_millis(500);

fn main() -> ExitCode {
    let args = match args::parse(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(None) => {
            print!("{}", args::USAGE);
            return ExitCode::SUCCESS;
        }
        Err(Some(msg)) => {
            eprintln!("virtual-uno: {msg}\n\n{}", args::USAGE);
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("virtual-uno: {msg}");
            ExitCode::FAILURE
        }
    }
}

/// Carries out one command; errors are reported and otherwise ignored.
fn execute(uno: &mut Uno, line: &str, watch: &[u8]) {
    match Command::parse(line) {
        Ok(None) => {}
        Ok(Some(Command::ShowPins)) => println!("{}{}", pins_line(uno, watch), at(uno)),
        Ok(Some(Command::Chip(_))) if uno.wiznet().is_none() => {
            eprintln!("virtual-uno: {}: no Ethernet shield (--wiznet w5100 or w5500)", line.trim());
        }
        Ok(Some(cmd)) => match cmd.apply(uno) {
            Ok(()) => println!("set: {}", line.trim()),
            Err(e) => eprintln!("virtual-uno: {}: {e}", line.trim()),
        },
        Err(msg) => eprintln!("virtual-uno: {msg}"),
    }
}

/// `pins: 13=on 2=off ...` for the watched pins.
fn pins_line(uno: &Uno, watch: &[u8]) -> String {
    let states: Vec<String> = watch
        .iter()
        .map(|&p| {
            let on = uno.pin(p).map(|s| s.level).unwrap_or(false);
            format!("{p}={}", if on { "on" } else { "off" })
        })
        .collect();
    format!("pins: {}", states.join(" "))
}

/// ` (at 12.345 s)`: the board's simulated time, which falls behind the wall clock when the
/// host cannot keep up (the lag lines on stderr say by how much).
fn at(uno: &Uno) -> String {
    format!(" (at {:.3} s)", cycles_to_duration(uno.now()).as_secs_f64())
}

/// Why the board reset, as `reset:` lines say it.
fn reset_line(cause: Option<ResetCause>, bootloader: bool) -> String {
    let then = if bootloader { "the bootloader starts" } else { "the program starts again" };
    match cause {
        Some(ResetCause::PowerOn) => format!("reset: power-on; {then}"),
        Some(ResetCause::External) => format!("reset: RESET pin (DTR: a program opened the port, or `reset`); {then}"),
        Some(ResetCause::Watchdog) => "reset: watchdog; the program starts".to_owned(),
        None => "reset".to_owned(),
    }
}

/// The chip with its program: the firmware file, else what `--state` holds (else erased),
/// and the bootloader on top.
fn board(args: &args::Args, options: Options) -> Result<(Uno, Option<State>), String> {
    let mut uno = match &args.elf {
        Some(elf) => Uno::load_with(elf, options),
        None => Uno::erased(options),
    }
    .map_err(|e| e.to_string())?;
    let state = match &args.state {
        Some(dir) => Some(State::open(dir, &mut uno, args.elf.is_some())?),
        None => None,
    };
    if let Some(hex) = &args.bootloader {
        let before = uno.flash();
        let start = uno.install_bootloader(hex).map_err(|e| e.to_string())?;
        let program = program_bytes(&before[..start as usize]);
        if args.elf.is_some() && before[start as usize..].iter().any(|&b| b != 0xFF) {
            return Err(format!("the firmware reaches into the boot section at 0x{start:05x}"));
        }
        println!("bootloader: {} at 0x{start:05x}, started at every reset", hex.display());
        match program {
            0 => println!("program: none (flash erased): flash one through the port"),
            n => println!("program: {n} bytes"),
        }
    }
    Ok((uno, state))
}

/// How far the program reaches: up to its last byte that is not erased (0xFF).
fn program_bytes(flash: &[u8]) -> usize {
    flash.iter().rposition(|&b| b != 0xFF).map_or(0, |i| i + 1)
}

fn run(args: &args::Args) -> Result<(), String> {
    let options =
        Options { chip: args.chip, usart: args.usart, wiznet: args.wiznet, wiznet_cs: args.cs, ..Options::new() };
    let (mut uno, mut state) = board(args, options)?;
    let (chip, usart) = (uno.chip(), uno.usart());
    let whole_board = args.bootloader.is_some() || state.is_some();
    if whole_board {
        uno.hard_reset(ResetCause::PowerOn);
    }
    let watch = match &args.watch {
        Some(pins) if !pins.is_empty() && !chip.has_uno_pinout() => {
            return Err(format!("--watch: pin numbers are the Uno's; the {chip} has none of them"));
        }
        Some(pins) => pins.clone(),
        None => args::default_watch(chip),
    };
    println!("chip: {chip}, USART{usart} on the pty");
    if let (Some(model), Some((port, bit))) = (args.wiznet, uno.wiznet_cs()) {
        println!("shield: {model} on the SPI port, chip select P{port}{bit}");
    }
    let mut net = match args.tcp.is_empty() && args.connect.is_empty() && args.udp.is_empty() && args.dhcp.is_none() {
        true => None,
        false => {
            let net = Net::bind(&args.tcp, args.messages)
                .map_err(|e| format!("--tcp: {e}"))?
                .with_outgoing(&args.connect)
                .with_udp(&args.udp)
                .map_err(|e| format!("--udp: {e}"))?;
            Some(match args.dhcp {
                Some(lease) => net.with_dhcp(lease),
                None => net,
            })
        }
    };
    for cmd in &args.initial {
        cmd.apply(&mut uno).map_err(|e| e.to_string())?;
    }

    // Ctrl-C, SIGTERM and SIGHUP arrive as a readable descriptor instead of interrupting us.
    let mut signals = SigSet::empty();
    for sig in [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP] {
        signals.add(sig);
    }
    signals.thread_block().map_err(|e| format!("cannot block signals: {e}"))?;
    let signal_fd = SignalFd::with_flags(&signals, SfdFlags::SFD_NONBLOCK).map_err(|e| format!("signalfd: {e}"))?;

    let mut pty = Pty::open().map_err(|e| format!("cannot open a pseudo-terminal: {e}"))?;
    println!("pty: {}", pty.path().display());
    let _link = match &args.link {
        Some(path) => {
            let link = Link::create(path, pty.path()).map_err(|e| format!("cannot link {}: {e}", path.display()))?;
            println!("link: {} -> {}", path.display(), pty.path().display());
            Some(link)
        }
        None => None,
    };
    let mut pins = match args.pins {
        Some(rx_tx) => {
            let pins = PinWire::open(&mut uno, rx_tx, args.pins_frame, args.pins_link.as_deref())?;
            println!("pin line: {} ({})", pins.pty().path().display(), pins.pins());
            if let Some(path) = &args.pins_link {
                println!("pin line link: {} -> {}", path.display(), pins.pty().path().display());
            }
            Some(pins)
        }
        None => None,
    };
    let mut dtr = None;
    if args.auto_reset {
        let opens = |e| format!("cannot watch {} for opens: {e}", pty.path().display());
        dtr = Some(Dtr::watch(pty.path()).map_err(opens)?);
        println!("auto-reset: opening the port resets the board, as DTR does on a real one");
    }
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

    let mut wire = Wire::new(usart);
    let mut clock = Clock::new(uno.now());
    let mut serial: Option<Settings> = None;
    let mut pin_levels = String::new();
    let (mut lag_total, mut lag_window, mut lag_reported) = (Duration::ZERO, Duration::ZERO, None::<Instant>);
    let mut buf = [0u8; 1024];
    // The power-on reset of a whole board is reported by the loop's first turn, as the others.
    let mut resets = 0;
    let mut saved = Instant::now();
    let mut stopped = false;

    loop {
        // Wait for input until the next slice is due (not at all if the simulation is behind).
        let behind = clock.due().saturating_sub(uno.now());
        let timeout = if behind >= SLICE_CYCLES {
            PollTimeout::ZERO
        } else {
            PollTimeout::from(u8::try_from(cycles_to_duration(SLICE_CYCLES - behind).as_millis().max(1)).unwrap_or(1))
        };
        let mut fds = vec![PollFd::new(signal_fd.as_fd(), PollFlags::POLLIN), PollFd::new(pty.fd(), PollFlags::POLLIN)];
        if let Some(pins) = &pins {
            fds.push(PollFd::new(pins.pty().fd(), PollFlags::POLLIN));
        }
        if let Some(dtr) = &dtr {
            fds.push(PollFd::new(dtr.fd(), PollFlags::POLLIN));
        }
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
                eprintln!("virtual-uno: {name}, stopping");
            }
            break;
        }
        if ready[1] {
            let n = pty.read(&mut buf).map_err(|e| format!("reading the pty: {e}"))?;
            if n > 0 {
                let master = pty.master_settings().map_err(|e| format!("reading the pty's settings: {e}"))?;
                match wire.receive(&mut uno, &buf[..n], master).map_err(|e| e.to_string())? {
                    Some(report) if report.is_trouble() => eprintln!("virtual-uno: {report}"),
                    Some(report) => println!("line: {report}"),
                    None => {}
                }
            }
        }
        if let Some(pins) = pins.as_mut().filter(|_| ready[2]) {
            match pins.receive(&mut uno)? {
                Some(report) if report.is_trouble() => eprintln!("virtual-uno: pin line: {report}"),
                Some(report) => println!("pin line: {report}"),
                None => {}
            }
        }
        let open: Vec<usize> = (0..sources.len()).filter(|&i| sources[i].open).collect();
        for (k, i) in open.into_iter().enumerate() {
            if ready[first_source + k] {
                for line in sources[i].read_lines() {
                    execute(&mut uno, &line, &watch);
                }
            }
        }

        if dtr.as_mut().is_some_and(Dtr::raised) {
            uno.hard_reset(ResetCause::External);
        }

        // Run up to the wall clock, one slice at most, then pass on what the firmware sent.
        // A whole board whose program stopped waits for a reset, as a hung chip does.
        let due = clock.due();
        if due > uno.now() && !stopped {
            let target = due.min(uno.now() + SLICE_CYCLES);
            match run_slice(&mut uno, target, net.as_mut()) {
                Err(e @ uno_sim::Error::Stopped { .. }) if whole_board => {
                    println!("stopped: {e}; the board waits for a reset");
                    stopped = true;
                }
                other => other.map_err(|e| e.to_string())?,
            }
        }
        if stopped {
            clock = Clock::new(uno.now());
        }
        wire.transmit(&mut uno, &mut pty).map_err(|e| format!("writing the pty: {e}"))?;
        if let Some(pins) = pins.as_mut() {
            for trouble in pins.transmit(&mut uno)? {
                eprintln!("virtual-uno: {trouble}");
            }
        }

        let (now_resets, cause) = uno.resets();
        if now_resets != resets {
            resets = now_resets;
            println!("{}", reset_line(cause, args.bootloader.is_some()));
            stopped = false;
            save(&mut state, &uno, &mut saved)?;
        } else if saved.elapsed() >= SAVE_EVERY {
            save(&mut state, &uno, &mut saved)?;
        }

        let now_serial = uno.serial_config().map(|cfg| Settings::of_firmware(&cfg));
        if now_serial != serial {
            serial = now_serial;
            match serial {
                Some(s) => println!("serial: {s} (firmware's USART{usart})"),
                None => println!("serial: off (firmware's USART{usart})"),
            }
        }
        let now_pins = pins_line(&uno, &watch);
        if now_pins != pin_levels && !watch.is_empty() {
            println!("{now_pins}{}", at(&uno));
            pin_levels = now_pins;
        }

        // Behind the wall clock: report it, and drop the debt instead of racing to catch up.
        let lag = cycles_to_duration(clock.due().saturating_sub(uno.now()));
        if lag > LAG_WARN {
            lag_total += lag;
            lag_window += lag;
            clock = Clock::new(uno.now());
            let since = lag_reported.map(|t| t.elapsed());
            if since.is_none_or(|d| d >= LAG_REPORT_EVERY) {
                match since {
                    None => eprintln!("virtual-uno: the simulation is {} ms behind real time", lag.as_millis()),
                    Some(d) => eprintln!(
                        "virtual-uno: the simulation fell {} ms behind real time in {:.1} s ({:.0} % speed)",
                        lag_window.as_millis(),
                        d.as_secs_f64(),
                        100.0 * (1.0 - lag_window.as_secs_f64() / d.as_secs_f64()).max(0.0)
                    ),
                }
                lag_window = Duration::ZERO;
                lag_reported = Some(Instant::now());
            }
        }
    }

    save(&mut state, &uno, &mut saved)?;
    let (rx, tx) = wire.counts();
    eprintln!(
        "virtual-uno: stopped after {:.1} s simulated; {rx} bytes received, {tx} sent; {} ms behind real time in all",
        cycles_to_duration(uno.now()).as_secs_f64(),
        lag_total.as_millis()
    );
    if let Some(pins) = &pins {
        let (rx, tx, malformed) = pins.counts();
        eprintln!("virtual-uno: pin line: {rx} bytes received, {tx} sent, {malformed} of them malformed");
    }
    Ok(())
}

/// Runs the board up to `target`; with a TCP bridge, in steps of `net::BRIDGE_CYCLES`, the bridge
/// polled after each (its events printed).
fn run_slice(uno: &mut Uno, target: u64, mut net: Option<&mut Net>) -> Result<(), uno_sim::Error> {
    loop {
        let step = match &net {
            Some(net) => target.min(net.next_poll().max(uno.now() + 1)),
            None => target,
        };
        uno.run_until(step)?;
        if let Some(net) = net.as_deref_mut().filter(|net| uno.now() >= net.next_poll()) {
            for line in net.poll(uno) {
                println!("{line}");
            }
        }
        if uno.now() >= target {
            return Ok(());
        }
    }
}

/// Writes `--state` back if it changed.
fn save(state: &mut Option<State>, uno: &Uno, saved: &mut Instant) -> Result<(), String> {
    *saved = Instant::now();
    match state {
        Some(state) => state.save(uno).map_err(|e| format!("saving the board's state: {e}")),
        None => Ok(()),
    }
}
