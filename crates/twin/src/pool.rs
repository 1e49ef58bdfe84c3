//! Twin pool runs: the reference vehicle free-running in a pool under a logged command
//! (manoeuvre plus a pilot's corrections that keep it off the walls), seen through the sensors
//! of seed 001's test (UWB, a fixed imaging sonar, a nine-axis IMU, a depth gauge), with
//! optional left-out effects concealed in the plant. The effects and the true motion go to a
//! truth folder outside `cases/`, never into the run's files.

use super::world::{Effect, State, WorldPlant};
use hydrofit_core::model::Pool;
use hydrofit_core::model::{Hydro, Plant, Vec6, Vehicle};
use hydrofit_core::rng::Rng;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod render;
pub use render::{Latency, NAV_DVL_PERIOD_S, render, render_nav};

pub const POOL: Pool = Pool {
    length_m: 25.0,
    width_m: 12.0,
    depth_m: 4.0,
};
/// Where the umbilical enters the water: the middle of one short side, at the surface.
pub const TETHER_ANCHOR: [f64; 3] = [0.5, 6.0, 0.0];
/// The imaging sonar: on the same short side, looking down the pool (+x).
pub const SONAR_AT: [f64; 2] = [0.3, 6.0];
pub const SONAR_HALF_FOV_DEG: f64 = 65.0;
pub const SONAR_RANGE_M: (f64, f64) = (1.0, 20.0);
const G: f64 = 9.80665;
/// Largest command the thrusters can deliver: X, Y, Z in N, N in N m.
const LIMITS: [f64; 4] = [110.0, 90.0, 100.0, 10.0];

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Manoeuvre {
    /// Surge steps and reversals with small yaw moments.
    SurgeSteps,
    /// Sway and heave steps, offset in time.
    SwayHeave,
    /// Yaw steps while moving forward.
    YawTurns,
    /// Pseudo-random binary sequences on every DOF at once.
    Prbs,
    /// Overlapping sinusoids on every DOF.
    Mixed,
    /// A command profile given from outside (`hydrofit design`), flown open loop.
    Designed,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunSpec {
    pub name: String,
    pub role: String,
    pub manoeuvre: Manoeuvre,
    pub duration_s: f64,
    /// Whether the run has sonar positions (the sonar is not always recorded).
    pub sonar: bool,
}

pub fn default_runs() -> Vec<RunSpec> {
    let r = |name: &str, role: &str, m, sonar| RunSpec {
        name: name.into(),
        role: role.into(),
        manoeuvre: m,
        duration_s: 120.0,
        sonar,
    };
    vec![
        r("surge_steps", "train", Manoeuvre::SurgeSteps, true),
        r("sway_heave", "train", Manoeuvre::SwayHeave, true),
        r("yaw_turns", "train", Manoeuvre::YawTurns, true),
        r("prbs_a", "train", Manoeuvre::Prbs, false),
        r("mixed", "validate", Manoeuvre::Mixed, true),
        r("prbs_b", "validate", Manoeuvre::Prbs, true),
    ]
}

/// The effects concealed in the shipped pool runs.
pub fn default_effects() -> Vec<Effect> {
    vec![
        Effect::ThrusterLag {
            time_constant_s: 0.35,
        },
        Effect::TetherDrag {
            coefficient: 1.2,
            slack_m: 2.0,
        },
    ]
}

/// Sensor errors drawn for one run (part of the truth, not of the run's files).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Sensors {
    pub uwb_sigma_m: [f64; 3],
    pub uwb_outlier_rate: f64,
    pub sonar_sigma_m: f64,
    pub imu_yaw_sigma_deg: f64,
    pub gyro_sigma_dps: f64,
    pub gyro_bias_dps: f64,
    pub accel_sigma_g: f64,
    pub accel_bias_g: [f64; 3],
    pub depth_sigma_m: f64,
}

impl Sensors {
    fn draw(rng: &mut Rng) -> Sensors {
        Sensors {
            uwb_sigma_m: [0.04, 0.04, 0.08],
            uwb_outlier_rate: 0.03,
            sonar_sigma_m: 0.02,
            imu_yaw_sigma_deg: 0.8,
            gyro_sigma_dps: 0.3,
            gyro_bias_dps: 2.0 * rng.uniform() - 1.0,
            accel_sigma_g: 0.01,
            accel_bias_g: std::array::from_fn(|_| 0.006 * (2.0 * rng.uniform() - 1.0)),
            depth_sigma_m: 0.01,
        }
    }
}

