//! The Modbus register map and byte order proven against an independent implementation,
//! pymodbus 3.16 (tests/peers/):
//!
//! * pymodbus as a PLC would use it, against `drivedeck sim --modbus-tcp`: the PDI driven
//!   by plain register writes and reads packed by hand from the spec (protocol notes §1.2 to §1.6);
//! * pymodbus as a plain register bank, logging every write: what our client puts on the
//!   wire, register by register.
//!
//! The peers come from ./.venv, which `cargo test` makes with the versions pinned in
//! tests/peers/requirements.txt. Without them a test passes without running and says
//! `SKIPPED …` in the output; with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) it fails.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::process::Command;
use std::time::Duration;

use serde_json::{Value as Json, json};

use common::{Process, Python, Sim};
use drivedeck::link::modbus::client::{DEFAULT_TIMEOUT, ModbusLink};
use drivedeck::link::{Link, LinkSpec};
use drivedeck::pdi::{RxImage, SetValues, Status};

/// Time a peer script may take; each takes well under two seconds when all is well.
const PEER_TIMEOUT: Duration = Duration::from_secs(30);

/// Run the PLC-style client for one scenario against a fresh `drivedeck sim`.
fn plc(python: &Python, scenario: &str) -> Json {
    let (_sim, addr) = Sim::tcp(&[]);
    common::run_peer(
        python,
        "pymodbus_client.py",
        &[
            "tcp",
            &addr.ip().to_string(),
            &addr.port().to_string(),
            scenario,
        ],
        PEER_TIMEOUT,
    )
}

#[test]
fn pymodbus_moves_the_drive_with_plain_register_writes() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let got = plc(&python, "move");
    let mut rest = got.clone();
    let mut take = |key: &str| {
        rest.as_object_mut()
            .and_then(|o| o.remove(key))
            .unwrap_or_else(|| panic!("no {key} in {got}"))
    };
    // The time is reported, not asserted to the millisecond (a loaded machine is slower).
    let seconds = take("seconds").as_f64().expect("seconds");
    let on_the_way = take("positions_on_the_way").as_u64().expect("count");
    let statusword = take("statusword_6041").as_u64().expect("6041h");
    // FC 16 to 5996: [0, 2000, 200, 0x0014]; TargetReached cleared while moving, set at the
    // end; 6064h at 5002-5003, high word first, is the target; ReturnValue holds the
    // position (PDI spec §2.2.11); 6061h, in the low byte of 5001, is Profile Position.
    assert_eq!(
        rest,
        json!({
            "accepted_error": false,
            "left_target": true,
            "target_reached": true,
            "status_error": false,
            "error_code_603f": 0,
            "return_value": 2000,
            "mode_6061": 1,
            "position_6064": 2000,
            "velocity_6044": 0,
        }),
        "{got}"
    );
    // 6041h: Operation enabled (bits 0-6 masked 6Fh = 27h) and Target reached (bit 10).
    assert_eq!(statusword & 0x6F, 0x27, "6041h = {statusword:04X}h");
    assert_ne!(statusword & 0x0400, 0, "6041h = {statusword:04X}h");
    // The position was live on the way, not just the target copied at the end.
    assert!(on_the_way >= 1, "{got}");
    assert!(seconds < 8.0, "{got}");
    println!("pymodbus move: {seconds} s, {got}");
}

#[test]
fn pymodbus_reads_and_writes_objects_through_the_pdi() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let got = plc(&python, "objects");
    let read = |value: i64| json!({"toggled": true, "error": false, "return_value": value, "return_value_u32": value as u32});
    let written = json!({"toggled": true, "error": false});
    assert_eq!(
        got,
        json!({
            // 1018h:01 vendor id 26Ch, read with FC 23 (write 5996.., read 4996.. at once).
            "read_1018_01": read(0x26C),
            // The same command byte again is not a new command: nothing toggles and the
            // ReturnValue keeps the old answer...
            "repeat_without_toggle": {"toggled": false},
            "return_value_after_ignored_repeat": 0x26C,
            // ...with ToggleCmd (Cmd bit 7) it is: 1018h:02 product code.
            "repeat_with_toggle": read(66),
            "cmd_byte_of_repeat": 0x8E,
            "write_203b_01": written,
            "read_203b_01": read(1000),
            // -100000 = FFFE7960h needs both words of SetValue1 and of ReturnValue.
            "write_2400_01": written,
            "read_2400_01": read(-100_000),
            // A missing object: PdiStatusError with the abort code 06020000h.
            "read_2fff_00": {
                "toggled": true,
                "error": true,
                "return_value": 0x0602_0000,
                "return_value_u32": 0x0602_0000u32,
            },
            "read_after_error": read(0x26C),
        }),
        "{got}"
    );
}

