//! A case series: one template case and a sweep of its parameters, defined in
//! `pipeline.yaml`, expanded into one case folder per combination. A parameter is a
//! top-level entry of one of the template's dictionaries (`appliedForce 2;` in
//! `constant/dynamicMeshDict`); each case is the template with those entries' values
//! replaced, written where a run by hand would find it, so a new value is one new case.

use crate::core::provenance::InputFile;
use crate::pipeline::contract::Variant;
use serde::{Deserialize, Serialize};
use serde_yaml_ng::Value;
use std::path::Path;

/// The `series:` settings of an OpenFOAM stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Series {
    /// Folder the cases are written to, one sub-folder each, relative to the project
    /// (default `cases/cfd/<stage>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cases: Option<String>,
    /// A case's folder name, `{parameter}` standing for the label of its value
    /// (default: the labels joined by `_`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Parameter -> its values, in order. A list sets the entry named like the parameter to
    /// each value (labelled by itself); a map gives each value a label, and a value that is
    /// itself a map sets several entries at once (`x: {dirX: 1, dirY: 0, dirZ: 0}`).
    pub sweep: serde_yaml_ng::Mapping,
}

/// One value of a parameter: its label and the entries it sets.
#[derive(Debug, Clone, PartialEq)]
struct Level {
    label: String,
    entries: Vec<(String, String)>,
}

/// A YAML scalar as it goes into a dictionary.
fn scalar(v: &Value) -> Option<String> {
    match v {
        Value::Number(n) => Some(n.to_string()),
        Value::String(s) => Some(s.clone()),
        Value::Bool(b) => Some(if *b { "yes" } else { "no" }.to_string()),
        _ => None,
    }
}

/// An entry name a dictionary can hold as a plain word.
fn entry_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | ':'))
        && !s.starts_with(|c: char| c.is_ascii_digit())
}

/// A value written into a dictionary must not end its entry or open a block.
fn entry_value(s: &str) -> bool {
    !s.trim().is_empty() && !s.contains([';', '{', '}', '\n', '"']) && !s.contains("//")
}

impl Series {
    /// The parameters and their levels, checked.
    fn parameters(&self) -> Result<Vec<(String, Vec<Level>)>, String> {
        if self.sweep.is_empty() {
            return Err(
                "`series.sweep` is empty: give at least one parameter and its values".into(),
            );
        }
        let mut out = Vec::new();
        for (k, v) in &self.sweep {
            let name = scalar(k).ok_or("a sweep parameter must be a name")?;
            let level = |label: String, v: &Value| -> Result<Level, String> {
                let entries = match v {
                    Value::Mapping(m) => m
                        .iter()
                        .map(|(e, x)| {
                            let e = scalar(e).unwrap_or_default();
                            let x = scalar(x).ok_or_else(|| {
                                format!("`{name}: {label}`: the value of `{e}` must be a number or a word")
                            })?;
                            Ok((e, x))
                        })
                        .collect::<Result<Vec<_>, String>>()?,
                    other => vec![(
                        name.clone(),
                        scalar(other).ok_or_else(|| {
                            format!("`{name}`: a value must be a number, a word or a map of entries")
                        })?,
                    )],
                };
                for (e, x) in &entries {
                    if !entry_name(e) {
                        return Err(format!(
                            "`{e}` (in `{name}`) is not a dictionary entry name"
                        ));
                    }
                    if !entry_value(x) {
                        return Err(format!(
                            "`{e}: {x}` (in `{name}`) cannot be written as an entry's value (no `;`, braces, quotes or comments)"
                        ));
                    }
                }
                Ok(Level { label, entries })
            };
            let levels = match v {
                Value::Sequence(s) => s
                    .iter()
                    .map(|x| level(scalar(x).unwrap_or_default(), x))
                    .collect::<Result<Vec<_>, _>>()?,
                Value::Mapping(m) => m
                    .iter()
                    .map(|(l, x)| level(scalar(l).unwrap_or_default(), x))
                    .collect::<Result<Vec<_>, _>>()?,
                _ => {
                    return Err(format!(
                        "`{name}`: give its values as a list or a map of labels to values"
                    ));
                }
            };
            if levels.is_empty() {
                return Err(format!("`{name}` has no values"));
            }
            out.push((name, levels));
        }
        Ok(out)
    }

