//! `drivedeck io` and `drivedeck output`: the inputs and outputs by name over Modbus TCP
//! and EtherNet/IP; a
//! forced output shows in 60FEh:01 (and its mask bit in :02) while the command holds it,
//! and is released when it ends — after --hold, and on Ctrl-C.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::Duration;

use common::Sim;
use common::cli::{json, run, start};

fn read(link: &str, object: &str) -> u64 {
    let value = json(&["--link", link, "read", object]);
    value["hex"]
        .as_str()
        .and_then(|h| u64::from_str_radix(h.trim_end_matches('h'), 16).ok())
        .unwrap_or_else(|| panic!("{object}: {value:#}"))
}

/// A served drive a second client may talk to while `output` holds the first connection.
fn served() -> (Sim, String) {
    let (sim, addr) = Sim::tcp(&["--max-clients", "2"]);
    (sim, format!("modbus-tcp://{addr}"))
}

#[test]
fn the_inputs_and_outputs_are_listed_by_name() {
    let (_sim, link) = served();
    let io = json(&["--link", &link, "io"]);
    assert_eq!(io["inputs"][0]["name"], "negative limit switch", "{io:#}");
    assert_eq!(io["inputs"][4]["name"], "input 1", "{io:#}");
    // The simulated machine: a normally closed limit switch on input 1, so the input is
    // inverted and its terminal high while the switch is not pressed.
    assert_eq!(
        io["inputs"][4]["special_function"], "negative limit switch",
        "{io:#}"
    );
    assert_eq!(io["inputs"][4]["inverted"], true, "{io:#}");
    assert_eq!(io["inputs"][4]["terminal_high"], true, "{io:#}");
    assert_eq!(io["inputs"][4]["on"], false, "{io:#}");
    assert_eq!(
        io["inputs"][4]["label"], "input 1 (negative limit switch, inverted, terminal high)",
        "{io:#}"
    );
    assert_eq!(io["inputs"][7]["label"], "input 4", "{io:#}");
    assert_eq!(io["outputs"][0]["number"], 1, "{io:#}");
    assert_eq!(io["outputs"][0]["forced"], false, "{io:#}");
    assert!(io["analog_input_3220"].as_i64().is_some(), "{io:#}");
}

#[test]
fn a_forced_output_shows_while_held_and_is_released_after_hold() {
    let (_sim, link) = served();
    let mut held = start(&["--link", &link, "output", "2", "on", "--hold", "3"]);
    held.expect_line("the output forced", Duration::from_secs(10));
    let bit = 1 << 17;
    assert_eq!(read(&link, "60FE:01") & bit, bit, "on");
    assert_eq!(read(&link, "60FE:02") & bit, bit, "forced");
    // The simulated machine loops output 2 back to input 6.
    let io = json(&["--link", &link, "io"]);
    assert_eq!(io["inputs"][9]["name"], "input 6", "{io:#}");
    assert_eq!(io["inputs"][9]["on"], true, "{io:#}");
    assert_eq!(io["outputs"][1]["forced"], true, "{io:#}");
    let status = held
        .wait(Duration::from_secs(10))
        .expect("ends after --hold");
    assert!(status.success(), "{}", held.report());
    assert_eq!(read(&link, "60FE:01"), 0, "released");
    assert_eq!(read(&link, "60FE:02"), 0, "released");
}

#[test]
fn ctrl_c_releases_a_forced_output() {
    let (_sim, link) = served();
    let mut held = start(&["--link", &link, "output", "3", "on"]);
    held.expect_line("the output forced", Duration::from_secs(10));
    assert_eq!(read(&link, "60FE:02") & (1 << 18), 1 << 18);
    held.signal("INT");
    let status = held.wait(Duration::from_secs(10)).expect("ends on Ctrl-C");
    assert_eq!(status.code(), Some(130), "{}", held.report());
    assert!(
        held.report().contains("output 3 released"),
        "{}",
        held.report()
    );
    assert_eq!(read(&link, "60FE:01"), 0);
    assert_eq!(read(&link, "60FE:02"), 0);
}

#[test]
fn inputs_and_a_forced_output_over_ethernet_ip() {
    let (_sim, addr) = Sim::enip(&[]);
    let link = format!("enip://{addr}");
    let io = json(&["--link", &link, "io"]);
    assert_eq!(
        io["inputs"][4]["label"], "input 1 (negative limit switch, inverted, terminal high)",
        "{io:#}"
    );
    let held = run(&["--link", &link, "output", "1", "on", "--hold", "0.5"]);
    assert_eq!(held.0, 0, "{}{}", held.1, held.2);
    assert!(held.1.contains("output 1 released"), "{}{}", held.1, held.2);
    assert_eq!(read(&link, "60FE:01"), 0, "released");
    assert_eq!(read(&link, "60FE:02"), 0, "released");
}
