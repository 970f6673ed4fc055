//! libmodbus 3.1.6's own unit tests (`.ci/libmodbus-tests`): its programs, what a run of its
//! `unit-test-client` reports, the reference run against libmodbus's own server, and a run
//! judged against that reference and the deviations a test expects.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use uno_sim::built::built;

use super::{run, workspace};

/// libmodbus 3.1.6's test program `name`, built by `.ci/libmodbus-tests` (`make setup`).
pub fn program(name: &str) -> PathBuf {
    built(workspace().join("target/libmodbus-tests").join(name), "make setup")
}

/// A check of unit-test-client.c, by its source line, and why it goes another way than
/// against libmodbus's own server.
pub type Check = (u32, &'static str);

/// What a run of `unit-test-client-all` (or a variant) printed.
pub struct Run {
    /// Its output, stdout and stderr.
    pub out: String,
    /// The checks that failed: the source line of each, and libmodbus's text.
    pub failed: Vec<(u32, String)>,
    /// How many checks passed (lines ending with `OK`).
    pub passed: usize,
    /// Its wall time.
    pub took: Duration,
}

impl Run {
    /// `client tcp`, which talks to 127.0.0.1:1502; killed after two minutes.
    pub fn tcp(client: &Path) -> Run {
        let started = Instant::now();
        let (_, out) = run(Command::new(client).arg("tcp"), Duration::from_secs(120));
        let took = started.elapsed();
        let failed = out
            .lines()
            .filter_map(|l| {
                let rest = l.strip_prefix("Line ")?;
                let (line, what) = rest.split_once(": assertion error for ")?;
                Some((line.parse().ok()?, what.to_owned()))
            })
            .collect();
        let passed = out.lines().filter(|l| l.ends_with("OK")).count();
        Run { out, failed, passed, took }
    }

    /// True when it got to its end (`N CHECKS FAILED.`).
    pub fn ran_through(&self) -> bool {
        self.out.contains("CHECKS FAILED.")
    }

    /// True when the check at `line` failed (once or more: a line can check several times).
    pub fn fails(&self, line: u32) -> bool {
        self.failed.iter().any(|&(l, _)| l == line)
    }
}

/// libmodbus's own `unit-test-server tcp`, listening on 127.0.0.1:1502 once started (it serves
/// one connection, then quits; over TCP it answers every unit id). Stopped when dropped.
pub struct TcpServer(Child);

impl TcpServer {
    pub fn start() -> TcpServer {
        // Another program there (an interop run of the TCP server's) would answer in its place.
        drop(TcpListener::bind("127.0.0.1:1502").expect("127.0.0.1:1502 is taken: another program listens there"));
        let server = Command::new(program("unit-test-server"))
            .arg("tcp")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("unit-test-server");
        let server = TcpServer(server);
        let deadline = Instant::now() + Duration::from_secs(5);
        while TcpListener::bind("127.0.0.1:1502").is_ok() {
            assert!(Instant::now() < deadline, "unit-test-server did not listen on 1502");
            thread::sleep(Duration::from_millis(20));
        }
        server
    }
}

impl Drop for TcpServer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The reference: `client tcp` against libmodbus's own server ([`TcpServer`]). What fails here
/// fails anywhere: the client's own float conversions (no request sent), and on a busy machine
/// a check of timing (its 7 ms byte timeout against the server's byte every 5 ms).
pub fn reference(client: &Path) -> Run {
    let server = TcpServer::start();
    let reference = Run::tcp(client);
    drop(server);
    assert!(
        reference.ran_through() && reference.passed > 90,
        "{} did not run through against libmodbus's own server:\n{}",
        client.display(),
        reference.out
    );
    reference
}

/// Judges `run` against `reference`: each check that fails in the run must fail in the
/// reference too or be one of `expected`, and each of `expected` must fail; `unjudged` may go
/// either way. Prints every check of the three lists with its outcome and reason; `Err` names
/// the checks that do not fit.
pub fn judge(run: &Run, reference: &Run, expected: &[Check], unjudged: &[Check]) -> Result<(), String> {
    for (line, what) in &reference.failed {
        println!("  line {line}: fails against libmodbus's own server too: {what}");
    }
    for &(line, why) in expected {
        println!(
            "  line {line}: {} {why}",
            if run.fails(line) { "fails as expected:" } else { "PASSES, not expected:" }
        );
    }
    for &(line, why) in unjudged {
        println!("  line {line}: {}, not judged: {why}", if run.fails(line) { "fails" } else { "passes" });
    }
    let listed = |line: u32| expected.iter().chain(unjudged).any(|&(l, _)| l == line) || reference.fails(line);
    let unexpected: Vec<String> =
        run.failed.iter().filter(|(l, _)| !listed(*l)).map(|(l, what)| format!("line {l}: {what}")).collect();
    let missing: Vec<u32> = expected.iter().map(|&(l, _)| l).filter(|&l| !run.fails(l)).collect();
    if run.ran_through() && unexpected.is_empty() && missing.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{}failed checks not explained {unexpected:?}; expected deviations that did not fail {missing:?}",
            if run.ran_through() { "" } else { "the client did not run through; " }
        ))
    }
}
