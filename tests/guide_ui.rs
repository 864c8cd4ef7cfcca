//! The guide from the window: the "?" beside the name and F1 open the guide's index in
//! the browser — the package's pages where installed, else the pages built into the
//! binary, written into the cache folder with the links between them kept.
//!
//! The browser is a script here (`DRIVEDECK_OPENER`, the program the window opens pages
//! and folders with), which notes what it was asked to open.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::os::unix::fs::PermissionsExt;
use std::time::Duration;

use drivedeck::ui::Settings;
use eframe::egui;
use egui_kittest::kittest::Queryable;
use window::{harness_with, step_until};

#[test]
fn the_question_mark_and_f1_open_the_guide_in_the_browser() {
    let dir = common::temp_dir("guide-ui");
    let opened = dir.path().join("opened.txt");
    let script = dir.path().join("browser.sh");
    std::fs::write(
        &script,
        format!("#!/bin/sh\necho \"$1\" >> '{}'\n", opened.display()),
    )
    .unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    // The only test of this binary: nothing else reads the environment meanwhile.
    unsafe {
        std::env::set_var("DRIVEDECK_OPENER", &script);
        std::env::set_var("XDG_CACHE_HOME", dir.path().join("cache"));
    }
    let mut harness = harness_with(Settings::default(), false, egui::vec2(1366.0, 768.0));
    harness.run();
    harness.get_by_label("?").click();
    harness.run();
    let read = || std::fs::read_to_string(&opened).unwrap_or_default();
    step_until(
        &mut harness,
        "the browser asked",
        Duration::from_secs(5),
        |_| read().lines().count() == 1,
    );
    let index = read().trim().to_owned();
    assert!(
        index == "/usr/share/doc/drivedeck/guide/index.html"
            || index.starts_with(
                &dir.path()
                    .join("cache/drivedeck/guide-")
                    .display()
                    .to_string()
            ),
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
        read().lines().count() == 2
    });
}
