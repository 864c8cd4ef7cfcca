//! How the tests get their Python peers (tests/common/peers.rs) and how a test that passes
//! without its peer says so: the one pinned list, a venv made once under the lock even by
//! racing threads and then reused, a broken one made again, the reason of a failure kept,
//! the skip line past libtest's capture, and the summary `peers_status` prints.
//!
//! A stand-in Python (a shell script) makes the venvs here, so nothing is downloaded.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Barrier};
use std::thread;
use std::time::{Duration, SystemTime};

use common::peers::{self, PeerCheck, Pin, Record, Venv};
use common::temp_dir;

const PINS: &str = "# a comment\npymodbus==3.16.1\n\ncanopen==2.4.1  # trailing comment\n";
const INSTALLED: &str = r#"{"pymodbus": "3.16.1", "canopen": "2.4.1"}"#;

/// Write an executable script. Through `sh`, not from this process: a file this
/// multithreaded process has open for writing can be inherited by a child another test
/// forks meanwhile, and then cannot be run ("Text file busy").
fn write_script(path: &Path, body: &str) {
    let mut sh = Command::new("sh")
        .args(["-c", r#"cat > "$0" && chmod 755 "$0""#])
        .arg(path)
        .stdin(Stdio::piped())
        .spawn()
        .expect("sh");
    sh.stdin
        .take()
        .expect("stdin")
        .write_all(format!("#!/bin/sh\n{body}").as_bytes())
        .expect("script");
    assert!(sh.wait().expect("sh").success(), "{}", path.display());
}

/// A stand-in `python3` whose `-m venv DIR` makes DIR/bin/python, a stand-in venv Python:
/// `-c …` prints the "installed" packages (state/installed.json), `-m pip --version`
/// answers, `-m pip install` "installs" state/after-pip.json. Each venv and pip run is
/// logged.
struct Fake {
    dir: tempfile::TempDir,
}

impl Fake {
    fn new(venv: &str, pip: &str) -> Fake {
        let dir = temp_dir("fake-python");
        let root = dir.path().display().to_string();
        fs::write(dir.path().join("requirements.txt"), PINS).expect("pins");
        fs::write(dir.path().join("after-pip.json"), INSTALLED).expect("after pip");
        write_script(
            &dir.path().join("venv-python"),
            &format!(
                r#"case "$1" in
  -c) cat "{root}/installed.json" 2>/dev/null || echo '{{}}' ;;
  -m) if [ "$3" = "--version" ]; then echo "pip 0 (stand-in)"; exit 0; fi
      echo pip >> "{root}/log"
      {pip} ;;
esac
"#
            ),
        );
        write_script(
            &dir.path().join("python3"),
            &format!(
                r#"[ "$1 $2" = "-m venv" ] || exit 2
echo venv >> "{root}/log"
sleep 0.2
{venv}
mkdir -p "$3/bin" && cp "{root}/venv-python" "$3/bin/python"
"#
            ),
        );
        Fake { dir }
    }

    fn working() -> Fake {
        Fake::new(
            "",
            r#"cp "$(dirname "$0")/../../after-pip.json" "$(dirname "$0")/../../installed.json""#,
        )
    }

    fn venv(&self) -> Venv {
        Venv {
            dir: self.dir.path().join("venv"),
            requirements: self.dir.path().join("requirements.txt"),
            lock: self.dir.path().join("venv.lock"),
            python3: self.dir.path().join("python3"),
            failure: None,
            announce: false,
        }
    }

    /// What ran, in order: `venv`, `pip`.
    fn log(&self) -> Vec<String> {
        fs::read_to_string(self.dir.path().join("log"))
            .unwrap_or_default()
            .lines()
            .map(str::to_owned)
            .collect()
    }
}

#[test]
fn the_requirements_file_pins_every_peer_and_ci_keeps_no_list_of_its_own() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let text = fs::read_to_string(root.join(peers::REQUIREMENTS)).expect("requirements");
    let pins = peers::parse_pins(&text).expect("pins");
    let version = |name: &str| {
        pins.iter()
            .find(|p| p.name == name)
            .map(|p| p.version.clone())
            .unwrap_or_else(|| panic!("{name} is not pinned: {pins:?}"))
    };
    // Each within the versions the peers check for (tests/common/mod.rs).
    let prefixes = [common::PYMODBUS, common::PYTHON_CANOPEN, common::PYCOMM3].concat();
    for (module, prefix) in prefixes {
        let name = common::distribution(module);
        assert!(
            version(name).starts_with(prefix),
            "{name} {}",
            version(name)
        );
    }
    assert_eq!(pins.len(), 5, "{pins:?}");
    let ci = fs::read_to_string(root.join(".ci/run")).expect(".ci/run");
    for pin in &pins {
        assert!(
            !ci.contains(&format!("{}==", pin.name)),
            ".ci/run pins {} itself",
            pin.name
        );
    }
}

