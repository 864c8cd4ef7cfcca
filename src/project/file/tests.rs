//! Projects saved and opened again; files that are no project refused with their cause.

use proptest::prelude::*;
use serde_json::json;

use super::*;
use crate::od::backup::{self, SavedObject};
use crate::od::{Address, DataType, Value as OdValue};
use crate::project::{Format, MAX_PINS};
use crate::worker::LinkLossAction;

fn identity(serial: u32) -> DeviceIdentity {
    DeviceIdentity {
        vendor: Some(0x26C),
        product: Some(0x1234),
        revision: Some(3),
        serial: Some(serial),
        name: Some("drivedeck simulated drive".into()),
        hardware: None,
        software: Some("FIR-v0".into()),
    }
}

fn a_backup() -> Backup {
    Backup {
        format: backup::FORMAT.into(),
        version: backup::VERSION,
        saved_at: 1_700_000_000,
        link: "modbus-tcp://127.0.0.1:1502".into(),
        identity: identity(7),
        objects: vec![SavedObject {
            address: "6081:00".into(),
            name: "Profile velocity".into(),
            dtype: DataType::Unsigned32,
            value: OdValue::Uint(200),
            shown: "200".into(),
        }],
        unreadable: vec![("2031:00".into(), "refused".into())],
    }
}

/// Two drives, the first with everything a drive can have.
fn project() -> Project {
    let mut x = Drive::new(
        "X axis",
        "modbus-tcp://127.0.0.1:1502".parse().expect("spec"),
    );
    x.options = DriveOptions {
        poll_rate: 250.0,
        on_link_loss: LinkLossAction::SwitchOff,
        lost_after: 5,
    };
    x.watch = vec![
        Pin {
            address: Address::new(0x6041, 0),
            format: Format::Bits,
        },
        Pin {
            address: Address::new(0x6064, 0),
            format: Format::Decimal,
        },
    ];
    x.identity = Some(identity(7));
    x.backup = Some(a_backup());
    let y = Drive::new("Y axis", "canopen+sim://?node=2".parse().expect("spec"));
    let mut project = Project::new(vec![x, y]).expect("a project");
    project.plot = Some(json!({"window_s": 5.0, "shown": ["position", "velocity"]}));
    project
}

fn error_of(text: &str) -> String {
    Project::from_json(text).expect_err("refused").to_string()
}

fn edited(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let mut value: serde_json::Value = serde_json::from_str(&project().to_json()).expect("JSON");
    edit(&mut value);
    value.to_string()
}

#[test]
fn a_project_saved_and_opened_again_is_equal_backups_included() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let path = dir.path().join("machine.json");
    let project = project();
    save(&project, &path).expect("saved");
    let text = std::fs::read_to_string(&path).expect("the file");
    assert!(text.contains("\"format\": \"drivedeck-project\""), "{text}");
    assert!(text.contains("\"version\": 1"), "{text}");
    assert!(
        text.contains("\"link\": \"canopen+sim://?node=2\""),
        "{text}"
    );
    let opened = open(&path).expect("opened");
    assert_eq!(opened, project);
    assert_eq!(opened.drives[0].backup, Some(a_backup()));
    // And again: the text is stable.
    assert_eq!(opened.to_json(), text);
}

#[test]
fn a_drive_written_with_only_name_and_link_gets_the_defaults() {
    let text = r#"{"format": "drivedeck-project", "version": 1,
        "drives": [{"name": "Spindle", "link": "sim"}]}"#;
    let project = Project::from_json(text).expect("a project");
    assert_eq!(project.drives, vec![Drive::new("Spindle", LinkSpec::Sim)]);
    assert_eq!(project.plot, None);
}

