//! A pool run after import and fusion, as the `pool` stage stores it: the logged command and
//! the fused state on its time base (Parquet), and what was done to get there (JSON).

use super::{Fused, Stats};
use crate::core::model::Pool;
use crate::core::provenance::InputFile;
use crate::pool::import::Role;
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What the import and fusion recorded besides the table.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunMeta {
    pub run: String,
    pub role: Role,
    pub description: String,
    pub pool: Option<Pool>,
    pub tether_anchor_m: Option<[f64; 3]>,
    /// Where the run started, [x, y] (run.yaml's `start_m`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_m: Option<[f64; 2]>,
    pub sources: Vec<InputFile>,
    /// Which of u, v, w, r the sensors gave.
    pub known: [bool; 4],
    pub sensors: Vec<String>,
    pub stats: Stats,
    /// Fusion statistics without the sonar, when the run has one.
    pub stats_without_sonar: Option<Stats>,
    pub notes: Vec<String>,
    /// What was done to the logs' timing (docs/formats.md: every repair said in the report).
    #[serde(default)]
    pub repairs: Vec<String>,
    /// Whether the run logged commanded forces (`thrust.csv`); see [`FusedRun::require_force`].
    #[serde(default = "yes")]
    pub force_logged: bool,
    /// The actuators of `actuators.csv`, held on the command clock in [`ACTUATORS`].
    #[serde(default)]
    pub actuators: Vec<String>,
    /// The run's `design.json`, when `hydrofit design` proposed it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<serde_json::Value>,
    /// Whether the run rolls or pitches (attitude over 5 deg RMS,
    /// [`crate::pool::fusion::rotation::tilted`]), modelled or not.
    #[serde(default)]
    pub tilted: bool,
}

fn yes() -> bool {
    true
}

#[cfg(test)]
impl RunMeta {
    /// A run called `run` with every velocity known and nothing else recorded, for tests.
    pub(crate) fn bare(run: &str, role: Role) -> RunMeta {
        RunMeta {
            run: run.into(),
            role,
            description: String::new(),
            pool: None,
            tether_anchor_m: None,
            start_m: None,
            sources: vec![],
            known: [true; 4],
            sensors: vec![],
            stats: Stats::default(),
            stats_without_sonar: None,
            notes: vec![],
            repairs: vec![],
            force_logged: true,
            actuators: vec![],
            design: None,
            tilted: false,
        }
    }
}

/// A fused run as stored: the thrust log and the fused state on its time base.
#[derive(Debug, Clone)]
pub struct FusedRun {
    pub meta: RunMeta,
    /// X, Y, Z, N per sample (the logged command).
    pub thrust: Vec<[f64; 4]>,
    /// K, M per sample, when the command log has them (a vehicle actuated in roll and pitch).
    pub moments: Vec<[f64; 2]>,
    pub fused: Fused,
    pub without_sonar: Option<Fused>,
    /// Each actuator of `meta.actuators` (SI units) on the fused time base.
    pub actuators: Vec<Vec<f64>>,
}

pub const META: &str = "run.json";
pub const TABLE: &str = "fused.parquet";
pub const TABLE_NO_SONAR: &str = "fused_without_sonar.parquet";
pub const ACTUATORS: &str = "actuators.parquet";

/// Writes the actuator columns (`names`, each on the fused time base) to `path`.
pub fn write_actuators(path: &Path, names: &[String], cols: &[Vec<f64>]) -> anyhow::Result<()> {
    let cols: Vec<Column> = names
        .iter()
        .zip(cols)
        .map(|(n, c)| Column::new(n.as_str().into(), c))
        .collect();
    let mut df = DataFrame::new_infer_height(cols)?;
    let tmp = path.with_extension("tmp");
    ParquetWriter::new(std::fs::File::create(&tmp)?).finish(&mut df)?;
    std::fs::rename(tmp, path)?;
    Ok(())
}

fn read_actuators(path: &Path, names: &[String]) -> anyhow::Result<Vec<Vec<f64>>> {
    if names.is_empty() {
        return Ok(Vec::new());
    }
    let df = ParquetReader::new(std::fs::File::open(path)?).finish()?;
    names
        .iter()
        .map(|n| Ok(df.column(n)?.f64()?.into_no_null_iter().collect()))
        .collect()
}
const VEL: [&str; 4] = ["u", "v", "w", "r"];
const TAU: [&str; 4] = ["X", "Y", "Z", "N"];