#[test]
fn a_requirements_line_without_one_version_is_refused() {
    assert_eq!(
        peers::parse_pins("a==1.0\nb-c==2\n"),
        Ok(vec![
            Pin {
                name: "a".into(),
                version: "1.0".into()
            },
            Pin {
                name: "b-c".into(),
                version: "2".into()
            },
        ])
    );
    for bad in ["pymodbus>=3", "pymodbus", "pymodbus==3.16.1,<4", "==3"] {
        let err = peers::parse_pins(bad).expect_err(bad);
        assert!(
            err.contains("line 1") && err.contains("name==version"),
            "{err}"
        );
    }
    assert!(peers::parse_pins("# only a comment\n").is_err());
}

#[test]
fn racing_threads_make_the_venv_once_under_the_lock_and_later_calls_reuse_it() {
    let fake = Fake::working();
    let venv = fake.venv();
    let start = Arc::new(Barrier::new(4));
    let racers: Vec<_> = (0..4)
        .map(|_| {
            let (venv, start) = (venv.clone(), start.clone());
            thread::spawn(move || {
                start.wait();
                venv.provision()
            })
        })
        .collect();
    for racer in racers {
        assert_eq!(racer.join().expect("racer"), Ok(venv.python()));
    }
    assert_eq!(fake.log(), ["venv", "pip"]);
    // Checked, not installed again.
    assert_eq!(venv.provision(), Ok(venv.python()));
    assert_eq!(fake.log(), ["venv", "pip"]);
    // A new pin installs again into the same venv.
    fs::write(&venv.requirements, "pymodbus==3.17.0\n").expect("new pin");
    fs::write(
        fake.dir.path().join("after-pip.json"),
        r#"{"pymodbus": "3.17.0"}"#,
    )
    .expect("pip");
    assert_eq!(venv.provision(), Ok(venv.python()));
    assert_eq!(fake.log(), ["venv", "pip", "pip"]);
}

#[test]
fn a_broken_venv_is_made_again() {
    let fake = Fake::working();
    let venv = fake.venv();
    // Half made: a Python that cannot even list its packages, no pip.
    fs::create_dir_all(venv.dir.join("bin")).expect("bin");
    write_script(&venv.python(), "exit 1\n");
    fs::write(venv.dir.join("leftover"), "").expect("leftover");
    assert_eq!(venv.provision(), Ok(venv.python()));
    assert_eq!(fake.log(), ["venv", "pip"]);
    assert!(!venv.dir.join("leftover").exists());
}

#[test]
fn a_venv_that_cannot_be_made_gives_the_reason_and_what_to_do() {
    // No python3 at all.
    let fake = Fake::working();
    let mut venv = fake.venv();
    venv.python3 = PathBuf::from("/nonexistent/python3");
    let err = venv.provision().expect_err("no python3");
    assert!(
        err.contains("cannot run `/nonexistent/python3 -m venv") && err.contains("python3-venv"),
        "{err}"
    );

    // python3 without its venv module (Debian without python3-venv).
    let fake = Fake::new(
        "echo 'The virtual environment was not created: ensurepip is not available' >&2; exit 1",
        "",
    );
    let err = fake.venv().provision().expect_err("no venv module");
    assert!(
        err.contains("ensurepip is not available") && err.contains("apt-get install python3"),
        "{err}"
    );

    // pip without network: its errors, not its retry warnings.
    let fake = Fake::new(
        "",
        "echo 'WARNING: Retrying after connection broken by NewConnectionError' >&2
      echo 'ERROR: Could not find a version that satisfies the requirement pymodbus==3.16.1' >&2
      exit 1",
    );
    let err = fake.venv().provision().expect_err("no network");
    assert!(
        err.contains("pip install -r")
            && err.contains("Could not find a version")
            && err.contains("network access")
            && !err.contains("Retrying"),
        "{err}"
    );

    // pip "succeeds" but the versions are still not the pinned ones.
    let fake = Fake::new("", "true");
    let err = fake.venv().provision().expect_err("still missing");
    assert!(
        err.contains("after pip install") && err.contains("pymodbus not installed"),
        "{err}"
    );
}

#[test]
fn a_failure_stands_for_the_rest_of_the_run_instead_of_trying_again() {
    let failing = Fake::new("echo 'no venv module' >&2; exit 1", "");
    let run = temp_dir("peer-run");
    let mut venv = failing.venv();
    venv.failure = Some(run.path().join("provisioning-failed"));
    let first = venv.provision().expect_err("fails");
    assert!(first.contains("no venv module"), "{first}");
    // A later test binary of the run (with a python3 that would work now) is told the
    // same, without trying again.
    let working = Fake::working();
    let mut later = working.venv();
    later.failure = venv.failure.clone();
    let again = later.provision().expect_err("kept");
    assert!(
        again.starts_with(&first) && again.contains("the next `cargo test` tries again"),
        "{again}"
    );
    assert_eq!(working.log(), Vec::<String>::new());
    // A new run tries again.
    later.failure = Some(run.path().join("next-run/provisioning-failed"));
    assert_eq!(later.provision(), Ok(later.python()));
}

