//! `drivedeck od list`: the built-in catalog and EDS files offline, and values read from
//! the simulated drive with `--link`.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::cli::{fails, json, ok};

/// The rows of a text listing (without the header), by address.
fn table(stdout: &str) -> Vec<&str> {
    let mut lines = stdout.lines();
    let header = lines.next().unwrap_or_default();
    assert!(header.starts_with("INDEX:SUB  TYPE"), "{stdout}");
    lines.collect()
}

/// The text columns of a row, split at runs of two or more spaces.
fn columns(row: &str) -> Vec<&str> {
    row.split("  ")
        .map(str::trim)
        .filter(|c| !c.is_empty())
        .collect()
}

const SIM_EDS: &str = "assets/od/drivedeck-sim.eds";
const E35: &str = "tests/data/eds/e35.eds";
const SAMPLE: &str = "tests/data/eds/sample.eds";
const LOCAL_NODE: &str = "tests/peers/canopen_local_node.eds";

#[test]
fn the_built_in_catalog_filtered_by_index_and_name() {
    let (stdout, stderr) = ok(&["od", "list", "--filter", "1018"]);
    let rows = table(&stdout);
    assert_eq!(rows.len(), 5, "{stdout}");
    assert_eq!(
        columns(rows[1]),
        [
            "1018h:01h",
            "U32",
            "ro",
            "Identity Object / Vendor-ID",
            "620"
        ]
    );
    assert_eq!(stderr, "");
    // One entry by INDEX:SUB, in any written form.
    for filter in ["1018:01", "1018h:1h", "0x1018.1"] {
        let (stdout, _) = ok(&["od", "list", "--filter", filter]);
        assert_eq!(table(&stdout).len(), 1, "{filter}: {stdout}");
    }
    // By name, any case: units and limits are shown.
    let (stdout, _) = ok(&["od", "list", "--filter", "QUICK STOP OPTION"]);
    assert_eq!(
        columns(table(&stdout)[0]),
        [
            "605Ah:00h",
            "I16",
            "rw",
            "Quick Stop Option Code",
            "2",
            "0..6"
        ]
    );
    let (stdout, _) = ok(&["od", "list", "--filter", "profile velocity"]);
    assert!(table(&stdout)[0].ends_with("rpm"), "{stdout}");
    // Nothing matches: an empty list and a note.
    let (stdout, stderr) = ok(&["od", "list", "--filter", "no such object"]);
    assert_eq!(stdout, "");
    assert!(
        stderr.contains("no object matches 'no such object'"),
        "{stderr}"
    );
}

#[test]
fn the_shipped_eds_lists_the_catalog() {
    let (stdout, stderr) = ok(&["od", "list", "--eds", SIM_EDS, "--node", "1"]);
    let (builtin, _) = ok(&["od", "list"]);
    // Same objects, names, types, access, defaults, limits and units as the catalog.
    assert_eq!(stdout, builtin);
    assert_eq!(stderr, "");
    // Node 5: the COB-IDs follow; without a node id they stay formulas.
    let (stdout, _) = ok(&[
        "od", "list", "--eds", SIM_EDS, "--node", "5", "--filter", "1014",
    ]);
    assert_eq!(columns(table(&stdout)[0])[4], "133");
    let (stdout, stderr) = ok(&["od", "list", "--eds", SIM_EDS, "--filter", "1800:01"]);
    assert_eq!(columns(table(&stdout)[0])[4], "$NODEID+0x80000180");
    assert!(stderr.contains("give --node N"), "{stderr}");
}

#[test]
fn a_real_eds_with_its_warnings() {
    let (stdout, stderr) = ok(&["od", "list", "--eds", E35, "--filter", "6060"]);
    let rows = table(&stdout);
    assert_eq!(rows.len(), 1, "{stdout}");
    assert_eq!(
        columns(rows[0]),
        [
            "6060h:00h",
            "I8",
            "rww",
            "Modes of operation",
            "1",
            "-2..10"
        ]
    );
    // The file's problems, with its name and the line.
    assert!(
        stderr.contains("warning: e35.eds line 116: [ManufacturerObjects] SupportedObjects=105"),
        "{stderr}"
    );
    assert_eq!(stderr.matches("warning: ").count(), 3, "{stderr}");
    // By name, case-insensitive; the catalog adds the unit of a CiA 402 object.
    let (stdout, _) = ok(&["od", "list", "--eds", E35, "--filter", "TARGET position"]);
    let rows = table(&stdout);
    assert_eq!(rows.len(), 2, "{stdout}");
    assert!(
        rows[0].starts_with("2C03h:02h  U8      wo     Learned position / Learn target position")
    );
    assert!(
        rows[1].starts_with("607Ah:00h  I32     rww    Target position")
            && rows[1].ends_with("0.1°"),
        "{stdout}"
    );
    // sample.eds: a DCF, whose own node id resolves its formulas.
    let (stdout, _) = ok(&["od", "list", "--eds", SAMPLE, "--filter", "1400:01"]);
    assert_eq!(columns(table(&stdout)[0])[4], "528");
}

