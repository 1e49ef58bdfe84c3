//! `pipeline.yaml`: the vehicle and the named stages, parsed with every error located.

use super::contract::{self, Artifact, Kind, Registry, StageImpl};
use super::locate::KeyIndex;
use crate::core::diag::{InputError, nearest};
use crate::core::model::Vehicle;
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
        None if !candidates.is_empty() => use_one_of(candidates.iter().copied()),
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
        // A setting's own check names its key: "`slurm.mem`: ...". The nearest key written
        // on a line of its own (a flow mapping's keys share their parent's line).
        if let Some(sub) = what
            .strip_prefix('`')
            .and_then(|w| w.split_once("`: "))
            .map(|(k, _)| k)
            .filter(|k| {
                k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "._".contains(c))
            })
        {
            let mut path = format!("{key_path}.{sub}");
            loop {
                if self.index.find(&path).is_some() {
                    return self.error(&path, what, fix);
                }
                match path.rsplit_once('.') {
                    Some((parent, _)) if parent.len() > key_path.len() => path = parent.to_string(),
                    _ => break,
                }
            }
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
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let p = Parser {
        path,
        kinds,
        text,
        index: KeyIndex::new(text),
    };
    // Repeated keys first: serde keeps the last of a map's (a stage declared twice) silently.
    crate::core::input::yaml::<serde_yaml_ng::Value>(
        path,
        text,
        "see the README's description of pipeline.yaml",
    )?;
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

/// Checks one declared stage against the kinds and the other stages; the spec it stands for.
fn check_stage(
    p: &Parser,
    name: &str,
    rs: &RawStage,
    all: &BTreeMap<String, RawStage>,
) -> Result<StageSpec, InputError> {
    let d = Declared {
        p,
        name,
        at: format!("stages.{name}"),
        rs,
        all,
    };
    d.check_name()?;
    let kind = d.kind()?;
    let imp = d.settings(kind)?;
    d.check_inputs(kind)?;
    for f in &rs.from {
        d.check_upstream(kind, f)?;
    }
    d.check_requires(kind)?;
    d.check_scored(kind)?;
    Ok(StageSpec {
        name: name.to_string(),
        kind,
        imp,
        inputs: rs.inputs.clone(),
        from: rs.from.clone(),
    })
}

/// One stage as written under `stages`, with the other stages it may read from.
struct Declared<'s> {
    p: &'s Parser<'s>,
    name: &'s str,
    /// `stages.<name>`: the key its errors point at.
    at: String,
    rs: &'s RawStage,
    all: &'s BTreeMap<String, RawStage>,
}

