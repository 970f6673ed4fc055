//! What the interop tests share: one virtual board at a time, the workspace, a child's
//! output collected, a program kept running with its log, a command run with a time limit,
//! a child stopped, the Python; libmodbus's own unit tests run and judged (`libmodbus`).
#![allow(dead_code)]

pub mod libmodbus;

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

/// A program kept running with its stdout and stderr collected into one log; stopped
/// (`stop`) when dropped.
pub struct Spawned {
    child: Child,
    log: Arc<Mutex<String>>,
}

impl Spawned {
    pub fn start(cmd: &mut Command) -> Spawned {
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {cmd:?}: {e}"));
        let log = Arc::new(Mutex::new(String::new()));
        collect(child.stdout.take().unwrap(), log.clone());
        collect(child.stderr.take().unwrap(), log.clone());
        Spawned { child, log }
    }

    pub fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }

    /// How many lines of the log contain `what`.
    pub fn count(&self, what: &str) -> usize {
        self.log().lines().filter(|l| l.contains(what)).count()
    }

    /// Waits up to `limit` for `what` in the log.
    pub fn wait_for(&self, what: &str, limit: Duration) -> bool {
        let deadline = Instant::now() + limit;
        while Instant::now() < deadline {
            if self.log().contains(what) {
                return true;
            }
            thread::sleep(Duration::from_millis(20));
        }
        false
    }

    /// The port the log prints after `prefix` (`tcp: 127.0.0.1:` and the port: where a bridge
    /// listens), waited for up to 10 s; `what` names the program in the failure.
    pub fn port_after(&self, prefix: &str, what: &str) -> u16 {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let log = self.log();
            if let Some(at) = log.find(prefix) {
                let rest = &log[at + prefix.len()..];
                return rest[..rest.find(' ').unwrap_or(rest.len())].parse().expect("the port printed");
            }
            assert!(Instant::now() < deadline, "{what} did not listen in 10 s:\n{log}");
            thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Spawned {
    fn drop(&mut self) {
        stop(&mut self.child);
    }
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
