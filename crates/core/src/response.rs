//! The response table: applied force, velocity and acceleration per DOF on one time base.
//! Every CFD importer (STAR-CCM+, OpenFOAM) produces one; it is cached as Parquet.

use crate::dof::Dof;
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Where a column's values came from, so the report can say what was measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Read from a column of the file.
    Column,
    /// Applied force taken from `pipeline.yaml` (the file had no force column).
    Configured,
    /// Read from the case's own dictionaries (an OpenFOAM case's body acceleration x mass).
    Case,
    /// Acceleration by central differences of the velocity (the file had no acceleration column).
    Differentiated,
}

/// One DOF's histories, SI units, body frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub force: Vec<f64>,
    pub velocity: Vec<f64>,
    pub accel: Vec<f64>,
    pub force_source: Source,
    pub accel_source: Source,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Response {
    pub t: Vec<f64>,
    pub dofs: BTreeMap<Dof, Series>,
    /// Roll and pitch (rad) per sample where measured (a pool run's attitude sensor); empty
    /// for a CFD run, whose body is held level. Only a coupled model's buoyancy uses them.
    pub attitude: Vec<[f64; 2]>,
}

impl Response {
    /// The first sample from `from_t` on whose time, force, velocity or acceleration (in the
    /// DOFs `dofs`) is not a finite number, said as `t = 3.2 s: surge velocity is inf`. A
    /// solver fed such a value returns nonsense or never returns.
    pub fn non_finite(&self, dofs: &[Dof], from_t: f64) -> Option<String> {
        for (k, &t) in self.t.iter().enumerate() {
            if !t.is_finite() {
                return Some(format!("sample {k}: the time is {t}"));
            }
            if t < from_t {
                continue;
            }
            for (d, s) in self.dofs.iter().filter(|(d, _)| dofs.contains(d)) {
                for (what, v) in [
                    ("applied force", s.force[k]),
                    ("velocity", s.velocity[k]),
                    ("acceleration", s.accel[k]),
                ] {
                    if !v.is_finite() {
                        return Some(format!("t = {t} s: the {d} {what} is {v}"));
                    }
                }
            }
        }
        None
    }

