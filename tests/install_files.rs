//! `drivedeck install-files DIR`: the man pages and shell completions a package installs,
//! generated from the command line's definitions — a page for the tool and one for every
//! command `--help` lists, completions for bash, zsh and fish that know every command —
//! and the user guide as HTML.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::cli::run;

/// The commands `drivedeck --help` lists.
fn commands() -> Vec<String> {
    let (code, out, err) = run(&["--help"]);
    assert_eq!(code, 0, "{err}");
    out.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .filter(|c| c != "help")
        .collect()
}

#[test]
fn man_pages_and_completions_cover_every_command() {
    let dir = common::temp_dir("install-files");
    let (code, out, err) = run(&["install-files", dir.path().to_str().unwrap()]);
    assert_eq!(code, 0, "{out}{err}");
    let commands = commands();
    assert!(commands.len() > 30, "{commands:?}");
    assert!(commands.iter().any(|c| c == "commission"));
    assert!(
        !commands.iter().any(|c| c == "install-files"),
        "hidden from --help"
    );
    let main = std::fs::read_to_string(dir.path().join("drivedeck.1")).unwrap();
    assert!(
        main.contains(".TH drivedeck 1"),
        "{}",
        &main[..200.min(main.len())]
    );
    for command in &commands {
        let page = dir.path().join(format!("drivedeck-{command}.1"));
        let text =
            std::fs::read_to_string(&page).unwrap_or_else(|e| panic!("{}: {e}", page.display()));
        // roff writes a hyphen as \-.
        let roff = command.replace('-', "\\-");
        assert!(
            text.contains(&format!(".TH drivedeck\\-{roff} 1"))
                || text.contains(&format!(".TH drivedeck-{command} 1")),
            "{command}: {}",
            &text[..200.min(text.len())]
        );
        assert!(main.contains(&roff), "{command} in drivedeck.1");
    }
    for (file, shell) in [
        ("drivedeck.bash", "bash"),
        ("_drivedeck", "zsh"),
        ("drivedeck.fish", "fish"),
    ] {
        let text = std::fs::read_to_string(dir.path().join(file))
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        for command in &commands {
            assert!(
                text.contains(command.as_str()),
                "{shell} completion lacks {command}"
            );
        }
    }
    // The guide as HTML, one page per Markdown page, its pictures from img/ beside it
    // (where the package installs docs/guide/img).
    for page in drivedeck::guide::PAGES {
        let html = dir
            .path()
            .join("guide")
            .join(drivedeck::guide::html_name(page.file));
        let text =
            std::fs::read_to_string(&html).unwrap_or_else(|e| panic!("{}: {e}", html.display()));
        assert!(text.starts_with("<!DOCTYPE html>"), "{}", html.display());
    }
    let index = std::fs::read_to_string(dir.path().join("guide/index.html")).unwrap();
    assert!(
        index.contains("src=\"img/window.png\"") || !index.contains("<img"),
        "pictures from img/"
    );
    let start = std::fs::read_to_string(dir.path().join("guide/01-getting-started.html")).unwrap();
    assert!(
        start.contains("src=\"img/window.png\""),
        "pictures from img/"
    );
}

#[test]
fn the_desktop_entry_validates_and_names_the_windows_app_id_and_icon() {
    let entry = std::fs::read_to_string("assets/drivedeck.desktop").unwrap();
    assert!(entry.contains("\nIcon=drivedeck\n"));
    assert!(entry.contains(&format!(
        "\nStartupWMClass={}\n",
        drivedeck::ui::run::APP_ID
    )));
    for size in [16, 32, 48, 64, 128, 256, 512] {
        let png = std::fs::read(format!("assets/icons/drivedeck-{size}.png")).unwrap();
        assert!(png.starts_with(b"\x89PNG"), "{size}");
    }
    let Ok(out) = std::process::Command::new("desktop-file-validate")
        .arg("assets/drivedeck.desktop")
        .output()
    else {
        common::skip_or_fail(
            "desktop-file-validate is not installed (.ci/run installs desktop-file-utils)",
        );
        return;
    };
    common::peers::record(common::peers::RAN, "");
    assert!(
        out.status.success() && out.stdout.is_empty(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
