//! The shape of the code, checked: the import graph of the top-level modules has no circle,
//! and nothing below the stages imports a stage (stages are adapters over the library, never
//! a library for it). Read from the sources, so a new `use` that breaks the layering fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Top-level module -> the top-level modules its production code names through `crate::`.
fn import_graph() -> BTreeMap<String, BTreeSet<String>> {
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                // Unit tests may use anything (the twin above all): they are not the library.
                if path.file_name().is_some_and(|n| n != "tests") {
                    stack.push(path);
                }
                continue;
            }
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if !name.ends_with(".rs") || name == "tests.rs" {
                continue;
            }
            let rel = path
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .to_string();
            let module = rel.split('/').next().unwrap().trim_end_matches(".rs");
            let text = std::fs::read_to_string(&path).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            let targets = graph.entry(module.to_string()).or_default();
            for t in crate_paths(code) {
                if t != module {
                    targets.insert(t);
                }
            }
        }
    }
    graph
}

/// The first segment of every `crate::` path in `code`, grouped imports included.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let code: String = code
        .lines()
        .map(|l| l.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // `crate::{a::b, c, d::{e, f}}`: the first segment of each top-level item.
            let (mut depth, mut item) = (0, String::new());
            for ch in group.chars() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(first_segment(&item));
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                if depth == 0 {
                    item.push(ch);
                }
            }
            out.insert(first_segment(&item));
        } else {
            out.insert(first_segment(rest));
        }
    }
    out.remove("");
    out
}

fn first_segment(s: &str) -> String {
    s.trim()
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect()
}

#[test]
fn the_module_graph_has_no_circle() {
    let graph = import_graph();
    assert!(graph.len() > 10, "read too few modules: {graph:?}");
    for start in graph.keys() {
        let mut seen = BTreeSet::new();
        let mut path = BTreeMap::new();
        let mut stack = vec![start.clone()];
        while let Some(m) = stack.pop() {
            for next in graph.get(&m).into_iter().flatten() {
                if next == start {
                    let mut chain = vec![m.clone()];
                    while let Some(p) = path.get(chain.last().unwrap()) {
                        chain.push(String::clone(p));
                    }
                    chain.reverse();
                    panic!(
                        "import circle: {start} -> {} -> {start}",
                        chain.join(" -> ")
                    );
                }
                if seen.insert(next.clone()) {
                    path.insert(next.clone(), m.clone());
                    stack.push(next.clone());
                }
            }
        }
    }
}

#[test]
fn only_the_command_line_imports_stages() {
    let graph = import_graph();
    let allowed = ["stage", "cmd", "cli", "main", "lib"];
    for (module, targets) in &graph {
        if allowed.contains(&module.as_str()) {
            continue;
        }
        for upward in ["stage", "cmd", "cli"] {
            assert!(
                !targets.contains(upward),
                "`{module}` imports `{upward}`: move the type it needs down to the module that \
                 owns the concept"
            );
        }
    }
    // The engine knows the kinds only through the registry it is given.
    assert!(!graph["pipeline"].contains("stage"));
}

#[test]
fn the_graph_reader_sees_grouped_imports() {
    let found = crate_paths("use crate::{a::b, c, d::{e, f}};\nlet x = crate::g::h(); // crate::z");
    let want: BTreeSet<String> = ["a", "c", "d", "g"].map(String::from).into();
    assert_eq!(found, want);
}
