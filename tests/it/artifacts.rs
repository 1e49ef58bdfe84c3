//! A stage never fails on its own cache file because of a number the stage before it wrote:
//! every artifact of real builds (the shipped project, the field-trial identifiers' examples)
//! is read back by its own type with every float in it replaced by what a non-finite number is
//! written as (`{"not_finite": "NaN" | "+inf" | "-inf"}`), and by `null` (what older caches and
//! serde_json wrote). A field that cannot take it is named.

use crate::common::{example, ok, project};
use std::path::Path;

/// Every number with a fraction or an exponent (how a float is written) as `null`.
fn null_floats(json: &str) -> String {
    replace_floats(json, |_| "null".into())
}

/// Every float as the tagged non-finite value, NaN, +inf and -inf in turn.
fn tag_floats(json: &str) -> String {
    let words = ["NaN", "+inf", "-inf"];
    replace_floats(json, |i| {
        format!("{{\"not_finite\": \"{}\"}}", words[i % 3])
    })
}

/// Every number with a fraction or an exponent as `with(its index)`.
fn replace_floats(json: &str, with: impl Fn(usize) -> String) -> String {
    let mut count = 0;
    let b = json.as_bytes();
    let mut out = String::with_capacity(json.len());
    let mut i = 0;
    let mut in_string = false;
    while i < b.len() {
        let c = b[i] as char;
        if in_string {
            out.push(c);
            if c == '\\' && i + 1 < b.len() {
                out.push(b[i + 1] as char);
                i += 2;
                continue;
            }
            in_string = c != '"';
            i += 1;
            continue;
        }
        if c == '"' {
            in_string = true;
            out.push(c);
            i += 1;
            continue;
        }
        if c == '-' || c.is_ascii_digit() {
            let start = i;
            while i < b.len() && matches!(b[i] as char, '-' | '+' | '.' | 'e' | 'E' | '0'..='9') {
                i += 1;
            }
            let n = &json[start..i];
            if n.contains(['.', 'e', 'E']) {
                out.push_str(&with(count));
                count += 1;
            } else {
                out.push_str(n);
            }
            continue;
        }
        out.push(c);
        i += 1;
    }
    out
}

/// Reads `text` as the artifact `name`, by its type.
fn read_as(name: &str, text: &str) -> Result<(), String> {
    use hydrofit::*;
    let r = |e: serde_json::Error| e.to_string();
    match name {
        "fit.json" => hydrofit::core::lenient::from_str::<identify::result::FitResult>(text)
            .map(drop)
            .map_err(r),
        "field.json" => hydrofit::core::lenient::from_str::<field::FieldResult>(text)
            .map(drop)
            .map_err(r),
        "compare.json" => hydrofit::core::lenient::from_str::<compare::artifact::Comparison>(text)
            .map(drop)
            .map_err(r),
        "diagnosis.json" => hydrofit::core::lenient::from_str::<diagnose::Diagnosis>(text)
            .map(drop)
            .map_err(r),
        "figures.json" => hydrofit::core::lenient::from_str::<Vec<diagnose::Figure>>(text)
            .map(drop)
            .map_err(r),
        "scores.json" => hydrofit::core::lenient::from_str::<validate::pool::Scores>(text)
            .map(drop)
            .map_err(r),
        "run.json" => hydrofit::core::lenient::from_str::<pool::fusion::run::RunMeta>(text)
            .map(drop)
            .map_err(r),
        "response.json" => hydrofit::core::lenient::from_str::<core::response::ResponseMeta>(text)
            .map(drop)
            .map_err(r),
        "track.json" => hydrofit::core::lenient::from_str::<cfd::openfoam::Track>(text)
            .map(drop)
            .map_err(r),
        n if n.starts_with("sim__") => {
            hydrofit::core::lenient::from_str::<validate::pool::Simulated>(text)
                .map(drop)
                .map_err(r)
        }
        _ => Ok(()),
    }
}

fn check_objects(
    root: &Path,
    seen: &mut std::collections::BTreeSet<String>,
    bad: &mut Vec<String>,
) {
    for entry in walk(&root.join(".hydrofit/objects")) {
        let name = entry.file_name().unwrap().to_string_lossy().to_string();
        // The report's object holds the published files, whose shapes docs/formats.md fixes
        // for other tools: no stage reads them back.
        let published = entry
            .parent()
            .is_some_and(|d| d.join("index.html").exists());
        if !name.ends_with(".json") || name.starts_with('.') || published {
            continue;
        }
        let text = std::fs::read_to_string(&entry).unwrap();
        read_as(&name, &text).unwrap_or_else(|e| panic!("{name} as written does not read: {e}"));
        for (how, altered) in [("null", null_floats(&text)), ("tagged", tag_floats(&text))] {
            if let Err(e) = read_as(&name, &altered) {
                bad.push(format!("{name} ({how}): {e}"));
            }
        }
        seen.insert(name.split("__").next().unwrap().to_string());
    }
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn every_artifact_reads_back_with_its_floats_absent() {
    let mut seen = std::collections::BTreeSet::new();
    let mut bad = Vec::new();
    let p = project();
    ok(p.path(), &["build"]);
    check_objects(p.path(), &mut seen, &mut bad);
    for name in ["tank_submarine", "dsrv", "field_rov"] {
        let e = example(name);
        ok(e.path(), &["build"]);
        check_objects(e.path(), &mut seen, &mut bad);
    }
    for kind in [
        "fit.json",
        "field.json",
        "compare.json",
        "diagnosis.json",
        "scores.json",
        "run.json",
        "response.json",
        "track.json",
        "sim",
    ] {
        assert!(
            seen.contains(kind),
            "no {kind} among the builds' artifacts: {seen:?}"
        );
    }
    assert!(
        bad.is_empty(),
        "artifacts a non-finite number breaks:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_float_nuller_leaves_integers_and_strings() {
    assert_eq!(
        null_floats(r#"{"a": 1.5, "b": 3, "c": "x 2.5", "d": [-1e-3, 7], "e": "q\"1.0"}"#),
        r#"{"a": null, "b": 3, "c": "x 2.5", "d": [null, 7], "e": "q\"1.0"}"#
    );
    assert_eq!(
        tag_floats(r#"[1.5, 2, 1e3, -0.5]"#),
        r#"[{"not_finite": "NaN"}, 2, {"not_finite": "+inf"}, {"not_finite": "-inf"}]"#
    );
}
