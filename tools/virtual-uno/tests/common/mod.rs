//! What the interop tests share: one virtual board at a time, the workspace, a child's
//! output collected, a command run with a time limit, a child stopped, the Python.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;

/// One virtual board at a time: each keeps a CPU core busy, and a starved one answers late.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

pub fn serialise() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Collects a child's output as it comes, so that a transcript survives a kill.
pub fn collect(stream: impl Read + Send + 'static, into: Arc<Mutex<String>>) {
    thread::spawn(move || {
        for line in BufReader::new(stream).lines().map_while(Result::ok) {
            into.lock().unwrap().push_str(&(line + "\n"));
        }
    });
}

/// Stops `child` as a user would: SIGTERM, 5 s to end, then SIGKILL.
pub fn stop(child: &mut Child) {
    let _ = kill(Pid::from_raw(child.id() as i32), Signal::SIGTERM);
    let deadline = Instant::now() + Duration::from_secs(5);
    while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
        thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// Runs `cmd` to completion (killed after `limit`); returns success and stdout + stderr.
pub fn run(cmd: &mut Command, limit: Duration) -> (bool, String) {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let out = Arc::new(Mutex::new(String::new()));
    collect(child.stdout.take().unwrap(), out.clone());
    collect(child.stderr.take().unwrap(), out.clone());
    let deadline = Instant::now() + limit;
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        thread::sleep(Duration::from_millis(10));
    };
    thread::sleep(Duration::from_millis(50)); // let the readers finish
    let text = out.lock().unwrap().clone();
    match status {
        Some(status) => (status.success(), text),
        None => (false, format!("{text}(killed after {limit:?})\n")),
    }
}

/// The Python `.ci/setup` prepared, named in target/toolchain.env (which `.ci/cargo` reads);
/// Debian's python3 without it, which has pymodbus but not minimalmodbus.
pub fn python() -> String {
    std::env::var("INTEROP_PYTHON").unwrap_or_else(|_| "/usr/bin/python3".into())
}
