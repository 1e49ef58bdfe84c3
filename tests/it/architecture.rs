//! The shape of the code, checked. Read from the sources, so a new `use` or a long function
//! that breaks a rule fails here:
//! - the module graph has no circle, between files or between feature folders;
//! - `core` names no feature, the engine (`pipeline`) no feature, and a feature's stage adapter
//!   is named only by the registry of kinds (`kinds.rs`) and the command line;
//! - no function is longer than 80 lines;
//! - `docs/architecture.md` names every stage kind and top-level folder, and nothing else;
//! - every source path the documents name exists.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The longest function allowed, in lines from its signature to its closing brace.
const MAX_FN_LINES: usize = 80;

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The source trees read, each with the module the product knows it as: `src/`, and the
/// workspace crates it re-exports as modules of its own (`pub use hydrofit_core as core`).
/// Inside a crate, `crate::` is that module; anywhere, its crate name is.
const ROOTS: [(&str, &str, &str); 3] = [
    ("", "src", "hydrofit"),
    ("core", "crates/core/src", "hydrofit_core"),
    ("twin", "crates/twin/src", "hydrofit_twin"),
];

fn root_dir(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Every `.rs` file of the [`ROOTS`] by its module path (`pool::import::timing`,
/// `core::model::dynamics`).
fn modules() -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    for (prefix, rel, _) in ROOTS {
        let root = root_dir(rel);
        let mut stack = vec![root.clone()];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    out.insert(join(prefix, &module_of(&root, &path)), path);
                }
            }
        }
    }
    out
}

/// The module `crate::` names inside the file at `path`.
fn crate_module(path: &Path) -> &'static str {
    ROOTS
        .iter()
        .filter(|(_, rel, _)| path.starts_with(root_dir(rel)))
        .max_by_key(|(_, rel, _)| rel.len())
        .map_or("", |(prefix, _, _)| prefix)
}

fn module_of(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts.join("::")
}