    /// `plant`'s velocities under this response's applied force, from its first measured state.
    pub fn simulate(&self, plant: &crate::model::Plant) -> Vec<crate::model::Vec6> {
        let tau: Vec<crate::model::Vec6> = (0..self.len()).map(|k| self.tau(k)).collect();
        plant.simulate_from(&self.t, &tau, self.nu(0), self.attitude(0), 0.01)
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Velocity 6-vector at sample `k` (DOFs not in the table are at rest).
    pub fn nu(&self, k: usize) -> [f64; 6] {
        self.pick(k, |s| &s.velocity)
    }

    pub fn nu_dot(&self, k: usize) -> [f64; 6] {
        self.pick(k, |s| &s.accel)
    }

    /// Roll and pitch at sample `k` (level when not measured).
    pub fn attitude(&self, k: usize) -> [f64; 2] {
        self.attitude.get(k).copied().unwrap_or([0.0; 2])
    }

    pub fn tau(&self, k: usize) -> [f64; 6] {
        self.pick(k, |s| &s.force)
    }

    fn pick(&self, k: usize, f: impl Fn(&Series) -> &Vec<f64>) -> [f64; 6] {
        let mut out = [0.0; 6];
        for (d, s) in &self.dofs {
            out[d.index()] = f(s)[k];
        }
        out
    }

    /// The table as a polars frame: `t`, then per DOF `X`, `u`, `udot` (force, velocity, acceleration).
    pub fn to_frame(&self) -> PolarsResult<DataFrame> {
        let mut cols = vec![Column::new("t".into(), &self.t)];
        for (d, s) in &self.dofs {
            cols.push(Column::new(d.force().into(), &s.force));
            cols.push(Column::new(d.velocity().into(), &s.velocity));
            cols.push(Column::new(format!("{}dot", d.velocity()).into(), &s.accel));
        }
        DataFrame::new_infer_height(cols)
    }

    /// Inverse of `to_frame`; `sources` restores where each column came from.
    pub fn from_frame(
        df: &DataFrame,
        sources: &BTreeMap<Dof, (Source, Source)>,
    ) -> PolarsResult<Response> {
        let get = |name: &str| -> PolarsResult<Vec<f64>> {
            Ok(df.column(name)?.f64()?.into_no_null_iter().collect())
        };
        let mut r = Response {
            t: get("t")?,
            dofs: BTreeMap::new(),
            attitude: Vec::new(),
        };
        for (d, (fs, acs)) in sources {
            let s = Series {
                force: get(d.force())?,
                velocity: get(d.velocity())?,
                accel: get(&format!("{}dot", d.velocity()))?,
                force_source: *fs,
                accel_source: *acs,
            };
            r.dofs.insert(*d, s);
        }
        Ok(r)
    }

    pub fn write_parquet(&self, path: &Path) -> anyhow::Result<()> {
        let mut df = self.to_frame()?;
        let file = std::fs::File::create(path)?;
        ParquetWriter::new(file).finish(&mut df)?;
        Ok(())
    }

    pub fn read_parquet(
        path: &Path,
        sources: &BTreeMap<Dof, (Source, Source)>,
    ) -> anyhow::Result<Response> {
        let file = std::fs::File::open(path)?;
        let df = ParquetReader::new(file).set_rechunk(true).finish()?;
        Ok(Response::from_frame(&df, sources)?)
    }

    pub fn sources(&self) -> BTreeMap<Dof, (Source, Source)> {
        self.dofs
            .iter()
            .map(|(d, s)| (*d, (s.force_source, s.accel_source)))
            .collect()
    }
}

/// Central differences (one-sided at the ends) on a possibly uneven time base.
pub fn differentiate(t: &[f64], x: &[f64]) -> Vec<f64> {
    let n = t.len();
    if n < 2 {
        return vec![0.0; n];
    }
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            (x[b] - x[a]) / (t[b] - t[a])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parquet_round_trip() {
        let mut r = Response {
            t: vec![0.0, 0.1, 0.2],
            dofs: BTreeMap::new(),
            attitude: Vec::new(),
        };
        r.dofs.insert(
            Dof::Yaw,
            Series {
                force: vec![1.0; 3],
                velocity: vec![0.0, 0.5, 0.7],
                accel: vec![5.0, 3.5, 2.0],
                force_source: Source::Configured,
                accel_source: Source::Differentiated,
            },
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.parquet");
        r.write_parquet(&p).unwrap();
        assert_eq!(Response::read_parquet(&p, &r.sources()).unwrap(), r);
    }

    #[test]
    fn differentiates_a_parabola_exactly_inside() {
        let t: Vec<f64> = (0..5).map(|k| k as f64 * 0.5).collect();
        let x: Vec<f64> = t.iter().map(|t| t * t).collect();
        let d = differentiate(&t, &x);
        for k in 1..4 {
            assert!((d[k] - 2.0 * t[k]).abs() < 1e-12);
        }
    }
}

/// What the import wrote besides the table: where it came from and what was done to it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ResponseMeta {
    pub case: String,
    pub source: crate::provenance::InputFile,
    pub dofs: Vec<Dof>,
    pub sources: BTreeMap<Dof, (Source, Source)>,
    pub rows_read: usize,
    pub rows_kept: usize,
    pub notes: Vec<String>,
    /// The body's mass when the case states its own (an OpenFOAM case), kg; otherwise the
    /// vehicle's in pipeline.yaml applies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_mass_kg: Option<f64>,
    /// Every input file when the case is more than `source` (an OpenFOAM case folder).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub all_inputs: Vec<crate::provenance::InputFile>,
    /// Forces and masses per metre of span (a 2D case, as the project's OpenFOAM cylinder is).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub per_metre_of_span: bool,
    /// How an OpenFOAM case was run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub openfoam: Option<RunInfo>,
}

pub const TABLE: &str = "response.parquet";
pub const META: &str = "response.json";

/// Loads a response written by any `Responses` stage.
pub fn load(dir: &Path) -> anyhow::Result<(ResponseMeta, Response)> {
    let meta: ResponseMeta = crate::fsutil::read_json(&dir.join(META))?;
    let r = Response::read_parquet(&dir.join(TABLE), &meta.sources)?;
    Ok((meta, r))
}

/// How an OpenFOAM case's results came about; shown in the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    pub solver: String,
    pub openfoam: String,
    /// True when this build ran the solver; false when it read results left in the case.
    pub ran_in_this_build: bool,
    pub steps: usize,
    pub end_time_s: f64,
    pub cpu_time_s: Option<f64>,
    pub wall_time_s: Option<f64>,
    pub applied_force_n: [f64; 3],
    pub mass_kg: f64,
    pub rho: f64,
    /// The Slurm job (or array task) that ran the case, in this build or when its results
    /// were made, and its node.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm_job: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<String>,
}
