//! Missing-physics diagnosis: why do the pool recordings and the CFD-identified model differ?
//!
//! 1. **Drift or structure.** The model's own parameters are re-estimated on the training runs
//!    (equation error, least squares). If that explains the held-out runs to within their
//!    measurement noise, nothing is missing: the parameters drifted.
//! 2. **Locate.** The CFD model's residual on the held-out runs: which run and DOF carries it,
//!    in which time windows, and in which regimes (after command steps, reverse or small
//!    commands, far from the tether anchor, near walls, ...), as shares of the error.
//! 3. **Test hypotheses.** Every effect of the table in docs/formats.md is a physically formed augmentation
//!    of the model ([`crate::core::model::effects`]) with one or two parameters, fitted by output
//!    error (the simulator driven by the logged thrust, the fused pose) on the training runs.
//!    The winner is the one with the lowest held-out error after a penalty per parameter; it is
//!    kept only if it improves the held-out error significantly, then the next effect is tested
//!    on top of it (greedy). What stays structured and large after that is `unexplained`.
//!
//! Errors are normalised per DOF by the mean square measured velocity of all runs in that DOF,
//! so surge (m/s) and yaw (rad/s) weigh alike; the noise floor is the same sum over the fused
//! velocities' own variances.

mod alike;
mod beside;
pub mod discover;
mod drift;
pub mod effects;
mod figures;
mod latency;
mod locate;
mod noise_rule;
mod readmit;
pub mod reckon;
mod record;
pub mod report;
pub mod result;
mod rival;
pub mod search;
mod select;
mod sentence;
mod settle;
pub mod slots;
mod spectrum;
pub mod stage;
pub mod start;
mod sums;
mod testable;
#[cfg(test)]
mod tests;
mod thrust_start;
mod unexplained;
mod verdict;
pub mod world;

use crate::core::dof::Dof;
use crate::core::model::{Plant, Pool, Vec6};
use crate::pool::fusion::run::FusedRun;
use effects::State;
use rayon::prelude::*;
use record::{Shifted, anchor_velocity, record_filter, recorded_attitude};
use std::collections::BTreeMap;
use std::sync::Arc;
pub(crate) use thrust_start::start_of;
use world::World;

pub use effects::{Hypothesis, REGISTRY, hypothesis};
pub use locate::{Mismatch, REGIMES, Regime, RegimeShare, locate, regime_shares};
pub use result::{Diagnosis, Figure};
pub use select::{Criteria, Search, Tested, params_map, select};
pub use slots::{SLOTS, Slots};
pub use sums::{Sums, noise_per_dof, residual, sums};
pub use testable::{Untested, untested};
pub use verdict::diagnose;

/// The pool DOFs, in the order of the fused tables: surge, sway, heave, yaw.
pub const DOFS: [Dof; 4] = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];

/// Integration step of the simulator, s (the twin and the thruster lag both need < 0.05).
const STEP: f64 = 0.025;

/// A fused pool run as the diagnosis reads it.
#[derive(Debug, Clone)]
pub struct Run {
    pub name: String,
    pub validate: bool,
    pub t: Vec<f64>,
    /// The DOFs of the per-DOF arrays below ([`Slots`]).
    pub slots: Slots,
    /// Logged command in the slots' DOFs ([X, Y, Z, N, K, M]), zero in a slot the model
    /// leaves out.
    pub cmd: Vec<[f64; SLOTS]>,
    pub vel: [Vec<f64>; SLOTS],
    pub std: [Vec<f64>; SLOTS],
    /// Per DOF, the share of `std` that is the sensor's own noise (below 1 for a navigation
    /// log's velocities, whose smoother assumes more): the noise floor counts only that.
    pub noise_share: [f64; SLOTS],
    pub pos: [Vec<f64>; 3],
    pub psi: Vec<f64>,
    pub pool: Option<Pool>,
    pub anchor: Option<[f64; 3]>,
    /// Whether `pos` is dead-reckoned from the navigation log's velocity and heading (no
    /// position sensor; run.yaml's `start_m` gave the start), see [`reckon`].
    pub dead_reckoned: bool,
    /// Recorded roll and pitch (rad) the simulation turns gravity with, for a model compared in
    /// roll and pitch; empty (level) otherwise.
    pub att: [Vec<f64>; 2],
    /// Times at which simulations of this run are re-anchored to the fused velocity (multiple
    /// shooting, where the model is locally unstable along it); empty: the whole run.
    pub anchors_s: Vec<f64>,
}

