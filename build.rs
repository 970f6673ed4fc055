//! Which AVR chip the firmware is built for, worked out once from the build's own flags so
//! that the firmware never names it twice: the last `-C target-cpu=NAME` of the build
//! (the avr-hal template's way, seen here in `CARGO_ENCODED_RUSTFLAGS`), else a JSON
//! target named `avr-NAME` (`avr-atmega328p.json`, as this repository and avr-hal's older
//! template name theirs). It sets `cfg(avr_chip = "NAME")` and writes that chip's table,
//! from its block of `chips/chips.txt`, into `OUT_DIR/chip.rs`, which `src/avr/chip.rs`
//! includes: `CHIP` and the `__chip!` macro that names its vectors. A chip the file does not
//! describe stops the build there, naming the chips it does. Host builds get no `avr_chip`
//! at all, and the first chip's `CHIP` for the docs built on the host (see `src/lib.rs`).
//!
//! The CPU clock, which the whole build shares: `AVR_CPU_FREQUENCY_HZ` in the environment
//! (the AVR Rust ecosystem's name for it, `avr-config`'s too; an avr-hal template firmware
//! sets it in `.cargo/config.toml`'s `[env]`), 16000000 when unset or 8000000. It sets
//! `cfg(avr_cpu_frequency_hz = "HZ")`, from which `src/link/timing.rs` takes `CLOCK_HZ`; any
//! other value stops the build there, naming the two. A change of it reruns this script, and
//! its new cfg rebuilds the crate.
//!
//! For this repository's examples only (feature `examples`): `AVR_MODBUS_EXAMPLE_USART=N`
//! sets `cfg(example_usart = "N")`, the USART `examples/boards.rs` serves on, so that
//! `make firmware` builds it for each USART without rebuilding anything but this crate;
//! `AVR_MODBUS_EXAMPLE_SHIELD=w5500` (or `w5100-int`, `w5500-int`) sets
//! `cfg(example_shield = "…")`, the chip `examples/tcp_server.rs` serves on and whether its
//! INT line is wired to pin 2 (unset: a W5100, polled).

use std::env;
use std::fmt::Write as _;
use std::fs;
use std::path::Path;

#[allow(dead_code)] // tools/sim reads the rest of each chip's facts
#[path = "chips/table.rs"]
mod table;

use table::Facts;

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=chips/chips.txt");
    println!("cargo::rerun-if-changed=chips/table.rs");
    println!("cargo::rerun-if-env-changed=AVR_MODBUS_EXAMPLE_USART");
    println!("cargo::rerun-if-env-changed=AVR_MODBUS_EXAMPLE_SHIELD");
    let dir = env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let text = fs::read_to_string(Path::new(&dir).join("chips/chips.txt")).expect("chips/chips.txt");
    let chips = table::parse(&text).unwrap_or_else(|error| panic!("{error}"));
    let mut values: Vec<String> = chips.iter().map(|chip| format!("\"{}\"", chip.cpu)).collect();
    values.push("\"unsupported\"".to_owned());
    println!("cargo::rustc-check-cfg=cfg(avr_chip, values({}))", values.join(", "));
    println!("cargo::rustc-check-cfg=cfg(example_usart, values(\"0\", \"1\", \"2\", \"3\", \"capture\"))");
    println!("cargo::rustc-check-cfg=cfg(example_shield, values(\"w5100\", \"w5500\", \"w5100-int\", \"w5500-int\"))");
    let clocks: Vec<String> = CLOCKS.iter().map(|(hz, _)| format!("\"{hz}\"")).collect();
    println!("cargo::rustc-check-cfg=cfg(avr_cpu_frequency_hz, values({}))", clocks.join(", "));
    println!("cargo::rerun-if-env-changed={CLOCK_VARIABLE}");
    match clock(env::var(CLOCK_VARIABLE).ok().as_deref()) {
        Ok(hz) => println!("cargo::rustc-cfg=avr_cpu_frequency_hz=\"{hz}\""),
        Err(message) => {
            eprintln!("{message}");
            std::process::exit(1);
        }
    }

    let out = Path::new(&env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("chip.rs");
    if env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("avr") {
        fs::write(out, table_of(&chips[0])).expect("OUT_DIR/chip.rs");
        return;
    }
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let target = env::var("TARGET").unwrap_or_default();
    let cpu = target_cpu(flags.split('\x1f')).or_else(|| json_target_cpu(&target));
    let generated = match cpu.as_deref().and_then(|cpu| chips.iter().find(|chip| chip.cpu == cpu)) {
        Some(chip) => {
            println!("cargo::rustc-cfg=avr_chip=\"{}\"", chip.cpu);
            table_of(chip) + &macro_of(chip)
        }
        None => {
            println!("cargo::rustc-cfg=avr_chip=\"unsupported\"");
            unsupported(&chips, &cpu.unwrap_or_else(|| format!("no -C target-cpu, target {target}")))
        }
    };
    fs::write(out, generated).expect("OUT_DIR/chip.rs");
    if let Ok(usart) = env::var("AVR_MODBUS_EXAMPLE_USART") {
        println!("cargo::rustc-cfg=example_usart=\"{usart}\"");
    }
    if let Ok(shield) = env::var("AVR_MODBUS_EXAMPLE_SHIELD") {
        println!("cargo::rustc-cfg=example_shield=\"{shield}\"");
    }
}

