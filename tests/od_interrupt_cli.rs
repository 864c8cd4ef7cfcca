//! Interrupted housekeeping and hostile input on the command line: `od restore` stopped by
//! Ctrl-C finishes the write in flight, says what was written and what not, and exits 130
//! (its writes printed as they are made); `od dump` over CANopen stopped by Ctrl-C puts
//! the PDI's PDO mapping back; a FIFO given as a project, backup or EDS file is refused at
//! once; strings from a file are shown escaped and a huge one shortened.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use common::cli::{command, fails, ok};
use common::{Process, PtyPair, Sim, temp_dir};

/// Long enough for any step of a loaded machine; never a measure of speed.
const PATIENCE: Duration = Duration::from_secs(30);

fn path_str(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// One Modbus TCP frame (MBAP header and PDU) from `stream`, or `None` at its end.
fn read_frame(stream: &mut TcpStream) -> Option<Vec<u8>> {
    let mut frame = vec![0u8; 6];
    stream.read_exact(&mut frame).ok()?;
    let len = usize::from(u16::from_be_bytes([frame[4], frame[5]]));
    let mut rest = vec![0u8; len];
    stream.read_exact(&mut rest).ok()?;
    frame.extend(rest);
    Some(frame)
}

/// An object write: FC 43, MEI type 0Dh, the access flag (the control byte's 01h) set.
fn is_object_write(frame: &[u8]) -> bool {
    frame.len() > 9 && frame[7] == 0x2B && frame[8] == 0x0D && frame[9] & 0x01 != 0
}

/// A proxy between one Modbus TCP client and the simulator that lets the first object
/// write through and holds every later one until the test releases it: the test knows
/// that a write is in flight (`held`), and decides when it is answered (`release`).
struct WriteGate {
    addr: SocketAddr,
    held: mpsc::Receiver<usize>,
    release: mpsc::Sender<()>,
}

impl WriteGate {
    fn start(server: SocketAddr) -> WriteGate {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("address");
        let (held_tx, held) = mpsc::channel();
        let (release, release_rx) = mpsc::channel::<()>();
        thread::spawn(move || {
            let Ok((mut client, _)) = listener.accept() else {
                return;
            };
            let Ok(mut upstream) = TcpStream::connect(server) else {
                return;
            };
            let (Ok(mut client_back), Ok(mut upstream_back)) =
                (client.try_clone(), upstream.try_clone())
            else {
                return;
            };
            thread::spawn(move || {
                let _ = std::io::copy(&mut upstream_back, &mut client_back);
            });
            let mut writes = 0;
            while let Some(frame) = read_frame(&mut client) {
                if is_object_write(&frame) {
                    writes += 1;
                    if writes > 1 {
                        let _ = held_tx.send(writes);
                        if release_rx.recv().is_err() {
                            return;
                        }
                    }
                }
                if upstream.write_all(&frame).is_err() {
                    return;
                }
            }
        });
        WriteGate {
            addr,
            held,
            release,
        }
    }
}

/// A backup of the simulator at `link` with `changed` settings changed: a restore of it
/// makes at least that many writes.
fn changed_backup(dir: &Path, link: &str) -> (PathBuf, usize) {
    let saved = dir.join("saved.json");
    ok(&["--link", link, "od", "dump", "--out", path_str(&saved)]);
    let mut backup: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&saved).expect("dump")).expect("JSON");
    let mut changed = 0;
    for object in backup["objects"].as_array_mut().expect("objects") {
        let address = object["address"].as_str().unwrap_or_default().to_owned();
        let value = object["value"]["value"].as_u64().unwrap_or(0);
        if object["value"]["kind"] == "uint"
            && address.as_str() >= "2000"
            && (1..1000).contains(&value)
        {
            object["value"]["value"] = (value + 1).into();
            object["shown"] = (value + 1).to_string().into();
            changed += 1;
        }
    }
    let file = dir.join("changed.json");
    std::fs::write(&file, backup.to_string()).expect("write");
    (file, changed)
}

