//! `od dump`, `od diff` and `od restore` against the simulated drive served on loopback:
//! a backup, two changes (a setting and a PDO mapping entry), a diff that lists exactly
//! those, a dry run that plans exactly their writes, a restore that undoes them, and a
//! diff that finds the drive equal to the file again. Also: a dump over every link reads
//! the whole configuration without a refusal, and broken files are refused with a reason.

mod common;

use std::process::{Command, Output};

use common::{Sim, TempDir};

fn drivedeck(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drivedeck"))
        .args(args)
        .env("HOME", std::env::temp_dir())
        .output()
        .expect("the binary runs")
}

/// Exit code, stdout, stderr.
fn run(args: &[&str]) -> (i32, String, String) {
    let out = drivedeck(args);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(args: &[&str]) -> (i32, serde_json::Value) {
    let mut all = vec!["--json"];
    all.extend_from_slice(args);
    let (code, stdout, stderr) = run(&all);
    let value =
        serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{all:?}: {e}: {stdout}{stderr}"));
    (code, value)
}

fn addresses(rows: &serde_json::Value) -> Vec<String> {
    rows.as_array()
        .expect("an array")
        .iter()
        .map(|r| r["address"].as_str().unwrap_or_default().to_owned())
        .collect()
}

#[test]
fn backup_change_diff_restore_round_trip_over_modbus_tcp() {
    let dir = TempDir::new("od-backup");
    let file = dir.path.join("drive.json");
    let file = file.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let link = link.as_str();

    let (code, dump) = json(&["--link", link, "od", "dump", "--out", file]);
    assert_eq!(code, 0, "{dump}");
    assert!(dump["objects"].as_u64().unwrap_or(0) > 200, "{dump}");
    assert_eq!(dump["identity"]["vendor"], 0x26C);
    assert_eq!(dump["unreadable"].as_array().map(Vec::len), Some(0));
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).expect("written")).expect("JSON");
    assert_eq!(saved["format"], "drivedeck backup");
    // Commands and process data are not configuration.
    for never in ["6040:00", "2291:04", "1010:01", "1003:00", "60FF:00"] {
        assert!(
            !addresses(&saved["objects"]).contains(&never.to_owned()),
            "{never} saved"
        );
    }

    // Nothing changed yet.
    let (code, diff) = json(&["--link", link, "od", "diff", file]);
    assert_eq!((code, diff["differs"].as_u64()), (0, Some(0)), "{diff}");

    // Two changes: a drive setting and a PDO mapping entry.
    for (address, value) in [("6081:00", "777"), ("1A00:01", "0x60410010")] {
        let (code, out, err) = run(&["--link", link, "write", address, value]);
        assert_eq!(code, 0, "{out}{err}");
    }

    let (code, diff) = json(&["--link", link, "od", "diff", file]);
    assert_eq!(code, 1, "{diff}");
    assert_eq!(
        addresses(&diff["objects"]),
        vec!["1A00h:01h", "6081h:00h"],
        "{diff}"
    );
    assert_eq!(diff["objects"][1]["file"], "200 rpm");
    assert_eq!(diff["objects"][1]["device"], "777 rpm");

    // The dry run plans the setting, then the mapping with its procedure; writes nothing.
    let (code, plan) = json(&["--link", link, "od", "restore", file, "--dry-run"]);
    assert_eq!(code, 0, "{plan}");
    assert_eq!(
        addresses(&plan["steps"]),
        vec!["6081h:00h", "1A00h:00h", "1A00h:01h", "1A00h:00h"],
        "{plan}"
    );
    assert!(
        plan["steps"]
            .as_array()
            .expect("steps")
            .iter()
            .all(|s| s["result"] == "planned")
    );
    let (code, _) = json(&["--link", link, "od", "diff", file]);
    assert_eq!(code, 1, "the dry run wrote something");

    // The restore writes them, stores, and compares again.
    let (code, restored) = json(&["--link", link, "od", "restore", file, "--store"]);
    assert_eq!(code, 0, "{restored}");
    assert_eq!(restored["written"], 4);
    assert_eq!(restored["refused"], 0);
    assert_eq!(restored["still_differs"], 0);
    assert_eq!(restored["stored"], serde_json::json!({"Ok": null}));
    let (code, diff) = json(&["--link", link, "od", "diff", file]);
    assert_eq!((code, diff["differs"].as_u64()), (0, Some(0)), "{diff}");

    // Text output for a person.
    let (code, stdout, _) = run(&["--link", link, "od", "restore", file]);
    assert_eq!(code, 0);
    assert!(stdout.contains("already matches"), "{stdout}");
}

