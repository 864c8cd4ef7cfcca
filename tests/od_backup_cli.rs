//! `od dump`, `od diff` and `od restore` against the simulated drive served on loopback:
//! a backup, two changes (a setting and a PDO mapping entry), a diff that lists exactly
//! those, a dry run that plans exactly their writes, a restore that undoes them, and a
//! diff that finds the drive equal to the file again. Also: a dump over every link reads
//! the whole configuration without a refusal, and broken files are refused with a reason.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::cli::{json, json_run, ok, run};
use common::{Sim, temp_dir};

fn addresses(rows: &serde_json::Value) -> Vec<String> {
    rows.as_array()
        .expect("an array")
        .iter()
        .map(|r| r["address"].as_str().unwrap_or_default().to_owned())
        .collect()
}

#[test]
fn backup_change_diff_restore_round_trip_over_modbus_tcp() {
    let dir = temp_dir("od-backup");
    let file = dir.path().join("drive.json");
    let file = file.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let link = link.as_str();

    let dump = json(&["--link", link, "od", "dump", "--out", file]);
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
    let (code, diff) = json_run(&["--link", link, "od", "diff", file]);
    assert_eq!((code, diff["differs"].as_u64()), (0, Some(0)), "{diff}");

    // Two changes: a drive setting and a PDO mapping entry.
    for (address, value) in [("6081:00", "777"), ("1A00:01", "0x60410010")] {
        ok(&["--link", link, "write", address, value]);
    }

    let (code, diff) = json_run(&["--link", link, "od", "diff", file]);
    assert_eq!(code, 1, "{diff}");
    assert_eq!(
        addresses(&diff["objects"]),
        vec!["1A00h:01h", "6081h:00h"],
        "{diff}"
    );
    assert_eq!(diff["objects"][1]["file"], "200 rpm");
    assert_eq!(diff["objects"][1]["device"], "777 rpm");

    // The dry run plans the setting, then the mapping with its procedure; writes nothing.
    let plan = json(&["--link", link, "od", "restore", file, "--dry-run"]);
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
    let (code, _) = json_run(&["--link", link, "od", "diff", file]);
    assert_eq!(code, 1, "the dry run wrote something");

    // The restore writes them, stores, and compares again.
    let restored = json(&["--link", link, "od", "restore", file, "--store"]);
    assert_eq!(restored["written"], 4);
    assert_eq!(restored["refused"], 0);
    assert_eq!(restored["still_differs"], 0);
    assert_eq!(restored["stored"], serde_json::json!({"Ok": null}));
    let (code, diff) = json_run(&["--link", link, "od", "diff", file]);
    assert_eq!((code, diff["differs"].as_u64()), (0, Some(0)), "{diff}");

    // Text output for a person.
    let (code, stdout, _) = run(&["--link", link, "od", "restore", file]);
    assert_eq!(code, 0);
    assert!(stdout.contains("already matches"), "{stdout}");
}

