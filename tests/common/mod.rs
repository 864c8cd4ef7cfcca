//! What the tests share beside the worker (`probe`) and the window (`window`): temporary
//! directories, child processes (`Process`), `drivedeck` on the command line (`cli`), the
//! simulated drive served in this process (`modbus_server`, `enip_adapter`) or as its own
//! process (`Sim`), socat pty pairs, and the Python peers (pymodbus, python-canopen,
//! pycomm3). Each test file takes what it needs (`mod common;`).
//!
//! The Python peers come from `./.venv`, which the first test that needs one makes with
//! the versions pinned in tests/peers/requirements.txt (see `peers`). A test whose peer
//! cannot be had passes without running it and says so in `cargo test`'s output
//! (`SKIPPED name: reason`); with `DRIVEDECK_REQUIRE_PEERS=1`, as `.ci/run` sets, it fails
//! instead.

#![allow(dead_code)]

pub mod cli;
pub mod peers;

use std::io::{BufRead, BufReader, Read};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::enip::AdapterOptions;
use drivedeck::sim::server::modbus::ServerOptions;

/// Whether a missing peer fails the test (CI) instead of skipping it.
pub fn peers_required() -> bool {
    std::env::var("DRIVEDECK_REQUIRE_PEERS").is_ok_and(|v| v == "1")
}

/// A test without its peer: skip it visibly here, fail it in CI.
pub fn skip_or_fail(reason: &str) {
    if peers_required() {
        panic!("DRIVEDECK_REQUIRE_PEERS=1 and {reason}");
    }
    peers::skip_visibly(peers::WITHOUT_PEER, reason);
}

/// A test that cannot run (all of) itself on this machine for a reason that is no peer
/// (no vcan0, no broadcast on loopback): it passes, saying so in `cargo test`'s output,
/// also in CI.
pub fn skip(reason: &str) {
    peers::skip_visibly(peers::WITHOUT_OTHER, reason);
}

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A Python interpreter that imports the peers' modules, with the version of each.
#[derive(Clone, Debug)]
pub struct Python {
    pub path: PathBuf,
    /// `(module, its __version__)` for every module asked for, in the order asked.
    pub versions: Vec<(String, String)>,
}

impl Python {
    /// The version `module` reported (`?` where it has no `__version__`).
    pub fn version(&self, module: &str) -> Option<&str> {
        self.versions
            .iter()
            .find(|(m, _)| m == module)
            .map(|(_, v)| v.as_str())
    }
}

/// Imports every module named on the command line and prints `{module: version}`.
const IMPORT_CHECK: &str = "\
import importlib, json, sys
out = {}
for name in sys.argv[1:]:
    module = importlib.import_module(name)
    out[name] = str(getattr(module, '__version__', '?'))
print(json.dumps(out))
";

/// The Python peer with `modules`, each `(import name, version prefix)`: an empty prefix
/// takes any version, `"3."` only 3.x. `None` (after `skip_or_fail`) when there is no
/// interpreter for the peers, or it cannot import one of them, or has a version the peers
/// were not written against.
pub fn python_with(modules: &[(&str, &str)]) -> Option<Python> {
    match check_python(modules) {
        Ok(python) => {
            peers::record(peers::RAN, "");
            Some(python)
        }
        Err(reason) => {
            skip_or_fail(&reason);
            None
        }
    }
}

