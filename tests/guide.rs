//! The user guide (`docs/guide/`) keeps up with the tool: every command the command line
//! knows (read from clap's own definition, hidden ones left out) is in the guide's
//! command-line page, every sub-command somewhere in the guide, every panel of the window
//! in the tour; every page stays short enough to read (≤ 300 lines) and the README fits
//! on two screens; every link and picture in them points at a file that exists.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use clap::CommandFactory;
use drivedeck::ui::drive::Drive;
use drivedeck::ui::settings::DriveSettings;
use drivedeck::ui::view::{BOTTOM, CENTRAL};

const GUIDE: &str = "docs/guide";
const COMMAND_LINE_PAGE: &str = "10-command-line.md";
const TOUR_PAGE: &str = "03-window.md";
/// A page longer than this is two pages.
const PAGE_LINES: usize = 300;
/// The README is a welcome, not the manual: two screens.
const README_LINES: usize = 160;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The guide's pages, by file name, with their text.
fn pages() -> Vec<(String, String)> {
    let mut pages: Vec<(String, String)> = std::fs::read_dir(root().join(GUIDE))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    pages.sort();
    assert!(pages.len() >= 11, "the guide has {} pages", pages.len());
    pages
}

fn page(name: &str) -> String {
    std::fs::read_to_string(root().join(GUIDE).join(name)).unwrap()
}

/// Whether `text` holds `phrase` as whole words: not inside a longer name
/// (`drivedeck od` is not found in `drivedeck odd`, nor `test-move` in `test-moves`).
fn mentions(text: &str, phrase: &str) -> bool {
    let is_name = |c: char| c.is_alphanumeric() || c == '-' || c == '_';
    text.match_indices(phrase).any(|(at, _)| {
        let before = text[..at].chars().next_back();
        let after = text[at + phrase.len()..].chars().next();
        !before.is_some_and(is_name) && !after.is_some_and(is_name)
    })
}

/// Every command clap knows and shows, as its path: `["status"]`, `["od", "dump"]`, …
fn commands() -> Vec<Vec<String>> {
    fn walk(command: &clap::Command, path: &[String], out: &mut Vec<Vec<String>>) {
        for sub in command.get_subcommands() {
            if sub.is_hide_set() || sub.get_name() == "help" {
                continue;
            }
            let mut path = path.to_vec();
            path.push(sub.get_name().to_owned());
            out.push(path.clone());
            walk(sub, &path, out);
        }
    }
    let mut out = vec![];
    walk(&drivedeck::cli::Cli::command(), &[], &mut out);
    out
}

#[test]
fn every_command_is_in_the_guide() {
    let commands = commands();
    assert!(commands.len() > 35, "{commands:?}");
    assert!(
        commands.iter().any(|c| c == &["od", "dump"]),
        "the walk reaches sub-commands: {commands:?}"
    );
    let command_line = page(COMMAND_LINE_PAGE);
    let guide: String = pages().into_iter().map(|(_, text)| text).collect();
    let mut missing = vec![];
    for path in &commands {
        let found = match path.as_slice() {
            // A command: on the command-line page, as the user types it.
            [name] => mentions(&command_line, &format!("drivedeck {name}")),
            // A sub-command: anywhere in the guide, after its parent (`od dump`).
            _ => mentions(&guide, &path.join(" ")),
        };
        if !found {
            missing.push(path.join(" "));
        }
    }
    assert!(
        missing.is_empty(),
        "commands the guide does not teach (a command goes into {GUIDE}/{COMMAND_LINE_PAGE} \
         as `drivedeck NAME …`, a sub-command anywhere as `PARENT NAME`): {missing:?}"
    );
}

#[test]
fn every_panel_of_the_window_is_in_the_tour() {
    let tour = page(TOUR_PAGE);
    let drive = Drive::new("X axis".into(), 0, DriveSettings::default(), 10, &[]);
    let mut missing = vec![];
    let titles = CENTRAL
        .iter()
        .chain(BOTTOM)
        .map(|panel| (panel.title)(&drive))
        // The panels beside the middle ones, which are not tabs of CENTRAL.
        .chain(["Watch", "Commands", "Drives", "Log"].map(String::from));
    for title in titles {
        if !mentions(&tour, &title) {
            missing.push(title);
        }
    }
    assert!(
        missing.is_empty(),
        "panels of the window {GUIDE}/{TOUR_PAGE} does not show: {missing:?}"
    );
}

#[test]
fn pages_are_short_and_the_readme_fits_on_two_screens() {
    let mut long = vec![];
    for (name, text) in pages() {
        let lines = text.lines().count();
        if lines > PAGE_LINES {
            long.push(format!("{name}: {lines} lines"));
        }
    }
    assert!(
        long.is_empty(),
        "guide pages over {PAGE_LINES} lines: {long:?}"
    );
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(
        lines <= README_LINES,
        "README.md has {lines} lines; the rest belongs in the guide"
    );
}

/// The relative targets of the Markdown links and pictures in `text`: `[..](target)`.
fn link_targets(text: &str) -> Vec<String> {
    let mut targets = vec![];
    let mut in_code = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code {
            continue;
        }
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            rest = &rest[at + 2..];
            let Some(end) = rest.find(')') else { break };
            let target = rest[..end].split_whitespace().next().unwrap_or("");
            let target = target.split('#').next().unwrap_or("");
            if !target.is_empty() && !target.contains("://") && !target.starts_with("mailto:") {
                targets.push(target.to_owned());
            }
            rest = &rest[end..];
        }
    }
    targets
}

#[test]
fn every_link_and_picture_points_at_a_file() {
    assert_eq!(
        link_targets("see [a](b.md#x) and ![p](img/p.png \"t\") or [w](https://x.org)"),
        ["b.md", "img/p.png"]
    );
    let mut documents: Vec<(PathBuf, String)> = pages()
        .into_iter()
        .map(|(name, text)| (Path::new(GUIDE).join(name), text))
        .collect();
    documents.push((
        PathBuf::from("README.md"),
        std::fs::read_to_string(root().join("README.md")).unwrap(),
    ));
    let mut broken = vec![];
    let mut pictures = 0;
    for (path, text) in &documents {
        let dir = root().join(path.parent().unwrap());
        for target in link_targets(text) {
            pictures += usize::from(target.ends_with(".png"));
            if !dir.join(&target).exists() {
                broken.push(format!("{}: {target}", path.display()));
            }
        }
    }
    assert!(broken.is_empty(), "links to nothing: {broken:?}");
    assert!(
        pictures >= 10,
        "the guide shows the window: {pictures} pictures"
    );
}

#[test]
fn every_page_is_built_into_the_binary() {
    let built: Vec<&str> = drivedeck::guide::PAGES.iter().map(|p| p.file).collect();
    for (name, text) in pages() {
        let page = drivedeck::guide::PAGES
            .iter()
            .find(|p| p.file == name)
            .unwrap_or_else(|| panic!("{name} is not in guide::PAGES ({built:?})"));
        assert_eq!(
            page.markdown, text,
            "{name}: the binary's copy is the file's"
        );
    }
}
