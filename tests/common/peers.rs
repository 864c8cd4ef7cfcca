//! The Python peers' interpreter, made on demand, and the record of which tests ran their
//! peer and which passed without it.
//!
//! `cargo test` needs no setup for the peers: the first test that asks for one makes
//! `./.venv` (gitignored) with the pinned versions of `tests/peers/requirements.txt`, the
//! one list of them, using the machine's `python3 -m venv` and pip (which needs network
//! access to PyPI). Later test binaries and runs only compare the installed versions with
//! that list (one Python start) and install again when they differ. Cargo runs the test
//! binaries one after another, but each runs its tests on several threads, and a developer
//! may start two `cargo test` at once: the check and the install happen once per test
//! binary (`OnceLock`) and under an exclusive lock on `./.venv.lock` (`File::lock`, an
//! `flock` on Linux, released when the file is closed, also when the process dies).
//!
//! `DRIVEDECK_PYTHON=/path/to/python` takes that interpreter as it is and makes nothing.
//!
//! When the venv cannot be made (no python3, no venv module, no network) the reason is
//! kept: every test that needs a peer gives it, and the later test binaries of the same
//! `cargo test` reuse it instead of trying again.
//!
//! libtest cannot mark a test skipped at run time, and it captures what a passing test
//! prints on the test's thread. A test that passes without its peer is therefore said at
//! the end of its test binary, after libtest's `test result:` line, from an `atexit`
//! callback on the main thread, to stderr: `SKIPPED: 7 tests of modbus_peers passed
//! without running: REASON` and their names (`tests/peer_venv.rs` checks that it shows).
//! It is also noted in this run's directory, from which `tests/peers_status.rs`
//! (harness = false, so nothing captures it either; cargo runs the test targets in name
//! order, so it comes after the peer tests) prints one summary of the whole run.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant, SystemTime};

/// The one list of the peers and their versions, relative to the crate.
pub const REQUIREMENTS: &str = "tests/peers/requirements.txt";

/// How long a kept provisioning failure stands when the run's directory is not a cargo
/// run's (a test binary started by hand from a shell, whose pid stays the same).
const FAILURE_STANDS: Duration = Duration::from_secs(3600);

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One line of the requirements file: `name==version`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pin {
    pub name: String,
    pub version: String,
}

/// The pins of a requirements file. Comments (`#`) and blank lines aside, every line must
/// pin one distribution to one version: the tests were written against exactly those.
pub fn parse_pins(text: &str) -> Result<Vec<Pin>, String> {
    let mut pins = vec![];
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let pin = line.split_once("==").and_then(|(name, version)| {
            let (name, version) = (name.trim(), version.trim());
            let plain = |s: &str| {
                !s.is_empty()
                    && s.chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
            };
            (plain(name) && plain(version)).then(|| Pin {
                name: name.to_owned(),
                version: version.to_owned(),
            })
        });
        match pin {
            Some(pin) => pins.push(pin),
            None => {
                return Err(format!(
                    "line {}: {line:?} is not `name==version` (each peer is pinned to one version)",
                    n + 1
                ));
            }
        }
    }
    if pins.is_empty() {
        return Err("no `name==version` line".to_owned());
    }
    Ok(pins)
}

/// Prints `{distribution: installed version or null}` for every name on the command line,
/// from the installed metadata (no import, so it is quick).
const INSTALLED: &str = "\
import json, sys
from importlib import metadata
out = {}
for name in sys.argv[1:]:
    try:
        out[name] = metadata.version(name)
    except metadata.PackageNotFoundError:
        out[name] = None
print(json.dumps(out))
";

/// What `python`'s environment has other than `pins` (`pymodbus 3.15.0, pinned 3.16.1`,
/// `pycomm3 not installed`); empty when it has them all. `Err` when `python` does not run
/// or does not answer.
pub fn differences(python: &Path, pins: &[Pin]) -> Result<Vec<String>, String> {
    let out = Command::new(python)
        .arg("-c")
        .arg(INSTALLED)
        .args(pins.iter().map(|p| &p.name))
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{} cannot list its packages ({}): {}",
            python.display(),
            out.status,
            tail(&out.stderr)
        ));
    }
    let installed: serde_json::Value = serde_json::from_slice(&out.stdout).map_err(|e| {
        format!(
            "{} printed no package list ({e}): {}",
            python.display(),
            tail(&out.stdout)
        )
    })?;
    Ok(pins
        .iter()
        .filter_map(|pin| match installed[&pin.name].as_str() {
            Some(v) if v == pin.version => None,
            Some(v) => Some(format!("{} {v}, pinned {}", pin.name, pin.version)),
            None => Some(format!("{} not installed", pin.name)),
        })
        .collect())
}

