//! Scenarios for proving the diagnosis (`twin check-diagnosis`, the benchmarks, the tests):
//! the twin's six pool runs with chosen effects concealed, written to a scratch folder, read
//! back and fused exactly as the `pool` stage does.

use crate::diagnose::Run;
use crate::pool::fusion::run::{FusedRun, RunMeta};
use crate::twin::pool as twin;
use crate::twin::world::Effect;
use rayon::prelude::*;

/// The fused runs of one generated scenario, as the `pool` stage would store them.
pub fn fused_runs(effects: &[Effect], seed: u64) -> anyhow::Result<Vec<FusedRun>> {
    fused_runs_seen(effects, seed, twin::Logs::Sensors)
}

/// [`fused_runs`] with the run folders holding `logs` (the pool's sensors or the vehicle's
/// navigation log).
pub fn fused_runs_seen(
    effects: &[Effect],
    seed: u64,
    logs: twin::Logs,
) -> anyhow::Result<Vec<FusedRun>> {
    fused_runs_of(&twin::Craft::reference(), effects, seed, logs)
}

/// [`fused_runs_seen`] with `craft` flying the runs.
pub fn fused_runs_of(
    craft: &twin::Craft,
    effects: &[Effect],
    seed: u64,
    logs: twin::Logs,
) -> anyhow::Result<Vec<FusedRun>> {
    let tmp = tempfile::tempdir()?;
    let root = tmp.path();
    let specs = twin::default_runs();
    twin::write_runs_of(
        craft,
        (&root.join("cases/pool"), &root.join("truth/pool")),
        &specs,
        (effects, seed),
        logs,
    )?;
    specs
        .par_iter()
        .map(|spec| fuse_folder(root, &spec.name))
        .collect::<anyhow::Result<_>>()
}

/// Imports and fuses the run folder `cases/pool/<name>` under `root` as the `pool` stage does.
pub fn fuse_folder(root: &std::path::Path, name: &str) -> anyhow::Result<FusedRun> {
    let dir = format!("cases/pool/{name}");
    let files: Vec<String> = std::fs::read_dir(root.join(&dir))?
        .map(|e| e.map(|e| format!("{dir}/{}", e.file_name().to_string_lossy())))
        .collect::<Result<_, _>>()?;
    let run = crate::pool::import::load(root, &dir, &files, None)?;
    let fused = crate::pool::fusion::fuse(&run, &Default::default());
    let thrust: Vec<[f64; 4]> = (0..run.thrust.len())
        .map(|k| std::array::from_fn(|q| run.thrust.cols[q][k]))
        .collect();
    let meta = RunMeta {
        run: name.to_string(),
        role: run.meta.role,
        description: run.meta.description.clone(),
        pool: run.meta.pool,
        tether_anchor_m: run.meta.tether_anchor_m,
        start_m: run.meta.start_m,
        sources: vec![],
        known: std::array::from_fn(|j| fused.vel[j].is_some()),
        sensors: vec![],
        stats: fused.stats.clone(),
        stats_without_sonar: None,
        notes: run.notes.clone(),
        repairs: run.repairs.clone(),
        force_logged: true,
        actuators: Vec::new(),
        design: None,
        tilted: false,
    };
    Ok(FusedRun {
        meta,
        thrust,
        moments: Vec::new(),
        fused,
        without_sonar: None,
        actuators: Vec::new(),
    })
}

/// The diagnosis' view of [`fused_runs`].
pub fn runs(effects: &[Effect], seed: u64) -> anyhow::Result<Vec<Run>> {
    fused_runs(effects, seed)?
        .iter()
        .map(|r| {
            Run::from_fused(r, crate::diagnose::Slots::POOL)
                .ok_or_else(|| anyhow::anyhow!("{}: not every DOF fused", r.meta.run))
        })
        .collect()
}

/// The reference vehicle identified from the twin's STAR-CCM+ cases by least squares, as the
/// shipped `fit` stage does (seed: the CFD noise).
pub fn cfd_fit_plant(seed: u64) -> anyhow::Result<crate::core::model::Plant> {
    use crate::core::model::{Hydro, Plant, Vehicle};
    use crate::identify::Estimator as _;
    let vehicle = Vehicle::reference();
    let mut responses = Vec::new();
    for c in &crate::twin::cfd::default_cases() {
        let text = crate::twin::cfd::export(&vehicle, Hydro::reference(), c, seed);
        let opts = crate::cfd::starccm::ImportOptions {
            columns: &Default::default(),
            dofs: &vehicle.dofs,
            configured_force: Default::default(),
        };
        responses.push(
            crate::cfd::starccm::parse("twin.csv", &text, &opts)
                .map_err(|e| anyhow::anyhow!("{e}"))?
                .response,
        );
    }
    let refs: Vec<_> = responses.iter().collect();
    let reg = crate::identify::Regression::build(&vehicle, &refs, 0.0);
    let fit = crate::identify::ols::Ols.fit(&reg, &Default::default())?;
    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
    Ok(Plant::new(&vehicle, reg.layout.to_hydro(&theta)))
}

/// The reference vehicle's model as a CFD identification would give it: every coefficient off
/// by 1 to 2.5 %, alternating in sign (the shipped CFD fit is 1.5 % off at worst).
pub fn cfd_plant() -> crate::core::model::Plant {
    cfd_plant_of(&twin::Craft::reference())
}

/// [`cfd_plant`] for `craft`: its true coefficients, each off by 1 to 2.5 %.
pub fn cfd_plant_of(craft: &twin::Craft) -> crate::core::model::Plant {
    use crate::core::model::{Hydro, Plant};
    let h = craft.hydro;
    let mut k = 0;
    let mut moved = |arr: [f64; 6]| {
        arr.map(|x| {
            let f = [0.015, -0.02, 0.01, -0.025, 0.02, -0.01][k % 6];
            k += 1;
            x * (1.0 + f)
        })
    };
    let added = moved(h.added_diag());
    let lin = moved(h.lin_diag());
    let quad = moved(h.quad_diag());
    Plant::new(&craft.vehicle, Hydro::diagonal(added, lin, quad))
}