impl Declared<'_> {
    /// An error at the stage's key followed by `sub` (`""`, `".kind"`, `".from"`, ...).
    fn error(&self, sub: &str, what: impl Into<String>, fix: impl Into<String>) -> InputError {
        self.p.error(&format!("{}{sub}", self.at), what, fix)
    }

    /// What the stage called `f` produces, when it is a stage of a known kind.
    fn produces(&self, f: &str) -> Option<Artifact> {
        self.all
            .get(f)
            .and_then(|s| contract::find(self.p.kinds, &s.kind))
            .map(|k| k.produces)
    }

    /// The name may become part of file and instance names: letters, digits, `_` and `-`.
    fn check_name(&self) -> Result<(), InputError> {
        let name = self.name;
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(self.error(
                "",
                format!(
                    "stage name `{name}` has characters other than letters, digits, `_` and `-`"
                ),
                "rename the stage",
            ));
        }
        Ok(())
    }

    /// The stage's kind, or an error suggesting the nearest registered one.
    fn kind(&self) -> Result<&'static Kind, InputError> {
        let kinds = self.p.kinds;
        let raw = &self.rs.kind;
        contract::find(kinds, raw).ok_or_else(|| {
            let names = kinds.iter().map(|k| k.name);
            let fix = match nearest(raw, names.clone()) {
                Some(s) => format!("did you mean `{s}`?"),
                None => use_one_of(names),
            };
            self.error(
                ".kind",
                format!("stage `{}`: unknown kind `{raw}`", self.name),
                fix,
            )
        })
    }

    /// The settings, parsed by the kind (an empty map when none are written).
    fn settings(&self, kind: &Kind) -> Result<Arc<dyn StageImpl>, InputError> {
        let settings = self
            .rs
            .settings
            .clone()
            .unwrap_or(serde_yaml_ng::Value::Mapping(Default::default()));
        self.check_numbers(&format!("{}.settings", self.at), &settings)?;
        (kind.parse)(settings).map_err(|e| self.p.serde_error(&format!("{}.settings", self.at), &e))
    }

    /// Every number in the settings is finite, and a duration (a key ending in `_s`) is not
    /// negative: `.nan` or `-1` there would otherwise surface far downstream, if at all.
    fn check_numbers(&self, at: &str, v: &serde_yaml_ng::Value) -> Result<(), InputError> {
        use serde_yaml_ng::Value;
        match v {
            Value::Mapping(m) => {
                for (k, x) in m {
                    let key = k.as_str().map_or_else(|| format!("{k:?}"), str::to_string);
                    let path = format!("{at}.{key}");
                    if let Some(f) = x.as_f64() {
                        if !f.is_finite() {
                            return Err(self.p.error(
                                &path,
                                format!("setting `{key}` is {f}, not a finite number"),
                                "write a number",
                            ));
                        }
                        if key.ends_with("_s") && f < 0.0 {
                            return Err(self.p.error(
                                &path,
                                format!(
                                    "setting `{key}` is {f} s; a time or duration is not negative"
                                ),
                                "write the time in seconds, 0 or more",
                            ));
                        }
                    }
                    self.check_numbers(&path, x)?;
                }
            }
            Value::Sequence(items) => {
                for x in items {
                    if x.as_f64().is_some_and(|f| !f.is_finite()) {
                        return Err(self.p.error(
                            at,
                            format!(
                                "a list under `{at}` holds {}, not a finite number",
                                x.as_f64().unwrap_or(f64::NAN)
                            ),
                            "write numbers",
                        ));
                    }
                    self.check_numbers(at, x)?;
                }
            }
            Value::Tagged(t) => self.check_numbers(at, &t.value)?,
            _ => {}
        }
        Ok(())
    }

    /// A fan-out kind needs input globs, a kind that reads only other stages has none, and
    /// every glob is valid and stays inside the project.
    fn check_inputs(&self, kind: &Kind) -> Result<(), InputError> {
        let (name, inputs) = (self.name, &self.rs.inputs);
        if kind.fan_out && inputs.is_empty() {
            return Err(self.error(
                "",
                format!("stage `{name}` ({}) has no inputs", kind.name),
                "add `inputs: [\"cases/...\"]` with the globs of the files it imports",
            ));
        }
        if !kind.fan_out && !kind.reads_files && !inputs.is_empty() {
            return Err(self.error(
                ".inputs",
                format!(
                    "stage `{name}` ({}) takes no input files; it reads other stages' results",
                    kind.name
                ),
                "remove `inputs` and list the stages it reads under `from`",
            ));
        }
        inputs.iter().try_for_each(|g| self.check_glob(g))
    }

    /// One input glob: valid syntax, relative, no `..`.
    fn check_glob(&self, g: &str) -> Result<(), InputError> {
        if let Err(e) = glob::Pattern::new(g) {
            return Err(self.error(
                ".inputs",
                format!("bad glob `{g}`: {e}"),
                "fix the pattern (`*` any name, `**` any folders)",
            ));
        }
        if g.starts_with('/') || g.split('/').any(|c| c == "..") {
            return Err(self.error(
                ".inputs",
                format!("input `{g}` is outside the project"),
                "use a path relative to the project folder, e.g. cases/cfd/starccm/*.csv",
            ));
        }
        Ok(())
    }

    /// One entry of `from`: a stage that exists and produces what this kind reads.
    fn check_upstream(&self, kind: &Kind, f: &str) -> Result<(), InputError> {
        let (name, all) = (self.name, self.all);
        let Some(up) = all.get(f) else {
            let fix = nearest(f, all.keys().map(|s| s.as_str()))
                .map_or("list only stages defined under `stages`".into(), |s| {
                    format!("did you mean `{s}`?")
                });
            return Err(self.error(
                ".from",
                format!("stage `{name}` reads from `{f}`, which is not a stage"),
                fix,
            ));
        };
        match self.produces(f) {
            Some(a) if !kind.consumes.contains(&a) => Err(self.error(
                ".from",
                format!(
                    "stage `{name}` ({}) cannot read from `{f}` ({}), which produces {}",
                    kind.name,
                    up.kind,
                    a.describe()
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
            )),
            _ => Ok(()),
        }
    }

    /// Under `from`: a stage producing each artifact the kind requires, and one producing
    /// any of those it requires one of.
    fn check_requires(&self, kind: &Kind) -> Result<(), InputError> {
        let (name, from) = (self.name, &self.rs.from);
        for need in kind.requires {
            if !from.iter().any(|f| self.produces(f) == Some(*need)) {
                return Err(self.error(
                    "",
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
        let one_of = kind.requires_one_of;
        if !one_of.is_empty()
            && !from
                .iter()
                .any(|f| self.produces(f).is_some_and(|a| one_of.contains(&a)))
        {
            let what: Vec<&str> = one_of.iter().map(|a| a.describe()).collect();
            let examples: Vec<&str> = one_of.iter().map(|a| a.example()).collect();
            return Err(self.error(
                "",
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
        Ok(())
    }
}

impl Declared<'_> {
    /// A kind that shows models on CFD responses ([`Kind::scored_by`]) reads the stage that
    /// scored every one of those models on every one of those responses.
    fn check_scored(&self, kind: &Kind) -> Result<(), InputError> {
        let Some(scorer) = kind.scored_by else {
            return Ok(());
        };
        let of = |a: Artifact| -> Vec<&str> {
            let from = self.rs.from.iter();
            from.filter(|f| self.produces(f) == Some(a))
                .map(String::as_str)
                .collect()
        };
        let (models, responses) = (of(Artifact::Model), of(Artifact::Responses));
        if models.is_empty() || responses.is_empty() {
            return Ok(());
        }
        let name = self.name;
        let shown: Vec<&str> = models.iter().chain(&responses).copied().collect();
        let Some(&v) = of(scorer).first() else {
            return Err(self.error(
                ".from",
                format!(
                    "stage `{name}` shows models ({}) on CFD cases ({}) but reads no stage that scores them ({})",
                    models.join(", "),
                    responses.join(", "),
                    scorer.example()
                ),
                format!(
                    "add `validate: {{kind: validate, from: [{}]}}` (with your pool stages, if any) and list `validate` under `{name}`'s `from`",
                    shown.join(", ")
                ),
            ));
        };
        let reads = self.all.get(v).map_or(&[][..], |s| s.from.as_slice());
        let missing: Vec<&str> = shown
            .iter()
            .filter(|s| !reads.iter().any(|r| r == *s))
            .copied()
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(self.error(
            ".from",
            format!(
                "stage `{name}` shows {} on CFD cases, but `{v}`, which scores the models on them, does not read {}",
                shown.join(", "),
                missing.join(", ")
            ),
            format!("add {} to `{v}`'s `from`", missing.join(", ")),
        ))
    }
}

/// `use one of `a`, `b``: the fix when no name is near enough to suggest.
fn use_one_of<'n>(names: impl Iterator<Item = &'n str>) -> String {
    format!(
        "use one of {}",
        names
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
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
