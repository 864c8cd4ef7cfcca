//! The layers keep: every `crate::` import in `src/` (unit tests excepted) is one that the
//! table in ARCHITECTURE.md allows. The table is the one source of the rule; this test
//! only reads it and the sources, and names every import it does not allow.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// What a module may import: other modules whole, and modules of which only the types at
/// the root and the submodules named (`link` (types; `spec`)).
#[derive(Debug, Default)]
struct Allowed {
    whole: BTreeSet<String>,
    types_only: BTreeSet<String>,
    /// Per types-only module, the submodules that may be imported whole.
    submodules: BTreeMap<String, BTreeSet<String>>,
}

/// The table between `<!-- layers -->` and `<!-- /layers -->` in ARCHITECTURE.md.
fn table(text: &str) -> Result<BTreeMap<String, Allowed>, String> {
    let start = text
        .find("<!-- layers -->")
        .ok_or("ARCHITECTURE.md has no <!-- layers --> table")?;
    let end = text
        .find("<!-- /layers -->")
        .ok_or("ARCHITECTURE.md has no <!-- /layers --> end")?;
    let mut rules = BTreeMap::new();
    for line in text[start..end].lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // | `module` | `a`, `b` (types) |
        if cells.len() < 3 || !cells[1].starts_with('`') {
            continue;
        }
        // `ui` models: the window's model files (listed under <!-- models -->), a rule of
        // their own beside the one of `ui`.
        let module = match cells[1].strip_suffix(" models") {
            Some(of) => format!("{} models", of.trim_matches('`')),
            None => cells[1].trim_matches('`').to_owned(),
        };
        let mut allowed = Allowed::default();
        for item in cells[2].split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let quoted: Vec<&str> = item.split('`').skip(1).step_by(2).collect();
            let name = quoted
                .first()
                .ok_or_else(|| format!("ARCHITECTURE.md: '{item}' is not a `module`"))?
                .to_string();
            if item.contains("(types") {
                let subs = quoted[1..].iter().map(|s| s.to_string()).collect();
                allowed.submodules.insert(name.clone(), subs);
                allowed.types_only.insert(name);
            } else {
                allowed.whole.insert(name);
            }
        }
        if rules.insert(module.clone(), allowed).is_some() {
            return Err(format!("ARCHITECTURE.md lists `{module}` twice"));
        }
    }
    Ok(rules)
}

/// Every .rs file under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a file under src/: `link/canopen/client.rs` → [link, canopen,
/// client]; `link/canopen/mod.rs` → [link, canopen].
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if let Some(last) = parts.last_mut() {
        *last = last.trim_end_matches(".rs").to_owned();
    }
    if parts
        .last()
        .is_some_and(|l| l == "mod" || l == "lib" || l == "main")
    {
        parts.pop();
    }
    parts
}

/// Files that are test modules as a whole (`#[cfg(test)] mod x;` in their parent).
fn test_files(files: &[PathBuf]) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    for file in files {
        let Ok(text) = std::fs::read_to_string(file) else {
            continue;
        };
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            if line.trim() != "#[cfg(test)]" {
                continue;
            }
            let Some(next) = lines.get(i + 1) else {
                continue;
            };
            let next = next
                .trim()
                .trim_start_matches("pub ")
                .trim_start_matches("pub(crate) ");
            if let Some(name) = next.strip_prefix("mod ").and_then(|n| n.strip_suffix(';')) {
                let dir = match file.file_name().and_then(|n| n.to_str()) {
                    Some("mod.rs" | "lib.rs" | "main.rs") => file.parent().map(Path::to_path_buf),
                    _ => Some(file.with_extension("")),
                };
                if let Some(dir) = dir {
                    out.insert(dir.join(format!("{name}.rs")));
                    out.insert(dir.join(name).join("mod.rs"));
                }
            }
        }
    }
    out
}

/// The code of a file without its unit tests (from the first `#[cfg(test)]` on) and
/// without comments, line by line (numbers kept).
fn code_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = vec![];
    for (i, line) in text.lines().enumerate() {
        if line.trim() == "#[cfg(test)]" {
            break;
        }
        let code = match line.find("//") {
            Some(at) => &line[..at],
            None => line,
        };
        out.push((i + 1, code.to_owned()));
    }
    out
}