/// Only run as a child of the two tests below: a peer test whose peer is missing.
#[test]
fn child_a_peer_test_without_its_peer() {
    if std::env::var_os("DRIVEDECK_PEER_VENV_CHILD").is_none() {
        return;
    }
    let got = common::python_with(&[("drivedeck_no_such_module", "")]);
    assert!(got.is_none());
}

/// Run `child_a_peer_test_without_its_peer` in a test binary of its own, as cargo does:
/// whether it passed, and its stdout and stderr in one stream, in the order written.
fn child(run: &Path, require: bool) -> (bool, String) {
    let (mut reader, writer) = std::io::pipe().expect("pipe");
    let mut command = Command::new(std::env::current_exe().expect("this test binary"));
    command
        .args(["--exact", "child_a_peer_test_without_its_peer"])
        .env("DRIVEDECK_PEER_VENV_CHILD", "1")
        .env("DRIVEDECK_PYTHON", "/nonexistent/python")
        .env("DRIVEDECK_PEER_RUN_DIR", run)
        .env_remove("DRIVEDECK_REQUIRE_PEERS")
        .stdout(writer.try_clone().expect("pipe"))
        .stderr(writer);
    if require {
        command.env("DRIVEDECK_REQUIRE_PEERS", "1");
    }
    let mut child = command.spawn().expect("the child runs");
    // The pipe's writing ends are the child's now: it ends when the child does.
    drop(command);
    let mut output = String::new();
    reader.read_to_string(&mut output).expect("its output");
    (child.wait().expect("the child ends").success(), output)
}

#[test]
fn a_test_without_its_peer_says_so_after_the_results_and_notes_it() {
    let run = temp_dir("peer-run");
    let (passed, output) = child(run.path(), false);
    assert!(passed, "{output}");
    // libtest reports it passed (it cannot do otherwise) and shows nothing it captured...
    let ok = output.find("test child_a_peer_test_without_its_peer ... ok\n");
    let result = output.find("test result: ok. 1 passed");
    // ...but the skip is in the output all the same, after libtest's result line (not in
    // the middle of its lines), with the reason and the test's name.
    let said = output.find(
        "SKIPPED: 1 test of peer_venv passed without running: no drivedeck_no_such_module: \
         cannot run /nonexistent/python (DRIVEDECK_PYTHON)",
    );
    let named = output.find("\n    peer_venv::child_a_peer_test_without_its_peer\n");
    assert!(
        ok.is_some() && ok < result && result < said && said < named,
        "{output}"
    );
    let records = peers::read_records(run.path());
    assert_eq!(records.len(), 1, "{records:?}");
    let (binary, test, kind) = (&records[0].binary, &records[0].test, &records[0].kind);
    assert_eq!(
        (binary.as_str(), test.as_str(), kind.as_str()),
        (
            "peer_venv",
            "child_a_peer_test_without_its_peer",
            peers::WITHOUT_PEER
        )
    );
    assert!(
        records[0]
            .reason
            .starts_with("no drivedeck_no_such_module: cannot run /nonexistent/python"),
        "{records:?}"
    );
}

#[test]
fn with_require_peers_a_test_without_its_peer_fails() {
    let run = temp_dir("peer-run");
    let (passed, output) = child(run.path(), true);
    assert!(!passed, "{output}");
    assert!(
        output.contains("DRIVEDECK_REQUIRE_PEERS=1 and no drivedeck_no_such_module: cannot run"),
        "{output}"
    );
    assert!(
        output.contains("test child_a_peer_test_without_its_peer ... FAILED"),
        "{output}"
    );
    assert!(!output.contains("SKIPPED"), "{output}");
}

#[test]
fn a_binarys_skips_are_said_once_per_reason_with_the_tests_it_kept_from_running() {
    let skips = [
        ("a".to_owned(), "no pymodbus: x".to_owned()),
        ("b".to_owned(), "socat is not installed".to_owned()),
        ("c".to_owned(), "no pymodbus: x".to_owned()),
    ];
    assert_eq!(
        peers::skips_block("modbus_rtu", &skips),
        "SKIPPED: 2 tests of modbus_rtu passed without running: no pymodbus: x\n\
         \x20   modbus_rtu::a\n\
         \x20   modbus_rtu::c\n\
         SKIPPED: 1 test of modbus_rtu passed without running: socat is not installed\n\
         \x20   modbus_rtu::b\n"
    );
    assert_eq!(peers::skips_block("modbus_rtu", &[]), "");
}

