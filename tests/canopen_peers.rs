//! CANopen proven against an independent implementation, python-canopen 2.4 on python-can
//! 4.6 (tests/peers/canopen_*.py), over slcan on socat pseudo-terminal pairs:
//!
//! * python-canopen as the master, with its own object dictionary written from the spec
//!   and its own PDO API, against `drivedeck sim --slcan A --node 5`: boot-up, heartbeat,
//!   NMT, expedited and segmented SDO, abort codes, the PDI PDOs of spec section 3, a move
//!   through RPDO1/TPDO1 and one through the PDI over SDO, and its node scanner;
//! * our master (`canopen+slcan://B`) against a python-canopen `LocalNode` behind a
//!   small slcan adapter emulated in Python: a CANopen device without the PDI, its objects
//!   read and written (the node confirms what it stored), its refusals decoded, and our
//!   bus scan finding it.
//!
//! The peers come from ./.venv, which `cargo test` makes with the versions pinned in
//! tests/peers/requirements.txt. Without them a test passes without running and says
//! `SKIPPED …` in the output; with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) it fails.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::{Value as Json, json};

use common::{Process, PtyPair, Python, Sim};
use drivedeck::cia::AbortCode;
use drivedeck::link::Refusal;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::Action;
use drivedeck::worker::{Event, ObjectError, ObjectPath, Rejection, Request};
use probe::Probe;

/// Time a peer script may take; the master script takes about 1.5 s when all is well.
const PEER_TIMEOUT: Duration = Duration::from_secs(30);
/// Time one request through the worker may take on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(10);

// ---------------------------------------------------------------------------------------
// python-canopen as master, our simulated node behind our emulated slcan adapter