/// Each path a `crate::…` or `super::…` import names, resolved to (top-level module,
/// the rest), with the line it starts on. Grouped imports (`crate::{a::B, c}`) may span
/// lines.
fn imports(own: &[String], lines: &[(usize, String)]) -> Vec<(usize, String, String)> {
    let mut text = String::new();
    let mut starts = vec![]; // (offset, line number)
    for (number, line) in lines {
        starts.push((text.len(), *number));
        text.push_str(line);
        text.push('\n');
    }
    let line_of = |offset: usize| {
        starts
            .iter()
            .rev()
            .find(|(at, _)| *at <= offset)
            .map_or(0, |(_, n)| *n)
    };
    let bytes = text.as_bytes();
    let mut found = vec![];
    let mut i = 0;
    while i < bytes.len() {
        if !text.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let rest = &text[i..];
        let boundary = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        let (base, skip): (Vec<String>, usize) = if boundary && rest.starts_with("crate::") {
            (vec![], "crate::".len())
        } else if boundary && rest.starts_with("super::") {
            // super::super::x from own = [a, b, c] → [a] then x.
            let mut depth = own.len();
            let mut j = 0;
            while text[i + j..].starts_with("super::") {
                depth = depth.saturating_sub(1);
                j += "super::".len();
            }
            (own[..depth].to_vec(), j)
        } else {
            i += 1;
            continue;
        };
        let at = line_of(i);
        let mut paths = vec![];
        collect(&text[i + skip..], &mut String::new(), &mut paths);
        for path in paths {
            let mut full = base.clone();
            full.extend(
                path.split("::")
                    .map(str::to_owned)
                    .filter(|s| !s.is_empty()),
            );
            if let Some((top, rest)) = full.split_first() {
                found.push((at, top.clone(), rest.join("::")));
            }
        }
        i += skip;
    }
    found
}