/// `python_with` without the skip: the peer, or why it is not there.
pub fn check_python(modules: &[(&str, &str)]) -> Result<Python, String> {
    let names: Vec<&str> = modules.iter().map(|(m, _)| *m).collect();
    let no = format!("no {}", names.join(", "));
    let path = peers::interpreter()
        .map_err(|e| format!("{no}: {e}; or set DRIVEDECK_PYTHON to a Python that has them"))?;
    // What to do about an interpreter that lacks them: only one the user chose can.
    let (who, fix) = if peers::python_from_env().is_some() {
        (
            format!("{} (DRIVEDECK_PYTHON)", path.display()),
            format!(
                "unset DRIVEDECK_PYTHON to let `cargo test` make .venv with {}",
                peers::REQUIREMENTS
            ),
        )
    } else {
        (
            path.display().to_string(),
            format!(
                "its versions are those of {}; remove .venv to have it made again",
                peers::REQUIREMENTS
            ),
        )
    };
    let out = Command::new(&path)
        .arg("-c")
        .arg(IMPORT_CHECK)
        .args(&names)
        .output()
        .map_err(|e| format!("{no}: cannot run {who}: {e}; {fix}"))?;
    if !out.status.success() {
        return Err(format!(
            "{no}: {who} cannot import them ({}); {fix}",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ));
    }
    let reported: serde_json::Value = serde_json::from_slice(&out.stdout).map_err(|e| {
        format!(
            "{no}: {who} printed no versions ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })?;
    let mut versions = vec![];
    for (module, prefix) in modules {
        let version = reported[*module].as_str().unwrap_or("?").to_owned();
        if !version.starts_with(prefix) {
            return Err(format!(
                "{no}: {who} has {module} {version}, the peers need {prefix}x; {fix}"
            ));
        }
        versions.push(((*module).to_owned(), version));
    }
    Ok(Python { path, versions })
}

/// The name a peer module is installed under on PyPI (`serial` is pyserial).
pub fn distribution(module: &str) -> &str {
    match module {
        "serial" => "pyserial",
        "can" => "python-can",
        other => other,
    }
}

/// The pymodbus peer's modules with their version prefixes (pyserial for RTU).
pub const PYMODBUS: &[(&str, &str)] = &[("pymodbus", "3.")];
/// The python-canopen peer's: canopen 2.x on python-can 4.x (the slcan interface needs
/// pyserial).
pub const PYTHON_CANOPEN: &[(&str, &str)] = &[("canopen", "2."), ("can", "4."), ("serial", "")];
/// The pycomm3 peer's (EtherNet/IP): 1.2.x, whose `generic_message`, `list_identity`,
/// `get_module_info` and `discover` the peer script uses.
pub const PYCOMM3: &[(&str, &str)] = &[("pycomm3", "1.2.")];

/// The pymodbus peer: pymodbus 3.x (`device_id=`, SimDevice) and any other `modules`
/// (e.g. `serial` for RTU).
pub fn python(modules: &[&str]) -> Option<Python> {
    let mut all = PYMODBUS.to_vec();
    all.extend(modules.iter().map(|m| (*m, "")));
    python_with(&all)
}

/// The python-canopen peer: canopen 2.x on python-can 4.x (the slcan interface needs
/// pyserial).
pub fn python_canopen() -> Option<Python> {
    python_with(PYTHON_CANOPEN)
}

/// The pycomm3 peer (EtherNet/IP): 1.2.x, whose `generic_message`, `list_identity`,
/// `get_module_info` and `discover` the peer script uses.
pub fn python_pycomm3() -> Option<Python> {
    python_with(PYCOMM3)
}

/// A peer script in tests/peers/.
pub fn peer_script(name: &str) -> PathBuf {
    manifest_dir().join("tests/peers").join(name)
}

/// `socat`, or `None` (after `skip_or_fail`).
pub fn socat() -> Option<PathBuf> {
    check_socat().map_err(|reason| skip_or_fail(&reason)).ok()
}

/// `socat`, or why it is not there.
pub fn check_socat() -> Result<PathBuf, String> {
    match Command::new("socat").arg("-V").output() {
        Ok(out) if out.status.success() => Ok(PathBuf::from("socat")),
        _ => Err("socat is not installed (apt-get install socat)".to_owned()),
    }
}

/// Debian's Chromium (or Chrome), for the record's browser test.
pub fn chromium() -> Result<PathBuf, String> {
    [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ]
    .iter()
    .map(PathBuf::from)
    .find(|p| p.exists())
    .ok_or_else(|| "chromium is not installed (.ci/run installs Debian's chromium)".to_owned())
}

/// desktop-file-validate, for the desktop entry's test.
pub fn check_desktop_file_validate() -> Result<PathBuf, String> {
    match Command::new("desktop-file-validate").arg("--help").output() {
        Ok(_) => Ok(PathBuf::from("desktop-file-validate")),
        Err(_) => Err(
            "desktop-file-validate is not installed (.ci/run installs desktop-file-utils)"
                .to_owned(),
        ),
    }
}

/// A fresh, empty directory under the system's temp dir, named `drivedeck-{what}-…`,
/// removed on drop.
pub fn temp_dir(what: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("drivedeck-{what}-"))
        .tempdir()
        .expect("temp dir")
}

/// Collect a child's stream on a thread: every line goes to the shared text and, when
/// asked, down a channel.
fn pump(
    stream: impl Read + Send + 'static,
    text: Arc<Mutex<String>>,
    lines: Option<mpsc::Sender<String>>,
) -> thread::JoinHandle<()> {
    thread::spawn(move || {
        for line in BufReader::new(stream).lines() {
            let Ok(line) = line else { break };
            if let Ok(mut all) = text.lock() {
                all.push_str(&line);
                all.push('\n');
            }
            if let Some(lines) = &lines {
                let _ = lines.send(line);
            }
        }
    })
}

/// A child process of a test, killed (by its own pid) and reaped on drop. Its stdout
/// arrives line by line; stdout and stderr are kept for failure messages.
pub struct Process {
    pub name: String,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    stdout: Arc<Mutex<String>>,
    stderr: Arc<Mutex<String>>,
    pumps: Vec<thread::JoinHandle<()>>,
}

impl Process {
    /// Start `command` with piped stdio. Its stdin stays open until drop, so a peer can
    /// end itself when the test goes away.
    pub fn spawn(name: &str, command: &mut Command) -> Process {
        let mut child = command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        let stdout = Arc::new(Mutex::new(String::new()));
        let stderr = Arc::new(Mutex::new(String::new()));
        let (tx, lines) = mpsc::channel();
        let pumps = vec![
            pump(
                child.stdout.take().expect("stdout"),
                stdout.clone(),
                Some(tx),
            ),
            pump(child.stderr.take().expect("stderr"), stderr.clone(), None),
        ];
        Process {
            name: name.to_owned(),
            stdin: child.stdin.take(),
            child,
            lines,
            stdout,
            stderr,
            pumps,
        }
    }

    /// The next line on stdout, or `None` at its end or after `timeout`.
    pub fn line(&self, timeout: Duration) -> Option<String> {
        self.lines.recv_timeout(timeout).ok()
    }

    /// The next line, or a panic that shows what the process said.
    pub fn expect_line(&mut self, what: &str, timeout: Duration) -> String {
        match self.line(timeout) {
            Some(line) => line,
            None => panic!("no {what} within {timeout:?}: {}", self.report()),
        }
    }

    /// Whether the process is still running.
    pub fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Send `signal` (INT, TERM, HUP, STOP, CONT) to the process, by its own pid.
    pub fn signal(&self, signal: &str) {
        let status = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(self.pid().to_string())
            .status()
            .expect("kill runs");
        assert!(status.success(), "kill -{signal} {} failed", self.name);
    }

    /// Everything it printed so far, for failure messages.
    pub fn report(&mut self) -> String {
        let status = match self.child.try_wait() {
            Ok(Some(status)) => format!("exited with {status}"),
            _ => "still running".to_owned(),
        };
        format!(
            "{} {status}; stdout:\n{}\nstderr:\n{}",
            self.name,
            self.stdout.lock().map(|s| s.clone()).unwrap_or_default(),
            self.stderr.lock().map(|s| s.clone()).unwrap_or_default()
        )
    }

    /// Wait for the process to end by itself, and for everything it printed.
    pub fn wait(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                // Its pipes are closed: the pumps finish with the last lines.
                for pump in self.pumps.drain(..) {
                    let _ = pump.join();
                }
                return Some(status);
            }
            if Instant::now() >= deadline {
                return None;
            }
            thread::sleep(Duration::from_millis(10));
        }
    }

    pub fn stdout(&self) -> String {
        self.stdout.lock().map(|s| s.clone()).unwrap_or_default()
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        drop(self.stdin.take());
        // Child::kill signals this child's own pid only.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Run a Python peer script to its end and parse the one JSON object it prints; a
/// failure carries everything the script printed.
pub fn try_run_peer(
    python: &Python,
    script: &str,
    args: &[&str],
    timeout: Duration,
) -> Result<serde_json::Value, String> {
    let mut command = Command::new(&python.path);
    command.arg(peer_script(script)).args(args);
    let started = Instant::now();
    let mut process = Process::spawn(script, &mut command);
    let Some(status) = process.wait(timeout) else {
        return Err(format!(
            "{script} {args:?} did not finish within {timeout:?}; {}",
            process.report()
        ));
    };
    let stdout = process.stdout();
    let last = stdout.lines().last().unwrap_or("");
    match serde_json::from_str::<serde_json::Value>(last) {
        Ok(value) if status.success() && value.get("failed").is_none() => Ok(value),
        Ok(_) => Err(format!(
            "{script} {args:?} failed after {:?}: {}",
            started.elapsed(),
            process.report()
        )),
        Err(e) => Err(format!(
            "{script} {args:?} printed no JSON ({e}): {}",
            process.report()
        )),
    }
}

/// `try_run_peer`, panicking on a failure.
pub fn run_peer(
    python: &Python,
    script: &str,
    args: &[&str],
    timeout: Duration,
) -> serde_json::Value {
    try_run_peer(python, script, args, timeout).unwrap_or_else(|e| panic!("{e}"))
}

/// `drivedeck sim` as its own process, as a user would start it.
pub struct Sim {
    pub process: Process,
    /// The first line it printed ("serving the simulated drive on …" or "… as CANopen
    /// node …").
    pub banner: String,
}

impl Sim {
    /// `drivedeck sim ARGS…` with `setup` done to its command (its environment), ready
    /// once it printed its banner.
    fn start(args: &[&str], what: &str, setup: impl FnOnce(&mut Command)) -> Sim {
        let mut command = Command::new(env!("CARGO_BIN_EXE_drivedeck"));
        command.arg("sim").args(args);
        setup(&mut command);
        let mut process = Process::spawn("drivedeck sim", &mut command);
        let banner = process.expect_line(what, Duration::from_secs(10));
        assert!(
            banner.starts_with("serving the simulated drive"),
            "{banner}; {}",
            process.report()
        );
        Sim { process, banner }
    }

    /// `drivedeck sim --modbus-tcp 127.0.0.1:0 ARGS…`: a free port, read from its banner.
    pub fn tcp(args: &[&str]) -> (Sim, SocketAddr) {
        Sim::tcp_with(args, |_| {})
    }

    /// `Sim::tcp` with `setup` done to the command first (its environment).
    pub fn tcp_with(args: &[&str], setup: impl FnOnce(&mut Command)) -> (Sim, SocketAddr) {
        let mut all = vec!["--modbus-tcp", "127.0.0.1:0"];
        all.extend_from_slice(args);
        let sim = Sim::start(&all, "Modbus TCP banner", setup);
        // "serving the simulated drive on Modbus TCP 127.0.0.1:PORT (…)"
        let addr = sim
            .banner
            .split("Modbus TCP ")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|a| a.parse().ok())
            .unwrap_or_else(|| panic!("no address in {:?}", sim.banner));
        (sim, addr)
    }

    /// `drivedeck sim --modbus-rtu PATH ARGS…` (factory settings unless ARGS say otherwise).
    pub fn rtu(path: &Path, args: &[&str]) -> Sim {
        let path = path.to_str().expect("utf-8 path");
        let mut all = vec!["--modbus-rtu", path];
        all.extend_from_slice(args);
        let sim = Sim::start(&all, "Modbus RTU banner", |_| {});
        assert!(sim.banner.contains("Modbus RTU"), "{}", sim.banner);
        sim
    }

    /// `drivedeck sim --enip 127.0.0.1:0 --enip-io-port 0 ARGS…`: the EtherNet/IP adapter
    /// on a free port (TCP explicit messages and UDP ListIdentity), read from its banner.
    pub fn enip(args: &[&str]) -> (Sim, SocketAddr) {
        Sim::enip_on("127.0.0.1:0", args)
    }

    /// `drivedeck sim --enip ADDR --enip-io-port 0 ARGS…`, for a client that only knows
    /// one port (e.g. 127.77.0.1:44818 for pycomm3's `discover`).
    pub fn enip_on(addr: &str, args: &[&str]) -> (Sim, SocketAddr) {
        let mut all = vec!["--enip", addr, "--enip-io-port", "0"];
        all.extend_from_slice(args);
        let sim = Sim::start(&all, "EtherNet/IP banner", |_| {});
        // "serving the simulated drive on EtherNet/IP 127.0.0.1:P (class 1 I/O on UDP …)"
        let addr = sim
            .banner
            .split("EtherNet/IP ")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|a| a.parse().ok())
            .unwrap_or_else(|| panic!("no address in {:?}", sim.banner));
        (sim, addr)
    }

    /// `drivedeck sim --slcan PATH --node NODE ARGS…`: a CANopen node behind an emulated
    /// slcan adapter on one end of a pty pair.
    pub fn slcan(path: &Path, node: u8, args: &[&str]) -> Sim {
        Sim::slcan_nodes(path, &[node], args)
    }

    /// `drivedeck sim --can IFACE --node N1 --node N2…`: CANopen nodes on a SocketCAN
    /// interface (vcan0 where the machine has one).
    pub fn can_nodes(iface: &str, nodes: &[u8]) -> Sim {
        let ids: Vec<String> = nodes.iter().map(u8::to_string).collect();
        let mut all = vec!["--can", iface];
        for id in &ids {
            all.extend(["--node", id.as_str()]);
        }
        Sim::start(&all, "SocketCAN banner", |_| {})
    }

    /// `drivedeck sim --slcan PATH --node N1 --node N2… ARGS…`: CANopen nodes, each a
    /// drive of its own, on one bus behind an emulated slcan adapter.
    pub fn slcan_nodes(path: &Path, nodes: &[u8], args: &[&str]) -> Sim {
        let path = path.to_str().expect("utf-8 path");
        let ids: Vec<String> = nodes.iter().map(u8::to_string).collect();
        let mut all = vec!["--slcan", path];
        for id in &ids {
            all.extend(["--node", id.as_str()]);
        }
        all.extend_from_slice(args);
        let sim = Sim::start(&all, "slcan banner", |_| {});
        let named = match ids.as_slice() {
            [one] => format!("CANopen node {one} behind"),
            many => format!("CANopen nodes {} behind", many.join(", ")),
        };
        assert!(
            sim.banner
                .contains(&format!("{named} an emulated slcan adapter")),
            "{}",
            sim.banner
        );
        sim
    }
}