impl Run {
    /// The sum over the run of DOF `j`'s noise variance: the fused variance, the sensor's own
    /// share ([`Run::noise_share`]). Every noise floor of the diagnosis is made of these.
    pub fn noise_sum(&self, j: usize) -> f64 {
        self.std[j].iter().map(|s| s * s).sum::<f64>() * self.noise_share[j].powi(2)
    }

    /// The run compared in `slots`; None when a DOF the model moves in was not fused (the run
    /// lacks a sensor it needs).
    pub fn from_fused(r: &FusedRun, slots: Slots) -> Option<Run> {
        let validate = r.meta.role == crate::pool::import::Role::Validate;
        let cmd = (0..r.thrust.len())
            .map(|k| {
                let c = r.tau(k);
                std::array::from_fn(|j| if slots.active[j] { c[j] } else { 0.0 })
            })
            .collect();
        Run::from_parts(&r.meta.run, validate, cmd, &r.fused, slots)
            .map(|run| Run {
                pool: r.meta.pool,
                anchor: r.meta.tether_anchor_m,
                ..run
            })
            .map(|run| run.reckoned_from(r.meta.start_m))
    }

    /// Without a horizontal position, the track dead-reckoned from `start` (when given) and
    /// the run's velocity and heading; the run unchanged otherwise.
    pub fn reckoned_from(mut self, start: Option<[f64; 2]>) -> Run {
        let Some(start) = start else {
            return self;
        };
        if effects::has_position(&self) {
            return self;
        }
        if let Some([x, y]) = reckon::track(&self.t, &self.vel[0], &self.vel[1], &self.psi, start) {
            let n = self.t.len();
            if self.pos[2].len() != n || self.pos[2].iter().any(|z| !z.is_finite()) {
                self.pos[2] = vec![0.0; n];
            }
            self.pos[0] = x;
            self.pos[1] = y;
            self.dead_reckoned = true;
        }
        self
    }

    pub fn from_parts(
        name: &str,
        validate: bool,
        cmd: Vec<[f64; SLOTS]>,
        f: &crate::pool::fusion::Fused,
        slots: Slots,
    ) -> Option<Run> {
        let n = f.t.len();
        let mut vel: [Vec<f64>; SLOTS] = Default::default();
        let mut std: [Vec<f64>; SLOTS] = Default::default();
        let mut noise_share = [1.0; SLOTS];
        for j in 0..SLOTS {
            if !slots.active[j] {
                // Held at rest and never scored.
                (vel[j], std[j]) = (vec![0.0; n], vec![0.0; n]);
                continue;
            }
            let (v, s, share) = slots::slot_channel(f, slots.dof(j))?;
            (vel[j], std[j], noise_share[j]) = (v.to_vec(), s.to_vec(), share);
        }
        let rp = &f.roll_pitch;
        let rotation = slots.slot(Dof::Roll).is_some() || slots.slot(Dof::Pitch).is_some();
        let att = match rotation && rp.roll.len() == n && rp.pitch.len() == n {
            true => [rp.roll.clone(), rp.pitch.clone()],
            false => Default::default(),
        };
        Some(Run {
            name: name.into(),
            validate,
            t: f.t.clone(),
            slots,
            cmd,
            vel,
            std,
            noise_share,
            pos: [f.x.clone(), f.y.clone(), f.z.clone()],
            psi: f.psi.clone(),
            pool: None,
            anchor: None,
            dead_reckoned: false,
            att,
            anchors_s: Vec::new(),
        })
    }

