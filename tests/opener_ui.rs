//! What the window opens in the browser: the guide (the "?" beside the name and F1: the
//! package's pages where installed, else the pages built into the binary, written into
//! the cache folder with the links between them kept) and a procedure's record (Open
//! record, once the run wrote it).
//!
//! The browser is a script here (`DRIVEDECK_OPENER`, the program the window opens pages
//! and folders with), which notes what it was asked to open.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

use drivedeck::ui::Settings;
use eframe::egui;
use egui_kittest::kittest::Queryable;
use window::{harness_with, step_until};

/// The stand-in browser, set for the whole binary before any window starts: a script
/// that appends what it is asked to open to the file returned.
fn browser() -> &'static Path {
    static OPENED: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &OPENED
        .get_or_init(|| {
            let dir = common::temp_dir("opener-ui");
            let opened = dir.path().join("opened.txt");
            let script = dir.path().join("browser.sh");
            std::fs::write(
                &script,
                format!("#!/bin/sh\necho \"$1\" >> '{}'\n", opened.display()),
            )
            .unwrap();
            std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
            // Before any window of this binary reads the environment (each test calls
            // this first; OnceLock makes the others wait).
            unsafe {
                std::env::set_var("DRIVEDECK_OPENER", &script);
                std::env::set_var("XDG_CACHE_HOME", dir.path().join("cache"));
            }
            (dir, opened)
        })
        .1
}

/// The lines the stand-in browser noted so far.
fn opened() -> Vec<String> {
    std::fs::read_to_string(browser())
        .unwrap_or_default()
        .lines()
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_question_mark_and_f1_open_the_guide_in_the_browser() {
    let cache = browser().parent().unwrap().join("cache");
    let mut harness = harness_with(Settings::default(), false, egui::vec2(1366.0, 768.0));
    harness.run();
    harness.get_by_label("?").click();
    harness.run();
    let guides = || {
        opened()
            .into_iter()
            .filter(|l| l.ends_with("index.html"))
            .collect::<Vec<_>>()
    };
    step_until(
        &mut harness,
        "the browser asked",
        Duration::from_secs(5),
        |_| guides().len() == 1,
    );
    let index = guides()[0].clone();
    assert!(
        index == "/usr/share/doc/drivedeck/guide/index.html"
            || index.starts_with(&cache.join("drivedeck/guide-").display().to_string()),
        "{index}"
    );
    let page = std::fs::read_to_string(&index).expect("the index is there");
    assert!(page.contains("The drivedeck guide"), "{page}");
    assert!(
        page.contains("href=\"03-window.html\""),
        "links kept as pages"
    );
    let folder = std::path::Path::new(&index).parent().unwrap();
    assert!(folder.join("11-troubleshooting.html").is_file());
    let log = &harness.state().shown().log;
    assert!(
        log.iter()
            .any(|e| e.what == format!("the guide: {index} opened in the browser")),
        "the log says so"
    );

    // F1, whatever has the keyboard.
    harness.key_press(egui::Key::F1);
    harness.run();
    step_until(&mut harness, "F1", Duration::from_secs(5), |_| {
        guides().len() == 2
    });
}

#[test]
fn open_record_shows_the_record_a_run_wrote() {
    browser();
    let dir = common::temp_dir("opener-record");
    let procedure = dir.path().join("short.toml");
    std::fs::write(
        &procedure,
        "[procedure]\nname = \"Short\"\n\n[[step]]\nkind = \"question\"\ntext = \"Guard closed?\"\nexpect = \"yes\"\n",
    )
    .unwrap();
    let record = dir.path().join("record.html");
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    window::connected(&mut harness);
    window::load_procedure(&mut harness, &procedure, &record);
    assert!(
        harness.query_by_label("Open record").is_none(),
        "no record yet"
    );
    harness.get_by_label_contains("Run on ").click();
    harness.step();
    step_until(&mut harness, "the question", Duration::from_secs(10), |h| {
        h.query_by_label("Yes").is_some()
    });
    harness.get_by_label("Yes").click();
    harness.step();
    step_until(&mut harness, "the record", Duration::from_secs(10), |h| {
        h.query_by_label("Open record").is_some()
    });
    assert!(record.is_file());
    harness.get_by_label("Open record").click();
    harness.run();
    let shown = record.display().to_string();
    step_until(
        &mut harness,
        "the browser asked",
        Duration::from_secs(5),
        |_| opened().contains(&shown),
    );
}