/// The paths at the start of `text`: `a::b::C` or a group `{a::B, c::{D, E}}`, each group
/// member as its own path, prefixed with `prefix`.
fn collect(text: &str, prefix: &mut String, out: &mut Vec<String>) {
    let mut path = String::new();
    for (at, c) in text.char_indices() {
        if c.is_alphanumeric() || c == '_' || c == ':' {
            path.push(c);
            continue;
        }
        if c == '{' {
            // Members up to the matching brace, split at top-level commas.
            let inner = &text[at + 1..];
            let mut depth = 0;
            let mut member_start = 0;
            for (k, d) in inner.char_indices() {
                match d {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        push_member(&inner[member_start..k], &format!("{prefix}{path}"), out);
                        return;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        push_member(&inner[member_start..k], &format!("{prefix}{path}"), out);
                        member_start = k + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        break;
    }
    out.push(format!("{prefix}{path}"));
}

fn push_member(member: &str, prefix: &str, out: &mut Vec<String>) {
    let member = member.trim();
    if member.is_empty() || member == "self" {
        if member == "self" {
            out.push(prefix.trim_end_matches("::").to_owned());
        }
        return;
    }
    let mut prefix = prefix.to_owned();
    collect(member, &mut prefix, out);
}

/// Whether `rest` (the path after `link::`) names only a type at the module's root.
fn is_root_type(rest: &str) -> bool {
    let first = rest.split("::").next().unwrap_or("");
    first.chars().next().is_some_and(char::is_uppercase)
}

/// The imports in `files` (path under src/, text) that `rules` does not allow, and the
/// modules that have no rule.
fn violations(rules: &BTreeMap<String, Allowed>, files: &[(PathBuf, String)]) -> Vec<String> {
    let mut bad = vec![];
    for (rel, text) in files {
        let own = module_path(rel);
        let Some(top) = own.first().cloned() else {
            continue; // lib.rs, main.rs: the crate root declares the modules
        };
        let Some(allowed) = rules.get(&top) else {
            bad.push(format!(
                "src/{}: module `{top}` is not in ARCHITECTURE.md's table",
                rel.display()
            ));
            continue;
        };
        for (line, target, rest) in imports(&own, &code_lines(text)) {
            if target == top || allowed.whole.contains(&target) {
                continue;
            }
            let first = rest.split("::").next().unwrap_or("");
            if allowed.types_only.contains(&target)
                && (is_root_type(&rest)
                    || allowed
                        .submodules
                        .get(&target)
                        .is_some_and(|subs| subs.contains(first)))
            {
                continue;
            }
            let how = if allowed.types_only.contains(&target) {
                " (only its types at the root may be)"
            } else {
                ""
            };
            bad.push(format!(
                "src/{}:{line}: `{top}` imports `{target}::{rest}`, which ARCHITECTURE.md does not allow{how}",
                rel.display()
            ));
        }
    }
    bad
}

fn rules() -> BTreeMap<String, Allowed> {
    let architecture =
        std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    table(&architecture).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_import_in_src_is_one_the_architecture_allows() {
    let rules = rules();
    let src = root().join("src");
    let mut paths = vec![];
    sources(&src, &mut paths);
    paths.sort();
    let tests = test_files(&paths);
    let files: Vec<(PathBuf, String)> = paths
        .iter()
        .filter(|p| !tests.contains(*p))
        .map(|p| {
            let rel = p.strip_prefix(&src).expect("under src").to_path_buf();
            (rel, std::fs::read_to_string(p).expect("readable source"))
        })
        .collect();
    let seen: BTreeSet<String> = files
        .iter()
        .filter_map(|(rel, _)| module_path(rel).first().cloned())
        .collect();
    for module in rules.keys().filter(|m| !m.ends_with(" models")) {
        assert!(
            seen.contains(module),
            "ARCHITECTURE.md lists `{module}`, which src/ does not have"
        );
    }
    let bad = violations(&rules, &files);
    assert!(
        bad.is_empty(),
        "{} forbidden imports:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn an_arrow_upwards_is_named_with_file_and_line() {
    let rules = rules();
    let files = vec![
        (
            PathBuf::from("ui/panel.rs"),
            "use crate::link::LinkSpec;\nuse crate::link::modbus::client::ModbusLink;\n".to_owned(),
        ),
        (
            PathBuf::from("link/canopen/client.rs"),
            "fn f() {\n    let _ = crate::sim::Drive::new();\n}\n".to_owned(),
        ),
        (
            PathBuf::from("telemetry/scope.rs"),
            "use crate::worker::Sample;\n".to_owned(),
        ),
        (
            PathBuf::from("pdi/mod.rs"),
            "use super::od::Address;\n".to_owned(),
        ),
    ];
    let bad = violations(&rules, &files);
    assert_eq!(bad.len(), 4, "{bad:#?}");
    assert!(
        bad[0].starts_with("src/ui/panel.rs:2: `ui` imports `link::modbus::client::ModbusLink`")
    );
    assert!(bad[1].starts_with("src/link/canopen/client.rs:2: `link` imports `sim::Drive::new`"));
    assert!(bad[2].starts_with("src/telemetry/scope.rs:1: `telemetry` imports `worker::Sample`"));
    assert!(bad[3].starts_with("src/pdi/mod.rs:1: `pdi` imports `od::Address`"));
}

#[test]
fn the_reader_finds_grouped_nested_and_relative_imports() {
    let own = vec!["ui".to_owned(), "panel".to_owned()];
    let lines = code_lines(
        "use crate::{link::modbus::client, worker::{Event, Request}};\n\
         use super::super::sim::Drive; // a comment with crate::cli\n\
         let x = crate::link::LinkSpec::Sim;\n\
         use crate::{\n    telemetry::Scope,\n    od,\n};\n\
         #[cfg(test)]\nuse crate::cli::main;\n",
    );
    let found: Vec<(usize, String, String)> = imports(&own, &lines);
    let names: Vec<String> = found
        .iter()
        .map(|(line, top, rest)| format!("{line} {top}::{rest}"))
        .collect();
    assert_eq!(
        names,
        [
            "1 link::modbus::client",
            "1 worker::Event",
            "1 worker::Request",
            "2 sim::Drive",
            "3 link::LinkSpec::Sim",
            "4 telemetry::Scope",
            "4 od::",
        ]
    );
    assert!(is_root_type("LinkSpec"));
    assert!(!is_root_type("modbus::client"));
    assert!(!is_root_type("serial_ports"));
}

#[test]
fn the_table_is_read_as_written() {
    let rules = table(
        "<!-- layers -->\n| module | may import |\n| --- | --- |\n| `a` | |\n| `b` | `a`, `c` (types; `grammar`) |\n<!-- /layers -->",
    )
    .expect("a table");
    assert!(rules["a"].whole.is_empty());
    assert!(rules["b"].whole.contains("a"));
    assert!(rules["b"].types_only.contains("c"));
    assert!(rules["b"].submodules["c"].contains("grammar"));
    assert!(table("| `a` | |").is_err());
}

// The window: models without egui, and no import circles but a panel's own.

/// The window's model files and folders (under src/), listed between `<!-- models -->` and
/// `<!-- /models -->` in ARCHITECTURE.md: the first cell of each row.
fn model_list(text: &str) -> Result<Vec<String>, String> {
    let start = text
        .find("<!-- models -->")
        .ok_or("ARCHITECTURE.md has no <!-- models --> list")?;
    let end = text
        .find("<!-- /models -->")
        .ok_or("ARCHITECTURE.md has no <!-- /models --> end")?;
    let mut models = vec![];
    for line in text[start..end].lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 3 || !cells[1].starts_with('`') {
            continue;
        }
        for path in cells[1].split('`').skip(1).step_by(2) {
            models.push(path.to_owned());
        }
    }
    Ok(models)
}

/// Whether `rel` (a file under src/) is one of the window's models.
fn is_model(rel: &Path, models: &[String]) -> bool {
    let rel = rel.to_string_lossy().replace('\\', "/");
    models.iter().any(|m| {
        if m.ends_with('/') {
            rel.starts_with(m.as_str())
        } else {
            rel == *m
        }
    })
}

/// The file of a module path under src/ (`["ui", "plots", "model"]` → ui/plots/model.rs),
/// as deep as files go; `None` when even the first is not a module of the crate.
fn module_file(src: &Path, path: &[String]) -> Option<PathBuf> {
    let mut dir = src.to_path_buf();
    let mut file = None;
    for seg in path {
        let as_dir = dir.join(seg).join("mod.rs");
        let as_file = dir.join(format!("{seg}.rs"));
        if as_dir.exists() {
            file = Some(as_dir);
        } else if as_file.exists() {
            file = Some(as_file);
        } else {
            break;
        }
        dir = dir.join(seg);
    }
    file
}

/// The folder a file's child modules are in.
fn children_dir(file: &Path) -> PathBuf {
    match file.file_name().and_then(|n| n.to_str()) {
        Some("mod.rs") => file.parent().map(Path::to_path_buf).unwrap_or_default(),
        _ => file.with_extension(""),
    }
}

/// The files of src/ that `file` (its code, `text`) imports: every `crate::` and `super::`
/// path, and every `use child::…` of one of its own child modules.
fn imported_files(src: &Path, file: &Path, text: &str) -> BTreeSet<PathBuf> {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let own = module_path(rel);
    let lines = code_lines(text);
    let mut out = BTreeSet::new();
    for (_, top, rest) in imports(&own, &lines) {
        let mut path = vec![top];
        path.extend(
            rest.split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_owned),
        );
        if let Some(target) = module_file(src, &path) {
            out.insert(target);
        }
    }
    let dir = children_dir(file);
    for (_, line) in &lines {
        let line = line
            .trim()
            .trim_start_matches("pub ")
            .trim_start_matches("pub(crate) ");
        let Some(used) = line.strip_prefix("use ") else {
            continue;
        };
        let first = used.split("::").next().unwrap_or("").trim();
        if first.is_empty() || !first.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue;
        }
        let mut path = vec![];
        path.extend(used.split("::").map(|s| s.trim().to_owned()));
        let as_dir = dir.join(first).join("mod.rs");
        let as_file = dir.join(format!("{first}.rs"));
        if as_dir.exists() || as_file.exists() {
            let base = dir.strip_prefix(src).unwrap_or(&dir);
            let mut full: Vec<String> = base
                .iter()
                .map(|p| p.to_string_lossy().into_owned())
                .collect();
            full.extend(path);
            if let Some(target) = module_file(src, &full) {
                out.insert(target);
            }
        }
    }
    out.remove(file);
    out
}

/// The strongly connected groups of more than one file in `edges` (Tarjan).
fn circles(edges: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    struct Walk<'a> {
        edges: &'a BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        index: BTreeMap<&'a PathBuf, usize>,
        low: BTreeMap<&'a PathBuf, usize>,
        stack: Vec<&'a PathBuf>,
        on_stack: BTreeSet<&'a PathBuf>,
        next: usize,
        found: Vec<Vec<PathBuf>>,
    }
    fn visit<'a>(w: &mut Walk<'a>, v: &'a PathBuf) {
        w.index.insert(v, w.next);
        w.low.insert(v, w.next);
        w.next += 1;
        w.stack.push(v);
        w.on_stack.insert(v);
        if let Some(targets) = w.edges.get(v) {
            for t in targets {
                let Some((t, _)) = w.edges.get_key_value(t) else {
                    continue;
                };
                if !w.index.contains_key(t) {
                    visit(w, t);
                    let low = w.low[t].min(w.low[v]);
                    w.low.insert(v, low);
                } else if w.on_stack.contains(t) {
                    let low = w.index[t].min(w.low[v]);
                    w.low.insert(v, low);
                }
            }
        }
        if w.low[v] == w.index[v] {
            let mut group = vec![];
            while let Some(u) = w.stack.pop() {
                w.on_stack.remove(u);
                group.push(u.clone());
                if u == v {
                    break;
                }
            }
            if group.len() > 1 {
                group.sort();
                w.found.push(group);
            }
        }
    }
    let mut w = Walk {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: vec![],
        on_stack: BTreeSet::new(),
        next: 0,
        found: vec![],
    };
    for v in edges.keys() {
        if !w.index.contains_key(v) {
            visit(&mut w, v);
        }
    }
    w.found
}

