//! `pipeline.yaml`: the vehicle and the named stages, parsed with every error located.

use super::contract::{self, Kind, Registry, StageImpl};
use super::locate::KeyIndex;
use crate::diag::{InputError, nearest};
use crate::model::Vehicle;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::sync::Arc;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    vehicle: Vehicle,
    stages: BTreeMap<String, RawStage>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStage {
    kind: String,
    #[serde(default)]
    inputs: Vec<String>,
    #[serde(default)]
    from: Vec<String>,
    #[serde(default)]
    settings: Option<serde_yaml_ng::Value>,
}

/// One stage as declared: its kind, parsed settings, input globs and upstream stages.
#[derive(Clone)]
pub struct StageSpec {
    pub name: String,
    pub kind: &'static Kind,
    pub imp: Arc<dyn StageImpl>,
    pub inputs: Vec<String>,
    pub from: Vec<String>,
}

#[derive(Clone)]
pub struct Spec {
    pub path: String,
    pub vehicle: Vehicle,
    /// Stages in dependency order (every stage after the ones it reads from).
    pub stages: Vec<StageSpec>,
}

impl Spec {
    pub fn stage(&self, name: &str) -> Option<&StageSpec> {
        self.stages.iter().find(|s| s.name == name)
    }
}

/// Splits serde's message into the text and, for unknown keys or values, a suggestion.
fn with_suggestion(msg: &str) -> (String, String) {
    let msg = msg
        .rfind(" at line ")
        .map_or(msg, |i| &msg[..i])
        .to_string();
    let unknown = ["unknown field `", "unknown variant `"]
        .iter()
        .find_map(|p| {
            let i = msg.find(p)? + p.len();
            Some(msg[i..].split('`').next()?.to_string())
        });
    let candidates: Vec<&str> = msg
        .split("expected")
        .nth(1)
        .map_or(vec![], |s| s.split('`').skip(1).step_by(2).collect());
    let fix = match unknown
        .as_deref()
        .and_then(|u| nearest(u, candidates.iter().copied()))
    {
        Some(s) => format!("did you mean `{s}`?"),
        None if !candidates.is_empty() => format!(
            "use one of {}",
            candidates
                .iter()
                .map(|c| format!("`{c}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None => "see the README's description of pipeline.yaml".into(),
    };
    (msg, fix)
}

pub struct Parser<'a> {
    path: &'a str,
    kinds: Registry,
    text: &'a str,
    index: KeyIndex,
}

impl<'a> Parser<'a> {
    fn error(&self, key_path: &str, what: impl Into<String>, fix: impl Into<String>) -> InputError {
        let e = InputError::file(self.path, what, fix);
        match self.index.find(key_path) {
            Some((l, c)) => e.at(l, Some(c)).with_source(self.text),
            None => e,
        }
    }

    fn serde_error(&self, key_path: &str, e: &serde_yaml_ng::Error) -> InputError {
        let (what, fix) = with_suggestion(&e.to_string());
        let quoted = |p: &str| {
            what.split(p)
                .nth(1)
                .and_then(|s| s.split('`').next())
                .map(str::to_string)
        };
        let (field, variant) = (quoted("unknown field `"), quoted("unknown variant `"));
        if let Some(loc) = e.location() {
            return InputError::file(self.path, what, fix)
                .at(loc.line(), Some(loc.column()))
                .with_source(self.text);
        }
        if let Some(f) = field {
            return self.error(&format!("{key_path}.{f}"), what, fix);
        }
        match variant.and_then(|v| self.value_after(key_path, &v)) {
            Some((l, c)) => InputError::file(self.path, what, fix)
                .at(l, Some(c))
                .with_source(self.text),
            None => self.error(key_path, what, fix),
        }
    }

    /// Where `value` is first written as a value at or below the line of `key_path`.
    fn value_after(&self, key_path: &str, value: &str) -> Option<(usize, usize)> {
        let (start, _) = self.index.find(key_path)?;
        self.text
            .lines()
            .enumerate()
            .skip(start - 1)
            .find_map(|(i, l)| {
                let (_, v) = l.split_once(':')?;
                let col = l.len() - v.len() + v.find(value)? + 1;
                (v.trim().trim_matches(['"', '\'']) == value).then_some((i + 1, col))
            })
    }
}

/// Parses and checks `text` (the contents of `path`); stage kinds are looked up in `kinds`.
pub fn parse(path: &str, text: &str, kinds: Registry) -> Result<Spec, InputError> {
    let p = Parser {
        path,
        kinds,
        text,
        index: KeyIndex::new(text),
    };
    let raw: RawSpec = serde_yaml_ng::from_str(text).map_err(|e| p.serde_error("", &e))?;
    let problems = raw.vehicle.problems();
    if let Some(first) = problems.first() {
        return Err(p.error(
            "vehicle",
            format!("vehicle: {first}"),
            problems[1..].join("; "),
        ));
    }
    let mut stages = Vec::new();
    for (name, rs) in &raw.stages {
        stages.push(check_stage(&p, name, rs, &raw.stages)?);
    }
    let order = topo_order(&p, &stages)?;
    let stages = order.into_iter().map(|i| stages[i].clone()).collect();
    Ok(Spec {
        path: path.to_string(),
        vehicle: raw.vehicle,
        stages,
    })
}

fn check_stage(
    p: &Parser,
    name: &str,
    rs: &RawStage,
    all: &BTreeMap<String, RawStage>,
) -> Result<StageSpec, InputError> {
    let at = format!("stages.{name}");
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(p.error(
            &at,
            format!("stage name `{name}` has characters other than letters, digits, `_` and `-`"),
            "rename the stage",
        ));
    }
    let kind = contract::find(p.kinds, &rs.kind).ok_or_else(|| {
        let names = p.kinds.iter().map(|k| k.name);
        let fix = match nearest(&rs.kind, names.clone()) {
            Some(s) => format!("did you mean `{s}`?"),
            None => format!(
                "use one of {}",
                names
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        p.error(
            &format!("{at}.kind"),
            format!("stage `{name}`: unknown kind `{}`", rs.kind),
            fix,
        )
    })?;
    let settings = rs
        .settings
        .clone()
        .unwrap_or(serde_yaml_ng::Value::Mapping(Default::default()));
    let imp = (kind.parse)(settings).map_err(|e| p.serde_error(&format!("{at}.settings"), &e))?;
    if kind.fan_out && rs.inputs.is_empty() {
        return Err(p.error(
            &at,
            format!("stage `{name}` ({}) has no inputs", kind.name),
            "add `inputs: [\"cases/...\"]` with the globs of the files it imports",
        ));
    }
    if !kind.fan_out && !kind.reads_files && !rs.inputs.is_empty() {
        return Err(p.error(
            &format!("{at}.inputs"),
            format!(
                "stage `{name}` ({}) takes no input files; it reads other stages' results",
                kind.name
            ),
            "remove `inputs` and list the stages it reads under `from`",
        ));
    }
    for g in &rs.inputs {
        if let Err(e) = glob::Pattern::new(g) {
            return Err(p.error(
                &format!("{at}.inputs"),
                format!("bad glob `{g}`: {e}"),
                "fix the pattern (`*` any name, `**` any folders)",
            ));
        }
        if g.starts_with('/') || g.split('/').any(|c| c == "..") {
            return Err(p.error(
                &format!("{at}.inputs"),
                format!("input `{g}` is outside the project"),
                "use a path relative to the project folder, e.g. cases/cfd/starccm/*.csv",
            ));
        }
    }
    for f in &rs.from {
        let Some(up) = all.get(f) else {
            let fix = nearest(f, all.keys().map(|s| s.as_str()))
                .map_or("list only stages defined under `stages`".into(), |s| {
                    format!("did you mean `{s}`?")
                });
            return Err(p.error(
                &format!("{at}.from"),
                format!("stage `{name}` reads from `{f}`, which is not a stage"),
                fix,
            ));
        };
        let up_kind = contract::find(p.kinds, &up.kind).map(|k| k.produces);
        if up_kind.is_some_and(|a| !kind.consumes.contains(&a)) {
            return Err(p.error(
                &format!("{at}.from"),
                format!(
                    "stage `{name}` ({}) cannot read from `{f}` ({}), which produces {}",
                    kind.name,
                    up.kind,
                    up_kind.unwrap().describe()
                ),
                format!(
                    "a {} stage reads {}",
                    kind.name,
                    kind.consumes
                        .iter()
                        .map(|a| a.describe())
                        .collect::<Vec<_>>()
                        .join(" and ")
                ),
            ));
        }
    }
    for need in kind.requires {
        if !rs.from.iter().any(|f| {
            all.get(f)
                .and_then(|s| contract::find(p.kinds, &s.kind))
                .is_some_and(|k| k.produces == *need)
        }) {
            return Err(p.error(
                &at,
                format!(
                    "stage `{name}` ({}) needs a stage that produces {} under `from`",
                    kind.name,
                    need.describe()
                ),
                format!(
                    "add such a stage to `from: [...]` (e.g. {})",
                    need.example()
                ),
            ));
        }
    }
    let produces = |f: &String| {
        all.get(f)
            .and_then(|s| contract::find(p.kinds, &s.kind))
            .map(|k| k.produces)
    };
    if !kind.requires_one_of.is_empty()
        && !rs
            .from
            .iter()
            .any(|f| produces(f).is_some_and(|a| kind.requires_one_of.contains(&a)))
    {
        let what: Vec<&str> = kind.requires_one_of.iter().map(|a| a.describe()).collect();
        let examples: Vec<&str> = kind.requires_one_of.iter().map(|a| a.example()).collect();
        return Err(p.error(
            &at,
            format!(
                "stage `{name}` ({}) needs a stage that produces {} under `from`",
                kind.name,
                what.join(" or ")
            ),
            format!(
                "add such a stage to `from: [...]` ({})",
                examples.join(" or ")
            ),
        ));
    }
    Ok(StageSpec {
        name: name.to_string(),
        kind,
        imp,
        inputs: rs.inputs.clone(),
        from: rs.from.clone(),
    })
}

/// Orders stages so each follows its upstream; a cycle is reported as `a -> b -> a`.
fn topo_order(p: &Parser, stages: &[StageSpec]) -> Result<Vec<usize>, InputError> {
    let idx: BTreeMap<&str, usize> = stages
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    // 0 = unvisited, 1 = on the current path, 2 = done.
    let mut state = vec![0u8; stages.len()];
    let mut order = Vec::new();
    fn visit(
        i: usize,
        stages: &[StageSpec],
        idx: &BTreeMap<&str, usize>,
        state: &mut [u8],
        path: &mut Vec<usize>,
        order: &mut Vec<usize>,
    ) -> Result<(), Vec<usize>> {
        match state[i] {
            2 => return Ok(()),
            1 => {
                let start = path.iter().position(|&j| j == i).unwrap_or(0);
                let mut cycle = path[start..].to_vec();
                cycle.push(i);
                return Err(cycle);
            }
            _ => {}
        }
        state[i] = 1;
        path.push(i);
        for f in &stages[i].from {
            visit(idx[f.as_str()], stages, idx, state, path, order)?;
        }
        path.pop();
        state[i] = 2;
        order.push(i);
        Ok(())
    }
    for i in 0..stages.len() {
        if let Err(cycle) = visit(i, stages, &idx, &mut state, &mut Vec::new(), &mut order) {
            let names: Vec<&str> = cycle.iter().map(|&j| stages[j].name.as_str()).collect();
            return Err(p.error(&format!("stages.{}.from", names[0]), format!("the stages form a cycle: {}", names.join(" -> ")), "a stage cannot read, directly or not, from itself: remove one of these `from` entries"));
        }
    }
    Ok(order)
}

#[cfg(test)]
mod tests;
