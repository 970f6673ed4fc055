//! Which AVR chip the firmware is built for, worked out once from the build's own flags so
//! that the firmware never names it twice: the last `-C target-cpu=NAME` of the build
//! (the avr-hal template's way, seen here in `CARGO_ENCODED_RUSTFLAGS`), else a JSON
//! target named `avr-NAME` (`avr-atmega328p.json`, as this repository and avr-hal's older
//! template name theirs). It sets `cfg(avr_chip = "NAME")`, which picks the chip's table in
//! `src/avr/chip.rs`; a chip the crate has no table for stops the build there, naming the
//! chips it supports. Host builds get no `avr_chip` at all.
//!
//! For this repository's examples only (feature `examples`): `AVR_MODBUS_EXAMPLE_USART=N`
//! sets `cfg(example_usart = "N")`, the USART `examples/boards.rs` serves on, so that
//! `make firmware` builds it for each USART without rebuilding anything but this crate.

use std::env;

/// The chips with a table in `src/avr/chip.rs`.
const CHIPS: [&str; 5] = ["atmega328p", "atmega168", "atmega32u4", "atmega1280", "atmega2560"];

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=AVR_MODBUS_EXAMPLE_USART");
    let mut chips = CHIPS.map(|chip| format!("\"{chip}\"")).join(", ");
    chips.push_str(", \"unsupported\"");
    println!("cargo::rustc-check-cfg=cfg(avr_chip, values({chips}))");
    println!("cargo::rustc-check-cfg=cfg(example_usart, values(\"0\", \"1\", \"2\", \"3\"))");

    if env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("avr") {
        return;
    }
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let target = env::var("TARGET").unwrap_or_default();
    let cpu = target_cpu(flags.split('\x1f')).or_else(|| json_target_cpu(&target));
    match cpu {
        Some(cpu) if CHIPS.contains(&cpu.as_str()) => println!("cargo::rustc-cfg=avr_chip=\"{cpu}\""),
        other => {
            println!("cargo::rustc-cfg=avr_chip=\"unsupported\"");
            let seen = other.unwrap_or_else(|| format!("no -C target-cpu, target {target}"));
            println!("cargo::rustc-env=AVR_MODBUS_CPU={seen}");
        }
    }
    if let Ok(usart) = env::var("AVR_MODBUS_EXAMPLE_USART") {
        println!("cargo::rustc-cfg=example_usart=\"{usart}\"");
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