/// The panel a file of src/ui is part of: its folder under src/ui (`browser`, `plots`), or
/// the file itself when it sits in src/ui.
fn panel_of(rel: &Path) -> String {
    let parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    match parts.as_slice() {
        [ui, dir, _, ..] if ui == "ui" => dir.clone(),
        _ => rel.to_string_lossy().into_owned(),
    }
}

/// Every non-test file of src/ui, with its text.
fn ui_files() -> Vec<(PathBuf, String)> {
    let src = root().join("src");
    let mut paths = vec![];
    sources(&src.join("ui"), &mut paths);
    paths.sort();
    let tests = test_files(&paths);
    paths
        .into_iter()
        .filter(|p| !tests.contains(p))
        .map(|p| {
            let text = std::fs::read_to_string(&p).expect("readable source");
            (p, text)
        })
        .collect()
}

/// What the window's rules find wrong: a model that uses egui or imports a view of another
/// panel (or the window's index), an import of a model beyond what `ui` models may, and
/// an import circle between files of different panels.
fn window_violations(
    src: &Path,
    files: &[(PathBuf, String)],
    models: &[String],
    rule: &Allowed,
) -> Vec<String> {
    let mut bad = vec![];
    let mut edges = BTreeMap::new();
    for (file, text) in files {
        let rel = file.strip_prefix(src).unwrap_or(file).to_path_buf();
        let targets = imported_files(src, file, text);
        if is_model(&rel, models) {
            for (line, code) in code_lines(text) {
                for gui in ["eframe::", "egui::", "egui_plot::", "egui_extras::"] {
                    let at = code.find(gui);
                    let boundary = at.is_some_and(|i| {
                        i == 0
                            || !code.as_bytes()[i - 1].is_ascii_alphanumeric()
                                && code.as_bytes()[i - 1] != b'_'
                    });
                    if boundary {
                        bad.push(format!(
                            "src/{}:{line}: a model of the window uses `{gui}`",
                            rel.display()
                        ));
                    }
                }
            }
            for (line, top, rest) in imports(&module_path(&rel), &code_lines(text)) {
                if top == "ui" || rule.whole.contains(&top) {
                    continue;
                }
                let first = rest.split("::").next().unwrap_or("");
                let types = rule.types_only.contains(&top)
                    && (is_root_type(&rest)
                        || rule.submodules.get(&top).is_some_and(|s| s.contains(first)));
                if !types {
                    bad.push(format!(
                        "src/{}:{line}: the `ui` model imports `{top}::{rest}`, which ARCHITECTURE.md does not allow models",
                        rel.display()
                    ));
                }
            }
            for target in &targets {
                let target_rel = target.strip_prefix(src).unwrap_or(target);
                let same_panel = panel_of(target_rel) == panel_of(&rel);
                if target_rel.starts_with("ui") && !is_model(target_rel, models) && !same_panel {
                    bad.push(format!(
                        "src/{}: a model of the window imports src/{}, which is no model",
                        rel.display(),
                        target_rel.display()
                    ));
                }
            }
        }
        edges.insert(file.clone(), targets);
    }
    for group in circles(&edges) {
        let rels: Vec<PathBuf> = group
            .iter()
            .map(|f| f.strip_prefix(src).unwrap_or(f).to_path_buf())
            .collect();
        let panel = panel_of(&rels[0]);
        if rels
            .iter()
            .all(|r| panel_of(r) == panel && r.iter().count() > 2)
        {
            // a panel's own files: its views and its model (printed, so a note can cite them)
            eprintln!(
                "a circle inside one panel: {}",
                rels.iter()
                    .map(|r| format!("src/{}", r.display()))
                    .collect::<Vec<_>>()
                    .join(" ↔ ")
            );
            continue;
        }
        bad.push(format!(
            "an import circle across panels: {}",
            rels.iter()
                .map(|r| format!("src/{}", r.display()))
                .collect::<Vec<_>>()
                .join(" → ")
        ));
    }
    bad
}