#[test]
fn python_canopen_masters_the_simulated_node_over_slcan() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let Some(pty) = PtyPair::new() else {
        return;
    };
    let mut sim = Sim::slcan(&pty.a, 5, &[]);
    let started = Instant::now();
    let got = common::try_run_peer(
        &python,
        "canopen_master.py",
        &[pty.b.to_str().expect("utf-8 path"), "5"],
        PEER_TIMEOUT,
    )
    .unwrap_or_else(|e| panic!("{e}\n{}", sim.process.report()));
    let elapsed = started.elapsed();

    let mut rest = got.clone();
    let mut take = |key: &str| {
        rest.as_object_mut()
            .and_then(|o| o.remove(key))
            .unwrap_or_else(|| panic!("no {key} in {got}"))
    };
    // Reported, not asserted to the millisecond: a loaded machine is slower.
    let move_seconds = take("move_seconds").as_f64().expect("seconds");
    let on_the_way = take("tpdo_positions_on_the_way").as_u64().expect("count");
    let statusword = take("statusword_6041").as_u64().expect("6041h");
    assert_eq!(
        rest,
        json!({
            // python-canopen's NodeScanner (SDO 1000h to ids 1-127) hears node 5 only.
            "scanner_nodes": [5],
            // NMT reset communication: boot-up (700h+5, 00h), Pre-operational (7Fh) in the
            // heartbeat once 1017h (ms) is set.
            "boot_up": true,
            "heartbeat_1017": 50,
            "state_after_boot": 0x7F,
            // 1018h:01 Nanotec 26Ch, expedited with the size given (43h = 4 bytes).
            "vendor_1018_01": 0x26C,
            "product_1018_02": 0x42,
            "expedited_1018_01": 0x43,
            // 1008h: segmented, initiate 41h (size given), four segments of 7 bytes at
            // most for 25 characters, c = 1 on the last.
            "name_1008": "drivedeck simulated drive",
            "segmented_1008": {"initiate": 0x41, "segments": 4, "last_segment_c": 1},
            "device_type_1000": 0x0004_0192,
            "read_back_6081": 1234,
            "read_back_6081_raw": "e1100000",
            // CiA 301 abort codes (protocol notes §2.5).
            "abort_missing_object": 0x0602_0000,
            "abort_missing_sub": 0x0609_0011,
            "abort_read_only": 0x0601_0002,
            "abort_too_long": 0x0607_0012,
            "abort_block_upload": 0x0504_0001,
            "segmented_download_6081": 777,
            "vendor_after_aborts": "6c020000",
            // The predefined connection set: RPDO1 on 200h+5, invalid until configured.
            "rpdo1_before": {"cob_id": 0x205, "enabled": false, "mapped": 0},
            // Spec section 3, as python-canopen's PDO API wrote it and read it back.
            "rpdo1_mapping": ["2291:01/32", "2291:02/16", "2291:03/8", "2291:04/8"],
            "tpdo1_mapping": ["2292:01/16", "603F:00/16", "2292:02/32"],
            "rpdo1_cob_id": 0x205,
            "tpdo1_cob_id": 0x185,
            "tpdo1_enabled": true,
            "tpdo1_event_timer": 100,
            "tpdo1_inhibit": 20,
            "raw_1a00": ["22920110", "603F0010", "22920220"],
            "raw_1600": ["22910120", "22910210", "22910308", "22910408"],
            "pdi_ctrl_2290": 1,
            "state_after_start": 5,
            // Cmd 20 through RPDO1; TPDO1 (decoded by python-canopen from its mapping)
            // shows the toggle, TargetReached, no error, ReturnValue = the position.
            "move_tpdo": {
                "toggled": true,
                "target_reached": true,
                "operation_enabled": true,
                "error": false,
                "error_code_603f": 0,
                "return_value": 2000,
            },
            "position_6064": 2000,
            // Cmd 21 by SDO writes to 2291h (spec 2.2.11): -500 from 2000.
            "sdo_move": {
                "toggled": true,
                "target_reached": true,
                "error": false,
                "position_6064": 1500,
                "return_value": 1500,
            },
            "rx_2291_read_back": [-500, 300, 0, 21],
            "state_after_stop": 4,
        }),
        "{got}"
    );
    // 6041h: Operation enabled (bits 0-6 masked 6Fh = 27h) and Target reached (bit 10).
    assert_eq!(statusword & 0x6F, 0x27, "6041h = {statusword:04X}h");
    assert_ne!(statusword & 0x0400, 0, "6041h = {statusword:04X}h");
    // TPDO1 went out on change while the motor moved, not only at the end.
    assert!(on_the_way >= 1, "{got}");
    assert!(sim.process.running(), "{}", sim.process.report());
    println!(
        "python-canopen {} / python-can {}: whole script {elapsed:?}, move {move_seconds} s, {on_the_way} positions on the way",
        python.version("canopen").unwrap_or("?"),
        python.version("can").unwrap_or("?"),
    );
}

// ---------------------------------------------------------------------------------------
// Our master against a python-canopen LocalNode

/// The python-canopen LocalNode, built from tests/peers/canopen_local_node.eds, behind its
/// emulated slcan adapter on one end of `pty`.
struct LocalNode {
    process: Process,
}

impl LocalNode {
    fn start(python: &Python, path: &Path, node: u8) -> LocalNode {
        let mut command = Command::new(&python.path);
        command
            .arg(common::peer_script("canopen_local_node.py"))
            .arg(path)
            .arg(node.to_string());
        let mut process = Process::spawn("canopen_local_node.py", &mut command);
        let first = process.expect_line("the ready line", Duration::from_secs(20));
        assert_eq!(
            serde_json::from_str::<Json>(&first).ok(),
            Some(json!({"ready": true, "node": node})),
            "{first}; {}",
            process.report()
        );
        LocalNode { process }
    }

    /// The next write the node reports having stored (other lines are skipped).
    fn next_write(&mut self) -> Json {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(line) = self.process.line(left) else {
                panic!(
                    "the LocalNode reported no write within {PATIENCE:?}: {}",
                    self.process.report()
                );
            };
            let event: Json =
                serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line:?}: {e}"));
            if event.get("written").is_some() {
                return event;
            }
        }
    }

    /// Writes reported without waiting: none are expected.
    fn stray_writes(&mut self) -> Vec<Json> {
        let mut out = vec![];
        while let Some(line) = self.process.line(Duration::from_millis(200)) {
            if let Ok(event) = serde_json::from_str::<Json>(&line)
                && event.get("written").is_some()
            {
                out.push(event);
            }
        }
        out
    }
}