/// The true motion of a run at the internal step, with the command and the body acceleration.
pub struct Truth {
    pub t: Vec<f64>,
    pub states: Vec<State>,
    pub accel: Vec<Vec6>,
    /// Commands at the thrust log's times (every `LOG_EVERY` steps).
    pub cmd: Vec<Vec6>,
}

const STEP: f64 = 0.01;
const LOG_EVERY: usize = 5; // thrust log at 20 Hz

fn square(t: f64, period: f64, levels: &[f64]) -> f64 {
    levels[((t / period) as usize) % levels.len()]
}

/// The manoeuvre's body-frame command [X, Y, Z, N] at time t, without the pilot.
fn program(m: Manoeuvre, t: f64, prbs: &mut [(f64, f64); 4], rng: &mut Rng) -> [f64; 4] {
    match m {
        Manoeuvre::SurgeSteps => [
            square(
                t,
                6.0,
                &[
                    30.0, 0.0, -25.0, 60.0, -45.0, 15.0, 85.0, -60.0, 0.0, 45.0, -20.0, 70.0,
                ],
            ),
            0.0,
            0.0,
            square(t, 15.0, &[1.0, -1.0, 0.0, 2.0]),
        ],
        Manoeuvre::SwayHeave => [
            square(t, 10.0, &[5.0, -5.0]),
            square(t, 5.0, &[20.0, -20.0, 40.0, -30.0, 0.0, 55.0, -45.0, 10.0]),
            square(t + 2.5, 5.0, &[15.0, -15.0, 30.0, -25.0, 0.0, 40.0, -35.0]),
            0.0,
        ],
        Manoeuvre::YawTurns => [
            30.0 + square(t, 20.0, &[0.0, 20.0, -10.0]),
            0.0,
            0.0,
            square(t, 4.0, &[3.0, -3.0, 6.0, 0.0, -5.0, 2.0, -7.0, 4.0]),
        ],
        Manoeuvre::Prbs => {
            let amp = [55.0, 35.0, 30.0, 4.0];
            std::array::from_fn(|i| {
                let (level, next) = &mut prbs[i];
                if t >= *next {
                    *level = if rng.uniform() < 0.5 { amp[i] } else { -amp[i] }
                        * (0.4 + 0.6 * rng.uniform());
                    *next = t + 1.0 + 3.0 * rng.uniform();
                }
                *level
            })
        }
        Manoeuvre::Mixed => [
            20.0 + 50.0 * (0.31 * t).sin(),
            25.0 * (0.53 * t + 1.0).sin(),
            20.0 * (0.41 * t).sin(),
            3.5 * (0.27 * t + 0.5).sin(),
        ],
        Manoeuvre::Designed => [0.0; 4],
    }
}

/// The pilot: pushes the vehicle back when it comes within `MARGIN` of a wall, the floor or
/// the surface, and damps its approach. Returns world-frame [Fx, Fy, Fz].
fn pilot(s: &State) -> [f64; 3] {
    const MARGIN: f64 = 3.0;
    const KP: f64 = 60.0;
    const KD: f64 = 80.0;
    let (c, sn) = (s.psi.cos(), s.psi.sin());
    let v = [
        c * s.nu[0] - sn * s.nu[1],
        sn * s.nu[0] + c * s.nu[1],
        s.nu[2],
    ];
    let bounds = [
        (POOL.length_m, MARGIN),
        (POOL.width_m, MARGIN),
        (POOL.depth_m, 1.0),
    ];
    std::array::from_fn(|i| {
        let (size, m) = bounds[i];
        let p = s.pos[i];
        if p < m {
            KP * (m - p) - KD * v[i].min(0.0)
        } else if p > size - m {
            -KP * (p - (size - m)) - KD * v[i].max(0.0)
        } else {
            0.0
        }
    })
}

/// The vehicle a pool run is flown with: its rigid body and true coefficients, and how the
/// manoeuvres' commands, the pilot's pushes and the thrusters' limits scale to it (per DOF,
/// X, Y, Z, N) so that it moves at the speeds the reference vehicle does.
#[derive(Debug, Clone)]
pub struct Craft {
    pub vehicle: Vehicle,
    pub hydro: Hydro,
    pub command_scale: [f64; 4],
}

impl Craft {
    /// The reference vehicle (seed 001's open-frame ROV, 35.2 kg).
    pub fn reference() -> Craft {
        Craft {
            vehicle: Vehicle::reference(),
            hydro: Hydro::reference(),
            command_scale: [1.0; 4],
        }
    }

