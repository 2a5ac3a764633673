//! The import graph of both crates has no cycles, and every integration-test file runs.
//!
//! Every `crate::…` and `super::…` path in a source file is resolved to the module it names; a
//! module is its file (`a/b.rs` or `a/b/mod.rs` is `a::b`). Modules are then grouped two levels
//! deep (`correctors::ann::lm` counts as `correctors::ann`), and the graph between groups must be
//! acyclic, as must the graph between the top-level modules. A module using its own parent (or
//! the parent re-exporting its child) is containment, not an import between groups.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `src/a/b/mod.rs` → `["a", "b"]`; `src/a/b.rs` → `["a", "b"]`; `src/lib.rs` → `[]`.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_string());
    }
    parts
}

/// Paths named in the text: `crate::a::b` and `super::c` (each `super` climbs one level).
fn referenced_paths(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let mut found = Vec::new();
    let code: String = text
        .lines()
        .filter(|l| {
            let t = l.trim_start();
            !t.starts_with("//")
        })
        .collect::<Vec<_>>()
        .join("\n");
    let bytes = code.as_bytes();
    for start in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(at) = code[from..].find(start) {
            let at = from + at;
            from = at + start.len();
            let preceded_by_ident = at > 0
                && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_' || bytes[at - 1] == b':');
            if preceded_by_ident {
                continue;
            }
            let mut base: Vec<String> = if start == "crate::" {
                Vec::new()
            } else {
                module[..module.len().saturating_sub(1)].to_vec()
            };
            let rest: String = code[from..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            for segment in rest.split("::").filter(|s| !s.is_empty()) {
                if segment == "super" {
                    base.pop();
                } else {
                    base.push(segment.to_string());
                }
            }
            found.push(base);
        }
    }
    found
}

fn group(module: &[String], depth: usize) -> Vec<String> {
    module[..module.len().min(depth)].to_vec()
}

fn is_prefix(a: &[String], b: &[String]) -> bool {
    a.len() <= b.len() && b[..a.len()] == *a
}