pub fn write_table(
    path: &Path,
    thrust: &[[f64; 4]],
    moments: &[[f64; 2]],
    f: &Fused,
) -> anyhow::Result<()> {
    let mut cols = vec![Column::new("t".into(), &f.t)];
    for (j, name) in TAU.iter().enumerate() {
        cols.push(Column::new(
            (*name).into(),
            thrust.iter().map(|r| r[j]).collect::<Vec<_>>(),
        ));
    }
    for (j, name) in ["K", "M"]
        .iter()
        .enumerate()
        .filter(|_| !moments.is_empty())
    {
        let c: Vec<f64> = moments.iter().map(|r| r[j]).collect();
        cols.push(Column::new((*name).into(), c));
    }
    let rp = &f.roll_pitch;
    for (j, name) in ["p", "q"].iter().enumerate() {
        if let (Some(v), Some(s)) = (&rp.rate[j], &rp.rate_std[j]) {
            cols.push(Column::new((*name).into(), v));
            cols.push(Column::new(format!("{name}_std").into(), s));
        }
    }
    for (name, v) in [("roll", &rp.roll), ("pitch", &rp.pitch)] {
        if !v.is_empty() {
            cols.push(Column::new(name.into(), v));
        }
    }
    for ((name, v), s) in VEL.iter().zip(&f.vel).zip(&f.std) {
        if let (Some(v), Some(s)) = (v, s) {
            cols.push(Column::new((*name).into(), v));
            cols.push(Column::new(format!("{name}_std").into(), s));
        }
    }
    for ((name, v), s) in VEL.iter().zip(&f.tracked.vel).zip(&f.tracked.std) {
        if let (Some(v), Some(s)) = (v, s) {
            cols.push(Column::new(format!("{name}_tracked").into(), v));
            cols.push(Column::new(format!("{name}_tracked_std").into(), s));
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

/// The command (X Y Z N, and K M when logged) and the fused state of a stored table.
type Table = (Vec<[f64; 4]>, Vec<[f64; 2]>, Fused);

fn read_table(path: &Path, known: [bool; 4], stats: Stats) -> anyhow::Result<Table> {
    let df = ParquetReader::new(std::fs::File::open(path)?)
        .set_rechunk(true)
        .finish()?;
    let get = |name: &str| -> anyhow::Result<Vec<f64>> {
        Ok(df.column(name)?.f64()?.into_no_null_iter().collect())
    };
    let t = get("t")?;
    let tau: Vec<Vec<f64>> = TAU.iter().map(|n| get(n)).collect::<Result<_, _>>()?;
    let thrust = (0..t.len())
        .map(|k| [tau[0][k], tau[1][k], tau[2][k], tau[3][k]])
        .collect();
    let mut vel: [Option<Vec<f64>>; 4] = Default::default();
    let mut std: [Option<Vec<f64>>; 4] = Default::default();
    for j in 0..4 {
        if known[j] {
            vel[j] = Some(get(VEL[j])?);
            std[j] = Some(get(&format!("{}_std", VEL[j]))?);
        }
    }
    let has = |name: &str| df.column(name).is_ok();
    let opt = |name: &str| -> anyhow::Result<Option<Vec<f64>>> {
        if has(name) {
            get(name).map(Some)
        } else {
            Ok(None)
        }
    };
    let moments = match (opt("K")?, opt("M")?) {
        (Some(k), Some(m)) => k.into_iter().zip(m).map(|(k, m)| [k, m]).collect(),
        _ => Vec::new(),
    };
    let roll_pitch = crate::pool::fusion::rotation::RollPitch {
        rate: [opt("p")?, opt("q")?],
        rate_std: [opt("p_std")?, opt("q_std")?],
        roll: opt("roll")?.unwrap_or_default(),
        pitch: opt("pitch")?.unwrap_or_default(),
    };
    let mut tracked = crate::pool::fusion::Tracked::default();
    for (j, name) in VEL.iter().take(3).enumerate() {
        tracked.vel[j] = opt(&format!("{name}_tracked"))?;
        tracked.std[j] = opt(&format!("{name}_tracked_std"))?;
    }
    let fused = Fused {
        t,
        vel,
        std,
        tracked,
        x: get("x")?,
        y: get("y")?,
        z: get("z")?,
        psi: get("psi")?,
        roll_pitch,
        stats,
    };
    Ok((thrust, moments, fused))
}

/// Loads a run written by a `pool` stage.
pub fn load(dir: &Path) -> anyhow::Result<FusedRun> {
    let meta: RunMeta = crate::core::fsutil::read_json(&dir.join(META))?;
    let (thrust, moments, fused) = read_table(&dir.join(TABLE), meta.known, meta.stats.clone())?;
    let without_sonar = match &meta.stats_without_sonar {
        Some(s) => Some(read_table(&dir.join(TABLE_NO_SONAR), meta.known, s.clone())?.2),
        None => None,
    };
    let actuators = read_actuators(&dir.join(ACTUATORS), &meta.actuators)?;
    Ok(FusedRun {
        meta,
        thrust,
        moments,
        fused,
        without_sonar,
        actuators,
    })
}

/// Loads a run for a model of `vehicle`: its command clipped at the vehicle's limits.
/// Fails for a run without a force log (see [`FusedRun::require_force`]).
pub fn load_for(dir: &Path, vehicle: &crate::core::model::Vehicle) -> anyhow::Result<FusedRun> {
    let run = load(dir)?;
    run.require_force()?;
    Ok(run.clip_to(vehicle))
}

/// The DOFs a pool run records, in the order of `Fused::vel` and the thrust columns.
pub const POOL_DOFS: [crate::core::dof::Dof; 4] = [
    crate::core::dof::Dof::Surge,
    crate::core::dof::Dof::Sway,
    crate::core::dof::Dof::Heave,
    crate::core::dof::Dof::Yaw,
];

impl FusedRun {
    /// An error for a run that logged no commanded forces: a model driven by forces cannot be
    /// fitted to it or simulated on it; the field-trial stages (`arx`, `integrated`) can.
    pub fn require_force(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.meta.force_logged,
            "pool run `{}` has no thrust.csv (only actuators.csv): a force-driven stage cannot use it; identify it with an `arx` or `integrated` stage, or add the commanded forces",
            self.meta.run
        );
        Ok(())
    }

    /// The actuator called `name` on the fused time base, when the run logged it.
    pub fn actuator(&self, name: &str) -> Option<&Vec<f64>> {
        let j = self.meta.actuators.iter().position(|n| n == name)?;
        self.actuators.get(j)
    }

    /// The logged command as the thrusters can deliver it: clipped at the vehicle's
    /// `command_limits` (a closed-loop controller asks for more than it gets). Said in the
    /// run's notes when any row was clipped.
    pub fn clip_to(mut self, vehicle: &crate::core::model::Vehicle) -> FusedRun {
        let mut clipped = 0usize;
        for row in &mut self.thrust {
            for (j, d) in POOL_DOFS.iter().enumerate() {
                let c = vehicle.clip_command(*d, row[j]);
                if c != row[j] {
                    clipped += 1;
                    row[j] = c;
                }
            }
        }
        if clipped > 0 {
            self.meta.notes.push(format!("{clipped} logged command values beyond the vehicle's command_limits were clipped to them"));
        }
        self
    }

    /// The fused velocity of DOF `d` (u, v, w, r from the fusion; p, q from the attitude
    /// sensor), when the run has it.
    pub fn velocity(&self, d: crate::core::dof::Dof) -> Option<&Vec<f64>> {
        self.channel(d, false)
    }

    /// The standard deviation of [`FusedRun::velocity`].
    pub fn velocity_std(&self, d: crate::core::dof::Dof) -> Option<&Vec<f64>> {
        self.channel(d, true)
    }

    fn channel(&self, d: crate::core::dof::Dof, std: bool) -> Option<&Vec<f64>> {
        let f = &self.fused;
        let rp = &f.roll_pitch;
        match d.index() {
            3 | 4 if std => rp.rate_std[d.index() - 3].as_ref(),
            3 | 4 => rp.rate[d.index() - 3].as_ref(),
            _ => {
                let j = POOL_DOFS.iter().position(|x| *x == d)?;
                if std {
                    f.std[j].as_ref()
                } else {
                    f.vel[j].as_ref()
                }
            }
        }
    }

    /// The logged command at sample `k` as a 6-vector X Y Z K M N (K and M zero when the log
    /// has none).
    pub fn tau(&self, k: usize) -> crate::core::model::Vec6 {
        let c = self.thrust[k];
        let [kk, m] = self.moments.get(k).copied().unwrap_or([0.0; 2]);
        [c[0], c[1], c[2], kk, m, c[3]]
    }

    /// The run with its logged command through a first-order lag of `lag_s`: paired with a
    /// recording that follows the motion by such a lag (a navigation filter's low-pass), the
    /// command as it shows in it (for a linear vehicle a lag on either side is the same).
    pub fn with_command_lagged(mut self, lag_s: f64) -> FusedRun {
        let lagged = crate::core::model::dynamics::lagged(&self.fused.t, &self.taus(), lag_s);
        self.set_command(&lagged);
        self
    }

    /// The run with its logged command replaced by the force `plant` says it gives: through
    /// the model's command lag and times its command gain ([`Plant::command`]).
    ///
    /// [`Plant::command`]: crate::core::model::Plant::command
    pub fn with_command_of(mut self, plant: &crate::core::model::Plant) -> FusedRun {
        if !plant.shapes_command() {
            return self;
        }
        let given = plant.command(&self.fused.t, &self.taus());
        self.set_command(&given);
        self
    }

    /// The logged command at every sample (X, Y, Z, K, M, N).
    fn taus(&self) -> Vec<crate::core::model::Vec6> {
        (0..self.thrust.len()).map(|k| self.tau(k)).collect()
    }

    /// The command replaced by `given` (X, Y, Z, K, M, N per sample).
    fn set_command(&mut self, given: &[crate::core::model::Vec6]) {
        let has_moments = !self.moments.is_empty();
        for (k, x) in given.iter().enumerate() {
            self.thrust[k] = [x[0], x[1], x[2], x[5]];
            if has_moments {
                self.moments[k] = [x[3], x[4]];
            }
        }
    }

    /// Roll and pitch at sample `k` (level where no sensor gave them).
    pub fn attitude(&self, k: usize) -> [f64; 2] {
        let rp = &self.fused.roll_pitch;
        let at = |v: &Vec<f64>| v.get(k).copied().filter(|x| x.is_finite()).unwrap_or(0.0);
        [at(&rp.roll), at(&rp.pitch)]
    }

    /// The run as a response table for the equation-error fit: the command as loaded (see
    /// [`load_for`], which clips it at the vehicle's limits), the fused velocity and its time
    /// derivative, and the attitude. The fused velocity is the smoother's state, so its
    /// central difference is smooth where a difference of raw samples would be noise. With a
    /// median `filter` (seed 003), translational velocities are cleaned before they are
    /// differentiated and angular accelerations after. None when a DOF of the vehicle was not
    /// fused (the Coriolis terms need every velocity).
    pub fn as_response(
        &self,
        vehicle: &crate::core::model::Vehicle,
        filter: Option<&crate::core::median::MedianFilter>,
    ) -> Option<crate::core::response::Response> {
        use crate::core::median::reject;
        use crate::core::response::{Series, Source, differentiate};
        let t = self.fused.t.clone();
        let mut r = crate::core::response::Response {
            attitude: (0..t.len()).map(|k| self.attitude(k)).collect(),
            t,
            dofs: Default::default(),
        };
        for d in crate::core::dof::Dof::ALL
            .iter()
            .filter(|d| vehicle.dofs.contains(d))
        {
            let mut v = self.velocity(*d)?.clone();
            if let (Some(f), false) = (filter, d.is_angular()) {
                v = reject(&v, f.length, f.width_m_s).0;
            }
            let mut accel = differentiate(&r.t, &v);
            if let (Some(f), true) = (filter, d.is_angular()) {
                accel = reject(&accel, f.length, f.width_deg_s2.to_radians()).0;
            }
            let force = (0..r.t.len()).map(|k| self.tau(k)[d.index()]).collect();
            r.dofs.insert(
                *d,
                Series {
                    force,
                    velocity: v,
                    accel,
                    force_source: Source::Column,
                    accel_source: Source::Differentiated,
                },
            );
        }
        Some(r)
    }

    /// Which of the vehicle's DOFs this run lacks a fused velocity for.
    pub fn missing_dofs(
        &self,
        vehicle: &crate::core::model::Vehicle,
    ) -> Vec<crate::core::dof::Dof> {
        crate::core::dof::Dof::ALL
            .into_iter()
            .filter(|d| vehicle.dofs.contains(d) && self.velocity(*d).is_none())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Commands beyond the vehicle's limits are clipped to them, DOF by DOF, and counted; a
    /// DOF without a limit is left as logged.
    #[test]
    fn commands_are_clipped_at_the_vehicles_limits() {
        let meta = RunMeta::bare("r", Role::Train);
        let fused = Fused {
            t: vec![0.0, 1.0],
            vel: Default::default(),
            std: Default::default(),
            x: vec![],
            y: vec![],
            z: vec![],
            psi: vec![],
            roll_pitch: Default::default(),
            tracked: Default::default(),
            stats: Stats::default(),
        };
        let run = FusedRun {
            meta,
            thrust: vec![[80.0, -10.0, -70.0, 20.0], [10.0, 10.0, 10.0, -12.0]],
            moments: Vec::new(),
            fused,
            without_sonar: None,
            actuators: Vec::new(),
        };
        let mut v = crate::core::model::Vehicle::reference();
        v.command_limits = [
            (crate::core::dof::Dof::Surge, 60.0),
            (crate::core::dof::Dof::Heave, 45.0),
            (crate::core::dof::Dof::Yaw, 9.0),
        ]
        .into_iter()
        .collect();
        let run = run.clip_to(&v);
        assert_eq!(
            run.thrust,
            vec![[60.0, -10.0, -45.0, 9.0], [10.0, 10.0, 10.0, -9.0]]
        );
        assert!(
            run.meta
                .notes
                .iter()
                .any(|n| n.starts_with("4 logged command values")),
            "{:?}",
            run.meta.notes
        );
    }
}
