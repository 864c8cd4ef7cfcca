//! The commissioning record in a real browser: Debian's Chromium, headless, opens a record
//! that `drivedeck commission` wrote for a run with failing steps, prints it to PDF, takes
//! a screenshot, and gives back the DOM it built and its network log. The page loaded no
//! resource (no request initiated by the page: a file:// page's requests carry the
//! initiator "null"; the browser's own background requests carry none) — and the same
//! check catches a copy of the page given an external stylesheet, so it can fail; the
//! verdict table is there and the failing steps are marked failed.
//!
//! Needs chromium (`.ci/run` installs it): skipped with a reason without it, and required
//! in CI. Named so that cargo runs it before `peers_status`, which counts it.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;
use std::process::Command;

use common::cli::run;

/// Chromium headless on `page` with `args`, a fresh profile, no background networking.
fn chrome(browser: &Path, profile: &Path, args: &[String], page: &Path) -> std::process::Output {
    let url = format!("file://{}", page.display());
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .output()
        .expect("chromium runs")
}

/// The URLs the page itself asked for, from a Chromium net log: requests whose initiator
/// is the page's (opaque) origin.
fn page_requests(netlog: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(netlog).expect("the net log");
    let log: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    log["events"]
        .as_array()
        .expect("events")
        .iter()
        .filter_map(|e| {
            let params = &e["params"];
            let initiator = params["initiator"].as_str()?;
            let from_page = initiator == "null" || initiator.starts_with("file:");
            from_page.then(|| params["url"].as_str().unwrap_or("?").to_owned())
        })
        .collect()
}

/// The DOM Chromium built of `page`, and what the page asked the network for.
fn open(browser: &Path, dir: &Path, page: &Path, name: &str) -> (String, Vec<String>) {
    let netlog = dir.join(format!("{name}-net.json"));
    let out = chrome(
        browser,
        &dir.join(format!("{name}-profile")),
        &[
            format!("--log-net-log={}", netlog.display()),
            "--dump-dom".into(),
        ],
        page,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        page_requests(&netlog),
    )
}

#[test]
fn chromium_prints_the_record_loads_nothing_and_shows_the_failed_steps() {
    let browser = match common::chromium() {
        Ok(browser) => browser,
        Err(why) => {
            common::skip_or_fail(&why);
            return;
        }
    };
    common::peers::record(common::peers::RAN, "");
    let dir = common::temp_dir("record-browser");
    let procedure = dir.path().join("short.toml");
    std::fs::write(
        &procedure,
        r#"[procedure]
name = "Browser check"
description = "Two steps fail: the operator says no, and a settling limit nobody meets."

[[step]]
kind = "identity"

[[step]]
kind = "question"
text = "Is the guard <closed> & locked?"
expect = "yes"

[[step]]
kind = "test-move"
from = 0
to = 1000
speed = 300
dwell_s = 0.3
[step.limits]
settling_s = 0.001

[[step]]
kind = "store"
"#,
    )
    .unwrap();
    let answers = dir.path().join("answers.txt");
    std::fs::write(&answers, "no\n").unwrap();
    let html = dir.path().join("record.html");
    let (code, out, err) = run(&[
        "--link",
        "sim",
        "commission",
        procedure.to_str().unwrap(),
        "--record",
        html.to_str().unwrap(),
        "--answers",
        answers.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{out}{err}");

    // Printed to PDF, and a screenshot.
    let pdf = dir.path().join("record.pdf");
    let printed = chrome(
        &browser,
        &dir.path().join("pdf-profile"),
        &[
            format!("--print-to-pdf={}", pdf.display()),
            "--no-pdf-header-footer".into(),
        ],
        &html,
    );
    assert!(
        printed.status.success(),
        "{}",
        String::from_utf8_lossy(&printed.stderr)
    );
    let bytes = std::fs::read(&pdf).expect("the PDF");
    assert!(bytes.starts_with(b"%PDF-"), "a PDF");
    assert!(bytes.len() > 5_000, "{} bytes", bytes.len());
    let png = dir.path().join("record.png");
    let shot = chrome(
        &browser,
        &dir.path().join("png-profile"),
        &[
            format!("--screenshot={}", png.display()),
            "--window-size=1200,1600".into(),
        ],
        &html,
    );
    assert!(
        shot.status.success(),
        "{}",
        String::from_utf8_lossy(&shot.stderr)
    );
    let bytes = std::fs::read(&png).expect("the screenshot");
    assert!(bytes.starts_with(b"\x89PNG"), "a PNG");
    assert!(bytes.len() > 20_000, "{} bytes", bytes.len());

    // The DOM the browser built: the verdict table, the failed steps marked, the text
    // from the file escaped (the question's <closed> is text, not a tag).
    let (dom, requests) = open(&browser, dir.path(), &html, "record");
    assert!(requests.is_empty(), "the page loaded {requests:?}");
    assert!(
        dom.contains("<table class=\"verdicts\">"),
        "the verdict table"
    );
    assert!(dom.contains("Overall: failed"));
    for step in [2, 3] {
        assert!(
            dom.contains(&format!("data-step=\"{step}\" data-verdict=\"failed\"")),
            "step {step} failed in the page"
        );
    }
    assert!(dom.contains("data-step=\"4\" data-verdict=\"passed\""));
    assert!(dom.contains("Is the guard &lt;closed&gt; &amp; locked?"));
    assert!(!dom.contains("<closed>"));
    assert!(dom.contains("<svg"), "the test move's plot inline");

    // The check can fail: a copy with an external stylesheet is caught.
    let page = std::fs::read_to_string(&html).unwrap();
    let tainted = dir.path().join("tainted.html");
    std::fs::write(
        &tainted,
        page.replacen(
            "<title>",
            "<link rel=\"stylesheet\" href=\"http://example.invalid/x.css\"><title>",
            1,
        ),
    )
    .unwrap();
    let (_, requests) = open(&browser, dir.path(), &tainted, "tainted");
    assert!(
        requests
            .iter()
            .any(|u| u.starts_with("http://example.invalid/")),
        "the external stylesheet was not seen: {requests:?}"
    );
}