/// A cycle in `edges`, if any (depth-first search).
fn find_cycle(edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Option<Vec<Vec<String>>> {
    fn visit(
        node: &Vec<String>,
        edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        state.insert(node.clone(), 1);
        stack.push(node.clone());
        for next in edges.get(node).into_iter().flatten() {
            match state.get(next).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|n| n == next).unwrap();
                    let mut cycle = stack[at..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(next, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(node.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in edges.keys() {
        if state.get(node).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(node, edges, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

fn check_crate(src: &Path) -> usize {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(src, f)).collect();
    let mut edge_count = 0;
    for depth in [1, 2] {
        let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
        for file in &files {
            let from = module_of(src, file);
            let text = std::fs::read_to_string(file).unwrap();
            for path in referenced_paths(&text, &from) {
                // The longest module the path names (the rest are items inside it).
                let Some(to) = (0..=path.len())
                    .rev()
                    .map(|n| path[..n].to_vec())
                    .find(|p| modules.contains(p))
                else {
                    continue;
                };
                let (a, b) = (group(&from, depth), group(&to, depth));
                if a.is_empty() || b.is_empty() || is_prefix(&a, &b) || is_prefix(&b, &a) {
                    continue;
                }
                edges.entry(a).or_default().insert(b);
            }
        }
        edge_count += edges.values().map(BTreeSet::len).sum::<usize>();
        if let Some(cycle) = find_cycle(&edges) {
            let names: Vec<String> = cycle.iter().map(|m| m.join("::")).collect();
            panic!("{}: import cycle: {}", src.display(), names.join(" → "));
        }
    }
    edge_count
}

#[test]
fn library_imports_have_no_cycles() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let edges = check_crate(&src);
    // The check saw the real graph (calibrate alone imports half the crate).
    assert!(
        edges > 40,
        "only {edges} edges found: is the scanner reading the sources?"
    );
}

#[test]
fn cli_imports_have_no_cycles() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../spincal-cli/src");
    let edges = check_crate(&src);
    assert!(edges > 10, "only {edges} edges found");
}

#[test]
fn the_scanner_finds_a_cycle_when_there_is_one() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::write(src.join("lib.rs"), "pub mod a;\npub mod b;\n").unwrap();
    std::fs::write(src.join("a.rs"), "use crate::b::B;\npub struct A;\n").unwrap();
    std::fs::write(
        src.join("b.rs"),
        "pub struct B;\nfn f() -> crate::a::A { crate::a::A }\n",
    )
    .unwrap();
    let caught = std::panic::catch_unwind(|| check_crate(src)).unwrap_err();
    let message = caught.downcast_ref::<String>().unwrap();
    assert!(message.contains("import cycle: a → b → a"), "{message}");
}

/// With `autotests = false` a file of a crate's tests/ is built only as a module of its
/// tests/suite.rs or as a `[[test]]` of its own in Cargo.toml: any other file would never run.
#[test]
fn every_test_file_runs() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut checked = 0;
    let mut missing = Vec::new();
    for krate in std::fs::read_dir(&crates).unwrap() {
        let krate = krate.unwrap().path();
        let tests = krate.join("tests");
        let Ok(suite) = std::fs::read_to_string(tests.join("suite.rs")) else {
            continue;
        };
        let manifest = std::fs::read_to_string(krate.join("Cargo.toml")).unwrap();
        for entry in std::fs::read_dir(&tests).unwrap() {
            let name = entry.unwrap().file_name().into_string().unwrap();
            let Some(module) = name.strip_suffix(".rs") else {
                continue;
            };
            checked += 1;
            let runs = name == "suite.rs"
                || suite.contains(&format!("\nmod {module};"))
                || manifest.contains(&format!("path = \"tests/{name}\""));
            if !runs {
                missing.push(tests.join(&name));
            }
        }
    }
    assert!(
        checked >= 30,
        "only {checked} test files found under {}",
        crates.display()
    );
    assert!(
        missing.is_empty(),
        "{missing:?} would never run: add `mod …;` to the crate's tests/suite.rs"
    );
}

/// Each library file's module and its code, without the unit tests that come last (after
/// `#[cfg(test)]` and `mod tests`).
fn library_code(src: &Path) -> Vec<(Vec<String>, String)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files
        .iter()
        .map(|file| {
            let text = std::fs::read_to_string(file).unwrap();
            let code = text.split("#[cfg(test)]\nmod tests").next().unwrap_or(&text);
            (module_of(src, file), code.to_string())
        })
        .collect()
}

/// The library's public items, one line each (`module: pub kind name`), sorted: every `pub`
/// declaration outside the files' test modules, methods included, under its nearest public
/// module. `pub(crate)` and narrower are not public and not listed.
fn public_surface(src: &Path) -> Vec<String> {
    let public = public_modules(src);
    let mut lines = Vec::new();
    for (mut module, code) in library_code(src) {
        // A private file of a folder module shows under the public module that re-exports it.
        while !public.contains(&module) {
            module.pop();
        }
        let module = module.join("::");
        for line in code.lines() {
            let t = line.trim_start();
            let Some(rest) = t.strip_prefix("pub ") else {
                continue;
            };
            let ident_end = |text: &str| {
                text.find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(text.len())
            };
            let (kind, name) = if let Some(path) = rest.strip_prefix("use ") {
                ("use", path.trim_end_matches(';').trim().to_string())
            } else if let Some(f) = rest
                .strip_prefix("const fn ")
                .or_else(|| rest.strip_prefix("unsafe fn "))
            {
                ("fn", f[..ident_end(f)].to_string())
            } else {
                let first = &rest[..ident_end(rest)];
                let after = rest[first.len()..].trim_start();
                if after.starts_with(':') && !after.starts_with("::") {
                    ("field", first.to_string())
                } else {
                    (first, after[..ident_end(after)].to_string())
                }
            };
            let module = if module.is_empty() { "spincal" } else { &module };
            lines.push(format!("{module}: pub {kind} {name}"));
        }
    }
    lines.sort();
    lines.dedup();
    lines
}

/// The public surface is checked into `tests/fixtures/public_api.txt`, so that a change to it
/// shows in review. After a deliberate change, `SPINCAL_BLESS=1` rewrites the file.
#[test]
fn the_public_surface_is_the_listed_one() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let listed_path = root.join("tests/fixtures/public_api.txt");
    let surface = public_surface(&root.join("src")).join("\n") + "\n";
    if std::env::var("SPINCAL_BLESS").as_deref() == Ok("1") {
        std::fs::write(&listed_path, &surface).unwrap();
    }
    let listed = std::fs::read_to_string(&listed_path).unwrap_or_default();
    if listed != surface {
        let (now, then): (BTreeSet<&str>, BTreeSet<&str>) =
            (surface.lines().collect(), listed.lines().collect());
        let added: Vec<&&str> = now.difference(&then).collect();
        let removed: Vec<&&str> = then.difference(&now).collect();
        panic!(
            "the public surface changed: added {added:#?}, removed {removed:#?}; if deliberate, run with SPINCAL_BLESS=1 and commit tests/fixtures/public_api.txt"
        );
    }
    // The scanner sees what it should: a public item, and not a crate-private one.
    assert!(listed.contains("correctors::rows: pub struct RowCorrector"));
    assert!(listed.contains("optim: pub fn levenberg_marquardt"));
    assert!(!listed.contains("pub(crate)"));
}

/// Every module's visibility from outside the crate: a module is public when its own `mod`
/// declaration and all its parents' are `pub`.
fn public_modules(src: &Path) -> BTreeSet<Vec<String>> {
    let mut declared: BTreeMap<Vec<String>, bool> = BTreeMap::new();
    for (module, code) in library_code(src) {
        for line in code.lines() {
            let t = line.trim_start();
            let (public, rest) = match t.strip_prefix("pub mod ") {
                Some(rest) => (true, rest),
                None => match t.strip_prefix("mod ").or_else(|| {
                    t.strip_prefix("pub(")
                        .and_then(|r| r.split_once(") mod "))
                        .map(|(_, r)| r)
                }) {
                    Some(rest) => (false, rest),
                    None => continue,
                },
            };
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            let mut path = module.clone();
            path.push(name);
            declared.insert(path, public);
        }
    }
    let mut public = BTreeSet::from([Vec::new()]);
    // Parents sort before their children, so each parent is settled first.
    for (path, is_pub) in &declared {
        if *is_pub && public.contains(&path[..path.len() - 1]) {
            public.insert(path.clone());
        }
    }
    public
}

/// Items that a public module re-exports (`pub use`) from another public module: each is then
/// reachable by two paths. The prelude is the one deliberate exception. Returns
/// `re-exporting module: pub use path` for each.
fn second_paths(src: &Path) -> Vec<String> {
    let public = public_modules(src);
    let mut found = Vec::new();
    for (module, code) in library_code(src) {
        if !public.contains(&module) {
            continue;
        }
        // The prelude, an inline module, is the deliberate second path for the common flow.
        let code = match code.split_once("pub mod prelude {") {
            Some((head, tail)) => format!("{head}{}", tail.split_once("\n}\n").map_or("", |(_, t)| t)),
            None => code.to_string(),
        };
        for (at, _) in code.match_indices("pub use ") {
            if !code[..at].ends_with('\n') {
                continue;
            }
            let statement = &code[at + "pub use ".len()..];
            let statement = &statement[..statement.find(';').unwrap_or(statement.len())];
            let source = statement
                .split('{')
                .next()
                .unwrap_or(statement)
                .trim()
                .trim_end_matches("::");
            let mut path: Vec<String> = match source.split_once("::") {
                Some(("crate", r)) => r.split("::").map(String::from).collect(),
                Some(("self", r)) => module
                    .iter()
                    .cloned()
                    .chain(r.split("::").map(String::from))
                    .collect(),
                _ => module
                    .iter()
                    .cloned()
                    .chain(source.split("::").map(String::from))
                    .collect(),
            };
            // `pub use a::b::Item;` names an item, not a module.
            if !statement.contains('{') {
                path.pop();
            }
            if public.contains(&path) && path != module {
                let name = if module.is_empty() {
                    "spincal".to_string()
                } else {
                    module.join("::")
                };
                found.push(format!(
                    "{name}: pub use {}",
                    statement.split_whitespace().collect::<Vec<_>>().join(" ")
                ));
            }
        }
    }
    found.sort();
    found
}

/// One path per public item: no public module re-exports another public module's items (the
/// prelude aside), so `spincal::a::X` and `spincal::b::X` never name the same thing.
#[test]
fn every_public_item_has_one_path() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let second = second_paths(&root.join("src"));
    assert!(second.is_empty(), "items reachable by a second path: {second:#?}");
}