    /// A vehicle of BlueROV2 Heavy size: 11.5 kg, I_zz 0.16 kg m^2, and the coefficients
    /// Wu (2018, "6-DoF modelling and control of a remotely operated vehicle", Flinders
    /// University) gives for it, which the BlueROV2 Heavy's Gazebo models use. Its drag is
    /// mostly quadratic (N_r -0.07 beside N_r|r| -1.55), its yaw inertia a ninth of the
    /// reference's. The commands are scaled by its quadratic drag against the reference's,
    /// so that it reaches the same speeds.
    pub fn small() -> Craft {
        let mut vehicle = Vehicle::reference();
        vehicle.name = "BlueROV2 Heavy-sized ROV (pool twin)".into();
        vehicle.mass_kg = 11.5;
        vehicle.inertia_kg_m2.zz = 0.16;
        let hydro = Hydro::diagonal(
            [-5.5, -12.7, -14.57, 0.0, 0.0, -0.12],
            [-4.03, -6.22, -5.18, 0.0, 0.0, -0.07],
            [-18.18, -21.66, -36.99, 0.0, 0.0, -1.55],
        );
        Craft::flown_as_the_reference(vehicle, hydro)
    }

    /// `vehicle` with `hydro`, its commands scaled by its quadratic drag against the
    /// reference's (per DOF, X, Y, Z, N) so that it reaches the reference's speeds.
    fn flown_as_the_reference(vehicle: Vehicle, hydro: Hydro) -> Craft {
        let (r, q) = (Hydro::reference().quad_diag(), hydro.quad_diag());
        let command_scale = [q[0] / r[0], q[1] / r[1], q[2] / r[2], q[5] / r[5]];
        Craft {
            vehicle,
            hydro,
            command_scale,
        }
    }

    /// The reference vehicle made 1.5 times longer, by geometric similarity: mass and added
    /// mass scale as the length cubed (118.8 kg), the yaw inertia and added inertia as its
    /// fifth power, a translational drag coefficient, linear or quadratic, as its square
    /// (the area), the yaw's linear damping as its fourth power and its quadratic damping as
    /// its fifth (the area times the arm, at the arm's speed). A vehicle heavier than every
    /// range the diagnosis was written for: its forces, thrust limits and effects are about
    /// twice the reference's.
    pub fn heavy() -> Craft {
        const L: f64 = 1.5;
        let mut vehicle = Vehicle::reference();
        vehicle.name = "light work-class ROV, the reference 1.5 times longer (pool twin)".into();
        vehicle.mass_kg *= L.powi(3);
        vehicle.inertia_kg_m2.zz *= L.powi(5);
        let r = Hydro::reference();
        let scale = |v: [f64; 6], t: i32, yaw: i32| -> [f64; 6] {
            std::array::from_fn(|i| v[i] * L.powi(if i < 3 { t } else { yaw }))
        };
        let hydro = Hydro::diagonal(
            scale(r.added_diag(), 3, 5),
            scale(r.lin_diag(), 2, 4),
            scale(r.quad_diag(), 2, 5),
        );
        Craft::flown_as_the_reference(vehicle, hydro)
    }

    /// By name: `reference`, `small` or `heavy`.
    pub fn named(name: &str) -> Result<Craft, String> {
        match name {
            "reference" => Ok(Craft::reference()),
            "small" => Ok(Craft::small()),
            "heavy" => Ok(Craft::heavy()),
            _ => Err(format!(
                "unknown twin vehicle `{name}`; known: reference (seed 001's 35.2 kg ROV), small (a BlueROV2 Heavy-sized 11.5 kg ROV), heavy (the reference 1.5 times longer, 118.8 kg)"
            )),
        }
    }

    /// How a force-like effect magnitude of the reference's scenarios scales to this vehicle:
    /// the mean of the horizontal and vertical command scales.
    pub fn force_scale(&self) -> f64 {
        let s = self.command_scale;
        (s[0] + s[1] + s[2]) / 3.0
    }
}

/// Simulates one run of the world plant; deterministic in (`seed`, run name).
pub fn simulate(world: &WorldPlant, spec: &RunSpec, seed: u64) -> Truth {
    simulate_scaled(world, spec, seed, [1.0; 4])
}

