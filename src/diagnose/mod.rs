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

pub mod discover;
mod drift;
pub mod effects;
mod figures;
mod locate;
pub mod reckon;
pub mod report;
pub mod result;
pub mod search;
mod select;
mod spectrum;
pub mod stage;
pub mod start;
#[cfg(test)]
mod tests;
mod unexplained;
mod verdict;
pub mod world;

use crate::core::dof::Dof;
use crate::core::model::{Plant, Pool, Vec6};
use crate::pool::fusion::run::FusedRun;
use effects::State;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::Arc;
use world::World;

pub use effects::{Hypothesis, REGISTRY, hypothesis};
pub use locate::{Mismatch, REGIMES, Regime, RegimeShare, locate, regime_shares};
pub use result::{Diagnosis, Figure};
pub use select::{Criteria, Search, Tested, Untested, params_map, select, untested};
pub use verdict::diagnose;

/// The pool DOFs, in the order of the fused tables: surge, sway, heave, yaw.
pub const DOFS: [Dof; 4] = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
const NU: [usize; 4] = [0, 1, 2, 5];

/// Integration step of the simulator, s (the twin and the thruster lag both need < 0.05).
const STEP: f64 = 0.025;

/// A fused pool run as the diagnosis reads it.
#[derive(Debug, Clone)]
pub struct Run {
    pub name: String,
    pub validate: bool,
    pub t: Vec<f64>,
    /// Logged command [X, Y, Z, N].
    pub cmd: Vec<[f64; 4]>,
    pub vel: [Vec<f64>; 4],
    pub std: [Vec<f64>; 4],
    /// Per DOF, the share of `std` that is the sensor's own noise (below 1 for a navigation
    /// log's velocities, whose smoother assumes more): the noise floor counts only that.
    pub noise_share: [f64; 4],
    pub pos: [Vec<f64>; 3],
    pub psi: Vec<f64>,
    pub pool: Option<Pool>,
    pub anchor: Option<[f64; 3]>,
    /// Whether `pos` is dead-reckoned from the navigation log's velocity and heading (no
    /// position sensor; run.yaml's `start_m` gave the start), see [`reckon`].
    pub dead_reckoned: bool,
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