#[test]
fn values_read_from_the_simulated_drive() {
    let (stdout, stderr) = ok(&["--link", "sim", "od", "list", "--filter", "1018"]);
    let rows = table(&stdout);
    assert_eq!(rows.len(), 5, "{stdout}{stderr}");
    assert!(rows[1].ends_with("620 (0000026Ch)"), "{stdout}");
    let (stdout, _) = ok(&["--link", "sim", "od", "list", "--filter", "1008"]);
    assert!(stdout.contains("\"drivedeck simulated drive\""), "{stdout}");
    let (stdout, _) = ok(&["--link", "sim", "od", "list", "--filter", "nominal current"]);
    assert!(
        table(&stdout)[0].ends_with("1800 mA (00000708h)"),
        "{stdout}"
    );
    // The whole catalog reads without a single error.
    let (stdout, _) = ok(&["--link", "sim", "od", "list"]);
    let all = table(&stdout);
    assert!(all.len() > 400);
    assert!(all.iter().all(|r| !r.contains("error:")), "{stdout}");
}

#[test]
fn objects_the_drive_lacks_show_their_error_and_the_list_goes_on() {
    // e35.eds describes another maker's drive: most of its manufacturer objects are not
    // in the simulated drive. Each says why, on its own line; the exit code is 0.
    let (stdout, _) = ok(&[
        "--link", "sim", "od", "list", "--eds", E35, "--filter", "2FF",
    ]);
    let rows = table(&stdout);
    assert!(rows.len() > 10);
    let missing = rows
        .iter()
        .filter(|r| {
            r.ends_with("error: abort 06020000h (Object does not exist in the object dictionary)")
        })
        .count();
    assert_eq!(missing, rows.len() - 1, "{stdout}");
    assert!(
        rows.iter()
            .any(|r| r.starts_with("2FF1h:00h")
                && r.ends_with("error: not read: a write-only object")),
        "{stdout}"
    );
    // Objects it has are read in the EDS's types.
    let (stdout, _) = ok(&[
        "--link", "sim", "od", "list", "--eds", E35, "--filter", "1018:01",
    ]);
    assert!(table(&stdout)[0].ends_with("620 (0000026Ch)"), "{stdout}");
}

#[test]
fn a_canopen_links_node_id_resolves_the_formulas() {
    let (stdout, _) = ok(&[
        "--link",
        "canopen+sim://?node=5",
        "od",
        "list",
        "--eds",
        SIM_EDS,
        "--filter",
        "1014",
    ]);
    let row = columns(table(&stdout)[0]);
    assert_eq!(row[4], "133");
    assert_eq!(row[5], "133 (00000085h)");
}

#[test]
fn json_lists() {
    let v = json(&["od", "list", "--eds", E35, "--filter", "6060"]);
    assert_eq!(v["source"], E35);
    assert_eq!(v["device"]["vendor_number"], 101);
    assert_eq!(v["warnings"].as_array().map(Vec::len), Some(3));
    let object = &v["objects"][0];
    assert_eq!(object["address"], "6060h:00h");
    assert_eq!(object["index"], 0x6060);
    assert_eq!(object["type"], "I8");
    assert_eq!(object["access"], "rww");
    assert_eq!(
        object["default"],
        serde_json::json!({"kind": "int", "value": 1})
    );
    assert_eq!(object["min"]["value"], -2);
    assert_eq!(object["value"], serde_json::Value::Null);

    let v = json(&["--link", "sim", "od", "list", "--filter", "1018:01"]);
    assert_eq!(v["link"], "sim");
    assert_eq!(v["source"], "built-in catalog");
    let object = &v["objects"][0];
    assert_eq!(
        object["value"],
        serde_json::json!({"kind": "uint", "value": 620})
    );
    assert_eq!(object["hex"], "0000026Ch");
    assert_eq!(object["error"], serde_json::Value::Null);

    let v = json(&["od", "list", "--eds", LOCAL_NODE, "--filter", "1014"]);
    assert_eq!(v["objects"][0]["default"], serde_json::Value::Null);
    assert_eq!(v["objects"][0]["default_formula"], "$NODEID+0x80");
    assert_eq!(v["node_id"], serde_json::Value::Null);
}

#[test]
fn unusable_files_are_refused() {
    let stderr = fails(&["od", "list", "--eds", "tests/data/eds/no-such.eds"], 2);
    assert!(
        stderr.contains("cannot read tests/data/eds/no-such.eds"),
        "{stderr}"
    );
    let stderr = fails(&["od", "list", "--eds", "Cargo.toml"], 2);
    assert!(
        stderr.contains("Cargo.toml: no object could be imported"),
        "{stderr}"
    );
    fails(&["od", "list", "--node", "200"], 2);
}
