//! The simulated EtherNet/IP adapter (`drivedeck sim --enip`) proven against an independent
//! EtherNet/IP client, pycomm3 1.2 (tests/peers/pycomm3_client.py), as a PLC programmer
//! would use it and with nothing of drivedeck on the client side:
//!
//! * the Nanotec object services (class 64h instance 1: 32h GetOD, 33h SetOD, 34h GetOD
//!   Rockwell) through pycomm3's `CIPDriver.generic_message`, in every request shape
//!   pycomm3 can produce: bare SendRRData, SendRRData with pycomm3's default route path
//!   appended, Unconnected_Send (52h) wrapping (with a route, and without one, which CIP
//!   refuses), and its default class 3 connection (Large_Forward_Open + SendUnitData),
//!   each also behind a backplane route `/1/0`;
//! * the CIP statuses of refusals, as pycomm3 reports them (status and its own text);
//! * the identity through pycomm3's `list_identity`, `get_module_info`, Get_Attribute_Single
//!   and `discover`;
//! * a move through the PDI by plain SetOD writes to 2291h and GetOD polls (spec 2.2.11).
//!
//! pycomm3 takes the TCP port in its path: `CIPDriver("127.0.0.1:PORT")`, and a CIP route
//! after it (`"127.0.0.1:PORT/1/0"`). Its `discover()` always sends to UDP port 44818, so
//! that test serves the adapter on 44818 of a loopback address of its own (127.77.x.y) and
//! gives pycomm3 that address as `broadcast_address`.
//!
//! The peers come from ./.venv, which `cargo test` makes with the versions pinned in
//! tests/peers/requirements.txt. Without them a test passes without running and says
//! `SKIPPED …` in the output; with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) it fails.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::net::Ipv4Addr;
use std::time::{Duration, Instant};

use serde_json::{Value as Json, json};

use common::{Python, Sim};

/// Time a peer script may take; each takes well under a second when all is well, the
/// discover scenario about one second per IPv4 address of the host's name.
const PEER_TIMEOUT: Duration = Duration::from_secs(30);

/// pycomm3's text for general status 05h. pycomm3 reads an absent additional status
/// (size 0) as extended status 0000h and appends its text for "05h, 0000h".
const PYCOMM3_05H: &str = "Destination unknown, class unsupported, instance undefined or structure element undefined (see extended status) - Extended status out of memory  (05, 00)";

/// Run one scenario of the pycomm3 peer against `addr`, with the sim's output on failure.
fn peer(python: &Python, sim: &mut Sim, host: &str, port: u16, scenario: &str) -> Json {
    let started = Instant::now();
    let got = common::try_run_peer(
        python,
        "pycomm3_client.py",
        &[host, &port.to_string(), scenario],
        PEER_TIMEOUT,
    )
    .unwrap_or_else(|e| panic!("{e}\n{}", sim.process.report()));
    assert!(sim.process.running(), "{}", sim.process.report());
    println!(
        "pycomm3 {} {scenario}: {:?}",
        python.version("pycomm3").unwrap_or("?"),
        started.elapsed()
    );
    got
}

