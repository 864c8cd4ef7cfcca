//! Projects on the command line, against simulated drives served on real sockets by
//! `drivedeck sim` (two Modbus TCP ports: two drives): `project new` with the drives'
//! identities, `--project FILE status` as one table (and JSON) with an unreachable drive
//! as a row saying why, `--drive NAME` moving only that drive, `od dump DIR` writing one
//! backup per drive, `project check` naming a changed device, and the refusals (an unknown
//! drive name lists the names; a broken project file names its cause).

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use common::Sim;
use common::cli::{fails, json, json_run, ok, run};
use drivedeck::od::backup::Backup;
use drivedeck::project::{self, Project};

/// The address in a "serving the simulated drive on Modbus TCP ADDR (…)" line.
fn tcp_address(banner: &str) -> String {
    banner
        .split("Modbus TCP ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {banner:?}"))
        .to_owned()
}

/// `drivedeck sim` serving two drives on two Modbus TCP ports: the sim and the two
/// connection strings.
fn two_drives() -> (Sim, String, String) {
    let (mut sim, first) = Sim::tcp(&["--modbus-tcp", "127.0.0.1:0", "--max-clients", "2"]);
    let second = sim
        .process
        .expect_line("the second port's banner", Duration::from_secs(10));
    (
        sim,
        format!("modbus-tcp://{first}"),
        format!("modbus-tcp://{}", tcp_address(&second)),
    )
}

/// A loopback port nothing listens on (bound, then let go).
fn closed_port() -> String {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let addr = listener.local_addr().expect("its address");
    drop(listener);
    format!("modbus-tcp://{addr}")
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 path")
}

/// `project new FILE "X axis=…" "Y axis=…" [--identify]`.
fn new_project(dir: &Path, x: &str, y: &str, identify: bool) -> PathBuf {
    let file = dir.join("machine.json");
    let xs = format!("X axis={x}");
    let ys = format!("Y axis={y}");
    let mut args = vec!["project", "new", path_str(&file), &xs, &ys];
    if identify {
        args.push("--identify");
    }
    ok(&args);
    file
}

/// The drives' rows of `--json --project FILE status`, by name.
fn rows(value: &serde_json::Value) -> Vec<serde_json::Value> {
    value["drives"].as_array().expect("drives").clone()
}

#[test]
fn status_of_two_served_drives_is_one_table_and_json() {
    let (_sim, x, y) = two_drives();
    let dir = common::temp_dir("project-status");
    let file = new_project(dir.path(), &x, &y, true);
    let saved = project::open(&file).expect("the project opens");
    assert_eq!(saved.drives.len(), 2);
    let identity = saved.drives[0].identity.clone().expect("an identity");
    assert_eq!(identity.vendor, Some(0x26C));

    let (text, _) = ok(&["--project", path_str(&file), "status"]);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[0].starts_with("drive "), "{text}");
    for (line, (name, link)) in lines[1..].iter().zip([("X axis", &x), ("Y axis", &y)]) {
        assert!(line.starts_with(name), "{text}");
        assert!(line.contains(link.as_str()), "{text}");
        assert!(line.contains("Switch on disabled"), "{text}");
        assert!(line.ends_with("same device"), "{text}");
    }

    let value = json(&["--project", path_str(&file), "status"]);
    assert_eq!(value["unreachable"], 0);
    let rows = rows(&value);
    assert_eq!(rows.len(), 2);
    for (row, name) in rows.iter().zip(["X axis", "Y axis"]) {
        assert_eq!(row["name"], name);
        assert_eq!(row["reached"], true);
        assert_eq!(row["state"], "Switch on disabled");
        assert_eq!(row["moving"], false);
        assert_eq!(row["error"], serde_json::Value::Null);
        // What `status` prints for one drive.
        assert_eq!(row["status"]["bits"].as_array().map(Vec::len), Some(11));
    }
}

#[test]
fn an_unreachable_drive_is_a_row_saying_why_and_the_other_still_prints() {
    let (_sim, x) = Sim::tcp(&[]);
    let x = format!("modbus-tcp://{x}");
    let y = closed_port();
    let dir = common::temp_dir("project-unreachable");
    let file = new_project(dir.path(), &x, &y, false);

    let (code, text, stderr) = run(&["--timeout", "5", "--project", path_str(&file), "status"]);
    assert_eq!(code, 1, "{text}{stderr}");
    let x_row = text
        .lines()
        .find(|l| l.starts_with("X axis"))
        .expect("X's row");
    assert!(x_row.contains("Switch on disabled"), "{text}");
    assert!(x_row.ends_with("not recorded"), "{text}");
    let y_row = text
        .lines()
        .find(|l| l.starts_with("Y axis"))
        .expect("Y's row");
    assert!(
        y_row.contains(&format!("unreachable: cannot connect to {y}")),
        "{text}"
    );

    let (code, value) = json_run(&["--timeout", "5", "--project", path_str(&file), "status"]);
    assert_eq!(code, 1);
    assert_eq!(value["unreachable"], 1);
    let rows = rows(&value);
    assert_eq!(rows[0]["reached"], true);
    assert_eq!(rows[1]["reached"], false);
    let error = rows[1]["error"].as_str().expect("a reason");
    assert!(
        error.starts_with(&format!("cannot connect to {y}")),
        "{error}"
    );
}