    /// None when a DOF was not fused (the run lacks a sensor it needs).
    pub fn from_fused(r: &FusedRun) -> Option<Run> {
        let validate = r.meta.role == crate::pool::import::Role::Validate;
        Run::from_parts(
            &r.meta.run,
            validate,
            &r.thrust,
            &r.fused,
            r.meta.pool,
            r.meta.tether_anchor_m,
        )
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
        thrust: &[[f64; 4]],
        f: &crate::pool::fusion::Fused,
        pool: Option<Pool>,
        anchor: Option<[f64; 3]>,
    ) -> Option<Run> {
        // The velocities that keep the motion (a navigation log's smoothed under its sensor's
        // own noise): the diagnosis compares simulations with them, and a flattened motion
        // hides what the model lacks.
        let [u, v, w, r] = [0, 1, 2, 3].map(|j| f.tracking(j));
        let (u, v, w, r) = (u?, v?, w?, r?);
        Some(Run {
            name: name.into(),
            validate,
            t: f.t.clone(),
            cmd: thrust.to_vec(),
            vel: [u.0.to_vec(), v.0.to_vec(), w.0.to_vec(), r.0.to_vec()],
            std: [u.1.to_vec(), v.1.to_vec(), w.1.to_vec(), r.1.to_vec()],
            noise_share: [u.2, v.2, w.2, r.2],
            pos: [f.x.clone(), f.y.clone(), f.z.clone()],
            psi: f.psi.clone(),
            pool,
            anchor,
            dead_reckoned: false,
            anchors_s: Vec::new(),
        })
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
    /// A term found by [`discover`] beyond the named effects, added as a force.
    pub discovered: Option<Arc<discover::Discovered>>,
}

/// A set of effects with their parameter values.
pub type Selection = Vec<(&'static Hypothesis, Vec<f64>)>;

pub fn augmentation(sel: &[(&'static Hypothesis, Vec<f64>)]) -> Augmentation {
    let mut a = Augmentation::default();
    for (h, p) in sel {
        let term = (h.build)(p);
        a.delay_s += term.delay_s();
        if term.acts_on_plant() {
            a.terms.push(term);
        }
    }
    a
}

/// The model's velocities [u, v, w, r] at the run's sample times, driven by the logged command,
/// from the run's first fused velocity. Position and heading are taken from the fused track
/// at each sample (they are measured to centimetres; integrating them would let a small
/// velocity error move the vehicle to the wrong tether length or wall distance). With a sensor
/// delay d, the recording at t + d is what the vehicle did at t.
pub fn simulate(plant: &Plant, aug: &Augmentation, run: &Run) -> Vec<[f64; 4]> {
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

/// A run's recording read `delay` seconds late (a sensor delay), each sample's shifted time
/// located once for every series; without a delay, the samples themselves.
struct Shifted {
    delay: f64,
    loc: Vec<(usize, Option<f64>)>,
}

impl Shifted {
    fn new(t: &[f64], delay: f64) -> Shifted {
        let loc = if delay == 0.0 {
            Vec::new()
        } else {
            t.iter()
                .map(|&tk| crate::pool::fusion::locate(t, tk + delay))
                .collect()
        };
        Shifted { delay, loc }
    }

    fn at(&self, series: &[f64], k: usize) -> f64 {
        if self.delay == 0.0 {
            series[k]
        } else {
            crate::pool::fusion::interp_at(series, self.loc[k])
        }
    }
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

/// The fused velocities at sample `k` as the centred mean over five samples: a window started
/// from one noisy sample would carry that sample's noise through it (and a time shift that
/// interpolates between samples would look like an improvement).
fn anchor_velocity(run: &Run, rec: &Shifted, k: usize, s: &mut State) {
    let n = run.t.len();
    let (a, b) = (k.saturating_sub(2), (k + 2).min(n - 1));
    for (j, &i) in NU.iter().enumerate() {
        s.nu[i] = (a..=b).map(|q| rec.at(&run.vel[j], q)).sum::<f64>() / (b - a + 1) as f64;
    }
}

/// [`simulate`], and the sample after which it diverged.
fn simulate_checked(
    plant: &Plant,
    aug: &Augmentation,
    run: &Run,
) -> (Vec<[f64; 4]>, Option<usize>) {
    let w = world_for(plant, aug, run);
    let n = run.t.len();
    let cmd6 = |k: usize| -> Vec6 {
        let c = run.cmd[k];
        [c[0], c[1], c[2], 0.0, 0.0, c[3]]
    };
    let rec = Shifted::new(&run.t, aug.delay_s);
    let mut s = State::default();
    for (j, &i) in NU.iter().enumerate() {
        s.nu[i] = rec.at(&run.vel[j], 0);
    }
    s.thrust = w.shape_command(&cmd6(0));
    let mut out = Vec::with_capacity(n);
    let anchors = crate::core::model::stability::anchors(&run.t, &run.anchors_s);
    let mut next_anchor = 1;
    let discovered = aug.discovered.as_ref().map(|d| (d, d.prepare(run)));
    for k in 0..n {
        if anchors.get(next_anchor) == Some(&k) {
            // Multiple shooting: the window starts again from the fused state (thruster
            // states carry over).
            anchor_velocity(run, &rec, k, &mut s);
            next_anchor += 1;
        }
        out.push([s.nu[0], s.nu[1], s.nu[2], s.nu[5]]);
        if k + 1 == n {
            break;
        }
        s.pos = [0, 1, 2].map(|j| rec.at(&run.pos[j], k));
        s.psi = rec.at(&run.psi, k);
        let span = run.t[k + 1] - run.t[k];
        let m = crate::core::model::dynamics::substeps(span, STEP);
        let c = cmd6(k);
        let external = discovered
            .as_ref()
            .map_or([0.0; 6], |(d, pre)| d.force(run, pre, k, &s));
        for _ in 0..m {
            s = w.step_with(&s, &c, span / m as f64, &external);
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

/// Per-DOF sums of a simulation against a run's recording.
#[derive(Debug, Clone, Copy, Default)]
pub struct Sums {
    pub sse: [f64; 4],
    /// Huber loss: squared error up to the DOF's threshold, linear beyond it.
    pub huber: [f64; 4],
    pub sae: [f64; 4],
    pub sam: [f64; 4],
    pub n: [f64; 4],
}

impl Sums {
    fn add(&mut self, o: &Sums) {
        for j in 0..4 {
            self.sse[j] += o.sse[j];
            self.huber[j] += o.huber[j];
            self.sae[j] += o.sae[j];
            self.sam[j] += o.sam[j];
            self.n[j] += o.n[j];
        }
    }

    /// Normalised robust cost: sum over DOFs of the mean Huber loss / mean square velocity.
    /// Below the threshold it is the mean squared error; a short burst far beyond it (a sensor
    /// glitch, a bump against the wall) counts linearly and cannot decide the ranking.
    pub fn cost(&self, scale: &[f64; 4]) -> f64 {
        (0..4)
            .map(|j| {
                if self.n[j] > 0.0 {
                    self.huber[j] / self.n[j] / scale[j]
                } else {
                    0.0
                }
            })
            .sum()
    }

    /// The plain mean-square cost (what the noise floor is compared with).
    pub fn mse_cost(&self, scale: &[f64; 4]) -> f64 {
        (0..4)
            .map(|j| {
                if self.n[j] > 0.0 {
                    self.sse[j] / self.n[j] / scale[j]
                } else {
                    0.0
                }
            })
            .sum()
    }

    /// Normalised MAE per DOF (seed 003): mean |error| / mean |measured|.
    pub fn nmae(&self) -> [f64; 4] {
        std::array::from_fn(|j| {
            if self.sam[j] > 0.0 {
                self.sae[j] / self.sam[j]
            } else {
                f64::NAN
            }
        })
    }
}

/// Residual (simulated - recorded) at each recorded sample, per DOF. With a sensor delay d the
/// recording at t shows what the vehicle did at t - d: the simulation (smooth) is read there,
/// never the recording between its samples (interpolating a noisy recording would lower its
/// noise and pass for an improvement). Samples before the simulation starts are NaN.
pub fn residual(sim: &[[f64; 4]], run: &Run, delay: f64) -> [Vec<f64>; 4] {
    let start = *run.t.first().unwrap_or(&0.0);
    let loc: Vec<(usize, Option<f64>)> = if delay == 0.0 {
        Vec::new()
    } else {
        run.t
            .iter()
            .map(|&tk| crate::pool::fusion::locate(&run.t, tk - delay))
            .collect()
    };
    std::array::from_fn(|j| {
        let series: Vec<f64> = sim.iter().map(|x| x[j]).collect();
        (0..run.t.len())
            .map(|k| {
                let ts = run.t[k] - delay;
                if ts < start - 1e-9 {
                    f64::NAN
                } else if delay == 0.0 {
                    series[k] - run.vel[j][k]
                } else {
                    crate::pool::fusion::interp_at(&series, loc[k]) - run.vel[j][k]
                }
            })
            .collect()
    })
}

/// Per-DOF sums of a simulation against a run, with the Huber thresholds `delta` (per DOF).
pub fn sums(sim: &[[f64; 4]], run: &Run, delay: f64, delta: &[f64; 4]) -> Sums {
    let e = residual(sim, run, delay);
    let mut s = Sums::default();
    for j in 0..4 {
        for (k, x) in e[j].iter().enumerate() {
            if x.is_finite() {
                s.sse[j] += x * x;
                let a = x.abs();
                s.huber[j] += if a <= delta[j] {
                    x * x
                } else {
                    delta[j] * (2.0 * a - delta[j])
                };
                s.sae[j] += x.abs();
                s.sam[j] += run.vel[j][k].abs();
                s.n[j] += 1.0;
            }
        }
    }
    s
}

/// Per DOF, the noise floor of the normalised cost on `runs`: their mean noise variance
/// ([`Run::noise_sum`]) over the DOF's scale. The diagnosis's floor is the sum over DOFs.
pub fn noise_per_dof(runs: &[Run], scale: &[f64; 4]) -> [f64; 4] {
    std::array::from_fn(|j| {
        let n: usize = runs.iter().map(|r| r.std[j].len()).sum();
        runs.iter().map(|r| r.noise_sum(j)).sum::<f64>() / n.max(1) as f64 / scale[j]
    })
}

/// The data of one diagnosis: runs split by role, with the scale of each DOF.
pub struct Data {
    pub train: Vec<Run>,
    pub validate: Vec<Run>,
    pub scale: [f64; 4],
    /// Huber thresholds per DOF: a quarter of the RMS velocity, and at least three times the
    /// fused velocity's mean standard deviation (noise is never down-weighted).
    pub delta: [f64; 4],
    /// Noise floor of the normalised cost on the held-out runs (fused variances, the sensors'
    /// own share: [`Run::noise_share`]).
    pub noise_cost: f64,
    /// The effects to test ([`effects::REGISTRY`] unless a caller chooses others).
    pub effects: effects::Registry,
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
        let all = || train.iter().chain(&validate);
        let scale: [f64; 4] = std::array::from_fn(|j| {
            let (s, n) = all().fold((0.0, 0.0), |(s, n), r| {
                (
                    s + r.vel[j].iter().map(|v| v * v).sum::<f64>(),
                    n + r.vel[j].len() as f64,
                )
            });
            (s / n.max(1.0)).max(1e-12)
        });
        let noise_cost = noise_per_dof(&validate, &scale).iter().sum();
        let delta: [f64; 4] = std::array::from_fn(|j| {
            let (s, n) = all().fold((0.0, 0.0), |(s, n), r| {
                (s + r.std[j].iter().sum::<f64>(), n + r.std[j].len() as f64)
            });
            (0.25 * scale[j].sqrt()).max(3.0 * s / n.max(1.0))
        });
        Ok(Data {
            effects: REGISTRY,
            train,
            validate,
            scale,
            delta,
            noise_cost,
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
        let samples: [f64; 4] =
            std::array::from_fn(|j| self.train.iter().map(|r| r.vel[j].len() as f64).sum());
        let mut total = Sums::default();
        // As many runs at once as there are threads, added in the runs' order.
        for chunk in self.train.chunks(rayon::current_num_threads().max(1)) {
            let part: Vec<Sums> = chunk
                .par_iter()
                .map(|r| self.run_sums(plant, aug, r))
                .collect();
            part.iter().for_each(|p| total.add(p));
            let lower: f64 = (0..4)
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
pub fn nmae_map(s: &Sums) -> BTreeMap<Dof, f64> {
    let v = s.nmae();
    DOFS.iter()
        .enumerate()
        .filter(|(j, _)| v[*j].is_finite())
        .map(|(j, d)| (*d, v[j]))
        .collect()
}

/// Runs the residual of a model over a set of runs.
pub fn residuals(plant: &Plant, aug: &Augmentation, runs: &[Run]) -> Vec<[Vec<f64>; 4]> {
    runs.par_iter()
        .map(|r| residual(&simulate(plant, aug, r), r, aug.delay_s))
        .collect()
}