    /// The command at sample k as a generalised force (zero outside the slots).
    pub fn cmd6(&self, k: usize) -> Vec6 {
        // Slot j is the DOF of index j in nu.
        self.cmd[k]
    }

    /// Gravity's direction in the body frame at sample k: from the recorded roll and pitch,
    /// level without them.
    pub fn gravity(&self, k: usize) -> [f64; 3] {
        match (self.att[0].get(k), self.att[1].get(k)) {
            (Some(&phi), Some(&theta)) if phi.is_finite() && theta.is_finite() => {
                crate::core::model::dynamics::gravity_body(phi, theta)
            }
            _ => crate::core::model::dynamics::LEVEL,
        }
    }

    /// Sets the slots' velocities of `s` to the recording's at sample k.
    pub fn set_velocity(&self, k: usize, s: &mut State) {
        for j in 0..SLOTS {
            s.nu[j] = self.vel[j][k];
        }
    }

    /// Straight-line length from the tether's anchor at sample k, m.
    pub fn tether_length(&self, k: usize) -> Option<f64> {
        let pos = [self.pos[0][k], self.pos[1][k], self.pos[2][k]];
        Some(crate::core::model::pool::tether_length(self.anchor?, pos))
    }

    /// Distance to the nearest side wall at sample k, m.
    pub fn wall_distance(&self, k: usize) -> Option<f64> {
        Some(self.pool?.wall_distance(self.pos[0][k], self.pos[1][k]))
    }
}

/// What a hypothesis adds to the model: plant effects and a sensor time offset.
#[derive(Debug, Clone, Default)]
pub struct Augmentation {
    pub terms: Vec<Arc<dyn effects::Term>>,
    pub delay_s: f64,
    /// Time constant of the recording's low-pass, s (see [`record_filter`]).
    pub filter_s: f64,
    /// The terms found by [`discover`] beyond the named effects, added as forces.
    pub discovered: Vec<Arc<discover::Discovered>>,
}

