//! The repository stands alone: no source, test or document cites a file that lives outside
//! it. What the code relies on about the buses is in `docs/protocol-notes.md`, with the
//! public source of each fact; comments cite that ("protocol notes §2.4") or the vendor's
//! document by its own section ("PDI spec §3.2").
//!
//! Refused: the word `FACTS` (a research file kept outside the repository), identifiers
//! such as `facts_1_2` that name its sections, and paths into the directory beside the
//! repository (`../shared`, `/work/shared`).

use std::fs;
use std::path::{Path, PathBuf};

/// Where the rule applies, relative to the crate root.
const SCOPE: &[&str] = &[
    "src",
    "tests",
    "benches",
    "docs",
    "README.md",
    "BENCHMARKS.md",
];

/// This file names what it refuses, so it is the one file left out.
const THIS_FILE: &str = "tests/repository_stands_alone.rs";

/// Paths that leave the repository.
const OUTSIDE_PATHS: &[&str] = &["../shared", "/work/shared"];

/// Every way `line` points outside the repository, as short descriptions.
fn outside_references(line: &str) -> Vec<String> {
    let mut found = vec![];
    for (at, _) in line.match_indices("FACTS") {
        let before = line[..at].chars().next_back();
        let after = line[at + "FACTS".len()..].chars().next();
        let is_word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
        if !is_word(before) && !is_word(after) {
            found.push("cites FACTS".to_string());
        }
    }
    let lower = line.to_ascii_lowercase();
    for (at, _) in lower.match_indices("facts_") {
        let rest = &lower[at + "facts_".len()..];
        if rest.starts_with(|c: char| c.is_ascii_digit()) {
            found.push(format!("names a FACTS section: {}", &line[at..]));
        }
    }
    for path in OUTSIDE_PATHS {
        if line.contains(path) {
            found.push(format!("points to {path}"));
        }
    }
    found
}

/// The text files under `path`, skipping build output, caches and hidden directories.
fn text_files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_file() {
        out.push(path.to_path_buf());
        return;
    }
    let Ok(entries) = fs::read_dir(path) else {
        return;
    };
    for entry in entries.flatten() {
        let child = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if child.is_dir() && (name.starts_with('.') || name == "target" || name == "__pycache__") {
            continue;
        }
        text_files(&child, out);
    }
}

#[test]
fn nothing_in_the_repository_cites_a_file_outside_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![];
    for place in SCOPE {
        text_files(&root.join(place), &mut files);
    }
    files.sort();
    assert!(
        files.iter().any(|f| f.ends_with("src/lib.rs")),
        "the walk found no sources under {}",
        root.display()
    );
    assert!(
        files.iter().any(|f| f.ends_with("docs/protocol-notes.md")),
        "docs/protocol-notes.md is missing: the facts the code relies on belong there"
    );

    let mut offences = vec![];
    for file in &files {
        let relative = file.strip_prefix(root).unwrap_or(file);
        if relative == Path::new(THIS_FILE) {
            continue;
        }
        // Binary files (images, compiled caches) are not text anyone cites from.
        let Ok(text) = fs::read_to_string(file) else {
            continue;
        };
        for (n, line) in text.lines().enumerate() {
            for what in outside_references(line) {
                offences.push(format!("{}:{}: {what}", relative.display(), n + 1));
            }
        }
    }
    assert!(
        offences.is_empty(),
        "these lines point outside the repository; cite docs/protocol-notes.md §x.y or the \
         vendor document's section instead:\n{}",
        offences.join("\n")
    );
}

#[test]
fn the_check_finds_what_it_is_meant_to_find() {
    for line in [
        "/// Function codes drivedeck speaks (FACTS 1.4).",
        "//! objects of FACTS section 5",
        "    fn od_read_packs_as_facts_1_2() {",
        "//! Layers (see `../shared/DESIGN.md`)",
        "condensed from /work/shared/FACTS.md",
    ] {
        assert!(!outside_references(line).is_empty(), "missed: {line}");
    }
    for line in [
        "//! the facts the code relies on, with their sources (protocol notes §2.4)",
        "/// SDO frames (CiA 301; protocol notes §2.4).",
        "let shared = SharedDrive::new(); // a drive shared by the servers",
        "const FACTSHEET: &str = \"\";",
        "fn the_facts_of_life() {}",
    ] {
        assert!(
            outside_references(line).is_empty(),
            "flagged wrongly: {line}: {:?}",
            outside_references(line)
        );
    }
}