#[test]
fn a_restore_stopped_by_ctrl_c_finishes_the_write_in_flight_and_says_what_was_written() {
    let dir = temp_dir("od-restore-sigint");
    let (_sim, server) = Sim::tcp(&[]);
    let direct = format!("modbus-tcp://{server}");
    let (file, changed) = changed_backup(dir.path(), &direct);
    assert!(changed >= 10, "only {changed} settings to change");

    let gate = WriteGate::start(server);
    let link = format!("modbus-tcp://{}", gate.addr);
    let mut restore = common::cli::start(&["--link", &link, "od", "restore", path_str(&file)]);
    // The second write is held: the first was answered, and printed before it was sent.
    let second = gate
        .held
        .recv_timeout(PATIENCE)
        .unwrap_or_else(|_| panic!("no second write: {}", restore.report()));
    assert_eq!(second, 2);
    let first = loop {
        let line = restore.expect_line("the first write's line", PATIENCE);
        if line.trim_start().starts_with("1.") {
            break line;
        }
    };
    assert!(first.ends_with("  written"), "{first}");
    assert!(
        restore.running(),
        "the restore ended early: {}",
        restore.report()
    );
    restore.signal("INT");
    // Let the write in flight through; should the signal not be seen yet when it is
    // answered, the next one too, until the restore stops.
    let status = loop {
        let _ = gate.release.send(());
        if let Some(status) = restore.wait(Duration::from_millis(200)) {
            break status;
        }
        let _ = gate.held.recv_timeout(PATIENCE);
    };
    let report = restore.report();
    assert_eq!(status.code(), Some(130), "{report}");
    let stdout = restore.stdout();
    // The write in flight was finished and printed.
    assert!(
        stdout
            .lines()
            .any(|l| l.trim_start().starts_with("2.") && l.ends_with("  written")),
        "{report}"
    );
    let written = stdout.lines().filter(|l| l.ends_with("  written")).count();
    let total = stdout
        .lines()
        .find_map(|l| {
            l.split(" of ")
                .nth(1)?
                .strip_suffix(" writes done, 0 refused")
        })
        .and_then(|n| n.parse::<usize>().ok())
        .unwrap_or_else(|| panic!("no summary line: {report}"));
    assert!(
        written >= 2 && written < total,
        "{written} of {total}: {report}"
    );
    assert!(
        report.contains(&format!(
            "interrupted by SIGINT (Ctrl-C); the restore stopped after the write in flight: written {written}, refused 0, not written {} of {total} writes; run `od restore` again to write the rest",
            total - written
        )),
        "{report}"
    );
}

/// The value of `address` on the slcan node at `pty`, read with the PDI on PDO 2 so that
/// PDO 1's objects are read as they are, not as this reading maps them.
fn read_beside_pdo1(pty: &Path, node: u8, address: &str) -> String {
    let link = format!(
        "canopen+slcan://{}?bitrate=1000000&node={node}&pdo=2",
        pty.display()
    );
    let value = common::cli::json(&["--link", &link, "read", address]);
    value["hex"].as_str().expect("hex").to_owned()
}

#[test]
fn a_dump_over_canopen_stopped_by_ctrl_c_puts_the_pdo_mapping_back() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    let before = (
        read_beside_pdo1(&pair.b, 5, "1400:01"),
        read_beside_pdo1(&pair.b, 5, "1600:00"),
    );
    assert_eq!(before, ("80000205h".to_owned(), "00h".to_owned()));
    let dir = temp_dir("od-dump-sigint");
    let out = dir.path().join("dump.json");
    let link = format!(
        "canopen+slcan://{}?bitrate=1000000&node=5",
        pair.b.display()
    );
    let mut dump: Process = common::cli::start(&[
        "--link",
        &link,
        "--trace",
        "od",
        "dump",
        "--out",
        path_str(&out),
    ]);
    // Ctrl-C once the PDI's mapping is on the drive (RPDO1 with its 4 entries).
    let deadline = Instant::now() + PATIENCE;
    while !dump.report().contains("download 1600h:00h, 1 byte 04") {
        assert!(
            dump.running() && Instant::now() < deadline,
            "no mapping seen: {}",
            dump.report()
        );
        thread::sleep(Duration::from_millis(5));
    }
    dump.signal("INT");
    let status = dump.wait(PATIENCE).expect("the dump ends");
    let report = dump.report();
    assert_eq!(status.code(), Some(130), "{report}");
    assert!(
        report.contains("interrupted by SIGINT (Ctrl-C)"),
        "{report}"
    );
    assert!(!out.exists(), "a backup was written: {report}");
    let after = (
        read_beside_pdo1(&pair.b, 5, "1400:01"),
        read_beside_pdo1(&pair.b, 5, "1600:00"),
    );
    assert_eq!(after, before, "the mapping was left on the drive: {report}");
}