fn record(binary: &str, test: &str, kind: &str, reason: &str) -> Record {
    Record {
        binary: binary.into(),
        test: test.into(),
        kind: kind.into(),
        reason: reason.into(),
    }
}

fn checks(pymodbus: Result<&str, &str>) -> Vec<PeerCheck> {
    vec![
        PeerCheck {
            peer: "pymodbus",
            python: true,
            found: pymodbus.map(str::to_owned).map_err(str::to_owned),
        },
        PeerCheck {
            peer: "python-canopen",
            python: true,
            found: Ok("canopen 2.4.1, pyserial 3.5".into()),
        },
        PeerCheck {
            peer: "socat",
            python: false,
            found: Ok("socat".into()),
        },
    ]
}

#[test]
fn the_summary_is_one_line_when_the_peers_ran_and_a_block_when_tests_went_without() {
    let python = Ok(PathBuf::from("/x/.venv/bin/python"));
    let ran = [
        record("enip_peers", "a", peers::RAN, ""),
        record("modbus_peers", "b", peers::RAN, ""),
        record("modbus_peers", "c", peers::RAN, ""),
        // Ran its peer, then had no socat: did not run.
        record("canopen_peers", "d", peers::RAN, ""),
        record(
            "canopen_peers",
            "d",
            peers::WITHOUT_PEER,
            "socat is not installed",
        ),
    ];
    let found = Ok("pymodbus 3.16.1, pyserial 3.5");
    let all = peers::summary(&python, &checks(found), &ran[..3], false);
    assert_eq!(
        all,
        "peers: pymodbus 3.16.1, pyserial 3.5, canopen 2.4.1 at /x/.venv/bin/python, and socat \
         — 3 peer tests ran against them for real (enip_peers 1, modbus_peers 2)\n"
    );
    let none = peers::summary(&python, &checks(found), &[], false);
    assert!(none.contains("none ran before this"), "{none}");

    let without = [
        record("modbus_peers", "e", peers::WITHOUT_PEER, "no pymodbus"),
        record("modbus_peers", "f", peers::WITHOUT_PEER, "no pymodbus"),
        record("modbus_rtu", "g", peers::WITHOUT_PEER, "no pymodbus"),
        record("can_buses", "h", peers::WITHOUT_OTHER, "no vcan0"),
    ];
    let records: Vec<Record> = ran.iter().chain(&without).cloned().collect();
    let block = peers::summary(&python, &checks(Err("no pymodbus")), &records, false);
    assert!(block.contains("\nPEER TESTS SKIPPED\n"), "{block}");
    assert!(
        block.contains("  pymodbus: NOT AVAILABLE: no pymodbus\n"),
        "{block}"
    );
    assert!(
        block.contains("  python-canopen: canopen 2.4.1, pyserial 3.5\n"),
        "{block}"
    );
    assert!(
        block.contains("  4 tests passed without running their peer (canopen_peers 1, modbus_peers 2, modbus_rtu 1)"),
        "{block}"
    );
    assert!(
        block.contains("  3 peer tests ran for real (enip_peers 1, modbus_peers 2)"),
        "{block}"
    );
    assert!(block.contains("fails them instead"), "{block}");
    assert!(
        block.contains("also passed without running all of themselves: can_buses::h (no vcan0)"),
        "{block}"
    );
    // In CI the block says it is a failure.
    let ci = peers::summary(&python, &checks(Err("no pymodbus")), &[], true);
    assert!(
        ci.contains("DRIVEDECK_REQUIRE_PEERS=1: a missing peer is a failure"),
        "{ci}"
    );
    // Every peer there but a test went without (socat): still the block.
    let socat = peers::summary(&python, &checks(found), &ran, false);
    assert!(
        socat.contains("PEER TESTS SKIPPED") && socat.contains("canopen_peers 1"),
        "{socat}"
    );
}

#[test]
fn old_runs_notes_are_removed_and_the_current_kept() {
    let root = temp_dir("peer-runs");
    let (old, current, recent) = (
        root.path().join("1"),
        root.path().join("2"),
        root.path().join("3"),
    );
    let two_days_ago = SystemTime::now() - Duration::from_secs(2 * 24 * 3600);
    for dir in [&old, &current, &recent] {
        fs::create_dir_all(dir).expect("run dir");
        fs::write(dir.join("x.log"), "").expect("log");
    }
    for dir in [&old, &current] {
        fs::File::open(dir)
            .and_then(|f| f.set_modified(two_days_ago))
            .expect("age");
    }
    assert_eq!(
        peers::prune_runs(root.path(), &current, Duration::from_secs(24 * 3600)),
        1
    );
    assert!(!old.exists() && current.exists() && recent.exists());
}
