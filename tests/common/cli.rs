//! `drivedeck` run as a user runs it, for the tests of the command line: to its end (exit
//! code, stdout, stderr), or started and left running as a `Process`.

use std::process::Command;

use super::Process;

/// The binary, with HOME in the temp dir (no settings of the user's) and the crate's root
/// as its working directory (relative paths are the repository's).
pub fn command() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_drivedeck"));
    command
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("HOME", std::env::temp_dir());
    command
}

/// `drivedeck ARGS…` to its end: exit code (-1 after a signal), stdout, stderr.
pub fn run(args: &[&str]) -> (i32, String, String) {
    let out = command().args(args).output().expect("the binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// stdout and stderr of a run that must succeed.
pub fn ok(args: &[&str]) -> (String, String) {
    let (code, stdout, stderr) = run(args);
    assert_eq!(code, 0, "{args:?} failed: {stdout}{stderr}");
    (stdout, stderr)
}

/// stderr of a run that must end with exit code `code`.
pub fn fails(args: &[&str], code: i32) -> String {
    let (got, stdout, stderr) = run(args);
    assert_eq!(got, code, "{args:?}: {stdout}{stderr}");
    stderr
}

/// `drivedeck --json ARGS…` that must succeed: what it printed, parsed.
pub fn json(args: &[&str]) -> serde_json::Value {
    let (code, value) = json_run(args);
    assert_eq!(code, 0, "{args:?} failed: {value}");
    value
}

/// `drivedeck --json ARGS…`, succeeding or not: exit code and what it printed, parsed.
pub fn json_run(args: &[&str]) -> (i32, serde_json::Value) {
    let mut all = vec!["--json"];
    all.extend_from_slice(args);
    let (code, stdout, stderr) = run(&all);
    let value =
        serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{all:?}: {e}: {stdout}{stderr}"));
    (code, value)
}

/// `drivedeck ARGS…` started, its output collected; killed on drop.
pub fn start(args: &[&str]) -> Process {
    let mut command = command();
    command.args(args);
    Process::spawn("drivedeck", &mut command)
}