/// The link to CANopen node `node` behind the slcan adapter at `path`, at 1 Mbit/s.
pub fn slcan_spec(path: &Path, node: u8) -> drivedeck::link::LinkSpec {
    format!(
        "canopen+slcan://{}?bitrate=1000000&node={node}",
        path.display()
    )
    .parse()
    .expect("spec")
}

/// Two connected pseudo-terminals from socat, `a` and `b`, in a temp dir of their own.
pub struct PtyPair {
    pub a: PathBuf,
    pub b: PathBuf,
    process: Process,
    _dir: tempfile::TempDir,
}

impl PtyPair {
    /// `None` (after `skip_or_fail`) without socat.
    pub fn new() -> Option<PtyPair> {
        let socat = socat()?;
        let dir = temp_dir("pty");
        let a = dir.path().join("A");
        let b = dir.path().join("B");
        let mut command = Command::new(socat);
        command.args([
            "-d",
            "-d",
            &format!("pty,raw,echo=0,link={}", a.display()),
            &format!("pty,raw,echo=0,link={}", b.display()),
        ]);
        let mut process = Process::spawn("socat", &mut command);
        // Ready when both links exist and socat says it moves data.
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let ready = a.exists()
                && b.exists()
                && process
                    .stderr
                    .lock()
                    .is_ok_and(|s| s.contains("starting data transfer loop"));
            if ready {
                break;
            }
            assert!(
                process.running() && Instant::now() < deadline,
                "socat made no pty pair in {}; {}",
                dir.path().display(),
                process.report()
            );
            thread::sleep(Duration::from_millis(10));
        }
        Some(PtyPair {
            a,
            b,
            process,
            _dir: dir,
        })
    }

    pub fn running(&mut self) -> bool {
        self.process.running()
    }
}

