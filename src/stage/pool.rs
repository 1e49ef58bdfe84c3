//! `kind: pool` — imports one pool test folder and fuses its sensors into body-frame velocities
//! with uncertainties (one instance per run folder).

use super::{Artifact, InputFile, Kind, RunCtx, StageImpl};
use crate::fusion::{self, Fused, Stats};
use crate::io::pool::{self, Role};
use crate::model::effects::Pool;
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

pub static KIND: Kind = Kind {
    name: "pool",
    version: 1,
    fan_out: true,
    reads_files: false,
    input_filter: None,
    produces: Artifact::PoolRuns,
    consumes: &[],
    requires: &[],
    uses_vehicle: super::VehicleUse::Dofs,
    publishes_to: None,
    parse: |v| Ok(Arc::new(serde_yaml_ng::from_value::<Settings>(v)?)),
};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    pub fusion: fusion::Settings,
}

/// What the import and fusion recorded besides the table.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunMeta {
    pub run: String,
    pub role: Role,
    pub description: String,
    pub pool: Option<Pool>,
    pub tether_anchor_m: Option<[f64; 3]>,
    pub sources: Vec<InputFile>,
    /// Which of u, v, w, r the sensors gave.
    pub known: [bool; 4],
    pub sensors: Vec<String>,
    pub stats: Stats,
    /// Fusion statistics without the sonar, when the run has one.
    pub stats_without_sonar: Option<Stats>,
    pub notes: Vec<String>,
}

/// A fused run as stored: the thrust log and the fused state on its time base.
#[derive(Debug, Clone)]
pub struct FusedRun {
    pub meta: RunMeta,
    /// X, Y, Z, N per sample (the logged command).
    pub thrust: Vec<[f64; 4]>,
    pub fused: Fused,
    pub without_sonar: Option<Fused>,
}

pub const META: &str = "run.json";
const TABLE: &str = "fused.parquet";
const TABLE_NO_SONAR: &str = "fused_without_sonar.parquet";
const VEL: [&str; 4] = ["u", "v", "w", "r"];
const TAU: [&str; 4] = ["X", "Y", "Z", "N"];

fn write_table(path: &Path, thrust: &[[f64; 4]], f: &Fused) -> anyhow::Result<()> {
    let mut cols = vec![Column::new("t".into(), &f.t)];
    for (j, name) in TAU.iter().enumerate() {
        cols.push(Column::new((*name).into(), thrust.iter().map(|r| r[j]).collect::<Vec<_>>()));
    }
    for ((name, v), s) in VEL.iter().zip(&f.vel).zip(&f.std) {
        if let (Some(v), Some(s)) = (v, s) {
            cols.push(Column::new((*name).into(), v));
            cols.push(Column::new(format!("{name}_std").into(), s));
        }
    }
    for (name, v) in [("x", &f.x), ("y", &f.y), ("z", &f.z), ("psi", &f.psi)] {
        cols.push(Column::new(name.into(), v));
    }
    let mut df = DataFrame::new_infer_height(cols)?;
    let tmp = path.with_extension("tmp");
    ParquetWriter::new(std::fs::File::create(&tmp)?).finish(&mut df)?;
    std::fs::rename(tmp, path)?;
    Ok(())
}

fn read_table(path: &Path, known: [bool; 4], stats: Stats) -> anyhow::Result<(Vec<[f64; 4]>, Fused)> {
    let df = ParquetReader::new(std::fs::File::open(path)?).set_rechunk(true).finish()?;
    let get = |name: &str| -> anyhow::Result<Vec<f64>> { Ok(df.column(name)?.f64()?.into_no_null_iter().collect()) };
    let t = get("t")?;
    let tau: Vec<Vec<f64>> = TAU.iter().map(|n| get(n)).collect::<Result<_, _>>()?;
    let thrust = (0..t.len()).map(|k| [tau[0][k], tau[1][k], tau[2][k], tau[3][k]]).collect();
    let mut vel: [Option<Vec<f64>>; 4] = Default::default();
    let mut std: [Option<Vec<f64>>; 4] = Default::default();
    for j in 0..4 {
        if known[j] {
            vel[j] = Some(get(VEL[j])?);
            std[j] = Some(get(&format!("{}_std", VEL[j]))?);
        }
    }
    let fused = Fused { t, vel, std, x: get("x")?, y: get("y")?, z: get("z")?, psi: get("psi")?, stats };
    Ok((thrust, fused))
}

/// Loads a run written by a `pool` stage.
pub fn load(dir: &Path) -> anyhow::Result<FusedRun> {
    let meta: RunMeta = super::read_json(&dir.join(META))?;
    let (thrust, fused) = read_table(&dir.join(TABLE), meta.known, meta.stats.clone())?;
    let without_sonar = match &meta.stats_without_sonar {
        Some(s) => Some(read_table(&dir.join(TABLE_NO_SONAR), meta.known, s.clone())?.1),
        None => None,
    };
    Ok(FusedRun { meta, thrust, fused, without_sonar })
}

impl StageImpl for Settings {
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let files: Vec<String> = ctx.inputs.iter().map(|f| f.path.clone()).collect();
        if files.is_empty() {
            anyhow::bail!("{}: the run folder is empty\n  help: a pool run needs at least run.yaml and thrust.csv", ctx.id);
        }
        let dir = common_dir(&files);
        let run = pool::load(ctx.root, &dir, &files)?;
        ctx.progress.set_message(format!("fusing {}", run.name));
        let fused = fusion::fuse(&run, &self.fusion);
        let without_sonar = run.sonar.as_ref().filter(|_| !self.fusion.exclude.iter().any(|e| e == "sonar")).map(|_| {
            let mut s = self.fusion.clone();
            s.exclude.push("sonar".into());
            fusion::fuse(&run, &s)
        });
        let thrust: Vec<[f64; 4]> = (0..run.thrust.len()).map(|k| [run.thrust.cols[0][k], run.thrust.cols[1][k], run.thrust.cols[2][k], run.thrust.cols[3][k]]).collect();
        write_table(&ctx.out.join(TABLE), &thrust, &fused)?;
        if let Some(f) = &without_sonar {
            write_table(&ctx.out.join(TABLE_NO_SONAR), &thrust, f)?;
        }
        let sensors = [("uwb", run.uwb.is_some()), ("sonar", run.sonar.is_some()), ("imu", run.imu.is_some()), ("depth", run.depth.is_some())]
            .into_iter()
            .filter(|(_, present)| *present)
            .map(|(n, _)| n.to_string())
            .collect();
        let mut notes = run.notes.clone();
        notes.extend(fused.stats.notes.iter().cloned());
        let meta = RunMeta {
            run: run.name.clone(),
            role: run.meta.role,
            description: run.meta.description.clone(),
            pool: run.meta.pool,
            tether_anchor_m: run.meta.tether_anchor_m,
            sources: ctx.inputs.to_vec(),
            known: std::array::from_fn(|j| fused.vel[j].is_some()),
            sensors,
            stats: fused.stats.clone(),
            stats_without_sonar: without_sonar.map(|f| f.stats),
            notes,
        };
        super::write_json(&ctx.out.join(META), &meta)
    }
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