/// A set of effects with their parameter values.
pub type Selection = Vec<(&'static Hypothesis, Vec<f64>)>;

/// Named effects kept beside a discovered candidate, its figures, and what the verdict says
/// of the choice.
type Chosen<T> = (Selection, result::Candidate, Vec<result::Figure>, T);

pub fn augmentation(sel: &[(&'static Hypothesis, Vec<f64>)]) -> Augmentation {
    let mut a = Augmentation::default();
    for (h, p) in sel {
        let term = (h.build)(p);
        a.delay_s += term.delay_s();
        a.filter_s += term.sensor_filter_s();
        if term.acts_on_plant() {
            a.terms.push(term);
        }
    }
    a
}

/// [`augmentation`] of `sel` with the discovered `terms` in the model beside it.
pub fn augmentation_beside(
    sel: &[(&'static Hypothesis, Vec<f64>)],
    terms: &[Arc<discover::Discovered>],
) -> Augmentation {
    let mut a = augmentation(sel);
    a.discovered = terms.to_vec();
    a
}

/// The model's velocities per slot at the run's sample times, driven by the logged command,
/// from the run's first fused velocity. Position and heading are taken from the fused track
/// at each sample (they are measured to centimetres; integrating them would let a small
/// velocity error move the vehicle to the wrong tether length or wall distance). With a sensor
/// delay d, the recording at t + d is what the vehicle did at t.
pub fn simulate(plant: &Plant, aug: &Augmentation, run: &Run) -> Vec<[f64; SLOTS]> {
    simulate_checked(plant, aug, run).0
}

/// The time at which the model's simulation of `run` (re-anchored as the run says) leaves the
/// range a vehicle can reach (50 m/s or rad/s, or not finite), if it does: such a model is
/// unsound, and no effect fitted on top of it means anything.
pub fn divergence(plant: &Plant, run: &Run) -> Option<f64> {
    simulate_checked(plant, &Augmentation::default(), run)
        .1
        .map(|k| run.t[k])
}

/// The diagnosis's world for a run: the plant with the augmentation's terms, in the run's pool.
fn world_for(plant: &Plant, aug: &Augmentation, run: &Run) -> World {
    let mut w = World::new(plant.clone(), aug.terms.clone());
    w.pool = run.pool;
    w.tether_anchor = run.anchor;
    // The pose is set from the recording at every sample; integrating it only matters to
    // effects that read it within a step.
    w.track_pose = w.effects_need_pose();
    w
}

/// The step of a simulation that carries roll and pitch: gravity is held through each step,
/// so the step resolves the restoring moment's oscillation (a fifth of 1 / omega, omega^2 =
/// eta_z / the roll or pitch inertia), at most [`STEP`]. A six-DOF model of a Gazebo BlueROV2
/// held level by a stiff moment (eta_z 1164 N m on 0.3 kg m^2) swung about level at [`STEP`],
/// tilting its buoyancy into surge and sway: the diagnosis scored held-out surge at 0.087 where
/// the validation had 0.023, and named a sensor delay for it.
fn attitude_step(plant: &Plant) -> f64 {
    let eta = plant.hydro.moment[2].abs();
    let m = plant.mass();
    let omega = [3, 4]
        .iter()
        .filter(|&&i| plant.active[i] && m[i] > 0.0)
        .map(|&i| (eta / m[i]).sqrt())
        .fold(0.0, f64::max);
    match omega > 0.0 {
        true => STEP.min(0.2 / omega).max(1e-4),
        false => STEP,
    }
}

/// [`simulate`], and the sample after which it diverged.
fn simulate_checked(
    plant: &Plant,
    aug: &Augmentation,
    run: &Run,
) -> (Vec<[f64; SLOTS]>, Option<usize>) {
    let rec = Shifted::new(&run.t, aug.delay_s);
    let (mut out, diverged) = simulate_vehicle(plant, aug, run, &rec);
    if aug.filter_s > 0.0 {
        record_filter(&mut out, run, &rec, aug.filter_s);
    }
    (out, diverged)
}

/// The vehicle's velocities as [`simulate`] gives them, before a sensor's low-pass, and the
/// sample after which the simulation diverged.
fn simulate_vehicle(
    plant: &Plant,
    aug: &Augmentation,
    run: &Run,
    rec: &Shifted,
) -> (Vec<[f64; SLOTS]>, Option<usize>) {
    let start = thrust_start::thrust_at_start(plant, aug, run, rec);
    simulate_from(plant, aug, run, rec, (start, run.t.len()))
}

/// The vehicle's velocities at the run's first `until` samples, the thrusters starting at
/// `start`, and the sample after which the simulation diverged ([`simulate_vehicle`]).
fn simulate_from(
    plant: &Plant,
    aug: &Augmentation,
    run: &Run,
    rec: &Shifted,
    (start, until): (Vec6, usize),
) -> (Vec<[f64; SLOTS]>, Option<usize>) {
    let mut w = world_for(plant, aug, run);
    let n = until.min(run.t.len());
    let mut s = State::default();
    for j in 0..SLOTS {
        s.nu[j] = rec.at(&run.vel[j], 0);
    }
    if aug.filter_s > 0.0 {
        anchor_velocity(run, rec, 0, aug.filter_s, &mut s);
    }
    s.thrust = start;
    let mut att = recorded_attitude(run, rec, 0);
    let step = att.map_or(STEP, |_| attitude_step(plant));
    let mut out = Vec::with_capacity(n);
    let anchors = crate::core::model::stability::anchors(&run.t, &run.anchors_s);
    let mut next_anchor = 1;
    // What the terms read besides the sample is the run's, the same for every term.
    let prepared = aug.discovered.first().map(|d| d.prepare(run));
    for k in 0..n {
        if anchors.get(next_anchor) == Some(&k) {
            // Multiple shooting: the window starts again from the fused state (thruster
            // states carry over).
            anchor_velocity(run, rec, k, aug.filter_s, &mut s);
            att = recorded_attitude(run, rec, k);
            next_anchor += 1;
        }
        out.push(s.nu);
        if k + 1 == n {
            break;
        }
        s.pos = [0, 1, 2].map(|j| rec.at(&run.pos[j], k));
        s.psi = rec.at(&run.psi, k);
        let span = run.t[k + 1] - run.t[k];
        let m = crate::core::model::dynamics::substeps(span, step);
        let c = run.cmd6(k);
        let external = prepared.as_ref().map_or([0.0; 6], |pre| {
            aug.discovered.iter().fold([0.0; 6], |acc, d| {
                let f = d.force(run, pre, k, &s);
                std::array::from_fn(|i| acc[i] + f[i])
            })
        });
        for _ in 0..m {
            let h = span / m as f64;
            let Some(a) = att.as_mut() else {
                s = w.step_with(&s, &c, h, &external);
                continue;
            };
            // Gravity is held through the step at the attitude of its middle (predicted from
            // the rates at its start), and the attitude moved with the step's mean rates: held
            // at the start's attitude instead, a swing about level gained energy every step.
            let start = crate::core::model::attitude::euler_rates(*a, &s.nu);
            let mid = [a[0] + 0.5 * h * start[0], a[1] + 0.5 * h * start[1]];
            w.gravity = crate::core::model::dynamics::gravity_body(mid[0], mid[1]);
            let next = w.step_with(&s, &c, h, &external);
            let mean: Vec6 = std::array::from_fn(|i| 0.5 * (s.nu[i] + next.nu[i]));
            let rate = crate::core::model::attitude::euler_rates(mid, &mean);
            *a = [a[0] + h * rate[0], a[1] + h * rate[1]];
            s = next;
        }
        if s.nu.iter().any(|x| !x.is_finite() || x.abs() > 50.0) {
            // Diverged: hold the last finite state so the cost is large but finite.
            let last = out[k].map(|x| x + 50.0);
            out.extend(std::iter::repeat_n(last, n - k - 1));
            return (out, Some(k));
        }
    }
    (out, None)
}

/// The data of one diagnosis: runs split by role, with the scale of each DOF.
pub struct Data {
    /// The DOFs of the per-DOF arrays, every run's.
    pub slots: Slots,
    pub train: Vec<Run>,
    pub validate: Vec<Run>,
    pub scale: [f64; SLOTS],
    /// Huber thresholds per DOF: a quarter of the RMS velocity, and at least three times the
    /// fused velocity's mean standard deviation (noise is never down-weighted).
    pub delta: [f64; SLOTS],
    /// Noise floor of the normalised cost on the held-out runs (fused variances, the sensors'
    /// own share: [`Run::noise_share`]).
    pub noise_cost: f64,
    /// The effects to test ([`effects::REGISTRY`] unless a caller chooses others).
    pub effects: effects::Registry,
    /// The vehicle's size against the one the effects' ranges were set for: its mass over
    /// the reference vehicle's (1 until the diagnosis sets it). On a smaller vehicle the
    /// search's grid of a force-like parameter spans this share of its range, on a heavier
    /// one the range is this many times wider ([`effects::Param::bounds`]).
    pub size: f64,
}

impl Data {
    pub fn new(runs: Vec<Run>) -> anyhow::Result<Data> {
        let (validate, train): (Vec<Run>, Vec<Run>) = runs.into_iter().partition(|r| r.validate);
        if train.is_empty() || validate.is_empty() {
            anyhow::bail!(
                "the diagnosis needs training and held-out pool runs ({} with role: train, {} with role: validate)\n  help: set `role: validate` in the run.yaml of at least one run and `role: train` in another",
                train.len(),
                validate.len()
            );
        }
        let slots = train[0].slots;
        let all = || train.iter().chain(&validate);
        let scale: [f64; SLOTS] = std::array::from_fn(|j| {
            let (s, n) = all().fold((0.0, 0.0), |(s, n), r| {
                (
                    s + r.vel[j].iter().map(|v| v * v).sum::<f64>(),
                    n + r.vel[j].len() as f64,
                )
            });
            (s / n.max(1.0)).max(1e-12)
        });
        let noise_cost = noise_per_dof(&validate, &scale).iter().sum();
        let delta: [f64; SLOTS] = std::array::from_fn(|j| {
            let (s, n) = all().fold((0.0, 0.0), |(s, n), r| {
                (s + r.std[j].iter().sum::<f64>(), n + r.std[j].len() as f64)
            });
            (0.25 * scale[j].sqrt()).max(3.0 * s / n.max(1.0))
        });
        Ok(Data {
            slots,
            effects: REGISTRY,
            train,
            validate,
            scale,
            delta,
            noise_cost,
            size: 1.0,
        })
    }

    /// The sums of one run simulated with `aug`.
    fn run_sums(&self, plant: &Plant, aug: &Augmentation, r: &Run) -> Sums {
        sums(&simulate(plant, aug, r), r, aug.delay_s, &self.delta)
    }

    pub fn eval(&self, plant: &Plant, aug: &Augmentation, validate: bool) -> Sums {
        let runs = if validate {
            &self.validate
        } else {
            &self.train
        };
        let parts: Vec<Sums> = runs
            .par_iter()
            .map(|r| self.run_sums(plant, aug, r))
            .collect();
        let mut total = Sums::default();
        parts.iter().for_each(|p| total.add(p));
        total
    }

    pub fn cost(&self, plant: &Plant, aug: &Augmentation, validate: bool) -> f64 {
        self.eval(plant, aug, validate).cost(&self.scale)
    }

    /// The training cost, or infinity as soon as it is certain to be at least `bound`: a
    /// search that only needs to know a candidate is no better than `bound` stops simulating
    /// it. After each run the Huber sums so far, divided by every sample the runs have (at
    /// least the count the cost divides by), are a lower bound of the cost, in floating point
    /// too (sums of non-negative terms and divisions by larger numbers round monotonically),
    /// so a finite answer is `cost(.., false)` to the bit.
    pub fn train_cost_below(&self, plant: &Plant, aug: &Augmentation, bound: f64) -> f64 {
        let samples: [f64; SLOTS] =
            std::array::from_fn(|j| self.train.iter().map(|r| r.vel[j].len() as f64).sum());
        let mut total = Sums::default();
        // As many runs at once as there are threads, added in the runs' order.
        for chunk in self.train.chunks(rayon::current_num_threads().max(1)) {
            let part: Vec<Sums> = chunk
                .par_iter()
                .map(|r| self.run_sums(plant, aug, r))
                .collect();
            part.iter().for_each(|p| total.add(p));
            let lower: f64 = (0..SLOTS)
                .map(|j| {
                    if samples[j] > 0.0 {
                        total.huber[j] / samples[j] / self.scale[j]
                    } else {
                        0.0
                    }
                })
                .sum();
            if lower >= bound {
                return f64::INFINITY;
            }
        }
        total.cost(&self.scale)
    }
}

/// Per-DOF held-out normalised MAE as docs/formats.md writes it.
pub fn nmae_map(s: &Sums, slots: &Slots) -> BTreeMap<Dof, f64> {
    let v = s.nmae();
    (0..SLOTS)
        .filter(|&j| v[j].is_finite())
        .map(|j| (slots.dof(j), v[j]))
        .collect()
}

/// Runs the residual of a model over a set of runs.
pub fn residuals(plant: &Plant, aug: &Augmentation, runs: &[Run]) -> Vec<[Vec<f64>; SLOTS]> {
    runs.par_iter()
        .map(|r| residual(&simulate(plant, aug, r), r, aug.delay_s))
        .collect()
}
