//! `drivedeck commission`: the shipped example procedure (ten steps) passes end to end on
//! the simulated drive; the same procedure with one limit made impossible exits 1 and the
//! record names that step, its measured value and its limit; a bad file is refused with
//! its line before anything moves; a project's drives are rehearsed in turn on simulated
//! stand-ins; Ctrl-C aborts (a halt sent) and the record says so. Every record
//! is a self-contained page and a JSON file whose SHA-256 seal holds.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use common::cli::{run, start};
use drivedeck::procedure::Record;

const EXAMPLE: &str = "assets/procedures/axis-commissioning.toml";
const BACKUP: &str = "assets/procedures/axis-backup.json";

/// The example procedure (and its backup) copied into `dir`, with `edit` applied.
fn procedure_in(dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(EXAMPLE).expect("the example");
    let path = dir.join("procedure.toml");
    std::fs::write(&path, edit(text)).expect("write");
    std::fs::copy(BACKUP, dir.join("axis-backup.json")).expect("copy the backup");
    path
}

fn answers_in(dir: &Path, lines: &str) -> PathBuf {
    let path = dir.join("answers.txt");
    std::fs::write(&path, lines).expect("write");
    path
}

/// `drivedeck [before…] commission PROCEDURE --record HTML [after…]`, as arguments.
fn commission(before: &[&str], procedure: &Path, html: &Path, after: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = before.iter().map(|a| (*a).to_owned()).collect();
    args.push("commission".into());
    args.push(procedure.display().to_string());
    args.push("--record".into());
    args.push(html.display().to_string());
    args.extend(after.iter().map(|a| (*a).to_owned()));
    args
}