#[test]
fn a_dump_reads_the_whole_configuration_over_every_link() {
    let dir = temp_dir("od-dump-links");
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
        let file = dir.path().join(format!("{n}.json"));
        let file = file.to_str().expect("utf-8 path");
        let (code, dump) = json_run(&["--link", link, "od", "dump", "--out", file]);
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
    let dir = temp_dir("od-bad-files");
    let missing = dir.path().join("none.json");
    let (code, _, stderr) = run(&["od", "diff", missing.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("cannot read"), "{stderr}");

    let not_json = dir.path().join("x.json");
    std::fs::write(&not_json, "hello").expect("write");
    let (code, _, stderr) = run(&["od", "restore", not_json.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("not a drivedeck backup"), "{stderr}");

    let other = dir.path().join("other.json");
    std::fs::write(
        &other,
        r#"{"format":"someone else's","version":1,"saved_at":0,"link":"sim","identity":{},"objects":[]}"#,
    )
    .expect("write");
    let (code, _, stderr) = run(&["od", "diff", other.to_str().expect("utf-8")]);
    assert_eq!(code, 2);
    assert!(stderr.contains("someone else's"), "{stderr}");

    // A file from another product is not restored without --force.
    let foreign = dir.path().join("foreign.json");
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
    let (stdout, stderr) = ok(&["od", "restore", path, "--dry-run"]);
    assert!(stderr.contains("another kind of device"), "{stderr}");
    assert!(stdout.contains("6081h:00h"), "{stdout}");
    let (stdout, _) = ok(&["od", "restore", path, "--force"]);
    assert!(stdout.contains("1 of 1 writes done"), "{stdout}");
}

/// A saved object as a backup file holds it.
fn saved_object(
    address: &str,
    name: &str,
    dtype: &str,
    kind: &str,
    value: i64,
) -> serde_json::Value {
    serde_json::json!({
        "address": address,
        "name": name,
        "type": dtype,
        "value": {"kind": kind, "value": value},
        "shown": value.to_string(),
    })
}

/// Objects a crafted or hand-edited file may name that a restore must never write:
/// commands, PDI set values and command, store/restore, NanoJ control, read-only objects,
/// and one the dictionary does not know. Each with a word its skip reason must hold.
fn never_restored() -> Vec<(serde_json::Value, &'static str, &'static str)> {
    vec![
        // The controlword "enable operation": writing it would switch the power stage on.
        (
            saved_object("6040:00", "Controlword", "UNSIGNED16", "uint", 0x000F),
            "6040h:00h",
            "command",
        ),
        (
            saved_object("2291:01", "PDI-SetValue1", "INTEGER32", "int", 5000),
            "2291h:01h",
            "command",
        ),
        (
            saved_object("2291:02", "PDI-SetValue2", "INTEGER16", "int", 300),
            "2291h:02h",
            "command",
        ),
        (
            saved_object("2291:03", "PDI-SetValue3", "INTEGER8", "int", 1),
            "2291h:03h",
            "command",
        ),
        (
            saved_object("2291:04", "PDI-Cmd", "INTEGER8", "int", 21),
            "2291h:04h",
            "command",
        ),
        // "load": restore the factory defaults at the next restart.
        (
            saved_object("1011:01", "Restore all", "UNSIGNED32", "uint", 0x6461_6F6C),
            "1011h:01h",
            "command",
        ),
        (
            saved_object("1010:01", "Save all", "UNSIGNED32", "uint", 0x6576_6173),
            "1010h:01h",
            "command",
        ),
        (
            saved_object("2300:00", "NanoJ Control", "UNSIGNED32", "uint", 1),
            "2300h:00h",
            "command",
        ),
        (
            saved_object("607A:00", "Target Position", "INTEGER32", "int", 100_000),
            "607Ah:00h",
            "process data",
        ),
        (
            saved_object("6041:00", "Statusword", "UNSIGNED16", "uint", 0x0237),
            "6041h:00h",
            "read-only",
        ),
        (
            saved_object("1018:01", "Vendor-ID", "UNSIGNED32", "uint", 0x1234),
            "1018h:01h",
            "read-only",
        ),
        (
            saved_object("2FF0:00", "Something else", "UNSIGNED32", "uint", 7),
            "2FF0h:00h",
            "not in the dictionary",
        ),
        // A known setting with another type than the dictionary's: not written blind.
        (
            saved_object("6083:00", "Profile Acceleration", "UNSIGNED8", "uint", 9),
            "6083h:00h",
            "U32",
        ),
    ]
}

#[test]
fn a_restore_never_writes_commands_process_data_or_read_only_objects() {
    let dir = temp_dir("od-restore-skips");
    let file = dir.path().join("crafted.json");
    let file = file.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let link = link.as_str();

    // A real backup of this drive, then the hand-edited additions.
    json(&["--link", link, "od", "dump", "--out", file]);
    let mut backup: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).expect("written")).expect("JSON");
    let crafted = never_restored();
    let objects = backup["objects"].as_array_mut().expect("objects");
    objects.retain(|o| o["address"] != "6083:00");
    objects.extend(crafted.iter().map(|(o, _, _)| o.clone()));
    std::fs::write(file, backup.to_string()).expect("write");
    // One real setting differs, so there is something to restore.
    ok(&["--link", link, "write", "6081:00", "777"]);
    let (controlword_before, _) = ok(&["--link", link, "read", "6040:00"]);

    // The dry run plans that one write and lists every crafted entry as skipped, with why.
    let plan = json(&["--link", link, "od", "restore", file, "--dry-run"]);
    assert_eq!(addresses(&plan["steps"]), vec!["6081h:00h"], "{plan}");
    let skipped = plan["skipped"].as_array().expect("skipped entries");
    for (_, address, word) in &crafted {
        let row = skipped
            .iter()
            .find(|s| s["address"] == *address)
            .unwrap_or_else(|| panic!("{address} not listed as skipped: {plan}"));
        let reason = row["reason"].as_str().unwrap_or_default();
        assert!(reason.contains(word), "{address}: {reason}");
    }
    assert_eq!(skipped.len(), crafted.len(), "{plan}");

    // The restore writes the setting and nothing else; the drive stays as it was.
    let restored = json(&["--link", link, "od", "restore", file]);
    assert_eq!(
        addresses(&restored["steps"]),
        vec!["6081h:00h"],
        "{restored}"
    );
    assert_eq!(restored["written"], 1, "{restored}");
    assert_eq!(restored["refused"], 0, "{restored}");
    assert_eq!(restored["still_differs"], 0, "{restored}");
    let (_, out, _) = run(&["--link", link, "read", "6040:00"]);
    assert_eq!(out, controlword_before, "the controlword was written");
    let (_, out, _) = run(&["--link", link, "read", "2291:01"]);
    assert!(!out.contains("5000"), "PDI-SetValue1 was written: {out}");

    // diff lists them as skipped and does not count them as differences.
    let diff = json(&["--link", link, "od", "diff", file]);
    assert_eq!(diff["differs"], 0, "{diff}");
    assert_eq!(diff["skipped"], crafted.len(), "{diff}");
    let rows = diff["objects"].as_array().expect("rows");
    for (_, address, word) in &crafted {
        let row = rows
            .iter()
            .find(|r| r["address"] == *address)
            .unwrap_or_else(|| panic!("{address} not in the diff: {diff}"));
        assert_eq!(row["state"], "skipped", "{row}");
        assert!(
            row["reason"].as_str().unwrap_or_default().contains(word),
            "{row}"
        );
    }

    // The same for a person reading the text.
    let (stdout, _) = ok(&["--link", link, "od", "restore", file, "--dry-run"]);
    assert!(
        stdout.contains("skipped") && stdout.contains("6040h:00h") && stdout.contains("command"),
        "{stdout}"
    );
    let (stdout, _) = ok(&["--link", link, "od", "diff", file]);
    assert!(
        stdout.contains("1011h:01h") && stdout.contains("skipped"),
        "{stdout}"
    );
}