#[test]
fn pymodbus_sees_the_function_codes_and_exceptions_of_the_spec() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let got = plc(&python, "access");
    // FC 3 and FC 4 return the same registers, with the PDI answer of the FC 6 command in
    // them: PDI-Status ToggleCmd, ReturnValue 26Ch, 6041h Switch on disabled (250h).
    let tx = json!([0x4000, 0, 0, 0x26C, 0x0250, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        got,
        json!({
            // Set values alone start nothing; FC 6 of 5999 = 010Eh (SetValue3 = subindex 1
            // in the high byte, Cmd 14 in the low byte) runs OD-Read 1018h:01.
            "toggled_by_set_values_alone": false,
            "fc6_exception": null,
            "fc6_toggled": true,
            "fc6_return_value": 0x26C,
            "fc3_tx": tx,
            "fc4_tx": tx,
            "fc3_rx": [0, 0, 0x1018, 0x010E],
            "fc4_rx": [0, 0, 0x1018, 0x010E],
            // Outside the map: illegal data address.
            "fc3_at_100": 2,
            "fc4_at_100": 2,
            "fc16_at_100": 2,
            "fc4_past_tx_image": 2,
            // Function codes a Nanotec drive lacks: illegal function.
            "fc22_mask_write": 1,
            "fc41_user_function": 1,
            "fc4_after_exceptions": true,
        }),
        "{got}"
    );
}

#[test]
fn pymodbus_second_client_is_closed_while_the_first_is_connected() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let got = plc(&python, "connections");
    assert_eq!(
        got,
        json!({
            "first_reads": true,
            "second_client": "closed",
            "first_reads_after_second": true,
            "new_client_after_first_left": true,
        }),
        "{got}"
    );
}

/// pymodbus as a register bank, preset with a TX side, logging every request.
struct RegisterBank {
    process: Process,
    port: u16,
}

impl RegisterBank {
    fn start(python: &Python, preset: &Json) -> RegisterBank {
        let mut command = Command::new(&python.path);
        command
            .arg(common::peer_script("pymodbus_server.py"))
            .arg(preset.to_string());
        let mut process = Process::spawn("pymodbus_server.py", &mut command);
        let first = process.expect_line("port", Duration::from_secs(20));
        let port = serde_json::from_str::<Json>(&first)
            .ok()
            .and_then(|j| j["port"].as_u64())
            .unwrap_or_else(|| panic!("no port in {first:?}; {}", process.report()))
            as u16;
        RegisterBank { process, port }
    }

    /// Every request logged so far, waiting `quiet` for stragglers.
    fn requests(&self, quiet: Duration) -> Vec<Json> {
        let mut out = vec![];
        while let Some(line) = self.process.line(quiet) {
            out.push(serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line:?}: {e}")));
        }
        out
    }
}

/// The TX side a drive would show: 4996.. PDI, 5000.. the factory process image. The
/// dummy byte (high byte of 5001) holds EEh to show it is not read as 6061h.
fn tx_preset() -> Json {
    json!({
        "4996": 0x4009, "4997": 0x8611, "4998": 0xFFFF, "4999": 0xFFFE,
        "5000": 0x0637, "5001": 0xEE01, "5002": 0x0001, "5003": 0x86A0,
        "5004": 0xFFFF, "5005": 0x0001, "5006": 0x0000,
    })
}

/// SetValue1 100000 (000186A0h), SetValue2 -2, SetValue3 -128, Cmd 20.
fn the_rx() -> RxImage {
    RxImage {
        values: SetValues {
            value1: 100_000,
            value2: -2,
            value3: -128,
        },
        cmd: 20,
    }
}

struct Seen {
    exchange: drivedeck::link::Exchange,
    read_back: Option<RxImage>,
    notices: Vec<String>,
    requests: Vec<Json>,
}

/// Connect our client to the register bank, make one exchange writing `the_rx()`, read
/// the RX registers back, and collect what pymodbus logged.
fn exchange_with_pymodbus(python: &Python, query: &str) -> Seen {
    let bank = RegisterBank::start(python, &tx_preset());
    let spec: LinkSpec = format!("modbus-tcp://127.0.0.1:{}{query}", bank.port)
        .parse()
        .expect("spec");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let (exchange, read_back, notices) = runtime.block_on(async {
        let mut link = ModbusLink::connect(&spec, DEFAULT_TIMEOUT)
            .await
            .unwrap_or_else(|e| panic!("connect to pymodbus: {e}"));
        let exchange = link.exchange(Some(&the_rx())).await.expect("exchange");
        let read_back = link.read_rx().await.expect("read back");
        let notices = link.take_notices();
        let _ = link.close().await;
        (exchange, read_back, notices)
    });
    let requests = bank.requests(Duration::from_millis(300));
    Seen {
        exchange,
        read_back,
        notices: notices.into_iter().map(|n| n.text).collect(),
        requests,
    }
}