/// Read one object through the worker, the link's own access (SDO) first.
fn read(probe: &mut Probe, address: Address, dtype: DataType) -> Result<Value, ObjectError> {
    probe.read(address, dtype, ObjectPath::Auto)
}

#[test]
fn our_master_reads_and_writes_a_python_canopen_local_node() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let Some(pty) = PtyPair::new() else {
        return;
    };
    let started = Instant::now();
    let mut node = LocalNode::start(&python, &pty.a, 7);
    let mut probe = Probe::connected(common::slcan_spec(&pty.b, 7));
    let info = probe.link_info();

    // Not a Nanotec drive: no 2291h/2292h, so object access only, and said so.
    assert!(!info.pdi, "{info:?}");
    assert!(
        info.description.contains("CANopen node 7")
            && info.description.contains("objects only: no PDI"),
        "{}",
        info.description
    );
    let objects_only = |n: &str| {
        n.contains("node 7 has no Plug & Drive interface")
            && n.contains("06020000h (Object does not exist in the object dictionary)")
    };
    if !probe.notices().iter().any(|n| objects_only(n)) {
        probe.wait(
            "the objects-only notice",
            PATIENCE,
            |e| matches!(e, Event::Notice(n) if objects_only(&n.text)),
        );
    }

    let u32_at = |index| Address::new(index, 0);
    // Identity (a record), the name (24 characters: a segmented upload), plain objects.
    for (sub, expected) in [
        (0u8, 4u64),
        (1, 0x1234_5678),
        (2, 0xC0DE),
        (3, 0x0001_0002),
        (4, 0x0BAD_BEEF),
    ] {
        let dtype = if sub == 0 {
            DataType::Unsigned8
        } else {
            DataType::Unsigned32
        };
        assert_eq!(
            read(&mut probe, Address::new(0x1018, sub), dtype),
            Ok(Value::Uint(expected)),
            "1018h:{sub:02X}h"
        );
    }
    assert_eq!(
        read(&mut probe, u32_at(0x1008), DataType::VisibleString),
        Ok(Value::Text("python-canopen LocalNode".into()))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x1000), DataType::Unsigned32),
        Ok(Value::Uint(0x000F_0191))
    );
    // The EDS gives the EMCY COB-ID as `$NODEID+0x80`: python-canopen resolved it for node 7.
    assert_eq!(
        read(&mut probe, u32_at(0x1014), DataType::Unsigned32),
        Ok(Value::Uint(0x87))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2000), DataType::Unsigned32),
        Ok(Value::Uint(0x1122_3344))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2001), DataType::Integer16),
        Ok(Value::Int(-1234))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2002), DataType::Unsigned32),
        Ok(Value::Uint(0xCAFE_F00D))
    );

    // Writes: the LocalNode reports what it stored, byte for byte, and it reads back.
    probe
        .write(
            u32_at(0x2000),
            DataType::Unsigned32,
            Value::Uint(0xDEAD_BEEF),
            ObjectPath::Auto,
        )
        .expect("write 2000h");
    assert_eq!(
        node.next_write(),
        json!({"written": "2000:00", "hex": "efbeadde", "value": 0xDEAD_BEEFu32})
    );
    probe
        .write(
            u32_at(0x2001),
            DataType::Integer16,
            Value::Int(-42),
            ObjectPath::Auto,
        )
        .expect("write 2001h");
    assert_eq!(
        node.next_write(),
        json!({"written": "2001:00", "hex": "d6ff", "value": -42})
    );
    // 20 characters: a segmented download.
    probe
        .write(
            u32_at(0x2003),
            DataType::VisibleString,
            Value::Text("written by drivedeck".into()),
            ObjectPath::Auto,
        )
        .expect("write 2003h");
    assert_eq!(
        node.next_write(),
        json!({
            "written": "2003:00",
            "hex": "7772697474656e2062792064726976656465636b",
            "value": "written by drivedeck",
        })
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2000), DataType::Unsigned32),
        Ok(Value::Uint(0xDEAD_BEEF))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2001), DataType::Integer16),
        Ok(Value::Int(-42))
    );
    assert_eq!(
        read(&mut probe, u32_at(0x2003), DataType::VisibleString),
        Ok(Value::Text("written by drivedeck".into()))
    );

    // Refusals come back as the decoded abort, and the node stored nothing.
    let read_only = probe
        .write(
            u32_at(0x2002),
            DataType::Unsigned32,
            Value::Uint(5),
            ObjectPath::Auto,
        )
        .expect_err("2002h is read-only");
    assert_eq!(
        read_only,
        ObjectError::Refused(Refusal::Abort(AbortCode::READ_ONLY))
    );
    let missing = probe
        .write(
            u32_at(0x2FFF),
            DataType::Unsigned32,
            Value::Uint(5),
            ObjectPath::Auto,
        )
        .expect_err("no 2FFFh");
    assert_eq!(
        missing,
        ObjectError::Refused(Refusal::Abort(AbortCode::NO_OBJECT))
    );
    let missing = read(&mut probe, u32_at(0x2FFF), DataType::Unsigned32).expect_err("no 2FFFh");
    assert_eq!(
        missing,
        ObjectError::Refused(Refusal::Abort(AbortCode::NO_OBJECT))
    );
    let no_sub =
        read(&mut probe, Address::new(0x1018, 9), DataType::Unsigned32).expect_err("no 1018h:09h");
    assert_eq!(
        no_sub,
        ObjectError::Refused(Refusal::Abort(AbortCode::NO_SUBINDEX))
    );
    // Two bytes for a 32-bit object: python-canopen checks the length.
    let short = probe
        .write(
            u32_at(0x2000),
            DataType::Unsigned16,
            Value::Uint(7),
            ObjectPath::Auto,
        )
        .expect_err("too short");
    assert_eq!(
        short,
        ObjectError::Refused(Refusal::Abort(AbortCode::TYPE_LENGTH_MISMATCH))
    );
    assert_eq!(node.stray_writes(), Vec::<Json>::new());
    assert_eq!(
        read(&mut probe, u32_at(0x2000), DataType::Unsigned32),
        Ok(Value::Uint(0xDEAD_BEEF))
    );

    // No PDI: a motion command is refused before anything is sent.
    let id = probe.send(Request::Command(Action::Velocity { speed: 100 }));
    let rejected = probe.wait(
        "the rejection",
        PATIENCE,
        |e| matches!(e, Event::Rejected { id: i, .. } if *i == id),
    );
    let refused = |e: &Event| matches!(e, Event::Rejected { reason: Rejection::Refused(r), .. } if r.contains("no Plug & Drive interface"));
    assert!(refused(&rejected), "{rejected:?}");

    // A scan on the open link finds the node with its identity, name and NMT state.
    let found = probe
        .scan(Request::Scan(common::slcan_spec(&pty.b, 7)), PATIENCE)
        .expect("scan");
    assert_eq!(found.len(), 1, "{found:?}");
    let device = &found[0];
    assert_eq!(
        (
            device.node,
            device.vendor,
            device.product,
            device.revision,
            device.serial
        ),
        (
            Some(7),
            Some(0x1234_5678),
            Some(0xC0DE),
            Some(0x0001_0002),
            Some(0x0BAD_BEEF)
        ),
        "{device:?}"
    );
    assert_eq!(device.name.as_deref(), Some("python-canopen LocalNode"));
    // The LocalNode's heartbeat (1017h = 100 ms) says Pre-operational.
    assert_eq!(
        device.state.as_deref(),
        Some("pre-operational"),
        "{device:?}"
    );

    assert!(node.process.running(), "{}", node.process.report());
    println!(
        "our master against the python-canopen {} LocalNode: {:?}; notices {:?}",
        python.version("canopen").unwrap_or("?"),
        started.elapsed(),
        probe.notices()
    );
}