/// A listener that accepts nothing: a tool that tried to connect would be seen.
fn silent_drive() -> (std::net::TcpListener, String) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    listener.set_nonblocking(true).expect("non-blocking");
    let link = format!("modbus-tcp://{}", listener.local_addr().expect("address"));
    (listener, link)
}

fn never_connected(listener: &std::net::TcpListener) -> bool {
    matches!(listener.accept(), Err(e) if e.kind() == std::io::ErrorKind::WouldBlock)
}

#[test]
fn a_file_naming_an_object_twice_or_none_is_refused_before_connecting() {
    let dir = temp_dir("od-restore-ambiguous");
    let (listener, link) = silent_drive();
    let header = r#""format":"drivedeck backup","version":1,"saved_at":0,"link":"sim","identity":{"vendor":620}"#;

    // 6081h twice, written two ways: which value would win?
    let twice = dir.path().join("twice.json");
    let objects = serde_json::json!([
        saved_object("6081:00", "Profile Velocity", "UNSIGNED32", "uint", 100),
        saved_object("6083:00", "Profile Acceleration", "UNSIGNED32", "uint", 500),
        saved_object("6081h:0", "Profile Velocity", "UNSIGNED32", "uint", 900),
    ]);
    std::fs::write(&twice, format!(r#"{{{header},"objects":{objects}}}"#)).expect("write");
    let twice = twice.to_str().expect("utf-8");
    for command in [
        vec!["od", "restore", twice],
        vec!["od", "restore", twice, "--dry-run"],
        vec!["od", "diff", twice],
    ] {
        let mut args = vec!["--link", link.as_str(), "--timeout", "5"];
        args.extend(command);
        let (code, stdout, stderr) = run(&args);
        assert_eq!(code, 2, "{args:?}: {stdout}{stderr}");
        assert!(
            stderr.contains("6081h:00h") && stderr.contains("twice"),
            "{args:?}: {stderr}"
        );
        assert!(never_connected(&listener), "{args:?} connected first");
    }

    // No objects at all.
    let empty = dir.path().join("empty.json");
    std::fs::write(&empty, format!(r#"{{{header},"objects":[]}}"#)).expect("write");
    let empty = empty.to_str().expect("utf-8");
    for command in ["restore", "diff"] {
        let args = [
            "--link",
            link.as_str(),
            "--timeout",
            "5",
            "od",
            command,
            empty,
        ];
        let (code, stdout, stderr) = run(&args);
        assert_eq!(code, 2, "{args:?}: {stdout}{stderr}");
        assert!(stderr.contains("nothing to restore"), "{args:?}: {stderr}");
        assert!(never_connected(&listener), "{args:?} connected first");
    }
}

#[test]
fn an_eds_given_to_diff_and_restore_judges_the_file() {
    let dir = temp_dir("od-restore-eds");
    // The simulated drive's EDS, but with 6081h declared process output (rww).
    let sim_eds = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/od/drivedeck-sim.eds"
    ))
    .expect("the sim's EDS");
    let section = sim_eds.find("[6081]").expect("6081h in the EDS");
    let access = section
        + sim_eds[section..]
            .find("AccessType=rw")
            .expect("its access");
    let eds_text = format!(
        "{}AccessType=rww{}",
        &sim_eds[..access],
        &sim_eds[access + "AccessType=rw".len()..]
    );
    let eds = dir.path().join("rww.eds");
    std::fs::write(&eds, eds_text).expect("write");
    let eds = eds.to_str().expect("utf-8");
    let file = dir.path().join("drive.json");
    let header = r#""format":"drivedeck backup","version":1,"saved_at":0,"link":"sim","identity":{"vendor":620,"product":66}"#;
    let objects = serde_json::json!([
        saved_object("6081:00", "Profile Velocity", "UNSIGNED32", "uint", 777),
        saved_object(
            "6083:00",
            "Profile Acceleration",
            "UNSIGNED32",
            "uint",
            1234
        ),
    ]);
    std::fs::write(&file, format!(r#"{{{header},"objects":{objects}}}"#)).expect("write");
    let file = file.to_str().expect("utf-8");

    // The built-in catalog: both are settings.
    let plan = json(&["od", "restore", file, "--dry-run", "--force"]);
    assert_eq!(
        addresses(&plan["steps"]),
        vec!["6081h:00h", "6083h:00h"],
        "{plan}"
    );
    // The EDS: 6081h is process data there, so it is skipped.
    let plan = json(&["od", "restore", file, "--dry-run", "--force", "--eds", eds]);
    assert_eq!(addresses(&plan["steps"]), vec!["6083h:00h"], "{plan}");
    assert_eq!(addresses(&plan["skipped"]), vec!["6081h:00h"], "{plan}");
    assert!(
        plan["skipped"][0]["reason"]
            .as_str()
            .is_some_and(|r| r.contains("rww")),
        "{plan}"
    );
    let (code, diff) = json_run(&["od", "diff", file, "--eds", eds]);
    assert_eq!(code, 1, "{diff}");
    assert_eq!(
        (diff["differs"].as_u64(), diff["skipped"].as_u64()),
        (Some(1), Some(1)),
        "{diff}"
    );
}