#[test]
fn hostile_and_broken_files_are_refused_with_their_cause() {
    let whole = project().to_json();
    let cases: Vec<(String, &str)> = vec![
        (
            whole[..whole.len() / 2].to_owned(),
            "not JSON (EOF while parsing",
        ),
        (String::new(), "not JSON"),
        ("[1, 2]".into(), "it is a JSON array, not an object"),
        (
            edited(|v| v["format"] = json!("drivedeck backup")),
            "its format is \"drivedeck backup\"",
        ),
        (edited(|v| v["format"] = json!(7)), "its format is a number"),
        (
            edited(|v| {
                v.as_object_mut().map(|o| o.remove("format"));
            }),
            "no \"format\" field",
        ),
        (
            edited(|v| v["version"] = json!(2)),
            "project version 2 is newer than this drivedeck reads (version 1)",
        ),
        (
            // A newer file is refused for its version even with fields this one lacks.
            edited(|v| {
                v["version"] = json!(3);
                v["cameras"] = json!([]);
            }),
            "project version 3 is newer",
        ),
        (
            edited(|v| v["version"] = json!(0)),
            "project version 0 does not exist",
        ),
        (
            edited(|v| v["version"] = json!(1.5)),
            "project version 1.5 does not exist",
        ),
        (
            edited(|v| v["version"] = json!("1")),
            "its \"version\" is a string (\"1\"), not a number: write it as 1, without quotes",
        ),
        (
            edited(|v| v["plots"] = json!({})),
            "the project's top level: unknown field `plots`",
        ),
        (
            edited(|v| v["drives"][1]["poll_rte"] = json!(5)),
            "drive 2: (\"Y axis\") unknown field `poll_rte`",
        ),
        (
            edited(|v| v["drives"][0]["options"]["pol_rate"] = json!(5)),
            "drive 1: (\"X axis\") options: unknown field `pol_rate`",
        ),
        (
            edited(|v| v["drives"][1]["name"] = json!("x AXIS")),
            "two drives are named \"X axis\" and \"x AXIS\"",
        ),
        (
            edited(|v| v["drives"][1]["name"] = json!(" ")),
            "drive 2's name \" \" is empty",
        ),
        (
            edited(|v| v["drives"][1]["name"] = json!("Y\u{7}")),
            "has a control character",
        ),
        (
            edited(|v| v["drives"][1]["link"] = json!("modbus-tcp://host:99999")),
            "drive 2: (\"Y axis\") ",
        ),
        (
            edited(|v| v["drives"][1]["link"] = json!("carrier-pigeon://coop")),
            "unknown scheme 'carrier-pigeon'",
        ),
        (
            edited(|v| v["drives"][0]["options"]["poll_rate"] = json!(0.0)),
            "drive \"X axis\": poll rate 0 Hz is outside 1 to 2000 Hz",
        ),
        (
            edited(|v| v["drives"][0]["options"]["lost_after"] = json!(1000)),
            "drive \"X axis\": lost_after 1000 is outside 1 to 100",
        ),
        (
            edited(|v| v["drives"][0]["options"]["on_link_loss"] = json!("Explode")),
            "unknown variant `Explode`",
        ),
        (
            edited(|v| v["drives"][0]["watch"][1]["address"] = json!({"index": 24641, "sub": 0})),
            "drive \"X axis\": 6041h:00h is watched twice",
        ),
        (
            edited(|v| {
                let pin = json!({"address": {"index": 1, "sub": 0}, "format": "Hex"});
                v["drives"][0]["watch"] = json!(
                    (0..=MAX_PINS as u16)
                        .map(|i| {
                            let mut p = pin.clone();
                            p["address"]["index"] = json!(0x2000 + i);
                            p
                        })
                        .collect::<Vec<_>>()
                );
            }),
            "33 watched objects; at most 32",
        ),
        (
            edited(|v| v["drives"][0]["backup"]["format"] = json!("something")),
            "drive 1: (\"X axis\") its backup: the file's format is 'something'",
        ),
        (
            edited(|v| v["drives"][0]["backup"]["objects"] = json!([])),
            "its backup: the file lists no objects",
        ),
        (
            edited(|v| v["drives"] = json!([])),
            "the project has no drives",
        ),
        (
            // The field by its path, in the file's words (no `struct Pin`).
            edited(|v| v["drives"][0]["watch"][1]["address"] = json!(true)),
            "drive 1: (\"X axis\") watch[1].address: invalid type: boolean `true`, expected an object",
        ),
        (
            edited(|v| v["drives"][0]["options"]["on_link_loss"] = json!("Fly")),
            "drive 1: (\"X axis\") options.on_link_loss: unknown variant `Fly`, expected one of",
        ),
        (
            edited(|v| v["drives"] = json!({"a": 1})),
            "the project's top level: drives: invalid type: an object, expected an array",
        ),
        (
            edited(|v| v["plot"] = json!(3)),
            "plot layout is a number, not an object",
        ),
    ];
    for (text, expected) in cases {
        let error = error_of(&text);
        assert!(
            error.contains(expected),
            "expected '{expected}' in '{error}' for {text}"
        );
    }
}