#[test]
fn the_scanner_finds_a_second_path_and_allows_a_facade_and_the_prelude() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir(src.join("b")).unwrap();
    std::fs::write(
        src.join("lib.rs"),
        "pub mod a;\npub mod b;\npub mod prelude {\n    pub use crate::a::A;\n}\n",
    )
    .unwrap();
    std::fs::write(src.join("a.rs"), "pub struct A;\npub struct X;\n").unwrap();
    std::fs::write(
        src.join("b/mod.rs"),
        "mod part;\npub use part::B;\npub use crate::a::{\n    X,\n};\n",
    )
    .unwrap();
    std::fs::write(src.join("b/part.rs"), "pub struct B;\n").unwrap();
    assert_eq!(second_paths(src), ["b: pub use crate::a::{ X, }"]);
    let surface = public_surface(src);
    assert!(surface.contains(&"b: pub struct B".to_string()), "{surface:?}");
}

/// The library's errors name its parameters (`sample_rate_hz`), never a front end's flags
/// (`--sample-rate`): the CLI and Python each put them in their own words.
#[test]
fn library_errors_name_parameters_not_flags() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut flagged = Vec::new();
    for (module, code) in library_code(&root.join("src")) {
        for line in code.lines().filter(|l| l.trim_start().starts_with("#[error(")) {
            let names_a_flag = line
                .match_indices("--")
                .any(|(at, _)| line[at + 2..].starts_with(|c: char| c.is_ascii_lowercase()));
            if names_a_flag {
                flagged.push(format!("{}: {}", module.join("::"), line.trim()));
            }
        }
    }
    assert!(flagged.is_empty(), "errors that name a CLI flag: {flagged:#?}");
}

/// The CLI parses, makes one library call and prints: no loop over rows or samples, which belong
/// to the library's pipelines (`correctors::stream` for `correct`), where Python reaches them too.
#[test]
fn the_cli_holds_no_loop_over_rows_or_samples() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("../spincal-cli/src"), &mut files);
    assert!(files.len() > 10, "the CLI's sources were not found");
    let row_level = [
        "RowReader",
        "RowCorrector",
        "next_record",
        "next_row",
        "correct_sample",
        "time_s[",
    ];
    let mut found = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            let loops_over_samples =
                code.contains("for ") && (code.contains(".len()") || code.contains("time_s"));
            if loops_over_samples || row_level.iter().any(|t| code.contains(t)) {
                found.push(format!("{}:{}: {}", file.display(), n + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "row-level code in the CLI: {found:#?}");
}