fn writes(requests: &[Json]) -> Vec<&Json> {
    requests
        .iter()
        .filter(|r| r.get("write_address").is_some())
        .collect()
}

#[test]
fn our_client_writes_the_pdi_high_word_first_as_pymodbus_decodes_it() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let seen = exchange_with_pymodbus(&python, "");
    // Exactly one write: FC 23 with 5996.. = SetValue1 high word, low word, SetValue2,
    // SetValue3 (80h) in the high byte and Cmd 20 (14h) in the low byte; reading 4996 and
    // the 7 registers of the factory TX image behind it; unit 0 (NT-MBAP, protocol notes §1.6).
    assert_eq!(
        writes(&seen.requests),
        vec![&json!({
            "fc": 23, "unit": 0,
            "write_address": 5996, "values": [0x0001, 0x86A0, 0xFFFE, 0x8014],
            "read_address": 4996, "read_count": 11,
        })],
        "{:#?}",
        seen.requests
    );
    // What pymodbus stored reads back as the same image.
    assert_eq!(seen.read_back, Some(the_rx()));
    // The TX registers decode high word first, 6061h from the low byte of 5001.
    let tx = seen.exchange.tx;
    assert_eq!(
        (tx.status, tx.error_code, tx.return_value),
        (Status(0x4009), 0x8611, -2)
    );
    let s = seen.exchange.signals;
    assert_eq!(
        (s.statusword(), s.mode(), s.position(), s.digital_inputs()),
        (Some(0x0637), Some(1), Some(100_000.0), Some(0x0001_0000))
    );
    // pymodbus has no FC 43 (MEI 0Dh): asked once (for 3602h), refused with exception 01,
    // and the link falls back to the PDI for objects and says so.
    let fc43 = seen.requests.iter().filter(|r| r["fc"] == 43).count();
    assert_eq!(fc43, 1, "{:#?}", seen.requests);
    assert!(
        seen.notices
            .iter()
            .any(|n| n.contains("does not support FC 43")),
        "{:?}",
        seen.notices
    );
}

#[test]
fn our_client_with_words_low_puts_the_low_word_first_and_uses_the_unit() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let seen = exchange_with_pymodbus(&python, "?unit=5&words=low");
    assert_eq!(
        writes(&seen.requests),
        vec![&json!({
            "fc": 23, "unit": 5,
            "write_address": 5996, "values": [0x86A0, 0x0001, 0xFFFE, 0x8014],
            "read_address": 4996, "read_count": 11,
        })],
        "{:#?}",
        seen.requests
    );
    assert!(seen.requests.iter().all(|r| r["unit"] == 5));
    assert_eq!(seen.read_back, Some(the_rx()));
    // The same registers read low word first give other numbers: the setting matters.
    let tx = seen.exchange.tx;
    assert_eq!(tx.return_value, 0xFFFE_FFFFu32 as i32);
    let s = seen.exchange.signals;
    assert_eq!(
        (s.position(), s.digital_inputs()),
        (Some(f64::from(0x86A0_0001u32 as i32)), Some(0x0000_0001))
    );
}

#[test]
fn bench_runs_pymodbus_side_by_side_on_the_same_server() {
    let Some(python) = common::python(&[]) else {
        return;
    };
    let report = common::cli::json(&[
        "bench",
        "--serve-sim",
        "modbus",
        "--seconds",
        "0.3",
        "--python",
        python.path.to_str().expect("utf-8 path"),
    ]);
    let ours = &report["links"][0]["results"][0];
    assert_eq!(ours["what"], "PDI exchange (write + read)", "{report:#}");
    let peer = &report["peer"];
    assert!(
        peer["what"]
            .as_str()
            .is_some_and(|w| w.starts_with("pymodbus 3.") && w.ends_with("FC 23 (write + read)")),
        "{report:#}"
    );
    for figures in [ours, peer] {
        assert!(
            figures["count"].as_u64().is_some_and(|n| n > 10),
            "{report:#}"
        );
        let (min, median, p99) = (
            figures["min_ms"].as_f64().unwrap_or(f64::NAN),
            figures["median_ms"].as_f64().unwrap_or(f64::NAN),
            figures["p99_ms"].as_f64().unwrap_or(f64::NAN),
        );
        assert!(0.0 < min && min <= median && median <= p99, "{report:#}");
    }

    // Without pymodbus the comparison is skipped with the reason, and the rest stands.
    let report = common::cli::json(&[
        "bench",
        "--serve-sim",
        "modbus",
        "--seconds",
        "0.2",
        "--python",
        "/nonexistent/python",
    ]);
    assert!(report["peer"].is_null());
    assert!(
        report["peer_skipped"]
            .as_str()
            .is_some_and(|s| s.contains("/nonexistent/python")),
        "{report:#}"
    );
}