/// What a command said, on one line, for a reason: its `ERROR:` lines (pip's, without its
/// retry warnings) if it has any, else its last lines.
fn tail(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let mut lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    if lines.iter().any(|l| l.starts_with("ERROR:")) {
        lines.retain(|l| l.starts_with("ERROR:"));
    }
    let tail = lines[lines.len().saturating_sub(4)..].join(" | ");
    if tail.is_empty() {
        "(no output)".to_owned()
    } else {
        tail
    }
}

/// Run `command`, or say what failed and what it printed.
fn run(what: &str, command: &mut Command) -> Result<(), String> {
    match command.output() {
        Err(e) => Err(format!("cannot run `{what}`: {e}")),
        Ok(out) if out.status.success() => Ok(()),
        Ok(out) => Err(format!(
            "`{what}` failed ({}): {}",
            out.status,
            tail(&[out.stderr, out.stdout].concat())
        )),
    }
}

/// A venv with the pinned peers: where it lives and how it is made.
#[derive(Clone, Debug)]
pub struct Venv {
    pub dir: PathBuf,
    pub requirements: PathBuf,
    /// The file locked while the venv is checked or made.
    pub lock: PathBuf,
    /// The Python that makes the venv (`python3 -m venv`).
    pub python3: PathBuf,
    /// Where a failure to make it is kept for the rest of the run, if anywhere.
    pub failure: Option<PathBuf>,
    /// Whether to say in the test output that it is installing (and how long it took).
    pub announce: bool,
}

impl Venv {
    /// The checkout's `.venv`, made with `python3` from PATH; a failure is kept in this
    /// run's directory.
    pub fn checkout() -> Venv {
        let root = manifest_dir();
        Venv {
            dir: root.join(".venv"),
            requirements: root.join(REQUIREMENTS),
            lock: root.join(".venv.lock"),
            python3: PathBuf::from("python3"),
            failure: Some(run_dir().join("provisioning-failed")),
            announce: true,
        }
    }

    /// The venv's interpreter.
    pub fn python(&self) -> PathBuf {
        self.dir.join("bin/python")
    }

    /// The venv's interpreter once it has every pin: as it is when it has them, else
    /// installed now. `Err` says why it cannot be had and what to do.
    pub fn provision(&self) -> Result<PathBuf, String> {
        let text = fs::read_to_string(&self.requirements)
            .map_err(|e| format!("cannot read {}: {e}", self.requirements.display()))?;
        let pins =
            parse_pins(&text).map_err(|e| format!("{}: {e}", self.requirements.display()))?;
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&self.lock)
            .map_err(|e| format!("cannot open the lock file {}: {e}", self.lock.display()))?;
        // Blocks while another test binary (or thread) checks or makes the venv; released
        // when `lock` is closed at the end of this function.
        lock.lock()
            .map_err(|e| format!("cannot lock {}: {e}", self.lock.display()))?;
        let python = self.python();
        let needs = match differences(&python, &pins) {
            Ok(d) if d.is_empty() => return Ok(python),
            Ok(d) => d.join(", "),
            Err(_) => "no working venv there".to_owned(),
        };
        if let Some(kept) = self.kept_failure() {
            return Err(kept);
        }
        let made = self.install(&python, &pins, &needs);
        if let (Err(reason), Some(failure)) = (&made, &self.failure) {
            if let Some(dir) = failure.parent() {
                let _ = fs::create_dir_all(dir);
            }
            let _ = fs::write(failure, reason);
        }
        made
    }

    /// A failure an earlier test binary of this run kept, if it is recent.
    fn kept_failure(&self) -> Option<String> {
        let failure = self.failure.as_ref()?;
        let age = fs::metadata(failure)
            .ok()?
            .modified()
            .ok()?
            .elapsed()
            .ok()?;
        if age > FAILURE_STANDS {
            return None;
        }
        let reason = fs::read_to_string(failure).ok()?;
        Some(format!(
            "{reason} (found by an earlier test binary of this `cargo test`; the next `cargo test` tries again)"
        ))
    }

    fn install(&self, python: &Path, pins: &[Pin], needs: &str) -> Result<PathBuf, String> {
        let started = Instant::now();
        self.say(&format!(
            "peers: making {} with {} ({needs}); once, ~10 s with network access",
            self.dir.display(),
            self.requirements.display()
        ));
        let has_pip = Command::new(python)
            .args(["-m", "pip", "--version"])
            .output()
            .is_ok_and(|out| out.status.success());
        if !has_pip {
            // Missing, or broken (half made, or its base Python gone): made anew.
            match fs::remove_dir_all(&self.dir) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => {
                    return Err(format!(
                        "cannot remove the broken venv {}: {e}",
                        self.dir.display()
                    ));
                }
            }
            let what = format!("{} -m venv {}", self.python3.display(), self.dir.display());
            run(
                &what,
                Command::new(&self.python3).args(["-m", "venv"]).arg(&self.dir),
            )
            .map_err(|e| {
                format!(
                    "{e}; install Python 3 with its venv module (Debian/Ubuntu: apt-get install python3 python3-venv)"
                )
            })?;
        }
        let what = format!(
            "{} -m pip install -r {}",
            python.display(),
            self.requirements.display()
        );
        run(
            &what,
            Command::new(python)
                .args(["-m", "pip", "install", "--disable-pip-version-check"])
                .args(["--no-input", "--quiet", "--retries", "1", "--timeout", "15"])
                .arg("-r")
                .arg(&self.requirements),
        )
        .map_err(|e| {
            format!("{e}; pip needs network access to PyPI (or an index set with PIP_INDEX_URL)")
        })?;
        let left = differences(python, pins)?;
        if !left.is_empty() {
            return Err(format!(
                "{} still differs from {} after pip install: {}",
                self.dir.display(),
                self.requirements.display(),
                left.join(", ")
            ));
        }
        self.say(&format!(
            "peers: {} ready in {:.1} s",
            self.dir.display(),
            started.elapsed().as_secs_f64()
        ));
        Ok(python.to_path_buf())
    }

    fn say(&self, line: &str) {
        if self.announce {
            announce(line);
        }
    }
}