/// Remove `key` from an object, panicking with the whole object when it is missing.
fn take(rest: &mut Json, key: &str) -> Json {
    let all = rest.to_string();
    rest.as_object_mut()
        .and_then(|o| o.remove(key))
        .unwrap_or_else(|| panic!("no {key} in {all}"))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The exchange of one bare GetOD of 1018h:01 in SendRRData: CPF items Null + unconnected
/// data, the spec's request bytes, the reply with the value.
fn bare_get_1018_01() -> (Json, Json) {
    (
        json!({
            "dir": ">", "command": "SendRRData", "items": ["null", "unconnected data"],
            // 32h, path size 2 words, class 64h, instance 1; index 1018h LE, sub 01h.
            "cip": "320220642401181001",
        }),
        json!({
            "dir": "<", "command": "SendRRData", "items": ["null", "unconnected data"],
            // B2h (reply bit), reserved, status 0, no additional status, 0000026Ch LE.
            "cip": "b20000006c020000",
        }),
    )
}

// ---------------------------------------------------------------------------------------
// 1. The acceptance check: bare unconnected messages, the spec's examples, refusals

#[test]
fn pycomm3_reads_and_writes_objects_with_bare_unconnected_messages() {
    let Some(python) = common::python_pycomm3() else {
        return;
    };
    let (mut sim, addr) = Sim::enip(&[]);
    let mut got = peer(&python, &mut sim, "127.0.0.1", addr.port(), "unconnected");
    let all = got.to_string();
    // 2031h:00 before the write is the simulated motor's default; reported, not asserted.
    let before = got["set_2031"]
        .as_object_mut()
        .and_then(|o| o.remove("before"))
        .unwrap_or_else(|| panic!("no set_2031.before in {all}"));
    assert_ne!(before, json!(0x304), "{all}");
    let (request, reply) = bare_get_1018_01();
    let refused = |status: u8, error: &str| json!({"ok": false, "status": status, "error": error, "data": ""});
    assert_eq!(
        got,
        json!({
            "pycomm3": python.version("pycomm3").unwrap_or("?"),
            // generic_message(service=0x32, class_code=0x64, instance=1, request_data=
            // 18 10 01, connected=False, unconnected_send=False, route_path=False), decoded
            // by pycomm3's own UDINT: the acceptance check.
            "vendor_1018_01": {"ok": true, "status": 0, "error": null, "value": 0x26C},
            "vendor_wire": {"request": request, "reply": reply},
            // A string comes back whole (25 bytes), no length prefix.
            "name_1008": {"text": "drivedeck simulated drive", "status": 0, "error": null},
            // 34h: type u16 | length u16 | value. 0007h UDINT, 0009h visible string,
            // 0004h DINT (CiA 301 data type codes).
            "rockwell_1018_01": {
                "ok": true, "status": 0, "error": null,
                "data": "070004006c020000",
                "decoded": {"type": 7, "length": 4, "value": "6c020000"},
            },
            "rockwell_1008": {
                "type": 9, "length": 25,
                "value": hex("drivedeck simulated drive".as_bytes()),
            },
            "rockwell_6064": {"type": 4, "length": 4, "value": "00000000"},
            // The spec's SetOD example byte for byte (EtherNet/IP chapter, 33h): request
            // 33 02 20 64 24 01 31 20 00 04 03 00 00, reply B3 00 00 00.
            "set_2031": {
                "ok": true, "status": 0, "error": null,
                "request_cip": "33022064240131200004030000",
                "reply_cip": "b3000000",
            },
            "read_back_2031": 0x304,
            // Abort codes as CIP statuses (module doc of src/sim/server/enip.rs), and the
            // text pycomm3 gives each.
            "missing_object_5fff": refused(0x05, PYCOMM3_05H),
            "missing_sub_1018_09": refused(0x14, "Attribute not supported"),
            "read_only_1018_01": refused(0x0E, "Attribute not settable"),
            "too_long_2031": refused(0x15, "Too much data"),
            "too_short_2031": refused(0x13, "Insufficient command data"),
            "rockwell_missing_5fff": refused(0x05, PYCOMM3_05H),
            "vendor_after_errors": 0x26C,
        }),
        "{all}"
    );
}

// ---------------------------------------------------------------------------------------
// 2. Every request shape pycomm3 makes

#[test]
fn pycomm3_request_shapes_bare_routed_unconnected_send_and_class3_all_reach_the_od() {
    let Some(python) = common::python_pycomm3() else {
        return;
    };
    let (mut sim, addr) = Sim::enip(&[]);
    let mut got = peer(&python, &mut sim, "127.0.0.1", addr.port(), "shapes");
    let all = got.to_string();
    assert_eq!(take(&mut got, "pycomm3"), json!(python.version("pycomm3")));

    // What every shape that reaches the drive reads, writes and is refused.
    let worked = |wrote: u32| {
        json!({
            "vendor_1018_01": "6c020000",
            "vendor_status": 0,
            "vendor_error": null,
            "name_1008": "drivedeck simulated drive",
            "rockwell_1018_01": {"type": 7, "length": 4, "value": "6c020000"},
            "set_2031_status": 0,
            "read_back_2031": wrote,
            "wrote_2031": wrote,
            "missing_object_status": 5,
        })
    };
    let with = |mut base: Json, extra: Json| {
        let base_map = base.as_object_mut().expect("object");
        for (k, v) in extra.as_object().expect("object") {
            base_map.insert(k.clone(), v.clone());
        }
        base
    };
    let (bare_request, bare_reply) = bare_get_1018_01();
    let rr = |cip: &str, dir: &str| json!({"dir": dir, "command": "SendRRData", "items": ["null", "unconnected data"], "cip": cip});
    // Unconnected_Send: 52h to the Connection Manager (class 06h instance 1), priority/tick
    // 0Ah, 05h timeout ticks, message length 9, the bare GetOD, one pad byte, the route.
    let unconnected_send = |route_words: u8, route: &str| {
        let mut request = rr(
            &format!(
                "5202200624010a050900320220642401181001{pad}{route_words:02x}00{route}",
                pad = "00"
            ),
            ">",
        );
        request["unconnected_send"] =
            json!({"embedded": "320220642401181001", "route_words": route_words, "route": route});
        request
    };
    // A class 3 connection: pycomm3's Large_Forward_Open (5Bh), transport A3h (class 3,
    // server, application trigger), to the Message Router 20 02 24 01 (behind the route),
    // O→T parameters 4200_0FA0h (point-to-point, variable size, 4000 bytes), RPIs
    // 00204001h µs (about 2.1 s).
    let class3 = |path: &str| {
        json!({
            "request": {
                "dir": ">", "command": "SendUnitData",
                "items": ["connected address", "connected data"],
                "connection_id": "O->T id of the Forward_Open reply",
                "sequence": 1, "cip": "320220642401181001",
            },
            "reply": {
                "dir": "<", "command": "SendUnitData",
                "items": ["connected address", "connected data"],
                "connection_id": "T->O id",
                "sequence": 1, "cip": "b20000006c020000",
            },
            "forward_open": {
                "service": 0x5B, "transport": 0xA3, "connection_path": path,
                "rpi_us": [0x0020_4001, 0x0020_4001], "ot_params": 0x4200_0FA0_u32,
                "reply_service": 0xDB, "reply_status": 0,
                "reply_apis_equal_rpis": true,
                "reply_to_id_is_pycomm3s": true,
                "reply_triad_echoed": true,
            },
            // Six requests, sequence counts 1..6, each echoed in its reply.
            "sequences_sent": [1, 2, 3, 4, 5, 6],
            "sequences_echoed": true,
            "connection_ids_sent": ["O->T id of the Forward_Open reply"],
            // close(): Forward_Close (4Eh, reply CEh), then UnRegisterSession.
            "closing": ["SendRRData 4e", "SendRRData ce", "UnRegisterSession"],
            "forward_close": {
                "reply_service": 0xCE, "reply_status": 0, "triad_echoed": true, "path": path,
            },
        })
    };
    // pycomm3's default route path (True) on a bare unconnected request: the driver's
    // route, padded with its size, after the request data. The GetOD data is then longer
    // than index + subindex: 15h, as the adapter documents.
    let default_route = |tail: &str, wrote: u32| {
        json!({
            "vendor_1018_01": "", "vendor_status": 0x15, "vendor_error": "Too much data",
            "request": rr(&format!("320220642401181001{tail}"), ">"),
            "reply": rr("b2001500", "<"),
            "wrote_2031": wrote,
            "closing": ["UnRegisterSession"],
        })
    };
    let closing_session = json!({"closing": ["UnRegisterSession"]});

    let expected = json!({
        // route_path=False: the bare request.
        "unconnected": with(
            with(worked(0x301), json!({"request": bare_request, "reply": bare_reply})),
            closing_session.clone(),
        ),
        // route_path=True (pycomm3's default) without Unconnected_Send: `00 00` appended.
        "unconnected_default_route": default_route("0000", 0x302),
        // unconnected_send=True: the empty route (size 0, reserved); the reply is the
        // embedded service's.
        "unconnected_send": with(
            with(
                worked(0x303),
                json!({"request": unconnected_send(0, ""), "reply": rr("b20000006c020000", "<")}),
            ),
            closing_session.clone(),
        ),
        // unconnected_send=True, route_path=False: the message, its pad byte and nothing
        // after it. Unconnected_Send needs the route path size: 13h.
        "unconnected_send_no_route": {
            "vendor_1018_01": "", "vendor_status": 0x13, "vendor_error": "Insufficient command data",
            "request": with(
                rr("5202200624010a05090032022064240118100100", ">"),
                json!({"unconnected_send": {
                    "embedded": "320220642401181001", "route": null, "after_message": "",
                }}),
            ),
            "reply": rr("d2001300", "<"),
            "wrote_2031": 0x304,
            "closing": ["UnRegisterSession"],
        },
        "connected": with(worked(0x305), class3("20022401")),
        // "127.0.0.1:PORT/1/0": port 1 (backplane) link 0, as for a ControlLogix slot.
        "unconnected_default_route_backplane": default_route("01000100", 0x306),
        "unconnected_send_backplane": with(
            with(
                worked(0x307),
                json!({"request": unconnected_send(1, "0100"), "reply": rr("b20000006c020000", "<")}),
            ),
            closing_session,
        ),
        "connected_backplane": with(worked(0x308), class3("010020022401")),
    });
    // Shape by shape, for a readable failure.
    for (shape, want) in expected.as_object().expect("object") {
        assert_eq!(&got[shape], want, "{shape}: {all}");
    }
    assert_eq!(got, expected, "{all}");
}

// ---------------------------------------------------------------------------------------
// 3. The identity as pycomm3 sees it

#[test]
fn pycomm3_reads_the_identity_by_list_identity_get_module_info_and_attributes() {
    let Some(python) = common::python_pycomm3() else {
        return;
    };
    let (mut sim, addr) = Sim::enip(&[]);
    let mut got = peer(&python, &mut sim, "127.0.0.1", addr.port(), "identity");
    let all = got.to_string();
    assert_eq!(take(&mut got, "pycomm3"), json!(python.version("pycomm3")));
    // pycomm3 names vendors from its copy of the ODVA list: Nanotec Electronic is 1368
    // (558h) there, which the adapter announces (26Ch, the CiA id in 1018h:01, would be
    // Parker Hannifin/Compumotor to an EtherNet/IP tool).
    let vendor_name = "Nanotec Electronic GmbH & Co. KG";
    let identity = json!({
        "vendor": vendor_name,
        // Device type 2Bh.
        "product_type": "Generic Device (keyable)",
        // 1018h:02 = 42h, revision from 1018h:03, serial 1018h:04, name 1008h.
        "product_code": 0x42,
        "revision": {"major": 3, "minor": 0},
        "status": "0000",
        "serial": "00001234",
        "product_name": "drivedeck simulated drive",
    });
    let mut listed = identity.clone();
    listed["encap_protocol_version"] = json!(1);
    listed["ip_address"] = json!("127.0.0.1");
    listed["state"] = json!(3);
    assert_eq!(
        got,
        json!({
            // CIPDriver.list_identity("127.0.0.1:PORT"): ListIdentity over TCP.
            "list_identity": listed,
            // The same reply, read raw: item 0Ch, the sockaddr (big-endian) names the
            // explicit-message port, vendor 558h.
            "list_identity_raw": {
                "item_type": 0x0C, "sin_family": 2, "sin_port": addr.port(),
                "sin_addr": "127.0.0.1", "vendor": 0x558, "device_type": 0x2B,
                "product_code": 0x42,
            },
            // get_module_info(0): Get_Attributes_All (01h) of Identity 01h/1 wrapped in
            // Unconnected_Send with the route port 1 (backplane), slot 0.
            "module_info": identity,
            "module_info_request": {"embedded": "010220012401", "route_words": 1, "route": "0100"},
            // Get_Attribute_Single decoded by pycomm3's UINT / UDINT / SHORT_STRING;
            // attribute 4 (revision) raw: major 3, minor 0.
            "get_attribute_single": {
                "1": 0x558, "2": 0x2B, "3": 0x42, "4": "0300", "5": 0, "6": 0x1234,
                "7": "drivedeck simulated drive",
            },
            "identity_attribute_99": {
                "ok": false, "status": 0x14, "error": "Attribute not supported", "data": "",
            },
            // Attribute 7 again in a class 3 connection.
            "connected_product_name": "drivedeck simulated drive",
            // Assembly attribute 4 (size): Common 128 bytes, PDI 8; attribute 3 of 104 is
            // the PDI's T→O image.
            "assembly_sizes": {"100": 128, "101": 128, "104": 8, "105": 8},
            "assembly_104_len": 8,
        }),
        "{all}"
    );
}

/// A loopback address of this test process's own for port 44818 (the whole of 127/8 is
/// the loopback interface on Linux).
fn own_loopback() -> Ipv4Addr {
    let pid = std::process::id();
    Ipv4Addr::new(127, 77, (pid >> 8) as u8, (pid as u8).clamp(1, 254))
}

#[test]
fn pycomm3_discovers_the_adapter_with_list_identity_over_udp() {
    let Some(python) = common::python_pycomm3() else {
        return;
    };
    let ip = own_loopback();
    let (mut sim, addr) = Sim::enip_on(&format!("{ip}:44818"), &[]);
    assert_eq!(addr.port(), 44818);
    let mut got = peer(&python, &mut sim, &ip.to_string(), 44818, "discover");
    let all = got.to_string();
    let seconds = take(&mut got, "seconds");
    let devices = take(&mut got, "devices");
    let devices = devices.as_array().expect("devices");
    // CIPDriver.discover(broadcast_address=IP) sends one ListIdentity datagram from a
    // socket bound to each IPv4 address of the host's name (three entries for 127.0.0.1
    // on a machine whose name resolves there), so the one adapter may be listed more than
    // once: every entry is the adapter.
    assert!(!devices.is_empty(), "pycomm3 discovered nothing: {all}");
    for device in devices {
        assert_eq!(
            device,
            &json!({
                "encap_protocol_version": 1,
                "ip_address": ip.to_string(),
                "vendor": "Nanotec Electronic GmbH & Co. KG",
                "product_type": "Generic Device (keyable)",
                "product_code": 0x42,
                "revision": {"major": 3, "minor": 0},
                "status": "0000",
                "serial": "00001234",
                "product_name": "drivedeck simulated drive",
                "state": 3,
            }),
            "{all}"
        );
    }
    println!("discover: {} entries in {seconds} s", devices.len());
}

// ---------------------------------------------------------------------------------------
// 4. A PLC-style move through the PDI by explicit messages

#[test]
fn pycomm3_moves_the_motor_through_the_pdi_with_setod_writes() {
    let Some(python) = common::python_pycomm3() else {
        return;
    };
    let (mut sim, addr) = Sim::enip(&[]);
    let mut got = peer(&python, &mut sim, "127.0.0.1", addr.port(), "move");
    let all = got.to_string();
    assert_eq!(take(&mut got, "pycomm3"), json!(python.version("pycomm3")));
    // Reported, not asserted to the millisecond: a loaded machine is slower.
    let seconds = take(&mut got, "move_seconds").as_f64().expect("seconds");
    let on_the_way = take(&mut got, "positions_on_the_way")
        .as_u64()
        .expect("count");
    let statusword = take(&mut got, "statusword_6041").as_u64().expect("6041h");
    assert_eq!(
        got,
        json!({
            // 2291h:04 holds no command on a fresh drive, so 20 is a new one (no toggle).
            "cmd_before": 0,
            // SetOD 2291h:01 = 2000 (i32), :02 = 200 (i16), :03 = 0 (i8), :04 = 20 (u8):
            // the command byte last, as spec 2.2.11 says.
            "writes": [0, 0, 0, 0],
            // PdiStatusToggleCmd flipped, TargetReached left and came back, no error;
            // ReturnValue holds the position (PDI spec §2.2.11).
            "left_target_reached": true,
            "arrived": {
                "toggled": true,
                "target_reached": true,
                "error": false,
                "position_6064": 2000,
                "return_value": 2000,
                "error_code_603f": 0,
            },
            "rx_2291_read_back": [2000, 200, 0, 20],
            // The PDI T→O assembly 104, read with Get_Attribute_Single attribute 3:
            // PDI-Status (= 2292h:01), 603Fh, ReturnValue.
            "assembly_104": {"status_equals_2292_01": true, "error_code": 0, "return_value": 2000},
        }),
        "{all}"
    );
    // 6041h: Operation enabled (bits 0-6 masked 6Fh = 27h) and Target reached (bit 10).
    assert_eq!(statusword & 0x6F, 0x27, "6041h = {statusword:04X}h");
    assert_ne!(statusword & 0x0400, 0, "6041h = {statusword:04X}h");
    // The position was live on the way, not only the target at the end.
    assert!(on_the_way >= 1, "{all}");
    println!("move: {seconds} s, {on_the_way} positions on the way");
}