#[test]
fn window_models_use_no_egui_and_ui_has_no_import_circle_across_panels() {
    let architecture =
        std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let models = model_list(&architecture).unwrap_or_else(|e| panic!("{e}"));
    let rules = rules();
    let rule = rules
        .get("ui models")
        .expect("ARCHITECTURE.md's layer table has a row for the `ui` models");
    let src = root().join("src");
    for model in &models {
        assert!(
            src.join(model).exists(),
            "ARCHITECTURE.md lists {model} as a model, which src/ does not have"
        );
    }
    let bad = window_violations(&src, &ui_files(), &models, rule);
    assert!(
        bad.is_empty(),
        "{} problems:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn a_model_with_egui_and_a_circle_across_panels_are_named() {
    let dir = tempfile::tempdir().expect("a folder");
    let src = dir.path();
    let write = |rel: &str, text: &str| {
        let path = src.join(rel);
        std::fs::create_dir_all(path.parent().expect("a folder")).expect("folders");
        std::fs::write(&path, text).expect("written");
        path
    };
    let files = vec![
        write("ui/mod.rs", "pub mod a;\npub mod b;\n"),
        write("ui/a/mod.rs", "mod model;\npub use model::M;\n"),
        write(
            "ui/a/model.rs",
            "use eframe::egui;\nuse crate::ui::b::view::V;\n",
        ),
        write("ui/b/mod.rs", "pub mod view;\n"),
        write("ui/b/view.rs", "use crate::ui::a::model::M;\n"),
    ];
    let files: Vec<(PathBuf, String)> = files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).expect("read");
            (p, text)
        })
        .collect();
    let models = vec!["ui/a/model.rs".to_owned()];
    let bad = window_violations(src, &files, &models, &Allowed::default());
    assert!(
        bad.iter()
            .any(|b| b.contains("ui/a/model.rs:1: a model of the window uses `eframe::`")),
        "{bad:#?}"
    );
    assert!(
        bad.iter()
            .any(|b| b.contains("imports src/ui/b/view.rs, which is no model")),
        "{bad:#?}"
    );
    assert!(
        bad.iter()
            .any(|b| b.starts_with("an import circle across panels")
                && b.contains("ui/a/model.rs")
                && b.contains("ui/b/view.rs")),
        "{bad:#?}"
    );
}