/// [`simulate`] with the manoeuvre's commands, the pilot's pushes and the thrusters' limits
/// scaled per DOF ([`Craft::command_scale`]).
pub fn simulate_scaled(world: &WorldPlant, spec: &RunSpec, seed: u64, scale: [f64; 4]) -> Truth {
    let mut rng = Rng::derive(seed, &format!("pool/{}/program", spec.name));
    let mut prbs = [(0.0, 0.0); 4];
    let n = (spec.duration_s / STEP).round() as usize + 1;
    let start = State {
        pos: [
            POOL.length_m / 2.0 + 2.0 * rng.uniform() - 1.0,
            POOL.width_m / 2.0 + rng.uniform() - 0.5,
            1.5,
        ],
        psi: std::f64::consts::PI * (2.0 * rng.uniform() - 1.0),
        ..State::default()
    };
    step_through(world, start, n, |t, s| {
        let p = program(spec.manoeuvre, t, &mut prbs, &mut rng);
        let f = pilot(s);
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let body = [
            scale[0] * (p[0] + c * f[0] + sn * f[1]),
            scale[1] * (p[1] - sn * f[0] + c * f[1]),
            scale[2] * (p[2] + f[2]),
            scale[3] * p[3],
        ];
        let b: [f64; 4] = std::array::from_fn(|i| (body[i] * 10.0).round() / 10.0);
        std::array::from_fn(|i| b[i].clamp(-scale[i] * LIMITS[i], scale[i] * LIMITS[i]))
    })
}

/// `n` steps of the world plant from `start`, the command [X, Y, Z, N] asked of `command` at
/// each logged sample (time, state) and held until the next.
fn step_through(
    world: &WorldPlant,
    start: State,
    n: usize,
    mut command: impl FnMut(f64, &State) -> [f64; 4],
) -> Truth {
    let mut truth = Truth {
        t: Vec::with_capacity(n),
        states: Vec::with_capacity(n),
        accel: Vec::with_capacity(n),
        cmd: Vec::with_capacity(n / LOG_EVERY + 1),
    };
    let (mut s, mut cmd) = (start, [0.0; 6]);
    for k in 0..n {
        let t = k as f64 * STEP;
        if k % LOG_EVERY == 0 {
            let b = command(t, &s);
            cmd = [b[0], b[1], b[2], 0.0, 0.0, b[3]];
            truth.cmd.push(cmd);
        }
        truth.t.push(t);
        truth.states.push(s);
        truth.accel.push(world.accel(&s, &cmd, t));
        s = world.step(&s, &cmd, STEP, t);
    }
    truth
}

/// What the truth folder records of a run: never read by the pipeline's fusion or fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthRecord {
    pub run: String,
    pub seed: u64,
    pub effects: Vec<Effect>,
    pub spec: RunSpec,
    pub sensors: Sensors,
}

/// True motion at the thrust log's times: `t,u,v,w,r,x,y,z,psi`.
pub fn truth_csv(truth: &Truth) -> String {
    let mut out = String::from("t,u,v,w,r,x_m,y_m,z_m,psi_rad\n");
    for k in (0..truth.t.len()).step_by(LOG_EVERY) {
        let s = &truth.states[k];
        let _ = writeln!(
            out,
            "{:.2},{:.6},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.6}",
            truth.t[k], s.nu[0], s.nu[1], s.nu[2], s.nu[5], s.pos[0], s.pos[1], s.pos[2], s.psi
        );
    }
    out
}

pub fn world(effects: &[Effect]) -> WorldPlant {
    world_of(&Craft::reference(), effects)
}

/// The pool world of `craft` with `effects` concealed.
pub fn world_of(craft: &Craft, effects: &[Effect]) -> WorldPlant {
    let mut w = WorldPlant::new(Plant::new(&craft.vehicle, craft.hydro));
    w.effects = effects.to_vec();
    w.pool = Some(POOL);
    w.tether_anchor = Some(TETHER_ANCHOR);
    w
}

/// Writes `cases_dir/<run>/` and `truth_dir/<run>.{csv,json}` for every run.
pub fn write_runs(
    cases_dir: &Path,
    truth_dir: &Path,
    runs: &[RunSpec],
    effects: &[Effect],
    seed: u64,
) -> anyhow::Result<Vec<PathBuf>> {
    write_runs_seen(cases_dir, truth_dir, runs, effects, seed, Logs::Sensors)
}