#[test]
fn a_named_drive_moves_alone_and_od_dump_writes_one_backup_per_drive() {
    let (_sim, x, y) = two_drives();
    let dir = common::temp_dir("project-move");
    let file = new_project(dir.path(), &x, &y, false);
    let file = path_str(&file);

    let moved = json(&[
        "--project",
        file,
        "--drive",
        "X axis",
        "move-abs",
        "1000",
        "--speed",
        "300",
        "--wait",
    ]);
    assert_eq!(moved["outcome"], "done");
    let value = json(&["--project", file, "status"]);
    let rows = rows(&value);
    assert_eq!(rows[0]["position"], 1000.0);
    assert_eq!(rows[1]["position"], 0.0);
    // --drive with status: the one drive, as `--link URL status` prints it.
    let one = json(&["--project", file, "--drive", "Y axis", "status"]);
    let link = one["link"].as_str().expect("the link");
    assert!(link.starts_with(&y), "{link}");

    let backups = dir.path().join("backups");
    let dumped = json(&["--project", file, "od", "dump", path_str(&backups)]);
    let drives = dumped["drives"].as_array().expect("drives");
    assert_eq!(drives.len(), 2);
    for (drive, stem) in drives.iter().zip(["X_axis", "Y_axis"]) {
        assert_eq!(drive["saved"], true, "{dumped}");
        let path = backups.join(format!("{stem}.json"));
        assert_eq!(drive["file"], path_str(&path));
        let text = std::fs::read_to_string(&path).expect("the backup");
        let backup = Backup::from_json(&text).expect("a backup");
        assert_eq!(backup.identity.vendor, Some(0x26C));
    }
    let mut names: Vec<String> = std::fs::read_dir(&backups)
        .expect("the folder")
        .map(|e| {
            e.expect("an entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    assert_eq!(names, ["X_axis.json", "Y_axis.json"]);
}

#[test]
fn project_check_names_a_changed_device_and_a_silent_one() {
    let (_sim, x, y) = two_drives();
    let dir = common::temp_dir("project-check");
    let file = new_project(dir.path(), &x, &y, true);
    let (text, _) = ok(&["project", "check", path_str(&file)]);
    assert_eq!(text, "X axis: same device\nY axis: same device\n");

    // Y's stored serial is another device's.
    let mut project: Project = project::open(&file).expect("opens");
    let seen = project.drives[1]
        .identity
        .as_ref()
        .and_then(|i| i.serial)
        .expect("a serial");
    if let Some(identity) = project.drives[1].identity.as_mut() {
        identity.serial = Some(seen ^ 0xFF);
    }
    project::save(&project, &file).expect("saved");
    let (code, text, stderr) = run(&["project", "check", path_str(&file)]);
    assert_eq!(code, 1, "{text}{stderr}");
    assert_eq!(
        text,
        format!(
            "X axis: same device\nY axis: serial number changed 0x{:08X} -> 0x{seen:08X}\n",
            seen ^ 0xFF
        )
    );
    // The status table says it too, and so does stderr.
    let (code, table, stderr) = run(&["--project", path_str(&file), "status"]);
    assert_eq!(code, 0, "{table}{stderr}");
    assert!(table.contains("serial number changed"), "{table}");
    assert!(
        stderr.contains("warning: Y axis: not the device the project saw: serial number changed"),
        "{stderr}"
    );

    // A one-shot command on that drive says so before it acts.
    let (_, stderr) = ok(&["--project", path_str(&file), "--drive", "Y axis", "status"]);
    assert!(
        stderr.contains(&format!(
            "warning: not the device the project saw: Y axis: serial number changed 0x{:08X} -> 0x{seen:08X}",
            seen ^ 0xFF
        )),
        "{stderr}"
    );
    let (_, stderr) = ok(&["--project", path_str(&file), "--drive", "X axis", "status"]);
    assert!(!stderr.contains("not the device"), "{stderr}");
    // --update stores what is seen now (the exit code still says what was found).
    let (code, text, _) = run(&["project", "check", path_str(&file), "--update"]);
    assert_eq!(code, 1, "{text}");
    assert!(
        text.ends_with(&format!(
            "stored the identities seen now in {}\n",
            path_str(&file)
        )),
        "{text}"
    );
    let (text, _) = ok(&["project", "check", path_str(&file)]);
    assert_eq!(text, "X axis: same device\nY axis: same device\n");
}

#[test]
fn project_check_says_why_a_drive_did_not_answer() {
    let (_sim, x) = Sim::tcp(&[]);
    let x = format!("modbus-tcp://{x}");
    let y = closed_port();
    let dir = common::temp_dir("project-silent");
    let file = new_project(dir.path(), &x, &y, false);
    let (code, value) = json_run(&["--timeout", "5", "project", "check", path_str(&file)]);
    assert_eq!(code, 1);
    assert_eq!(value["drives"][0]["verdict"], "not recorded");
    assert_eq!(value["drives"][1]["verdict"], "no answer");
    let text = value["drives"][1]["text"].as_str().expect("text");
    assert!(
        text.starts_with(&format!("Y axis: no answer (cannot connect to {y}")),
        "{text}"
    );
    // `new --identify` writes nothing when a drive does not answer.
    let other = dir.path().join("other.json");
    let xs = format!("X axis={x}");
    let ys = format!("Y axis={y}");
    let stderr = fails(
        &[
            "--timeout",
            "5",
            "project",
            "new",
            path_str(&other),
            &xs,
            &ys,
            "--identify",
        ],
        1,
    );
    assert!(
        stderr.contains("nothing was written: Y axis: no answer"),
        "{stderr}"
    );
    assert!(!other.exists());
}

#[test]
fn wrong_names_missing_drives_and_broken_files_are_refused() {
    let dir = common::temp_dir("project-refusals");
    let file = new_project(dir.path(), "sim", "canopen+sim://?node=2", false);
    let file = path_str(&file);
    let stderr = fails(&["--project", file, "--drive", "Z axis", "status"], 2);
    assert!(
        stderr.contains(
            "no drive named \"Z axis\" in the project; its drives: \"X axis\", \"Y axis\""
        ),
        "{stderr}"
    );
    let stderr = fails(&["--project", file, "move-abs", "100", "--speed", "100"], 2);
    assert!(
        stderr.contains("move-abs talks to one drive: give --drive NAME"),
        "{stderr}"
    );
    let stderr = fails(&["--project", file, "od", "dump"], 2);
    assert!(
        stderr.contains("od dump on a project: give a folder for one backup per drive"),
        "{stderr}"
    );
    let stderr = fails(&["--project", file, "--link", "sim", "status"], 2);
    assert!(stderr.contains("cannot be used with"), "{stderr}");
    let stderr = fails(&["--drive", "X axis", "status"], 2);
    assert!(stderr.contains("--project"), "{stderr}");
    let stderr = fails(&["--project", file, "sim"], 2);
    assert!(stderr.contains("sim does not use --project"), "{stderr}");
    // A project file named as the first argument, with a command: --project is the way.
    let stderr = fails(&[file, "status"], 2);
    assert!(stderr.contains("--project"), "{stderr}");
    // A mistyped command is still a mistyped command, not a project.
    let stderr = fails(&["stauts"], 2);
    assert!(stderr.contains("'stauts' is no command"), "{stderr}");
    // `project new` refuses two drives of one name and an existing file.
    let stderr = fails(&["project", "new", file, "A=sim"], 2);
    assert!(stderr.contains("exists: give --force"), "{stderr}");
    let other = dir.path().join("twice.json");
    let stderr = fails(&["project", "new", path_str(&other), "A=sim", "a=sim"], 2);
    assert!(
        stderr.contains("two drives are named \"A\" and \"a\""),
        "{stderr}"
    );
    let stderr = fails(&["project", "new", path_str(&other), "A=tcp:/x"], 2);
    assert!(stderr.contains("drive \"A\": "), "{stderr}");

    // Broken files: the window is not opened, the cause is named.
    let newer = dir.path().join("newer.json");
    std::fs::write(
        &newer,
        r#"{"format": "drivedeck-project", "version": 2, "drives": []}"#,
    )
    .expect("written");
    let stderr = fails(&[path_str(&newer)], 2);
    assert!(
        stderr.contains("project version 2 is newer than this drivedeck reads"),
        "{stderr}"
    );
    let truncated = dir.path().join("truncated.json");
    let text = std::fs::read_to_string(file).expect("the project");
    std::fs::write(&truncated, &text[..text.len() / 2]).expect("written");
    let stderr = fails(&["--project", path_str(&truncated), "status"], 2);
    assert!(stderr.contains("not JSON (EOF while parsing"), "{stderr}");
    let stderr = fails(&[path_str(&dir.path().join("nowhere.json"))], 2);
    assert!(stderr.contains("cannot read"), "{stderr}");
}

#[test]
fn a_project_named_first_goes_to_the_window_and_is_remembered() {
    let dir = common::temp_dir("project-window");
    let file = new_project(dir.path(), "sim", "canopen+sim://?node=2", false);
    let data = dir.path().join("data");
    // No display: the project is opened and checked, remembered, and handed to the
    // window, which cannot open here and says why.
    let out = common::cli::command()
        .arg(&file)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .env("XDG_DATA_HOME", &data)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the window could not open"), "{stderr}");
    assert_eq!(
        project::recent::last_project_in(&data.join(project::recent::APP_ID)),
        Some(file)
    );
}