/// The section numbers of `docs/protocol-notes.md`: "1", "1.1", … from its `##`/`###`
/// headings.
fn note_sections(notes: &str) -> Vec<String> {
    notes
        .lines()
        .filter_map(|line| {
            let rest = line
                .strip_prefix("### ")
                .or_else(|| line.strip_prefix("## "))?;
            let number = rest.split(' ').next()?;
            let valid = !number.is_empty()
                && number.chars().all(|c| c.is_ascii_digit() || c == '.')
                && number.chars().next().is_some_and(|c| c.is_ascii_digit());
            valid.then(|| number.to_string())
        })
        .collect()
}

/// A section number right after a `§`, without a sentence's full stop.
fn section_after(text: &str) -> Option<String> {
    let number: String = text
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    let number = number.trim_end_matches('.');
    (!number.is_empty()).then(|| number.to_string())
}

/// The protocol-notes sections `line` cites: every `§x.y` in a citation that starts with
/// "notes §" ("protocol notes §1.2 to §1.5", "protocol notes §2.4, §2.5"), up to the `)`,
/// `(`, `:` or `;` that ends it.
fn cited_sections(line: &str) -> Vec<String> {
    let mut out = vec![];
    for (at, _) in line.match_indices("notes §") {
        let citation = line[at..].split([')', '(', ':', ';']).next().unwrap_or("");
        for (mark, _) in citation.match_indices('§') {
            out.extend(section_after(&citation[mark + '§'.len_utf8()..]));
        }
    }
    out
}

#[test]
fn every_cited_section_of_the_protocol_notes_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let notes = fs::read_to_string(root.join("docs/protocol-notes.md"))
        .expect("docs/protocol-notes.md is readable");
    let sections = note_sections(&notes);
    assert!(
        sections.iter().any(|s| s == "5.1"),
        "no numbered sections found in docs/protocol-notes.md: {sections:?}"
    );

    let mut files = vec![];
    for place in ["src", "tests", "benches", "README.md", "BENCHMARKS.md"] {
        text_files(&root.join(place), &mut files);
    }
    files.sort();
    let mut missing = vec![];
    let mut cited = 0;
    for file in &files {
        let Ok(text) = fs::read_to_string(file) else {
            continue;
        };
        let relative = file.strip_prefix(root).unwrap_or(file);
        for (n, line) in text.lines().enumerate() {
            for section in cited_sections(line) {
                cited += 1;
                if !sections.contains(&section) {
                    missing.push(format!("{}:{}: §{section}", relative.display(), n + 1));
                }
            }
        }
    }
    assert!(cited > 50, "only {cited} citations of the notes found");

    // Cross-references inside the notes: `§x.y` not preceded by another document's name
    // ("PDI spec §2.2.5", "Modbus Application Protocol §6.17", "V1.02 §2.5.1.1").
    for (n, line) in notes.lines().enumerate() {
        for (mark, _) in line.match_indices('§') {
            let before = &line[..mark];
            if before.ends_with("spec ")
                || before.ends_with("Protocol ")
                || before.ends_with("V1.02 ")
            {
                continue;
            }
            if let Some(section) = section_after(&line[mark + '§'.len_utf8()..])
                && section.matches('.').count() <= 1
                && !sections.contains(&section)
            {
                missing.push(format!("docs/protocol-notes.md:{}: §{section}", n + 1));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "these cite sections docs/protocol-notes.md does not have:\n{}",
        missing.join("\n")
    );
}

#[test]
fn citations_are_read_the_way_comments_write_them() {
    assert_eq!(
        cited_sections("//! (PDI spec §3.2; protocol notes §1.2 to §1.5):"),
        ["1.2", "1.5"]
    );
    assert_eq!(
        cited_sections("/// after a protocol error (protocol notes §2.4, §2.5)."),
        ["2.4", "2.5"]
    );
    assert_eq!(
        cited_sections("/// (protocol notes §5.12: high, \\[M\\]). See PDI spec §2.2.5."),
        ["5.12"]
    );
    assert_eq!(cited_sections("/// notes §1.4)."), ["1.4"]);
    assert_eq!(
        cited_sections("// Protocol notes §1.2 (PDI spec §2.2.5): FC 16 to 5996"),
        ["1.2"]
    );
    assert_eq!(cited_sections("// PDI spec §2.2.11"), Vec::<String>::new());
    assert_eq!(
        note_sections(
            "# Title\n## 0 Reading\n### 0.1 Vendor\n### Not numbered\n## 5 Contradictions\n### 5.12 Word order"
        ),
        ["0", "0.1", "5", "5.12"]
    );
}