#[test]
fn the_one_shot_commands_and_scan_work_against_a_python_canopen_local_node() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let Some(pty) = PtyPair::new() else {
        return;
    };
    let started = Instant::now();
    let mut node = LocalNode::start(&python, &pty.a, 42);
    let link = format!(
        "canopen+slcan://{}?bitrate=1000000&node=42",
        pty.b.display()
    );
    let drivedeck = |args: &[&str]| {
        let mut all = vec!["--json", "--timeout", "10", "--link", &link];
        all.extend_from_slice(args);
        common::cli::run(&all)
    };
    let parsed = |what: &str, stdout: &str, stderr: &str| -> Json {
        serde_json::from_str(stdout).unwrap_or_else(|e| panic!("{what}: {e}: {stdout}{stderr}"))
    };

    // `scan`: no node needed in the link; the answer window is fixed, so a machine busy
    // elsewhere gets three tries to see the node with everything it has.
    let mut scans = vec![];
    let nodes = (0..3)
        .find_map(|_| {
            let (code, stdout, stderr) = drivedeck(&["scan"]);
            assert_eq!(code, 0, "scan: {stdout}{stderr}");
            let nodes = parsed("scan", &stdout, &stderr)["nodes"].clone();
            scans.push(nodes.clone());
            let complete = nodes
                .as_array()
                .is_some_and(|n| n.iter().any(|d| d["node"] == 42 && !d["name"].is_null()));
            complete.then_some(nodes)
        })
        .unwrap_or_else(|| panic!("three scans missed node 42: {scans:?}"));
    assert_eq!(
        nodes,
        json!([{
            "address": "node 42",
            "node": 42,
            "vendor": 0x1234_5678,
            "product": 0xC0DE,
            "revision": 0x0001_0002,
            "serial": 0x0BAD_BEEFu32,
            "name": "python-canopen LocalNode",
            "state": "pre-operational",
        }])
    );

    // `read`: the catalog's type for 1008h, --type for the node's own objects.
    let (code, stdout, stderr) = drivedeck(&["read", "1008"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    let read = parsed("read 1008", &stdout, &stderr);
    assert_eq!(
        read["value"],
        json!({"kind": "text", "value": "python-canopen LocalNode"})
    );
    assert!(
        read["notes"].as_array().is_some_and(|n| n
            .iter()
            .any(|t| t.as_str().is_some_and(|t| t.contains("object access only")))),
        "{read}"
    );
    let (code, stdout, stderr) = drivedeck(&["read", "2001:00", "--type", "i16"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert_eq!(
        parsed("read 2001", &stdout, &stderr)["value"]["value"],
        -1234
    );

    // `write`: the node stores it.
    let (code, stdout, stderr) = drivedeck(&["write", "2000:00", "0x01020304", "--type", "u32"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert_eq!(parsed("write 2000", &stdout, &stderr)["written"], true);
    assert_eq!(
        node.next_write(),
        json!({"written": "2000:00", "hex": "04030201", "value": 0x0102_0304})
    );

    // Refusals: exit code 1 and the decoded abort.
    let (code, stdout, stderr) = drivedeck(&["write", "2002:00", "1", "--type", "u32"]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    let error = parsed("write 2002", &stdout, &stderr)["error"].clone();
    assert_eq!(
        error,
        "write 1 to 2002h:00h: abort 06010002h (Attempt to write a read-only object)"
    );
    let (code, stdout, stderr) = drivedeck(&["read", "2FFF:00", "--type", "u32"]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    let error = parsed("read 2FFF", &stdout, &stderr)["error"].clone();
    assert_eq!(
        error,
        "read 2FFFh:00h: abort 06020000h (Object does not exist in the object dictionary)"
    );
    assert_eq!(node.stray_writes(), Vec::<Json>::new());
    assert!(node.process.running(), "{}", node.process.report());
    println!(
        "one-shot commands against the LocalNode: {:?}, {} scan(s)",
        started.elapsed(),
        scans.len()
    );
}