/// The interpreter `DRIVEDECK_PYTHON` names, if it names one.
pub fn python_from_env() -> Option<PathBuf> {
    std::env::var_os("DRIVEDECK_PYTHON")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
}

/// The interpreter for the peers, or why there is none: `DRIVEDECK_PYTHON` as it is, else
/// the checkout's `.venv`, checked (and made when needed) once per test binary.
pub fn interpreter() -> Result<PathBuf, String> {
    static ONCE: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    ONCE.get_or_init(|| match python_from_env() {
        Some(path) => Ok(path),
        None => Venv::checkout().provision(),
    })
    .clone()
}

/// Where this `cargo test` run keeps its notes: `target/tmp/peer-runs/PID`, PID that of
/// the cargo process, whose children all the test binaries of one run are.
/// `DRIVEDECK_PEER_RUN_DIR` puts them elsewhere (`tests/peer_venv.rs` does, for the
/// binaries it starts itself).
pub fn run_dir() -> PathBuf {
    match std::env::var_os("DRIVEDECK_PEER_RUN_DIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => runs_root().join(std::os::unix::process::parent_id().to_string()),
    }
}

/// The parent of the runs' directories.
pub fn runs_root() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("peer-runs")
}

/// Remove the runs' directories under `root` other than `keep` that were last touched
/// more than `older_than` ago; how many went.
pub fn prune_runs(root: &Path, keep: &Path, older_than: Duration) -> usize {
    let Ok(entries) = fs::read_dir(root) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| SystemTime::now().duration_since(t).ok())
            .is_some_and(|age| age > older_than);
        if path != keep && path.is_dir() && old && fs::remove_dir_all(&path).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Write `line` where `cargo test` shows it, also from a passing test: the stderr handle,
/// which libtest does not capture (it captures the `print!` family only,
/// rust-lang/rust#90785).
pub fn announce(line: &str) {
    let _ = std::io::stderr()
        .lock()
        .write_all(format!("{line}\n").as_bytes());
}

/// The running test's name (libtest names each test's thread after it).
fn test_name() -> String {
    std::thread::current().name().unwrap_or("?").to_owned()
}

/// What a test did, as noted in the run's directory.
pub const RAN: &str = "ran";
/// Passed without running its peer (or socat).
pub const WITHOUT_PEER: &str = "without-peer";
/// Passed without running (all of) itself for another reason of the machine (no vcan0…).
pub const WITHOUT_OTHER: &str = "without-other";

