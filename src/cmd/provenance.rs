//! `hydrofit provenance NAME`: value <- fit stage, method, settings <- imported cases <- files.

use crate::identify::Estimate;
use crate::identify::result::FitResult;
use crate::pipeline::cache::Cache;
use crate::pipeline::contract::Artifact;
use crate::pipeline::{Plan, explain};
use std::path::Path;
use std::process::ExitCode;

fn short(h: &str) -> &str {
    &h[..h.len().min(16)]
}

/// Prints where parameter `name` comes from, for every fit that identified it (or only the fit
/// stage `model`); when several did, says so first.
pub fn run(root: &Path, name: &str, model: Option<&str>) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let cache = plan.cache();
    let g = &plan.graph;
    let models: Vec<usize> = (0..g.instances.len())
        .filter(|&i| g.stage_of(i).kind.produces == Artifact::Model)
        .collect();
    if let Some(m) = model {
        let names: Vec<&str> = models.iter().map(|&i| g.instances[i].id.as_str()).collect();
        anyhow::ensure!(
            names.contains(&m),
            "--model {m}: no fit stage of that name; fit stages: {}",
            names.join(", ")
        );
    }
    let mut known = Vec::new();
    let mut traced = Vec::new();
    for &i in models
        .iter()
        .filter(|&&i| model.is_none_or(|m| g.instances[i].id == m))
    {
        let r = load_fit(&plan, &cache, i)?;
        known.extend(r.fit.parameters.iter().map(|p| p.name.clone()));
        if r.fit.parameters.iter().any(|p| p.name == name) {
            traced.push((i, r));
        }
    }
    if traced.is_empty() && model.is_none() && print_field(&plan, &cache, name, &mut known)? {
        return Ok(ExitCode::SUCCESS);
    }
    if traced.is_empty() {
        let hint = crate::core::diag::nearest(name, known.iter().map(|s| s.as_str()))
            .map_or(String::new(), |s| format!(" (did you mean {s}?)"));
        anyhow::bail!(
            "no identified parameter named {name}{hint}; parameters: {}",
            known.join(", ")
        );
    }
    if traced.len() > 1 {
        let names: Vec<&str> = traced
            .iter()
            .map(|(i, _)| g.instances[*i].id.as_str())
            .collect();
        crate::outln!(
            "{name} is identified by {} models ({}); each is traced below (--model NAME for one).",
            traced.len(),
            names.join(", ")
        );
    }
    for (i, r) in &traced {
        let p = r
            .fit
            .parameters
            .iter()
            .find(|p| p.name == name)
            .expect("kept above");
        print_trace(&plan, *i, r, p);
    }
    Ok(ExitCode::SUCCESS)
}

/// Parameter `name` as the field-trial stages (arx, integrated, adaptive) identified it, with
/// their input files; false when none did (their names are added to `known`).
fn print_field(
    plan: &Plan,
    cache: &Cache,
    name: &str,
    known: &mut Vec<String>,
) -> anyhow::Result<bool> {
    let g = &plan.graph;
    let mut found = false;
    for i in (0..g.instances.len()).filter(|&i| g.stage_of(i).kind.produces == Artifact::FieldModel)
    {
        if !cache.has(&plan.keys[i]) {
            anyhow::bail!(
                "stage {} is out of date; run `hydrofit build` first",
                g.instances[i].id
            );
        }
        let r = crate::field::load(&cache.object(&plan.keys[i]))?;
        known.extend(r.parameters.iter().map(|p| p.name.clone()));
        for p in r.parameters.iter().filter(|p| p.name == name) {
            found = true;
            let model = p
                .model
                .as_ref()
                .map_or(String::new(), |m| format!(" (model {m})"));
            crate::outln!("{} = {} ± {} {}{model}", p.name, p.value, p.stderr, p.unit);
            crate::outln!(
                "  <- stage {} (kind {}, key {}), method {}, settings {}",
                g.instances[i].id,
                g.stage_of(i).kind.name,
                short(&plan.keys[i]),
                r.method,
                r.settings
            );
            crate::outln!(
                "  <- estimated on {}; {} input files:",
                r.estimation_runs.join(", "),
                r.inputs.len()
            );
            for f in &r.inputs {
                crate::outln!("       {} blake3 {}", f.path, f.blake3);
            }
        }
    }
    Ok(found)
}