    /// One variant per combination of the parameters' levels (the first parameter varies
    /// slowest), named by `name` or the labels.
    pub fn variants(&self) -> Result<Vec<Variant>, String> {
        if let Some(c) = &self.cases {
            let p = Path::new(c);
            if c.trim().is_empty()
                || p.is_absolute()
                || p.components()
                    .any(|c| !matches!(c, std::path::Component::Normal(_)))
            {
                return Err(format!(
                    "`series.cases: {c}` must be a folder inside the project, relative to it, without `..` (e.g. cases/cfd/sphere)"
                ));
            }
        }
        let params = self.parameters()?;
        let total: usize = params.iter().map(|(_, l)| l.len()).product();
        if total > 10_000 {
            return Err(format!(
                "the sweep makes {total} cases; split it into stages of at most 10000"
            ));
        }
        let mut out: Vec<Variant> = Vec::with_capacity(total);
        let mut seen = std::collections::BTreeMap::new();
        for n in 0..total {
            let mut rest = n;
            let mut chosen = vec![&params[0].1[0]; params.len()];
            for (j, (_, levels)) in params.iter().enumerate().rev() {
                chosen[j] = &levels[rest % levels.len()];
                rest /= levels.len();
            }
            let name = match &self.name {
                Some(pattern) => {
                    let mut s = pattern.clone();
                    for ((p, _), l) in params.iter().zip(&chosen) {
                        s = s.replace(&format!("{{{p}}}"), &l.label);
                    }
                    s
                }
                None => chosen
                    .iter()
                    .map(|l| l.label.as_str())
                    .collect::<Vec<_>>()
                    .join("_"),
            };
            let name = folder_name(&name);
            if name.contains(['{', '}']) {
                return Err(format!(
                    "`series.name` ({}) names a parameter the sweep does not have; the parameters are {}",
                    self.name.as_deref().unwrap_or(""),
                    params
                        .iter()
                        .map(|(p, _)| format!("`{p}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            if let Some(first) = seen.insert(name.clone(), n) {
                return Err(format!(
                    "cases {} and {} of the sweep are both named `{name}`: put every parameter in `series.name`",
                    first + 1,
                    n + 1
                ));
            }
            let mut entries: Vec<(String, String)> = Vec::new();
            for l in &chosen {
                for (e, x) in &l.entries {
                    if entries.iter().any(|(f, _)| f == e) {
                        return Err(format!(
                            "the entry `{e}` is set by two parameters of the sweep"
                        ));
                    }
                    entries.push((e.clone(), x.clone()));
                }
            }
            out.push(Variant {
                name,
                params: entries,
            });
        }
        Ok(out)
    }

    /// The folder of the series' cases, relative to the project.
    pub fn cases_dir(&self, stage: &str) -> String {
        self.cases
            .clone()
            .unwrap_or_else(|| format!("cases/cfd/{stage}"))
            .trim_end_matches('/')
            .to_string()
    }
}

/// A case folder's name: path separators and blanks become `_`.
fn folder_name(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| {
            if c.is_whitespace() || matches!(c, '/' | '\\' | '(' | ')' | '"' | '\'') {
                '_'
            } else {
                c
            }
        })
        .collect();
    let s = s.trim_matches('_').to_string();
    if s.is_empty() || s == "." || s == ".." {
        "case".into()
    } else {
        s
    }
}

/// `text` with the value of its top-level entry `key` replaced by `value`, or `None` when
/// it has no such entry. Comments, strings and nested dictionaries are skipped over; the
/// rest of the text (comments after the value included) is kept as it was.
pub fn set_top_level(text: &str, key: &str, value: &str) -> Option<String> {
    let b = text.as_bytes();
    let (mut i, mut depth) = (0usize, 0i32);
    let mut at_start = true; // at the start of a statement
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                i += 2;
                while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                    i += 1;
                }
                i += 2;
            }
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += 1 + usize::from(b[i] == b'\\');
                }
                i += 1;
                at_start = false;
            }
            b'{' => {
                depth += 1;
                i += 1;
                at_start = true;
            }
            b'}' => {
                depth -= 1;
                i += 1;
                at_start = true;
            }
            b';' => {
                i += 1;
                at_start = true;
            }
            c if c.is_ascii_whitespace() => i += 1,
            _ => {
                let start = i;
                while i < b.len() && !b[i].is_ascii_whitespace() && !b";{}\"".contains(&b[i]) {
                    i += 1;
                }
                if depth == 0 && at_start && &text[start..i] == key {
                    // The value: up to the `;` that ends the entry, outside brackets.
                    let v0 = i;
                    let (mut j, mut paren) = (i, 0i32);
                    while j < b.len() {
                        match b[j] {
                            b'(' => paren += 1,
                            b')' => paren -= 1,
                            b';' if paren <= 0 => break,
                            b'{' | b'}' => return None,
                            _ => {}
                        }
                        j += 1;
                    }
                    if j >= b.len() {
                        return None;
                    }
                    let lead = text[v0..j].len() - text[v0..j].trim_start().len();
                    let pad = if lead == 0 { " " } else { &text[v0..v0 + lead] };
                    return Some(format!("{}{pad}{value}{}", &text[..v0], &text[j..]));
                }
                at_start = false;
            }
        }
    }
    None
}