/// Note in this run's directory what the running test did (`RAN`, `WITHOUT_PEER`,
/// `WITHOUT_OTHER`), one line in `<test binary>.log`, which each test binary starts anew.
pub fn record(kind: &str, reason: &str) {
    static LOG: OnceLock<Option<Mutex<File>>> = OnceLock::new();
    let log = LOG.get_or_init(|| {
        let dir = run_dir();
        fs::create_dir_all(&dir).ok()?;
        File::create(dir.join(format!("{}.log", env!("CARGO_CRATE_NAME"))))
            .ok()
            .map(Mutex::new)
    });
    if let Some(Ok(mut file)) = log.as_ref().map(Mutex::lock) {
        let reason = reason.replace(['\n', '\t'], " ");
        let _ = writeln!(file, "{}\t{kind}\t{reason}", test_name());
    }
}

// SAFETY: atexit(3) of the C library, which every Rust program on Linux links, takes any
// `extern "C" fn()` and calls it when the process exits; no argument can misuse it.
unsafe extern "C" {
    safe fn atexit(callback: extern "C" fn()) -> std::ffi::c_int;
}

/// The skips of this test binary, `(test, reason)`, for [`report_skips`].
static SKIPS: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());

/// Say in `cargo test`'s output that the running test passes without running (all of)
/// itself, and why, and note it (`kind`) for the summary. The saying waits for the end of
/// the test binary, after libtest's `test result:` line: a line written meanwhile from a
/// test's thread would land inside libtest's result lines of the tests finishing at the
/// same moment (it writes `test NAME ... `, then `ok`).
pub fn skip_visibly(kind: &str, reason: &str) {
    record(kind, reason);
    let Ok(mut skips) = SKIPS.lock() else {
        announce(&format!("SKIPPED {}: {reason}", test_name()));
        return;
    };
    if skips.is_empty() {
        // Runs when the test binary exits (libtest returns from main or calls exit);
        // if it cannot be registered, say it now rather than never.
        if atexit(report_skips) != 0 {
            announce(&format!("SKIPPED {}: {reason}", test_name()));
        }
    }
    skips.push((test_name(), reason.to_owned()));
}

/// The block [`report_skips`] writes: each reason once, then the tests it kept from
/// running.
pub fn skips_block(binary: &str, skips: &[(String, String)]) -> String {
    let mut reasons: Vec<&str> = vec![];
    for (_, reason) in skips {
        if !reasons.contains(&reason.as_str()) {
            reasons.push(reason);
        }
    }
    let mut out = String::new();
    for reason in reasons {
        let tests: Vec<&str> = skips
            .iter()
            .filter(|(_, r)| r == reason)
            .map(|(t, _)| t.as_str())
            .collect();
        out.push_str(&format!(
            "SKIPPED: {} test{} of {binary} passed without running: {reason}\n",
            tests.len(),
            if tests.len() == 1 { "" } else { "s" }
        ));
        for test in tests {
            out.push_str(&format!("    {binary}::{test}\n"));
        }
    }
    out
}

/// Write this binary's skips to stderr (an `atexit` callback: it must not unwind).
extern "C" fn report_skips() {
    let block = match SKIPS.lock() {
        Ok(skips) => skips_block(env!("CARGO_CRATE_NAME"), &skips),
        Err(_) => return,
    };
    let _ = std::io::stderr().lock().write_all(block.as_bytes());
}

/// One line of a run's notes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    pub binary: String,
    pub test: String,
    pub kind: String,
    pub reason: String,
}

/// The notes of one test binary's log.
pub fn parse_records(binary: &str, text: &str) -> Vec<Record> {
    text.lines()
        .filter_map(|line| {
            let mut fields = line.splitn(3, '\t');
            Some(Record {
                binary: binary.to_owned(),
                test: fields.next()?.to_owned(),
                kind: fields.next()?.to_owned(),
                reason: fields.next().unwrap_or("").to_owned(),
            })
        })
        .collect()
}

/// Every note in a run's directory, by test binary name.
pub fn read_records(dir: &Path) -> Vec<Record> {
    let Ok(entries) = fs::read_dir(dir) else {
        return vec![];
    };
    let mut logs: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "log"))
        .collect();
    logs.sort();
    logs.iter()
        .flat_map(|path| {
            let binary = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            parse_records(&binary, &fs::read_to_string(path).unwrap_or_default())
        })
        .collect()
}

