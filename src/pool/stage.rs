//! `kind: pool` — imports one pool test folder and fuses its sensors into body-frame velocities
//! with uncertainties (one instance per run folder).

use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};
use crate::pool::fusion::{self, run};
use crate::pool::import;
use serde::{Deserialize, Serialize};

pub static KIND: Kind = Kind {
    fan_out: true,
    uses_vehicle: crate::pipeline::contract::VehicleUse::Dofs,
    ..Kind::new("pool", Artifact::PoolRuns, parse_as::<Settings>)
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    pub fusion: fusion::Settings,
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let mut run = load_run(ctx)?;
        if let Some(d) = self.fusion.nav_latency_s {
            fusion::latency::take_out(&mut run, d)?;
        }
        ctx.progress.set_message(format!("fusing {}", run.name));
        let mut fused = fusion::fuse(&run, &self.fusion);
        let rolls = [crate::core::dof::Dof::Roll, crate::core::dof::Dof::Pitch];
        let modelled = ctx.vehicle.dofs.iter().any(|d| rolls.contains(d));
        let tilted = fusion::rotation::tilted(&run);
        let mut notes = Vec::new();
        if modelled {
            fused.roll_pitch = fusion::rotation::fuse(&run, &fused.t, &mut notes);
        } else {
            fused.stats.rates_unfused = fusion::rotation::logged_rates(&run);
        }
        // A run that rolls or pitches has its r from the gyro whatever the model's DOFs, so
        // that yaw is fitted to the same rate alone as beside roll and pitch.
        if (modelled || tilted)
            && let Some((r, sd)) = fusion::rotation::yaw_rate(&run, &fused.t, &mut notes)
        {
            (fused.vel[3], fused.std[3]) = (Some(r), Some(sd));
        }
        fused.stats.notes.extend(notes);
        let mut without_sonar = self.fuse_without_sonar(&run);
        if let Some(at) = self.fusion.nav_at_m {
            let note = fusion::lever::move_to_centre(&run, &mut fused, at)?;
            if let Some(f) = without_sonar.as_mut() {
                fusion::lever::move_to_centre(&run, f, at)?;
            }
            fused.stats.notes.push(note);
        }
        let (thrust, moments) = thrust_rows(&run);
        run::write_table(&ctx.out.join(run::TABLE), &thrust, &moments, &fused)?;
        if let Some(f) = &without_sonar {
            run::write_table(&ctx.out.join(run::TABLE_NO_SONAR), &thrust, &moments, f)?;
        }
        let actuators = match &run.actuators {
            Some(a) => {
                let cols: Vec<Vec<f64>> = (0..a.names.len())
                    .map(|j| crate::pool::import::actuators::hold_at(&a.log, j, &fused.t))
                    .collect();
                run::write_actuators(&ctx.out.join(run::ACTUATORS), &a.names, &cols)?;
                a.names.clone()
            }
            None => Vec::new(),
        };
        let sensors = run.sensors().iter().map(|(n, _)| n.to_string()).collect();
        let mut notes = run.notes.clone();
        notes.extend(fused.stats.notes.iter().cloned());
        let meta = run::RunMeta {
            run: run.name.clone(),
            role: run.meta.role,
            description: run.meta.description.clone(),
            pool: run.meta.pool,
            tether_anchor_m: run.meta.tether_anchor_m,
            start_m: run.meta.start_m,
            sources: sources(ctx, &run)?,
            known: std::array::from_fn(|j| fused.vel[j].is_some()),
            sensors,
            stats: fused.stats.clone(),
            stats_without_sonar: without_sonar.map(|f| f.stats),
            notes,
            repairs: run.repairs.clone(),
            force_logged: run.force_logged,
            actuators,
            design: run.design.clone(),
            tilted,
        };
        crate::core::fsutil::write_json(&ctx.out.join(run::META), &meta)
    }
}

impl Settings {
    /// The run fused once more without its sonar, when it has one the settings use, so the
    /// report can show what the sonar adds.
    fn fuse_without_sonar(&self, run: &import::PoolRun) -> Option<fusion::Fused> {
        run.sonar
            .as_ref()
            .filter(|_| !self.fusion.exclude.iter().any(|e| e == "sonar"))
            .map(|_| {
                let mut s = self.fusion.clone();
                s.exclude.push("sonar".into());
                fusion::fuse(run, &s)
            })
    }
}

/// The pool run of the instance's folder; an error when the folder is empty.
/// The run's input files, and the vehicle's log it was read from (by content, with the topics
/// and span used), which is also watched: an edited log reruns the run.
fn sources(
    ctx: &RunCtx,
    run: &import::PoolRun,
) -> anyhow::Result<Vec<crate::core::provenance::InputFile>> {
    let mut out = ctx.inputs.to_vec();
    if let Some(src) = &run.log_source {
        // A folder of topic files is read file by file: each is an input.
        let files = match src.files.is_empty() {
            true => std::slice::from_ref(&src.path),
            false => &src.files[..],
        };
        for f in files {
            let hash = crate::core::fsutil::hash_file(&ctx.root.join(f))
                .map_err(|e| anyhow::anyhow!("{f}: {e}"))?;
            out.push(crate::core::provenance::InputFile {
                topics: src.topics.clone(),
                span_s: Some(src.span_s),
                ..crate::core::provenance::InputFile::new(f, hash)
            });
        }
        crate::pipeline::cache::write_watched(ctx.out, ctx.root, files)?;
    }
    Ok(out)
}

fn load_run(ctx: &RunCtx) -> anyhow::Result<import::PoolRun> {
    let files: Vec<String> = ctx.inputs.iter().map(|f| f.path.clone()).collect();
    if files.is_empty() {
        anyhow::bail!(
            "{}: the run folder is empty\n  help: a pool run needs at least run.yaml and thrust.csv",
            ctx.id
        );
    }
    let dir = common_dir(&files);
    Ok(import::load(
        ctx.root,
        &dir,
        &files,
        ctx.vehicle.thrusters.as_ref(),
    )?)
}

/// The logged thrust, one [X, Y, Z, N] row per sample, and one [K, M] row per sample when
/// the log has them (a missing one of the two is zero: not commanded).
fn thrust_rows(run: &import::PoolRun) -> (Vec<[f64; 4]>, Vec<[f64; 2]>) {
    let c = &run.thrust.cols;
    let xyzn = (0..run.thrust.len())
        .map(|k| [c[0][k], c[1][k], c[2][k], c[3][k]])
        .collect();
    let given = |j: usize| run.thrust.has(j);
    let km = match given(4) || given(5) {
        true => (0..run.thrust.len())
            .map(|k| [4, 5].map(|j| if given(j) { c[j][k] } else { 0.0 }))
            .collect(),
        false => Vec::new(),
    };
    (xyzn, km)
}

/// The run folder: the longest common folder of its files.
fn common_dir(files: &[String]) -> String {
    let parts: Vec<Vec<&str>> = files.iter().map(|f| f.split('/').collect()).collect();
    let first = &parts[0];
    let mut n = first.len() - 1;
    for p in &parts[1..] {
        n = n.min(p.len() - 1);
        n = (0..n).take_while(|&i| p[i] == first[i]).count();
    }
    first[..n].join("/")
}