/// Where the build says the CPU's clock: the variable `avr-config` reads too.
const CLOCK_VARIABLE: &str = "AVR_CPU_FREQUENCY_HZ";

/// The clocks the crate's timing is worked out and tested for, in Hz, the default first,
/// and the boards that run at each.
const CLOCKS: [(&str, &str); 2] = [
    ("16000000", "the Uno, Nano, Mega, Leonardo and Pro Mini 5 V"),
    ("8000000", "the SparkFun Pro Mini 3.3 V and Pro Micro 3.3 V"),
];

/// The clock `AVR_CPU_FREQUENCY_HZ` (`value`; unset: the default) names, or why it can't be.
fn clock(value: Option<&str>) -> Result<&'static str, String> {
    let Some(value) = value else { return Ok(CLOCKS[0].0) };
    if let Some((hz, _)) = CLOCKS.iter().find(|(hz, _)| *hz == value.trim()) {
        return Ok(hz);
    }
    let supported: Vec<String> = CLOCKS.iter().map(|(hz, boards)| format!("{hz} ({boards})")).collect();
    Err(format!(
        "avr-modbus: {CLOCK_VARIABLE}={value:?} is a CPU clock it does not support: it supports {}, \
         {} being the default when the variable is unset. Its silences (T1.5, T3.5), \
         timeouts and milliseconds count Timer0 at the CPU clock / 64, and only at these clocks is \
         a millisecond a whole number of ticks within one turn of the counter (250 and 125); its \
         baud divisors and deadlines are tested at these two. An 8 MHz board's firmware says so \
         in its .cargo/config.toml: [env] {CLOCK_VARIABLE} = \"8000000\"",
        join(&supported, "and"),
        CLOCKS[0].0
    ))
}

/// `chip`'s `CHIP`.
fn table_of(chip: &Facts) -> String {
    let usarts = (0..4).map(|number| match chip.usarts.iter().find(|usart| usart.number == number) {
        Some(usart) => format!("Some({:#X})", usart.block),
        None => "None".to_owned(),
    });
    let (pin, bit) = chip.led;
    let [ss, mosi, sck, cs] = chip.spi;
    let (_, eicr, shift, mask, int_pin, int_bit) = chip.pin2_int;
    let table::Capture { block, timsk, tifr, port, pins: [rx, tx], peripheral: (pac, pac_size), .. } = &chip.capture;
    format!(
        "/// The {name}'s facts ({boards}).\n\
         pub(crate) const CHIP: Chip = Chip {{ usarts: [{usarts}], eeprom_size: {eeprom}, led: ({pin:#X}, {bit}), \
         spi: [{ss}, {mosi}, {sck}, {cs}], pin2_int: ({eicr:#X}, {shift}, {mask}, {int_pin:#X}, {int_bit}), \
         capture: CaptureTimer {{ block: {block:#X}, timsk: {timsk:#X}, tifr: {tifr:#X}, port: {port:#X}, rx: {rx}, tx: {tx}, \
         peripheral: ({pac:#X}, {pac_size:#X}) }} }};\n",
        name = chip.part,
        boards = chip.boards,
        usarts = usarts.collect::<Vec<_>>().join(", "),
        eeprom = chip.eeprom,
    )
}