/// The cached result of fit instance `i`; an error saying why when it is out of date.
pub fn load_fit(plan: &Plan, cache: &Cache, i: usize) -> anyhow::Result<FitResult> {
    let inst = &plan.graph.instances[i];
    if !cache.has(&plan.keys[i]) {
        let why = explain::reasons(cache.records().get(&inst.id), &plan.fields[i]);
        anyhow::bail!(
            "stage {} is out of date ({}); run `hydrofit build` first",
            inst.id,
            why.join("; ")
        );
    }
    crate::identify::result::load(&cache.object(&plan.keys[i]))
}

/// `p` as fit instance `i` identified it, the stage, method and settings, then the cases.
fn print_trace(plan: &Plan, i: usize, r: &FitResult, p: &Estimate) {
    crate::outln!(
        "{} = {} ± {} {}{}",
        p.name,
        p.value,
        p.stderr,
        p.unit,
        if p.identifiable {
            String::new()
        } else {
            format!("  (not identifiable from these {})", r.sources())
        }
    );
    crate::outln!(
        "  <- stage {} (kind {}, key {}), method {}, objective {}, settings {}",
        plan.graph.instances[i].id,
        plan.graph.stage_of(i).kind.name,
        short(&plan.keys[i]),
        r.method,
        r.objective.label(),
        r.settings
    );
    print_cases(plan, r);
    print_runs(plan, r);
}

/// The short cache key of stage instance `id`, `?` when the plan has no such instance.
fn key_of<'a>(plan: &'a Plan, id: &str) -> &'a str {
    plan.graph
        .instances
        .iter()
        .position(|x| x.id == id)
        .map_or("?", |j| short(&plan.keys[j]))
}

/// The pool runs a fit read (its training runs), each with its instance's key and its files'
/// hashes (for a vehicle's log, the span read and the topic of each signal).
fn print_runs(plan: &Plan, r: &FitResult) {
    if r.runs.is_empty() {
        return;
    }
    crate::outln!("  <- {} pool runs:", r.runs.len());
    for run in &r.runs {
        let key = key_of(plan, &run.id);
        crate::outln!(
            "       {} (key {key}) <- {} files:",
            run.id,
            run.inputs.len()
        );
        for f in &run.inputs {
            let span = f
                .span_s
                .map_or(String::new(), |[a, b]| format!(", span {a}-{b} s"));
            let topics = if f.topics.is_empty() {
                String::new()
            } else {
                let t: Vec<String> = f.topics.iter().map(|(k, v)| format!("{k} {v}")).collect();
                format!(", topics: {}", t.join(", "))
            };
            crate::outln!("           {} blake3 {}{span}{topics}", f.path, f.blake3);
        }
    }
}

/// The cases a fit read, each with its instance's key and its files' hashes.
fn print_cases(plan: &Plan, r: &FitResult) {
    if r.cases.is_empty() && !r.runs.is_empty() {
        return;
    }
    crate::outln!("  <- {} imported cases:", r.cases.len());
    for c in &r.cases {
        let key = key_of(plan, &c.id);
        if c.inputs.is_empty() {
            crate::outln!(
                "       {} (key {key}) <- {} blake3 {}",
                c.id,
                c.source.path,
                c.source.blake3
            );
        } else {
            crate::outln!("       {} (key {key}) <- {} files:", c.id, c.inputs.len());
            for f in &c.inputs {
                crate::outln!("           {} blake3 {}", f.path, f.blake3);
            }
        }
    }
}