/// What a run folder holds: the pool's own sensors ([`render`]: UWB, sonar, IMU, depth) or the
/// vehicle's navigation log ([`render_nav`]: DVL and AHRS, depth).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Logs {
    Sensors,
    Navigation,
}

/// [`write_runs`] with the run folders holding `logs`.
pub fn write_runs_seen(
    cases_dir: &Path,
    truth_dir: &Path,
    runs: &[RunSpec],
    effects: &[Effect],
    seed: u64,
    logs: Logs,
) -> anyhow::Result<Vec<PathBuf>> {
    let dirs = (cases_dir, truth_dir);
    write_runs_of(&Craft::reference(), dirs, runs, (effects, seed), logs)
}

/// [`write_runs_seen`] with `craft` flying the runs.
pub fn write_runs_of(
    craft: &Craft,
    (cases_dir, truth_dir): (&Path, &Path),
    runs: &[RunSpec],
    (effects, seed): (&[Effect], u64),
    logs: Logs,
) -> anyhow::Result<Vec<PathBuf>> {
    let w = world_of(craft, effects);
    let mut written = Vec::new();
    for spec in runs {
        let truth = simulate_scaled(&w, spec, seed, craft.command_scale);
        written.push(write_truth(
            (cases_dir, truth_dir),
            spec,
            &truth,
            (effects, seed),
            logs,
        )?);
    }
    Ok(written)
}

/// Flies `cmd` ([X, Y, Z, N] at the thrust log's 20 Hz) open loop from `start`: no pilot, the
/// command exactly as given (a designed run, whose plan kept it off the walls).
pub fn fly(world: &WorldPlant, cmd: &[[f64; 4]], start: State) -> Truth {
    let n = cmd.len().saturating_sub(1) * LOG_EVERY + 1;
    let mut next = cmd.iter();
    step_through(world, start, n, |_, _| {
        *next.next().expect("one command per logged sample")
    })
}

/// Writes the run folder (holding `logs`) and the truth of one simulated run.
pub fn write_truth(
    (cases_dir, truth_dir): (&Path, &Path),
    spec: &RunSpec,
    truth: &Truth,
    (effects, seed): (&[Effect], u64),
    logs: Logs,
) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(truth_dir)?;
    let sensors = Sensors::draw(&mut Rng::derive(
        seed,
        &format!("pool/{}/errors", spec.name),
    ));
    let latency = Latency::of(effects);
    let mut files = match logs {
        Logs::Sensors => render(spec, truth, &sensors, latency, seed),
        Logs::Navigation => render_nav(spec, truth, &sensors, latency, seed),
    };
    files.retain(|(name, _)| spec.sonar || *name != "sonar.csv");
    let record = TruthRecord {
        run: spec.name.clone(),
        seed,
        effects: effects.to_vec(),
        spec: spec.clone(),
        sensors,
    };
    let dir = super::write_run(
        cases_dir,
        truth_dir,
        &spec.name,
        &files,
        &truth_csv(truth),
        &record,
    )?;
    // A run without sonar: no sonar log left from an earlier write either.
    if !spec.sonar {
        let _ = std::fs::remove_file(dir.join("sonar.csv"));
    }
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pilot_keeps_every_run_inside_the_pool() {
        for craft in [Craft::reference(), Craft::small()] {
            let w = world_of(&craft, &default_effects());
            for spec in default_runs() {
                let truth = simulate_scaled(&w, &spec, 1, craft.command_scale);
                inside(&spec, &truth);
            }
        }
    }

    /// Every state of `truth` inside the pool, and a surge peak a pool run would have.
    fn inside(spec: &RunSpec, truth: &Truth) {
        for s in &truth.states {
            assert!(
                s.pos[0] > 0.3 && s.pos[0] < POOL.length_m - 0.3,
                "{}: x {}",
                spec.name,
                s.pos[0]
            );
            assert!(
                s.pos[1] > 0.3 && s.pos[1] < POOL.width_m - 0.3,
                "{}: y {}",
                spec.name,
                s.pos[1]
            );
            assert!(
                s.pos[2] > 0.0 && s.pos[2] < POOL.depth_m,
                "{}: z {}",
                spec.name,
                s.pos[2]
            );
        }
        let peak = truth
            .states
            .iter()
            .fold(0.0f64, |a, s| a.max(s.nu[0].abs()));
        // The sway and heave run of the small vehicle surges at 0.18 m/s at most.
        assert!(
            peak > 0.15 && peak < 1.6,
            "{}: peak surge {peak}",
            spec.name
        );
    }
}