/// Writes case `name` of the series: the template's input files (`template`, paths relative
/// to the project), each top-level entry of `params` set in the one file that defines it.
/// Files are written only where they differ, and input files the template no longer has are
/// removed (results left in the folder are kept). Returns the case's input files.
pub fn write_case(
    root: &Path,
    template: &[InputFile],
    template_rel: &str,
    case_rel: &str,
    params: &[(String, String)],
) -> anyhow::Result<Vec<InputFile>> {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for f in template {
        let rel = f.path[template_rel.len() + 1..].to_string();
        files.push((rel, std::fs::read(root.join(&f.path))?));
    }
    for (key, value) in params {
        let mut hits = Vec::new();
        for (rel, bytes) in files.iter_mut() {
            let Ok(text) = std::str::from_utf8(bytes) else {
                continue;
            };
            if let Some(new) = set_top_level(text, key, value) {
                hits.push(rel.clone());
                *bytes = new.into_bytes();
            }
        }
        anyhow::ensure!(
            !hits.is_empty(),
            crate::core::diag::InputError::file(
                template_rel,
                format!(
                    "no dictionary of the template case has a top-level entry `{key}` for the sweep to set"
                ),
                format!(
                    "add `{key} <value>;` at the top of the dictionary it belongs in (e.g. constant/dynamicMeshDict) and refer to it as ${key}"
                ),
            )
        );
        anyhow::ensure!(
            hits.len() == 1,
            crate::core::diag::InputError::file(
                template_rel,
                format!(
                    "the top-level entry `{key}` is defined in {}: the sweep cannot tell which to set",
                    hits.join(" and ")
                ),
                "define it once, and #include that dictionary or refer to it where it is needed",
            )
        );
    }
    let dir = root.join(case_rel);
    let mut out = Vec::new();
    for (rel, bytes) in &files {
        let to = dir.join(rel);
        if std::fs::read(&to).ok().as_deref() != Some(bytes.as_slice()) {
            std::fs::create_dir_all(to.parent().expect("has a parent"))?;
            crate::core::fsutil::write_atomic(&to, bytes)?;
        }
        out.push(InputFile::new(
            format!("{case_rel}/{rel}"),
            blake3::hash(bytes).to_hex().to_string(),
        ));
    }
    // Input files an earlier template had: a run by hand would read them.
    for rel in crate::core::fsutil::files_under(&dir, true)? {
        if super::is_case_input(&rel) && !files.iter().any(|(r, _)| *r == rel) {
            std::fs::remove_file(dir.join(&rel))?;
        }
    }
    Ok(out)
}