/// [`run`] with owned arguments.
fn run_with(args: &[String]) -> (i32, String, String) {
    run(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// [`start`] with owned arguments.
fn start_with(args: &[String]) -> common::Process {
    start(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// The example with a long test move (20 cycles, some 40 s), answered yes, started with
/// `before` (the link and its options) in a fresh folder: the folder (kept while the run
/// lives), the record's page and the running command.
fn long_run(what: &str, before: &[&str]) -> (tempfile::TempDir, PathBuf, common::Process) {
    let dir = common::temp_dir(what);
    let procedure = procedure_in(dir.path(), |t| t.replace("cycles = 2", "cycles = 20"));
    let answers = answers_in(dir.path(), "yes\n");
    let html = dir.path().join("record.html");
    let child = start_with(&commission(
        before,
        &procedure,
        &html,
        &["--answers", answers.to_str().unwrap()],
    ));
    (dir, html, child)
}

/// The record's JSON beside `html`, read, its seal checked.
fn record_of(html: &Path) -> Record {
    let text = std::fs::read_to_string(html.with_extension("json")).expect("the JSON record");
    let record: Record = serde_json::from_str(&text).expect("a record");
    assert!(record.verify(), "the SHA-256 seal holds");
    record
}

/// The page stands alone: no script, no external resource.
fn self_contained(html: &Path) -> String {
    let page = std::fs::read_to_string(html).expect("the HTML record");
    assert!(page.starts_with("<!DOCTYPE html>"));
    for bad in ["<script", "<link", "src=", "url(", "@import", "href=\"http"] {
        assert!(!page.contains(bad), "{bad} in the page");
    }
    page
}

#[test]
fn the_example_procedure_passes_end_to_end_on_the_simulated_drive() {
    let dir = common::temp_dir("commission");
    let procedure = procedure_in(dir.path(), |t| t);
    let answers = answers_in(dir.path(), "# the one question\nyes\n");
    let html = dir.path().join("record.html");
    let (code, out, err) = run_with(&commission(
        &["--link", "sim"],
        &procedure,
        &html,
        &[
            "--answers",
            answers.to_str().unwrap(),
            "--operator",
            "Test Bench",
        ],
    ));
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("Linear axis commissioning: passed"), "{out}");
    let record = record_of(&html);
    assert_eq!(record.operator, "Test Bench");
    assert_eq!(record.drives.len(), 1);
    let drive = &record.drives[0];
    let verdicts: Vec<&str> = drive.steps.iter().map(|s| s.verdict.word()).collect();
    assert_eq!(
        verdicts,
        [
            "skipped", "passed", "passed", "passed", "passed", "passed", "passed", "passed",
            "passed", "passed"
        ],
        "{err}"
    );
    // The test move's figures against its limits, and its plot.
    let test = &drive.steps[4];
    let overshoot = test.figures.iter().find(|f| f.name == "overshoot").unwrap();
    assert_eq!(overshoot.limit.as_deref(), Some("≤ 5"));
    assert_eq!(overshoot.passed, Some(true));
    assert!(test.plot.as_ref().is_some_and(|p| p.points.len() > 100));
    // The restart brought the three values of the backup back.
    assert!(
        drive.steps[9].note.contains("all 3 value(s) as stored"),
        "{}",
        drive.steps[9].note
    );
    // Settings away from the factory's: the backup's three among them.
    for object in ["6081h:00h", "6083h:00h", "6084h:00h"] {
        assert!(
            drive
                .differs_from_factory
                .iter()
                .any(|d| d.object == object),
            "{object}: {:?}",
            drive.differs_from_factory
        );
    }
    let page = self_contained(&html);
    assert!(page.contains("<svg"), "the plots inline");
    assert!(page.contains(&record.sha256));
    assert_eq!(page.matches("data-verdict=\"passed\"").count(), 9);
    // The simulated drive stood in for a machine's: the record says it was a rehearsal.
    assert!(record.rehearsal, "--link sim is a rehearsal");

    // `verify` holds the record to its seal, from the page's name or the JSON's.
    let (code, out, err) = run(&["verify", html.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.starts_with("the seal holds: "), "{out}");
    assert!(out.contains(&record.sha256), "{out}");
    // The overall verdict edited by hand, the JSON kept well-formed: exit 1, named.
    let json = html.with_extension("json");
    let mut value: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    value["verdict"] = "failed".into();
    std::fs::write(&json, serde_json::to_string_pretty(&value).unwrap()).unwrap();
    let (code, out, err) = run(&["verify", json.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(err.contains("changed after it was sealed"), "{err}");
    // Not a record at all: exit 2.
    let (code, _, err) = run(&["verify", procedure.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("not a drivedeck commissioning record"),
        "{err}"
    );
}

#[test]
fn an_impossible_limit_fails_its_step_and_the_record_names_value_and_limit() {
    let dir = common::temp_dir("commission-fail");
    let procedure = procedure_in(dir.path(), |t| {
        t.replace("settling_s = 1.0", "settling_s = 0.001")
    });
    let answers = answers_in(dir.path(), "yes\n");
    let html = dir.path().join("record.html");
    let (code, out, err) = run_with(&commission(
        &["--link", "sim"],
        &procedure,
        &html,
        &["--answers", answers.to_str().unwrap()],
    ));
    assert_eq!(code, 1, "{out}{err}");
    let record = record_of(&html);
    assert_eq!(record.verdict.word(), "failed");
    let step = &record.drives[0].steps[4];
    assert_eq!(step.verdict.word(), "failed");
    assert_eq!(step.kind, "test-move");
    let settling = step
        .figures
        .iter()
        .find(|f| f.name == "settling time")
        .unwrap();
    assert_eq!(settling.limit.as_deref(), Some("≤ 0.001"));
    assert_eq!(settling.passed, Some(false));
    let measured = settling.value.expect("measured");
    assert!(measured > 0.1, "{measured}");
    assert!(
        step.note.contains("settling time") && step.note.contains("≤ 0.001"),
        "{}",
        step.note
    );
    // The steps after it went on (a test's failure does not stop the run).
    assert_ne!(record.drives[0].steps[5].verdict.word(), "skipped");
    assert_eq!(record.drives[0].steps[9].verdict.word(), "passed");
    let page = self_contained(&html);
    assert!(
        page.contains("<tr class=\"failed\" data-step=\"5\""),
        "the failed row"
    );
    assert!(err.contains("[failed] Test move"), "{err}");
}

#[test]
fn a_bad_file_is_refused_with_its_line_before_anything_moves() {
    let dir = common::temp_dir("commission-bad");
    let html = dir.path().join("record.html");
    let cases = [
        (
            "input = \"positive limit switch\"",
            "input = \"left foot\"",
            "line 70 (step 7, input): unknown input \"left foot\"",
        ),
        (
            "speed = 300\ndwell_s",
            "speed = 0\ndwell_s",
            "line 44 (step 5, test-move)",
        ),
        ("kind = \"store\"", "kind = \"stor\"", "line 87, column 8"),
        (
            "file = \"axis-backup.json\"",
            "file = \"missing.json\"",
            "line 26 (step 2): the backup for drive cannot be used",
        ),
    ];
    for (from, to, expected) in cases {
        let procedure = procedure_in(dir.path(), |t| {
            assert!(t.contains(from), "{from}");
            t.replacen(from, to, 1)
        });
        let (code, out, err) = run_with(&commission(&["--link", "sim"], &procedure, &html, &[]));
        assert_eq!(code, 2, "{to}: {out}{err}");
        assert!(
            err.contains(expected),
            "{to}: expected {expected:?} in {err}"
        );
        assert!(!html.exists(), "no record for a refused file");
        assert!(!err.contains("commissioning drive"), "nothing ran: {err}");
    }
}

#[test]
fn a_projects_drives_are_rehearsed_in_turn_on_simulated_stand_ins() {
    let dir = common::temp_dir("commission-project");
    let project = dir.path().join("machine.json");
    let (code, out, err) = run(&[
        "project",
        "new",
        project.to_str().unwrap(),
        "X axis=modbus-tcp://192.0.2.10:502",
        "Y axis=modbus-tcp://192.0.2.11:502",
    ]);
    assert_eq!(code, 0, "{out}{err}");
    // A short procedure: the identity, a question, store and restart.
    let procedure = dir.path().join("short.toml");
    std::fs::write(
        &procedure,
        "[procedure]\nname = \"Short\"\n\n[[step]]\nkind = \"identity\"\n\n[[step]]\nkind = \"question\"\ntext = \"Guard closed?\"\nexpect = \"yes\"\n\n[[step]]\nkind = \"store\"\n\n[[step]]\nkind = \"reboot\"\nverify = [\"6083:00\"]\n",
    )
    .unwrap();
    let answers = answers_in(dir.path(), "yes\nno\n");
    let html = dir.path().join("rehearsal.html");
    let (code, out, err) = run(&[
        "--project",
        project.to_str().unwrap(),
        "commission",
        procedure.to_str().unwrap(),
        "--rehearse",
        "--record",
        html.to_str().unwrap(),
        "--answers",
        answers.to_str().unwrap(),
    ]);
    // The second drive's operator said no: that step fails, so the run exits 1.
    assert_eq!(code, 1, "{out}{err}");
    let record = record_of(&html);
    assert!(record.rehearsal);
    let names: Vec<&str> = record.drives.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["X axis", "Y axis"]);
    assert_eq!(record.drives[0].verdict.word(), "passed");
    assert_eq!(record.drives[1].verdict.word(), "failed");
    assert_eq!(record.drives[1].steps[1].verdict.word(), "failed");
    for drive in &record.drives {
        assert!(
            drive
                .link
                .starts_with("rehearsal: simulated drive on modbus-tcp://127.0.0.1:")
        );
        assert!(
            drive
                .link
                .contains("standing in for modbus-tcp://192.0.2.1"),
            "{}",
            drive.link
        );
        assert!(
            drive.steps[3].verdict.word() == "passed",
            "{:?}",
            drive.steps[3]
        );
    }
    let page = self_contained(&html);
    assert!(page.contains("Rehearsal: simulated drives stood in"));
}

#[test]
fn ctrl_c_aborts_the_run_and_the_record_says_so() {
    // A long test move to be interrupted in.
    let (_dir, html, mut child) = long_run("commission-abort", &["--link", "sim"]);
    // Connecting, the backup and the 3 s auto setup take about 4 s: then the test move
    // (20 cycles, some 40 s) runs.
    std::thread::sleep(Duration::from_secs(8));
    child.signal("INT");
    let status = child.wait(Duration::from_secs(15)).expect("ends on Ctrl-C");
    assert_eq!(status.code(), Some(130), "{}", child.report());
    let record = record_of(&html);
    let steps = &record.drives[0].steps;
    assert_eq!(steps[4].verdict.word(), "aborted", "{steps:?}");
    assert!(steps[4].note.contains("interrupted"), "{}", steps[4].note);
    assert!(steps[5..].iter().all(|s| s.verdict.word() == "skipped"));
    assert_eq!(record.verdict.word(), "aborted");
    self_contained(&html);
}

#[test]
fn a_test_that_runs_into_a_limit_switch_says_so() {
    let dir = common::temp_dir("commission-limit");
    // 300 rpm for 1.5 s and the ramps carry the simulated axis past its positive limit
    // switch at 36000 units.
    let procedure = dir.path().join("long.toml");
    std::fs::write(
        &procedure,
        "[procedure]\nname = \"Too long\"\n\n[[step]]\nkind = \"velocity-step\"\nspeed = 300\nhold_s = 1.5\n[step.limits]\nsettling_s = 1.5\n",
    )
    .unwrap();
    let html = dir.path().join("record.html");
    let (code, out, err) = run_with(&commission(&["--link", "sim"], &procedure, &html, &[]));
    assert_eq!(code, 1, "{out}{err}");
    let record = record_of(&html);
    let note = &record.drives[0].steps[0].note;
    assert!(
        note.contains("a limit switch was reached during the test"),
        "{note}"
    );
}

#[test]
fn a_drive_lost_mid_procedure_aborts_the_run_and_the_record_names_the_cause() {
    let (sim, addr) = common::Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let (_dir, html, mut child) = long_run("commission-lost", &["--link", &link]);
    // In the test move (after the backup and the 3 s auto setup), the drive goes away.
    std::thread::sleep(Duration::from_secs(8));
    sim.process.signal("KILL");
    let status = child.wait(Duration::from_secs(30)).expect("ends");
    // Not interrupted by anyone: a failed run.
    assert_eq!(status.code(), Some(1), "{}", child.report());
    let record = record_of(&html);
    let steps = &record.drives[0].steps;
    let aborted: Vec<_> = steps
        .iter()
        .filter(|s| s.verdict.word() == "aborted")
        .collect();
    assert_eq!(aborted.len(), 1, "{steps:#?}");
    assert!(
        aborted[0].note.contains("link") || aborted[0].note.contains("lost"),
        "{}",
        aborted[0].note
    );
    assert_eq!(aborted[0].number, 5, "the test move");
    assert!(steps[5..].iter().all(|s| s.verdict.word() == "skipped"));
    // The steps before it keep their verdicts.
    assert_eq!(steps[1].verdict.word(), "passed");
    self_contained(&html);
}

#[test]
fn ctrl_c_leaves_the_drive_as_on_exit_says() {
    let (_sim, addr) = common::Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let (_dir, html, mut child) = long_run(
        "commission-on-exit",
        &["--link", &link, "--on-exit", "switch-off"],
    );
    std::thread::sleep(Duration::from_secs(8));
    child.signal("INT");
    let status = child.wait(Duration::from_secs(15)).expect("ends on Ctrl-C");
    assert_eq!(status.code(), Some(130), "{}", child.report());
    // The drive, asked afterwards: switched off, not merely halted.
    let (code, out, err) = run(&["--link", &link, "--json", "status"]);
    assert_eq!(code, 0, "{out}{err}");
    let status: serde_json::Value = serde_json::from_str(&out).unwrap();
    let state = status["state"].as_str().unwrap_or_default().to_owned();
    assert!(
        !state.contains("Operation enabled"),
        "the power stage is off after the abort: {status:#}"
    );
    let record = record_of(&html);
    assert_eq!(record.drives[0].steps[4].verdict.word(), "aborted");
}
