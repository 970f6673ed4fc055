//! Compiles `csrc/shim.c` and the parts it uses (`csrc/spi.c`, `csrc/pins.c`, `csrc/timers.c`)
//! against the system's simavr (Debian: libsimavr-dev) and links it.

use std::path::PathBuf;
use std::process::Command;

/// `pkg-config <args> simavr`, split into words; empty if pkg-config or simavr.pc is missing.
fn pkg_config(args: &[&str]) -> Vec<String> {
    Command::new("pkg-config")
        .args(args)
        .arg("simavr")
        .output()
        .ok()
        .filter(|out| out.status.success())
        .map(|out| String::from_utf8_lossy(&out.stdout).split_whitespace().map(str::to_owned).collect())
        .unwrap_or_default()
}

fn main() {
    println!("cargo:rerun-if-changed=csrc/shim.c");
    println!("cargo:rerun-if-changed=csrc/spi.c");
    println!("cargo:rerun-if-changed=csrc/spi.h");
    println!("cargo:rerun-if-changed=csrc/pins.c");
    println!("cargo:rerun-if-changed=csrc/pins.h");
    println!("cargo:rerun-if-changed=csrc/timers.c");
    println!("cargo:rerun-if-changed=csrc/timers.h");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");

    let mut includes: Vec<PathBuf> =
        pkg_config(&["--cflags-only-I"]).iter().filter_map(|f| f.strip_prefix("-I")).map(PathBuf::from).collect();
    if includes.is_empty() {
        includes.push(PathBuf::from("/usr/include/simavr"));
    }
    if !includes.iter().any(|dir| dir.join("sim_avr.h").is_file()) {
        println!(
            "cargo:warning=simavr headers (sim_avr.h) not found in {includes:?}; install libsimavr-dev (simavr 1.6)"
        );
    }

    cc::Build::new()
        .file("csrc/shim.c")
        .file("csrc/spi.c")
        .file("csrc/pins.c")
        .file("csrc/timers.c")
        .includes(&includes)
        .flag("-std=gnu11")
        .warnings(true)
        .compile("unosim_shim");

    for flag in pkg_config(&["--libs-only-L"]) {
        if let Some(dir) = flag.strip_prefix("-L") {
            println!("cargo:rustc-link-search=native={dir}");
        }
    }
    println!("cargo:rustc-link-lib=dylib=simavr");
}