/// `chip`'s `__chip!`: its vectors' symbols (`__vector_N`) by name, its USARTs' numbers, a
/// build error for a USART it lacks, and the roles' default USART (the board's pins 0/1).
fn macro_of(chip: &Facts) -> String {
    let mut arms = String::new();
    for (name, vector) in ["TIMER0_COMPA", "TIMER0_COMPB", "TIMER0_OVF"].iter().zip(chip.timer0) {
        writeln!(arms, "    (vector {name}) => {{ \"__vector_{vector}\" }};").unwrap();
    }
    writeln!(arms, "    (vector PIN2_INT) => {{ \"__vector_{}\" }};", chip.pin2_int.0).unwrap();
    for usart in &chip.usarts {
        for (what, vector) in ["RX", "UDRE", "TX"].iter().zip(usart.vectors) {
            writeln!(arms, "    (vector USART{} {what}) => {{ \"__vector_{vector}\" }};", usart.number).unwrap();
        }
    }
    for usart in &chip.usarts {
        writeln!(arms, "    (usart USART{0}) => {{ {0} }};", usart.number).unwrap();
    }
    let capture = &chip.capture;
    for (what, vector) in ["CAPT", "COMPA", "COMPB"].iter().zip(capture.vectors) {
        writeln!(arms, "    (vector TIMER{} {what}) => {{ \"__vector_{vector}\" }};", capture.timer).unwrap();
    }
    writeln!(arms, "    (usart TIMER{}) => {{ $crate::__private::capture_line() }};", capture.timer).unwrap();
    writeln!(arms, "    (capture TIMER{}) => {{ true }};", capture.timer).unwrap();
    let names: Vec<String> = chip.usarts.iter().map(|usart| format!("USART{}", usart.number)).collect();
    let contiguous = chip.usarts.windows(2).all(|pair| pair[1].number == pair[0].number + 1);
    let theirs = match &names[..] {
        [one] => format!("one USART, {one} (pins 0/1)"),
        [first, .., last] if contiguous => format!("{first} to {last}"),
        _ => join(&names, "and"),
    };
    let verb = if chip.family.contains(" and ") { "have" } else { "has" };
    let default = chip.pins_0_1().number;
    format!(
        "\n/// The {name}'s vectors (`__vector_N`) and USARTs.\n\
         #[doc(hidden)]\n\
         #[macro_export]\n\
         macro_rules! __chip {{\n\
         {arms}    \
             (usart $other:ident) => {{\n        \
                 ::core::compile_error!(::core::concat!(\n            \
                     \"the {family} {verb} {theirs}, not \",\n            \
                     ::core::stringify!($other)\n        \
                 ))\n    \
             }};\n    \
             (vector $other:ident $what:ident) => {{ \"\" }};\n    \
             (capture $other:ident) => {{ false }};\n    \
             (default $($slave:tt)*) => {{ $crate::slave!(@on USART{default} $($slave)*); }};\n    \
             (default_master $($master:tt)*) => {{ $crate::master!(@on USART{default} $($master)*); }};\n    \
             (default_gateway $($gateway:tt)*) => {{ $crate::tcp_gateway!(@pick USART{default} $($gateway)*); }};\n\
         }}\n",
        name = chip.part,
        family = chip.family,
    )
}

/// The build error for a chip `chips` does not describe (`seen`), a table and a
/// `__chip!` that add none of their own.
fn unsupported(chips: &[Facts], seen: &str) -> String {
    let names: Vec<String> = chips.iter().map(|chip| chip.part.clone()).collect();
    let cpus: Vec<String> = chips.iter().map(|chip| chip.cpu.clone()).collect();
    let message = format!(
        "avr-modbus runs on the {} (build with -C target-cpu={}); this build is for {seen}",
        join(&names, "and"),
        join(&cpus, "or")
    );
    format!(
        "::core::compile_error!({message:?});\n\n\
         /// No table, so that the only error is the one above.\n\
         pub(crate) const CHIP: Chip = Chip {{ usarts: [None; 4], eeprom_size: 0, led: (0, 0), spi: [0; 4], pin2_int: (0, 0, 0, 0, 0), \
         capture: CaptureTimer {{ block: 0, timsk: 0, tifr: 0, port: 0, rx: 0, tx: 0, peripheral: (0, 0) }} }};\n\n\
         /// No vectors either.\n\
         #[doc(hidden)]\n\
         #[macro_export]\n\
         macro_rules! __chip {{\n    \
             (vector $($what:ident)*) => {{ \"\" }};\n    \
             (usart $what:ident) => {{ 0 }};\n    \
             (capture $what:ident) => {{ false }};\n    \
             (default $($slave:tt)*) => {{ $crate::slave!(@on USART0 $($slave)*); }};\n    \
             (default_master $($master:tt)*) => {{ $crate::master!(@on USART0 $($master)*); }};\n    \
             (default_gateway $($gateway:tt)*) => {{ $crate::tcp_gateway!(@pick USART0 $($gateway)*); }};\n\
         }}\n"
    )
}

/// `a, b, c and d` (or `or`).
fn join(words: &[String], last: &str) -> String {
    match words {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., final_word] => format!("{} {last} {final_word}", rest.join(", ")),
    }
}

/// The CPU the last `-C target-cpu=…` among rustc's flags names (rustc takes the last one).
fn target_cpu<'a>(flags: impl Iterator<Item = &'a str>) -> Option<String> {
    let mut cpu = None;
    let mut codegen_next = false;
    for flag in flags {
        let option = if codegen_next {
            Some(flag)
        } else {
            flag.strip_prefix("-C").or_else(|| flag.strip_prefix("--codegen")).map(|rest| rest.trim_start_matches('='))
        };
        codegen_next = matches!(flag, "-C" | "--codegen");
        if let Some(value) = option.and_then(|option| option.strip_prefix("target-cpu=")) {
            cpu = Some(value.to_owned());
        }
    }
    cpu
}

/// The CPU a JSON target named `avr-NAME` is for (cargo names the target by its file stem).
fn json_target_cpu(target: &str) -> Option<String> {
    let cpu = target.strip_prefix("avr-")?;
    (cpu != "none" && !cpu.contains('-')).then(|| cpu.to_owned())
}