#[test]
fn a_dump_reads_the_whole_configuration_over_every_link() {
    let dir = TempDir::new("od-dump-links");
    let (_modbus, modbus) = Sim::tcp(&[]);
    let (_enip, enip) = Sim::enip(&[]);
    let links = [
        "sim".to_owned(),
        "canopen+sim://?node=3".to_owned(),
        format!("modbus-tcp://{modbus}"),
        format!("enip://{enip}"),
    ];
    let mut counts = vec![];
    for (n, link) in links.iter().enumerate() {
        let file = dir.path.join(format!("{n}.json"));
        let file = file.to_str().expect("utf-8 path");
        let (code, dump) = json(&["--link", link, "od", "dump", "--out", file]);
        assert_eq!(code, 0, "{link}: {dump}");
        assert_eq!(
            dump["unreadable"].as_array().map(Vec::len),
            Some(0),
            "{link}: {dump}"
        );
        assert!(
            dump["notes"]
                .as_array()
                .expect("notes")
                .iter()
                .any(|n| n.as_str().is_some_and(|n| n.starts_with("read "))),
            "{dump}"
        );
        counts.push(dump["objects"].as_u64());
    }
    // The same settings whatever the link.
    assert!(counts.windows(2).all(|w| w[0] == w[1]), "{counts:?}");
}

#[test]
fn broken_files_are_refused_with_a_reason() {
    let dir = TempDir::new("od-bad-files");
    let missing = dir.path.join("none.json");
    let (code, _, stderr) = run(&["od", "diff", missing.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("cannot read"), "{stderr}");

    let not_json = dir.path.join("x.json");
    std::fs::write(&not_json, "hello").expect("write");
    let (code, _, stderr) = run(&["od", "restore", not_json.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("not a drivedeck backup"), "{stderr}");

    let other = dir.path.join("other.json");
    std::fs::write(
        &other,
        r#"{"format":"someone else's","version":1,"saved_at":0,"link":"sim","identity":{},"objects":[]}"#,
    )
    .expect("write");
    let (code, _, stderr) = run(&["od", "diff", other.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("someone else's"), "{stderr}");

    // A file from another product is not restored without --force.
    let foreign = dir.path.join("foreign.json");
    std::fs::write(
        &foreign,
        r#"{"format":"drivedeck backup","version":1,"saved_at":0,"link":"sim",
            "identity":{"vendor":1,"product":2},
            "objects":[{"address":"6081:00","name":"Profile Velocity","type":"UNSIGNED32",
                        "value":{"kind":"uint","value":5},"shown":"5 rpm"}]}"#,
    )
    .expect("write");
    let path = foreign.to_str().expect("utf-8");
    let (code, _, stderr) = run(&["od", "restore", path]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--force"), "{stderr}");
    // The dry run still shows what it would do, with the warning.
    let (code, stdout, stderr) = run(&["od", "restore", path, "--dry-run"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert!(stderr.contains("another kind of device"), "{stderr}");
    assert!(stdout.contains("6081h:00h"), "{stdout}");
    let (code, stdout, stderr) = run(&["od", "restore", path, "--force"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert!(stdout.contains("1 of 1 writes done"), "{stdout}");
}