/// Any free port on loopback.
pub fn loopback() -> SocketAddr {
    "127.0.0.1:0".parse().expect("address")
}

/// The simulated drive served over Modbus TCP in this process, on a free loopback port.
pub fn modbus_server(options: ServerOptions) -> ServerThread {
    ServerThread::modbus_tcp(loopback(), options).expect("the Modbus TCP server")
}

/// The simulated EtherNet/IP adapter in this process, on a free loopback port with its
/// class 1 I/O on a free UDP port (the tests run in parallel).
pub fn enip_adapter() -> ServerThread {
    ServerThread::enip(loopback(), enip_options()).expect("the EtherNet/IP adapter")
}

/// The adapter's options with its class 1 I/O on a free UDP port.
pub fn enip_options() -> AdapterOptions {
    AdapterOptions {
        io_port: 0,
        ..AdapterOptions::default()
    }
}

/// A current-thread runtime for a test that drives a link or a bus itself.
pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
}

/// Wait until `done` holds, or panic with `what` after `timeout`.
pub fn wait_until(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    eventually(what, timeout, || done().then_some(()));
}

/// Poll `check` until it gives `Some`, or panic with `what` after `timeout`.
pub fn eventually<T>(what: &str, timeout: Duration, mut check: impl FnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(value) = check() {
            return value;
        }
        assert!(Instant::now() < deadline, "no {what} within {timeout:?}");
        thread::sleep(Duration::from_millis(10));
    }
}