/// Whether one peer is there: what it is (`pymodbus 3.16.1, pyserial 3.5`) or why not.
#[derive(Clone, Debug)]
pub struct PeerCheck {
    pub peer: &'static str,
    /// Packages of the peers' Python (else a program of its own, such as socat).
    pub python: bool,
    pub found: Result<String, String>,
}

/// How many tests have a note of `kind` in `records`, and where: `"canopen_peers 3, eds 1"`.
/// A test that ran its peer but then went without something else (socat) did not run.
fn count(records: &[Record], kind: &str) -> (usize, String) {
    let mut per_binary: Vec<(&str, Vec<&str>)> = vec![];
    for r in records.iter().filter(|r| r.kind == kind) {
        let went_without = records
            .iter()
            .any(|o| o.binary == r.binary && o.test == r.test && o.kind != RAN);
        if kind == RAN && went_without {
            continue;
        }
        match per_binary.iter_mut().find(|(b, _)| *b == r.binary) {
            Some((_, tests)) if tests.contains(&r.test.as_str()) => {}
            Some((_, tests)) => tests.push(&r.test),
            None => per_binary.push((&r.binary, vec![&r.test])),
        }
    }
    let total = per_binary.iter().map(|(_, t)| t.len()).sum();
    let text = per_binary
        .iter()
        .map(|(b, t)| format!("{b} {}", t.len()))
        .collect::<Vec<_>>()
        .join(", ");
    (total, text)
}

/// The peer tests' status for the end of `cargo test`: one line when every peer is there
/// and no test went without, else a block nobody scrolls past.
pub fn summary(
    python: &Result<PathBuf, String>,
    checks: &[PeerCheck],
    records: &[Record],
    required: bool,
) -> String {
    let (ran, ran_where) = count(records, RAN);
    let (without, without_where) = count(records, WITHOUT_PEER);
    let mut out = String::new();
    let all_there = checks.iter().all(|c| c.found.is_ok());
    if all_there && without == 0 {
        // Each package once, those of the Python first: "pymodbus 3.16.1, pyserial 3.5".
        let mut packages: Vec<&str> = vec![];
        for check in checks.iter().filter(|c| c.python) {
            for package in check.found.as_deref().unwrap_or("").split(", ") {
                if !package.is_empty() && !packages.contains(&package) {
                    packages.push(package);
                }
            }
        }
        out.push_str(&format!("peers: {}", packages.join(", ")));
        if let Ok(python) = python {
            out.push_str(&format!(" at {}", python.display()));
        }
        let others: Vec<&str> = checks
            .iter()
            .filter(|c| !c.python)
            .map(|c| c.found.as_deref().unwrap_or(""))
            .collect();
        if !others.is_empty() {
            out.push_str(&format!(", and {}", others.join(", ")));
        }
        if ran > 0 {
            out.push_str(&format!(
                " — {ran} peer tests ran against them for real ({ran_where})\n"
            ));
        } else {
            out.push_str(
                " — the peer tests run against them (none ran before this in this `cargo test`)\n",
            );
        }
    } else {
        let rule = "=".repeat(78);
        out.push_str(&format!("{rule}\nPEER TESTS SKIPPED\n"));
        for check in checks {
            match &check.found {
                Ok(found) => out.push_str(&format!("  {}: {found}\n", check.peer)),
                Err(why) => out.push_str(&format!("  {}: NOT AVAILABLE: {why}\n", check.peer)),
            }
        }
        if without > 0 {
            out.push_str(&format!(
                "  {without} tests passed without running their peer ({without_where}); each binary named them after its `test result:` line above\n"
            ));
        } else {
            out.push_str("  the tests that need a missing peer pass without running it; each binary names them after its `test result:` line\n");
        }
        if ran > 0 {
            out.push_str(&format!("  {ran} peer tests ran for real ({ran_where})\n"));
        }
        if required {
            out.push_str("  DRIVEDECK_REQUIRE_PEERS=1: a missing peer is a failure\n");
        } else {
            out.push_str(
                "  DRIVEDECK_REQUIRE_PEERS=1 (as `bash .ci/run` sets) fails them instead\n",
            );
        }
        out.push_str(&format!("{rule}\n"));
    }
    let others: Vec<String> = records
        .iter()
        .filter(|r| r.kind == WITHOUT_OTHER)
        .map(|r| format!("{}::{} ({})", r.binary, r.test, r.reason))
        .collect();
    if !others.is_empty() {
        out.push_str(&format!(
            "also passed without running all of themselves: {}\n",
            others.join("; ")
        ));
    }
    out
}