/// The production code of a file: unit tests (`#[cfg(test)]` to the end, files named
/// `tests.rs` or under `tests/`) and comments removed.
fn production(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let code = text.split("#[cfg(test)]").next().unwrap();
    code.lines()
        .map(|l| l.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_test_file(m: &str) -> bool {
    m.split("::").any(|s| s == "tests")
}

/// Items a module re-exports from its children (`pub use child::{A, B}`): a path naming
/// `module::A` names the child that defines it.
fn reexports(mods: &BTreeMap<String, PathBuf>) -> BTreeMap<(String, String), String> {
    let mut out = BTreeMap::new();
    for (m, path) in mods {
        let code = production(path);
        for line in code.lines() {
            let Some(rest) = line.trim().strip_prefix("pub use ") else {
                continue;
            };
            let Some((child, items)) = rest.trim_end_matches(';').split_once("::") else {
                continue;
            };
            let child_mod = join(m, child);
            if !mods.contains_key(&child_mod) {
                continue;
            }
            for item in items.trim_matches(|c| c == '{' || c == '}').split(',') {
                let name = item.split(" as ").last().unwrap().trim();
                if !name.is_empty() {
                    out.insert((m.clone(), name.to_string()), child_mod.clone());
                }
            }
        }
    }
    out
}

fn join(a: &str, b: &str) -> String {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_string(),
        (_, true) => a.to_string(),
        _ => format!("{a}::{b}"),
    }
}

struct Graph {
    mods: BTreeMap<String, PathBuf>,
    reexports: BTreeMap<(String, String), String>,
}

impl Graph {
    fn new() -> Graph {
        let mods = modules();
        let reexports = reexports(&mods);
        Graph { mods, reexports }
    }

    /// The module a path (segments from the crate root) names: its longest prefix that is a
    /// module, followed through a re-export.
    fn resolve(&self, segs: &[&str]) -> Option<String> {
        (1..=segs.len()).rev().find_map(|i| {
            let m = segs[..i].join("::");
            if !self.mods.contains_key(&m) {
                return None;
            }
            match segs.get(i) {
                Some(item) => Some(
                    self.reexports
                        .get(&(m.clone(), item.to_string()))
                        .cloned()
                        .unwrap_or(m),
                ),
                None => Some(m),
            }
        })
    }

    /// Module -> the modules its production code names (`crate::` paths, `super::` paths and
    /// private `use child::` imports; a `pub use` of a child is a facade, not a dependency).
    fn edges(&self) -> BTreeMap<String, BTreeSet<String>> {
        let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (m, path) in &self.mods {
            if is_test_file(m) {
                continue;
            }
            let code = production(path);
            let here: Vec<&str> = if m.is_empty() {
                vec![]
            } else {
                m.split("::").collect()
            };
            let mut targets = BTreeSet::new();
            let own = ("crate", crate_module(path));
            let named = ROOTS.iter().map(|(prefix, _, name)| (*name, *prefix));
            for (marker, prefix) in std::iter::once(own).chain(named) {
                for p in crate_paths(&code, marker) {
                    let full: Vec<&str> = prefix
                        .split("::")
                        .filter(|s| !s.is_empty())
                        .chain(p.iter().map(String::as_str))
                        .collect();
                    targets.extend(self.resolve(&full));
                }
            }
            for (ups, p) in super_paths(&code) {
                let base = &here[..here.len().saturating_sub(ups)];
                let full: Vec<&str> = base
                    .iter()
                    .copied()
                    .chain(p.iter().map(String::as_str))
                    .collect();
                targets.extend(self.resolve(&full));
            }
            for line in code.lines() {
                if let Some(rest) = line.trim().strip_prefix("use ")
                    && let Some((child, _)) = rest.split_once("::")
                    && !matches!(child, "crate" | "super" | "self" | "std")
                {
                    let c = join(m, child);
                    if self.mods.contains_key(&c) {
                        targets.insert(c);
                    }
                }
            }
            targets.remove(m);
            out.insert(m.clone(), targets);
        }
        out
    }
}

/// Every path after `crate::` (or after another crate's name, `hydrofit_core::`), groups
/// expanded (`crate::{a::b, c::{d, e}}`).
fn crate_paths(code: &str, krate: &str) -> Vec<Vec<String>> {
    let marker = format!("{krate}::");
    let mut out = Vec::new();
    for (i, _) in code.match_indices(&marker) {
        if code[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        expand(&code[i + marker.len()..], &mut Vec::new(), &mut out);
    }
    out
}

/// `super::` chains and what follows them, as (levels up, path).
fn super_paths(code: &str) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("super::") {
        let before = &rest[..i];
        let after = &rest[i..];
        rest = &rest[i + "super::".len()..];
        if before.ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let mut ups = 0;
        let mut tail = after;
        while let Some(t) = tail.strip_prefix("super::") {
            ups += 1;
            tail = t;
        }
        let mut paths = Vec::new();
        expand(tail, &mut Vec::new(), &mut paths);
        out.extend(paths.into_iter().map(|p| (ups, p)));
        rest = &rest[(after.len() - tail.len()).saturating_sub("super::".len())..];
    }
    out
}

/// Reads one path tree at the start of `s`: `a::b::c`, `a::{b, c::d}`, `{a, b}`.
fn expand(s: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let s = s.trim_start();
    if let Some(group) = s.strip_prefix('{') {
        for item in split_group(group) {
            expand(item, &mut prefix.clone(), out);
        }
        return;
    }
    let ident: String = s
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    if ident.is_empty() {
        if !prefix.is_empty() {
            out.push(prefix.clone());
        }
        return;
    }
    let rest = &s[ident.len()..];
    if ident != "self" {
        prefix.push(ident);
    }
    match rest.strip_prefix("::") {
        Some(r) if !r.starts_with('<') => expand(r, prefix, out),
        _ => out.push(prefix.clone()),
    }
}

/// The top-level items of a `{...}` group (the text after `{`).
fn split_group(s: &str) -> Vec<&str> {
    let (mut depth, mut start, mut items) = (0, 0, Vec::new());
    for (i, ch) in s.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' if depth == 0 => {
                items.push(&s[start..i]);
                return items;
            }
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(&s[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    items
}

/// A circle in `graph`, as the modules along it, if there is one.
fn circle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    // Depth-first search with colours: grey on the stack, black done.
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        colour: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        colour.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for next in graph.get(n).into_iter().flatten() {
            match colour.get(next).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|s| s == next).unwrap();
                    let mut c = stack[at..].to_vec();
                    c.push(next.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(next, graph, colour, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        colour.insert(n.to_string(), 2);
        None
    }
    let mut colour = BTreeMap::new();
    for n in graph.keys() {
        if colour.get(n).copied().unwrap_or(0) == 0
            && let Some(c) = visit(n, graph, &mut colour, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

fn top(m: &str) -> String {
    m.split("::").next().unwrap().to_string()
}

fn folder_graph(edges: &BTreeMap<String, BTreeSet<String>>) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, ts) in edges {
        for t in ts {
            if top(m) != top(t) {
                out.entry(top(m)).or_default().insert(top(t));
            }
        }
    }
    out
}

#[test]
fn no_module_imports_in_a_circle() {
    let edges = Graph::new().edges();
    assert!(edges.len() > 100, "read too few modules: {}", edges.len());
    if let Some(c) = circle(&edges) {
        panic!("import circle: {}", c.join(" -> "));
    }
}

#[test]
fn feature_folders_import_in_one_direction() {
    let folders = folder_graph(&Graph::new().edges());
    if let Some(c) = circle(&folders) {
        panic!("the feature folders import each other: {}", c.join(" -> "));
    }
    assert!(
        folders.get("core").is_none_or(|t| t.is_empty()),
        "`core` names {:?}: what every feature shares cannot depend on a feature",
        folders.get("core")
    );
    assert_eq!(
        folders["pipeline"],
        BTreeSet::from(["core".to_string()]),
        "the engine knows the kinds only through the registry it is given"
    );
}

#[test]
fn only_the_registry_and_the_command_line_name_a_stage_adapter() {
    let edges = Graph::new().edges();
    let allowed = ["kinds", "cli", "cmd", "main", "lib", ""];
    for (m, targets) in &edges {
        for t in targets {
            let is_stage = t.ends_with("::stage");
            let same_feature = top(m) == top(t);
            assert!(
                !is_stage || same_feature || allowed.contains(&top(m).as_str()),
                "`{m}` names the stage adapter `{t}`: move what it needs out of the adapter into \
                 the feature's library"
            );
        }
    }
}

#[test]
fn no_function_is_longer_than_the_limit() {
    let mut long = Vec::new();
    for (m, path) in modules() {
        if is_test_file(&m) {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap();
        let lines: Vec<&str> = code.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            let Some(name) = fn_name(l) else { continue };
            let indent = &l[..l.len() - l.trim_start().len()];
            let Some(open) = (i..lines.len()).find(|&j| {
                let t = lines[j].trim_end();
                t.ends_with('{') || t.ends_with(';')
            }) else {
                continue;
            };
            if lines[open].trim_end().ends_with(';') {
                continue;
            }
            let close = (open + 1..lines.len())
                .find(|&j| lines[j] == format!("{indent}}}"))
                .unwrap_or(lines.len());
            if close - i + 1 > MAX_FN_LINES {
                long.push(format!(
                    "{} `{name}`: {} lines",
                    path.display(),
                    close - i + 1
                ));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines (split them into named steps):\n{}",
        long.join("\n")
    );
}

/// The name of the function a line declares, if it declares one.
fn fn_name(line: &str) -> Option<&str> {
    let mut t = line.trim_start();
    for prefix in [
        "pub(crate) ",
        "pub(super) ",
        "pub ",
        "const ",
        "async ",
        "unsafe ",
    ] {
        t = t.strip_prefix(prefix).unwrap_or(t);
    }
    let rest = t.strip_prefix("fn ")?;
    let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    Some(&rest[..end])
}

#[test]
fn the_architecture_document_names_what_the_code_has() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .unwrap();
    // Folders: every `name/` in the module map's first column.
    let named: BTreeSet<String> = doc
        .lines()
        .filter(|l| l.starts_with("| `"))
        .filter_map(|l| l.split('`').nth(1))
        .filter(|n| n.ends_with('/'))
        .map(|n| n.trim_end_matches('/').to_string())
        .collect();
    let crates = ROOTS.iter().map(|(prefix, _, _)| prefix.to_string());
    let folders: BTreeSet<String> = std::fs::read_dir(src())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
        .chain(crates.filter(|c| !c.is_empty()))
        .collect();
    assert_eq!(
        named, folders,
        "docs/architecture.md's module map against src/'s folders and the crates `core`, `twin`"
    );
    // Stage kinds: the list after "Stage kinds:" in backticks, against the registry.
    let line = doc
        .lines()
        .find(|l| l.starts_with("Stage kinds:"))
        .expect("docs/architecture.md has a `Stage kinds:` line");
    let documented: BTreeSet<String> = line
        .split('`')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect();
    let registered: BTreeSet<String> = hydrofit::kinds::KINDS
        .iter()
        .map(|k| k.name.to_string())
        .collect();
    assert_eq!(
        documented, registered,
        "docs/architecture.md's stage kinds against kinds::KINDS"
    );
}

/// Every source path the documents name in backticks (`src/pool/fusion/nav.rs`,
/// `crates/logs/src/mcap.rs`, `tests/it/e2e_field.rs`) exists: a file moved by a reshape
/// leaves no reader looking for it where it was.
#[test]
fn the_documents_name_source_paths_that_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.push(root.join("README.md"));
    let mut missing = Vec::new();
    for doc in &docs {
        let text = std::fs::read_to_string(doc).unwrap();
        let spans = text
            .lines()
            .filter(|l| !l.trim_start().starts_with("```"))
            .flat_map(|l| l.split('`').skip(1).step_by(2));
        for quoted in spans {
            let named = ["src/", "crates/", "tests/"]
                .iter()
                .any(|p| quoted.starts_with(p));
            let path = quoted.split([':', '#', ' ']).next().unwrap_or_default();
            if named && !path.contains('*') && !root.join(path).exists() {
                missing.push(format!("{}: {quoted}", doc.display()));
            }
        }
    }
    assert!(missing.is_empty(), "paths that do not exist: {missing:#?}");
}

#[test]
fn the_graph_reader_sees_grouped_imports_and_super_chains() {
    let found = crate_paths(
        "use crate::{a::b, c, d::{e, f}};\nlet x = crate::g::h::<T>();",
        "crate",
    );
    let want: Vec<Vec<String>> = [
        vec!["a", "b"],
        vec!["c"],
        vec!["d", "e"],
        vec!["d", "f"],
        vec!["g", "h"],
    ]
    .iter()
    .map(|v| v.iter().map(|s| s.to_string()).collect())
    .collect();
    assert_eq!(found, want);
    let sup = super_paths("use super::super::{x::Y, z};");
    assert_eq!(
        sup,
        vec![
            (2, vec!["x".to_string(), "Y".to_string()]),
            (2, vec!["z".to_string()])
        ]
    );
}
