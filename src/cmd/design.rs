//! `hydrofit design`: which run to fly next and what it will buy (see `design/`), from the
//! cache of the last build: the fit, its training runs as the pool stages fused them, and the
//! last diagnosis of it. Writes the folder a pool test can start from (see `design/files.rs`)
//! and prints what the run buys.

use crate::core::model::Pool;
use crate::design::propose::{Ask, Diagnosed, propose};
use crate::identify::result::FitResult;
use crate::pipeline::Plan;
use crate::pool::fusion::run::{FusedRun, load_for};
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path, ask: &Ask, out: &Path) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let (f, runs) = model_and_runs(&plan, ask.model.as_deref())?;
    let diagnosis = last_diagnosis(&plan);
    let diagnosed = match &diagnosis {
        Some(d) => Some(Diagnosed {
            diagnosis: d,
            plant: diagnosed_plant(&plan, d, &f)?,
        }),
        None => None,
    };
    let bar = crate::core::progress::Progress::new().bar(100, "design");
    let proposal = propose(
        &f,
        &runs,
        &plan.graph.spec.vehicle,
        diagnosed,
        ask,
        &|line| eprintln!("hydrofit: {line}"),
        &|x| bar.set_position((100.0 * x) as u64),
    );
    bar.finish_and_clear();
    let proposal = proposal?;
    let dir = if out.is_absolute() {
        out.to_path_buf()
    } else {
        root.join(out)
    };
    proposal.write(&dir)?;
    for line in proposal.written.table() {
        crate::outln!("{line}");
    }
    crate::outln!("wrote {}", dir.display());
    Ok(ExitCode::SUCCESS)
}

/// The model diagnosis `d` diagnosed, when it is another fit than `f`: its effects were
/// fitted beside that model.
fn diagnosed_plant(
    plan: &Plan,
    d: &crate::diagnose::Diagnosis,
    f: &FitResult,
) -> anyhow::Result<Option<crate::core::model::Plant>> {
    if d.baseline.model == f.stage {
        return Ok(None);
    }
    let i = crate::cmd::export::pick_fit(plan, Some(&d.baseline.model))?;
    let g = crate::cmd::provenance::load_fit(plan, &plan.cache(), i)?;
    Ok(Some(g.plant(&plan.graph.spec.vehicle)))
}

/// The last diagnosis in the cache (its look-alikes are designed for).
fn last_diagnosis(plan: &Plan) -> Option<crate::diagnose::Diagnosis> {
    let cache = plan.cache();
    let g = &plan.graph;
    (0..g.instances.len())
        .filter(|&i| g.stage_of(i).kind.name == "diagnose" && cache.has(&plan.keys[i]))
        .find_map(|i| {
            crate::core::fsutil::read_json(&cache.object(&plan.keys[i]).join("diagnosis.json")).ok()
        })
}

/// The fit stage asked for (or the pipeline's only fit of its own vehicle), and its training
/// runs as the pool stages fused them.
fn model_and_runs(plan: &Plan, model: Option<&str>) -> anyhow::Result<(FitResult, Vec<FusedRun>)> {
    let i = crate::cmd::export::pick_fit(plan, model)?;
    let cache = plan.cache();
    let f = crate::cmd::provenance::load_fit(plan, &cache, i)?;
    let vehicle = f.vehicle.clone().unwrap_or(plan.graph.spec.vehicle.clone());
    let mut runs = Vec::new();
    for r in &f.runs {
        let Some(j) = plan.graph.instances.iter().position(|x| x.id == r.id) else {
            continue;
        };
        anyhow::ensure!(
            cache.has(&plan.keys[j]),
            "pool run {} is out of date; run `hydrofit build` first",
            r.run
        );
        runs.push(load_for(&cache.object(&plan.keys[j]), &vehicle)?);
    }
    Ok((f, runs))
}

/// `25x12x4` as a pool.
pub fn parse_pool(s: &str) -> Result<Pool, String> {
    let v: Vec<f64> = s
        .split(['x', 'X'])
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--pool {s}: expected LENGTHxWIDTHxDEPTH in m, e.g. 25x12x4"))?;
    match v[..] {
        [length_m, width_m, depth_m] if v.iter().all(|x| x.is_finite() && *x > 0.0) => Ok(Pool {
            length_m,
            width_m,
            depth_m,
        }),
        _ => Err(format!(
            "--pool {s}: expected three positive sizes LENGTHxWIDTHxDEPTH in m, e.g. 25x12x4"
        )),
    }
}

/// `x,y,z,heading_deg` as a start.
pub fn parse_start(s: &str) -> Result<[f64; 4], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--start {s}: expected x,y,z,heading_deg (m, m, m, deg)"))?;
    <[f64; 4]>::try_from(v)
        .ok()
        .filter(|a| a.iter().all(|x| x.is_finite()))
        .ok_or_else(|| format!("--start {s}: expected four numbers x,y,z,heading_deg"))
}