/// The template case's folder: the one holding `system/controlDict` among `inputs`, the
/// files stage `stage` declares.
pub fn template_folder(stage: &str, inputs: &[InputFile]) -> anyhow::Result<String> {
    if inputs.is_empty() {
        anyhow::bail!(
            "stage `{stage}`: its `inputs` match no file, so the series has no template case\n  help: copy an OpenFOAM case (system/controlDict, constant/dynamicMeshDict, 0/, ...) into the folder the stage's `inputs` name, or correct the pattern in pipeline.yaml"
        );
    }
    inputs
        .iter()
        .find_map(|i| i.path.strip_suffix("/system/controlDict"))
        .map(str::to_string)
        .ok_or_else(|| {
            let first = &inputs[0].path;
            let folder = first.rsplit_once('/').map_or(first.as_str(), |(d, _)| d);
            anyhow::anyhow!(
                "{folder}: the series' template is not an OpenFOAM case: none of the {} files the stage `{stage}` reads is a system/controlDict\n  help: the stage's `inputs` must take in the whole template case folder (e.g. `cases/cfd/template/**`)",
                inputs.len()
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(yaml: &str) -> Series {
        serde_yaml_ng::from_str(yaml).unwrap()
    }

    #[test]
    fn a_sweep_expands_to_every_combination() {
        let s = series(
            "name: 'sphere_{force}N_{direction}'\nsweep:\n  force: [0.5, 2]\n  direction:\n    x: {dirX: 1, dirZ: 0}\n    z: {dirX: 0, dirZ: 1}\n",
        );
        let v = s.variants().unwrap();
        let names: Vec<&str> = v.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "sphere_0.5N_x",
                "sphere_0.5N_z",
                "sphere_2N_x",
                "sphere_2N_z"
            ]
        );
        assert_eq!(
            v[3].params,
            [("force", "2"), ("dirX", "0"), ("dirZ", "1")]
                .map(|(a, b)| (a.to_string(), b.to_string()))
        );
        // Without a pattern: the labels.
        let s = series("sweep: {appliedForce: [1, 4], mass: {light: 5, heavy: 9}}");
        let names: Vec<String> = s.variants().unwrap().into_iter().map(|v| v.name).collect();
        assert_eq!(names, ["1_light", "1_heavy", "4_light", "4_heavy"]);
    }

    #[test]
    fn bad_sweeps_are_refused_with_the_reason() {
        for (yaml, says) in [
            ("sweep: {}", "empty"),
            ("sweep: {force: []}", "no values"),
            ("sweep: {force: 3}", "list or a map"),
            ("name: 'c_{forse}'\nsweep: {force: [1, 2]}", "c_{forse}"),
            ("name: c\nsweep: {force: [1, 2]}", "both named `c`"),
            ("sweep: {force: ['1; endTime 9']}", "cannot be written"),
            ("sweep: {'bad name': [1]}", "not a dictionary entry name"),
            ("sweep: {a: {x: {g: 1}}, g: [2]}", "set by two parameters"),
            (
                "cases: ../elsewhere\nsweep: {force: [1]}",
                "inside the project",
            ),
            ("cases: /tmp/x\nsweep: {force: [1]}", "inside the project"),
        ] {
            let e = series(yaml).variants().unwrap_err();
            assert!(e.contains(says), "{yaml}: {e}");
        }
    }

    #[test]
    fn only_the_top_level_entry_is_set() {
        let text = "FoamFile { object d; }\n// force 9; in a comment\nappliedForce    2;    // N\nbodyMass 8;\ncoeffs\n{\n    appliedForce 7;\n    g (#eval{ $appliedForce / $bodyMass } 0 0);\n}\n";
        let out = set_top_level(text, "appliedForce", "0.5").unwrap();
        assert!(out.contains("appliedForce    0.5;    // N"), "{out}");
        assert!(out.contains("    appliedForce 7;"));
        assert!(out.contains("// force 9; in a comment"));
        let d = crate::cfd::openfoam::dict::parse(&out).unwrap();
        assert_eq!(
            crate::cfd::openfoam::dict::numbers(&[&d], "appliedForce").unwrap(),
            [0.5]
        );
        // A vector value, and entries that are not there at the top.
        let v = set_top_level("direction (1 0 0);\n", "direction", "(0 0 1)").unwrap();
        assert_eq!(v, "direction (0 0 1);\n");
        assert!(set_top_level(text, "g", "1").is_none());
        assert!(set_top_level(text, "object", "x").is_none());
        assert!(set_top_level(text, "missing", "1").is_none());
    }

    #[test]
    fn cases_are_written_from_the_template_and_kept_in_step() {
        let root = tempfile::tempdir().unwrap();
        let r = root.path();
        let t = "tpl";
        std::fs::create_dir_all(r.join("tpl/system")).unwrap();
        std::fs::create_dir_all(r.join("tpl/constant")).unwrap();
        std::fs::write(
            r.join("tpl/system/controlDict"),
            "application pimpleFoam;\nendTime 2;\n",
        )
        .unwrap();
        std::fs::write(r.join("tpl/constant/dyn"), "appliedForce 1;\nbodyMass 8;\n").unwrap();
        let inputs = |paths: &[&str]| -> Vec<InputFile> {
            paths
                .iter()
                .map(|p| InputFile::new(p.to_string(), String::new()))
                .collect()
        };
        let tpl = inputs(&["tpl/system/controlDict", "tpl/constant/dyn"]);
        let params = vec![("appliedForce".to_string(), "4".to_string())];
        let files = write_case(r, &tpl, t, "runs/f4", &params).unwrap();
        assert_eq!(files.len(), 2);
        let dyn_text = std::fs::read_to_string(r.join("runs/f4/constant/dyn")).unwrap();
        assert_eq!(dyn_text, "appliedForce 4;\nbodyMass 8;\n");
        assert_eq!(
            files[1].blake3,
            blake3::hash(dyn_text.as_bytes()).to_hex().to_string()
        );
        // Results left in the case stay; an input the template dropped goes.
        std::fs::write(r.join("runs/f4/log.pimpleFoam"), "End\n").unwrap();
        std::fs::write(r.join("runs/f4/constant/old"), "x 1;\n").unwrap();
        write_case(r, &tpl, t, "runs/f4", &params).unwrap();
        assert!(r.join("runs/f4/log.pimpleFoam").exists());
        assert!(!r.join("runs/f4/constant/old").exists());
        // An entry no dictionary has, or two define.
        let e = write_case(r, &tpl, t, "runs/x", &[("mass".into(), "3".into())]).unwrap_err();
        assert!(e.to_string().contains("top-level entry `mass`"), "{e}");
        std::fs::write(
            r.join("tpl/system/controlDict"),
            "application pimpleFoam;\nbodyMass 1;\n",
        )
        .unwrap();
        let e = write_case(r, &tpl, t, "runs/x", &[("bodyMass".into(), "3".into())]).unwrap_err();
        assert!(e.to_string().contains("defined in"), "{e}");
    }
}