#[test]
fn bytes_that_are_not_text_and_files_too_big_are_refused() {
    let error = Project::from_bytes(b"{\"format\": \xFF}").expect_err("refused");
    assert_eq!(
        error.to_string(),
        "not a drivedeck project: the file is not UTF-8 text (byte 11 is not)"
    );
    let dir = tempfile::tempdir().expect("a temp dir");
    let missing = open(&dir.path().join("nowhere.json")).expect_err("refused");
    assert!(missing.to_string().starts_with("cannot read "), "{missing}");
    assert!(missing.to_string().contains("nowhere.json"), "{missing}");
    let big = dir.path().join("big.json");
    let file = std::fs::File::create(&big).expect("a file");
    file.set_len(MAX_BYTES + 10).expect("a sparse file");
    let error = open(&big).expect_err("refused").to_string();
    assert!(
        error.contains(&format!(
            "is {} bytes: a project file is at most",
            MAX_BYTES + 10
        )),
        "{error}"
    );
}

#[test]
fn a_project_that_could_not_be_opened_again_is_not_saved() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let path = dir.path().join("machine.json");
    let mut twice = project();
    twice.drives[1].name = "X axis".into();
    let error = save(&twice, &path).expect_err("refused");
    assert!(
        error.to_string().contains("two drives are named"),
        "{error}"
    );
    assert!(!path.exists());
}

#[test]
fn a_drive_is_found_by_its_name_and_a_wrong_name_lists_the_names() {
    let project = project();
    assert_eq!(project.drive("Y axis").expect("found").name, "Y axis");
    let error = project.drive("Z axis").expect_err("not there");
    assert_eq!(
        error.to_string(),
        "no drive named \"Z axis\" in the project; its drives: \"X axis\", \"Y axis\""
    );
}

#[test]
fn file_stems_are_safe_names() {
    let stem = |name: &str| Drive::new(name, LinkSpec::Sim).file_stem();
    assert_eq!(stem("X axis"), "X_axis");
    assert_eq!(stem("../etc/passwd"), "___etc_passwd");
    assert_eq!(stem("Vorschub-2_b"), "Vorschub-2_b");
    assert_eq!(stem("..."), "drive___");
    assert_eq!(stem("Ä"), "drive_");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let _ = Project::from_bytes(&bytes);
    }

    #[test]
    fn a_mutated_project_never_panics_and_opens_only_as_a_valid_project(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
        truncate in any::<bool>(),
    ) {
        let mut bytes = project().to_json().into_bytes();
        for (at, byte) in edits {
            let i = at.index(bytes.len());
            bytes[i] = byte;
        }
        if truncate {
            bytes.truncate(cut.index(bytes.len()));
        }
        if let Ok(opened) = Project::from_bytes(&bytes) {
            // What opens is a project: checked, and it opens again from its own text.
            prop_assert!(opened.check().is_ok());
            prop_assert_eq!(Project::from_json(&opened.to_json()).ok(), Some(opened));
        }
    }
}

#[test]
fn two_drives_on_one_connection_are_refused_naming_both() {
    let drive = |name: &str, link: &str| Drive::new(name, link.parse().expect("a link"));
    let project = |drives: Vec<Drive>| Project { drives, plot: None };
    let same = project(vec![
        drive("X axis", "modbus-tcp://192.168.2.100:502"),
        drive("Y axis", "modbus-tcp://192.168.2.100:502?unit=0"),
    ]);
    let error = same.check().expect_err("one drive twice").to_string();
    assert!(
        error.contains(
            "drives \"X axis\" and \"Y axis\" both connect to Modbus TCP 192.168.2.100:502 unit 0"
        ),
        "{error}"
    );
    // A gateway's units, nodes on one bus, and simulated drives are drives of their own.
    let apart = project(vec![
        drive("A", "modbus-tcp://192.168.2.100:502?unit=1"),
        drive("B", "modbus-tcp://192.168.2.100:502?unit=2"),
        drive("C", "canopen+slcan:///dev/ttyACM0?node=1"),
        drive("D", "canopen+slcan:///dev/ttyACM0?node=2"),
        drive("E", "sim"),
        drive("F", "sim"),
    ]);
    assert!(apart.check().is_ok(), "{:?}", apart.check());
}