/// A FIFO in a temp dir, or `None` (said loudly) where mkfifo is missing.
fn fifo(dir: &Path) -> Option<PathBuf> {
    let path = dir.join("x");
    match std::process::Command::new("mkfifo").arg(&path).status() {
        Ok(status) if status.success() => Some(path),
        other => {
            eprintln!(
                "SKIPPED LOUDLY: mkfifo failed ({other:?}): a FIFO given as a file is not tested"
            );
            None
        }
    }
}

#[test]
fn a_fifo_given_as_project_backup_or_eds_is_refused_at_once() {
    let dir = temp_dir("fifo");
    let Some(fifo) = fifo(dir.path()) else {
        return;
    };
    let f = path_str(&fifo);
    let cases: [(&[&str], &str); 4] = [
        (&["--project", f, "status"], "a project file"),
        (&["od", "restore", f], "a backup file (od dump)"),
        (&["od", "diff", f], "a backup file (od dump)"),
        (&["od", "list", "--eds", f], "an EDS file"),
    ];
    for (args, what) in cases {
        // A run that waited on the pipe would never end: the test's own deadline says so.
        let mut run = command()
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("runs");
        let deadline = Instant::now() + PATIENCE;
        let status = loop {
            if let Some(status) = run.try_wait().expect("wait") {
                break status;
            }
            if Instant::now() > deadline {
                let _ = run.kill();
                panic!("{args:?} hangs on a FIFO");
            }
            thread::sleep(Duration::from_millis(10));
        };
        assert_eq!(status.code(), Some(2), "{args:?}");
        let stderr = fails(args, 2);
        assert_eq!(
            stderr.trim_end(),
            format!("drivedeck: {f} is a FIFO (named pipe), not a file: give {what}"),
            "{args:?}"
        );
    }
}

#[test]
fn escape_sequences_in_a_backup_are_shown_not_obeyed() {
    let dir = temp_dir("evil-backup");
    let (_sim, server) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{server}");
    let saved = dir.path().join("saved.json");
    ok(&["--link", &link, "od", "dump", "--out", path_str(&saved)]);
    let mut backup: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&saved).expect("dump")).expect("JSON");
    let evil = "\u{1b}[2J\u{1b}[31mEVIL\u{1b}]0;pwned\u{7}";
    backup["identity"]["name"] = evil.into();
    backup["identity"]["product"] = 0x99.into();
    let file = dir.path().join("evil.json");
    std::fs::write(&file, backup.to_string()).expect("write");
    let stderr = fails(&["--link", &link, "od", "restore", path_str(&file)], 2);
    assert!(
        !stderr.contains('\u{1b}') && !stderr.contains('\u{7}'),
        "{stderr:?}"
    );
    assert!(
        stderr.contains("saved from \\x1b[2J\\x1b[31mEVIL\\x1b]0;pwned\\x07, vendor"),
        "{stderr}"
    );
}

#[test]
fn a_huge_drive_name_in_a_project_is_shortened_in_the_message() {
    let dir = temp_dir("huge-name");
    let file = dir.path().join("machine.json");
    let name = "A".repeat(10 * 1024 * 1024);
    let project = serde_json::json!({
        "format": "drivedeck-project",
        "version": 1,
        "drives": [{ "name": name, "link": "sim" }],
    });
    std::fs::write(&file, project.to_string()).expect("write");
    let stderr = fails(&["--project", path_str(&file), "status"], 2);
    assert_eq!(
        stderr.trim_end(),
        format!(
            "drivedeck: {}: drive 1's name \"{}… (10485760 chars)\" is longer than 64 characters",
            file.display(),
            "A".repeat(200)
        )
    );
}
