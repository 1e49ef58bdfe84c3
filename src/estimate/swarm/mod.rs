//! Population-based estimators in the spirit of argmin's split (STYLE.md point 4): a `Problem`
//! (objective, bounds, evaluation count, whole-population evaluation in parallel), a `Solver`
//! that performs one iteration, and an `Executor` that owns the seed, the iteration limit,
//! restarts and progress.
//!
//! One file per method ([`qpso`], [`pso`], [`ga`]): its solver and its registry entry.

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::kernels::{l1_block, quad_all};
use super::output_error::OutputError;
use super::{Estimate, EstimateError, Fit, Options, Regression};
use crate::rng::Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

pub mod ga;
pub mod pso;
pub mod qpso;

/// Which norm of the equation error is minimised: seed 001 eq. 14 is L1 (sum |tau - tau_id| / sqrt K).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Norm {
    L1,
    #[default]
    L2,
}

/// The equation-error objective over a box of sign-constrained bounds.
pub struct Problem<'a> {
    reg: &'a Regression,
    /// Row weights (1 / the DOF's residual scale), so newtons and newton-metres compare.
    w: Vec<f64>,
    norm: Norm,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    /// For L2: the quadratic form f = c - 2 b.theta + theta' A theta, built once, so one
    /// evaluation costs p^2 instead of K p operations.
    a: Vec<f64>,
    b: Vec<f64>,
    c: f64,
    /// For L1: the rows and targets multiplied by their weights, built once, so one row of
    /// one evaluation costs p multiply-adds, an absolute value and a sum.
    wphi: Vec<f64>,
    wy: Vec<f64>,
    evals: AtomicUsize,
    /// Output error (seed 001 eq. 9): simulate the model under each case's applied force and
    /// compare velocities, instead of the equation error.
    output: Option<OutputError<'a>>,
}

impl<'a> Problem<'a> {
    /// Bounds: every coefficient is negative (docs/formats.md sign convention); its magnitude is
    /// bounded by a scale read from the data: added mass by 5 x the rigid-body mass of its DOF,
    /// linear drag by 3 x the smallest |force| / |speed| over samples moving at >= 5 % of the
    /// top speed, quadratic drag by 3 max|tau| / max|nu|^2.
    pub fn new(reg: &'a Regression, rigid_mass: &[f64; 6], norm: Norm) -> Problem<'a> {
        let p = reg.cols();
        let mut fmax = [0.0f64; 6];
        let mut vmax = [0.0f64; 6];
        let mut scale = [0.0f64; 6];
        let mut count = [0usize; 6];
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            fmax[d] = fmax[d].max(reg.y[i].abs());
            scale[d] += reg.y[i] * reg.y[i];
            count[d] += 1;
            // The linear-drag column of this row is -nu: its magnitude is the speed.
            for j in 0..p {
                let (g, dof) = reg.layout.slot(j);
                if dof.index() == d && g == crate::model::params::Group::LinearDrag {
                    vmax[d] = vmax[d].max(reg.row(i)[j].abs());
                }
            }
        }
        let w: Vec<f64> = reg
            .row_dof
            .iter()
            .map(|d| {
                1.0 / (scale[d.index()] / count[d.index()].max(1) as f64)
                    .sqrt()
                    .max(1e-9)
            })
            .collect();
        // Linear drag can be no larger than force / speed at any moving sample near steady
        // state; the smallest such ratio (the slowest steady case) bounds it far tighter than
        // max force / max speed.
        let col = |g: crate::model::params::Group, d: usize| {
            (0..p).find(|&j| reg.layout.slot(j) == (g, crate::dof::Dof::ALL[d]))
        };
        let mut amax = [0.0f64; 6];
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            if let Some(j) = col(crate::model::params::Group::AddedMass, d) {
                amax[d] = amax[d].max(reg.row(i)[j].abs());
            }
        }
        let mut lin_bound = [f64::INFINITY; 6];
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            let (Some(jl), Some(ja)) = (
                col(crate::model::params::Group::LinearDrag, d),
                col(crate::model::params::Group::AddedMass, d),
            ) else {
                continue;
            };
            let (v, a) = (reg.row(i)[jl].abs(), reg.row(i)[ja].abs());
            // Steady samples only (acceleration under 2 % of its peak): there force = drag.
            if v >= 0.05 * vmax[d] && v > 0.0 && a <= 0.02 * amax[d] {
                lin_bound[d] = lin_bound[d].min(reg.y[i].abs() / v);
            }
        }
        let mut lo = vec![0.0; p];
        let mut hi = vec![0.0; p];
        for j in 0..p {
            let (g, dof) = reg.layout.slot(j);
            let d = dof.index();
            let v = vmax[d].max(1e-3);
            lo[j] = -match g {
                crate::model::params::Group::AddedMass => 5.0 * rigid_mass[d],
                crate::model::params::Group::LinearDrag => 3.0 * lin_bound[d].min(fmax[d] / v),
                crate::model::params::Group::QuadraticDrag => 3.0 * fmax[d] / (v * v),
                // A constant force no larger than the largest force the rows need.
                crate::model::params::Group::Constant => fmax[d],
            };
            if g == crate::model::params::Group::Constant {
                hi[j] = fmax[d];
            }
        }
        let (mut a, mut b, mut c) = (vec![0.0; p * p], vec![0.0; p], 0.0);
        if norm == Norm::L2 {
            for i in 0..reg.rows() {
                let (row, wi) = (reg.row(i), w[i] * w[i]);
                for r in 0..p {
                    b[r] += wi * row[r] * reg.y[i];
                    for s in 0..p {
                        a[r * p + s] += wi * row[r] * row[s];
                    }
                }
                c += wi * reg.y[i] * reg.y[i];
            }
        }
        let (wphi, wy) = if norm == Norm::L1 {
            // The weights are positive, so |w (y - row . x)| = |(w row) . x - w y|.
            let wphi = reg
                .phi
                .chunks(p.max(1))
                .zip(&w)
                .flat_map(|(row, wi)| row.iter().map(move |v| wi * v))
                .collect();
            (wphi, reg.y.iter().zip(&w).map(|(y, wi)| wi * y).collect())
        } else {
            (Vec::new(), Vec::new())
        };
        Problem {
            reg,
            w,
            norm,
            lo,
            hi,
            a,
            b,
            c,
            wphi,
            wy,
            evals: AtomicUsize::new(0),
            output: None,
        }
    }

    /// The same bounds, with the output-error objective instead of the equation error.
    pub fn with_output_error(mut self, o: OutputError<'a>) -> Problem<'a> {
        self.output = Some(o);
        self
    }

    /// Row weights (for exporting the problem to another implementation).
    pub fn weights(&self) -> &[f64] {
        &self.w
    }

    pub fn dim(&self) -> usize {
        self.lo.len()
    }

    pub fn evaluations(&self) -> usize {
        self.evals.load(Ordering::Relaxed)
    }

    /// The objective: L1 as seed 001 eq. 14 (sum |w r| / sqrt K), L2 as mean (w r)^2.
    pub fn cost(&self, theta: &[f64]) -> f64 {
        self.evals.fetch_add(1, Ordering::Relaxed);
        if let Some(o) = &self.output {
            return o.cost(&self.reg.layout, theta);
        }
        let k = self.reg.rows().max(1) as f64;
        match self.norm {
            Norm::L2 => {
                let p = theta.len();
                let mut q = self.c;
                for r in 0..p {
                    q -= 2.0 * self.b[r] * theta[r];
                    let row = &self.a[r * p..(r + 1) * p];
                    q += theta[r] * row.iter().zip(theta).map(|(x, t)| x * t).sum::<f64>();
                }
                q.max(0.0) / k
            }
            Norm::L1 => {
                let mut s = 0.0;
                for i in 0..self.reg.rows() {
                    let fit: f64 = self.reg.row(i).iter().zip(theta).map(|(x, t)| x * t).sum();
                    s += (self.w[i] * (self.reg.y[i] - fit)).abs();
                }
                s / k.sqrt()
            }
        }
    }

    /// Costs of a whole population, evaluated in parallel; the result does not depend on the
    /// number of threads (each particle's cost is independent).
    pub fn cost_all(&self, pop: &[Vec<f64>]) -> Vec<f64> {
        if self.output.is_some() {
            return pop.par_iter().map(|x| self.cost(x)).collect();
        }
        match self.norm {
            // A few hundred flops: a thread hand-off costs more than the evaluation.
            Norm::L2 => self.l2_all(pop),
            Norm::L1 => self.l1_all(pop),
        }
    }

    /// L2 costs of a whole population from the quadratic form, vectorised across particles:
    /// q = c - 2 b.x + x' A x for every particle at once (parameters stored transposed).
    fn l2_all(&self, pop: &[Vec<f64>]) -> Vec<f64> {
        let m = pop.len();
        let p = self.dim();
        self.evals.fetch_add(m, Ordering::Relaxed);
        let mut xt = vec![0.0; p * m];
        for (i, x) in pop.iter().enumerate() {
            for j in 0..p {
                xt[j * m + i] = x[j];
            }
        }
        let mut q = vec![self.c; m];
        quad_all(&self.a, &self.b, &xt, p, &mut q);
        let k = self.reg.rows().max(1) as f64;
        q.into_iter().map(|v| v.max(0.0) / k).collect()
    }

    /// L1 costs of a whole population in one pass over the rows: each row is read once and
    /// multiplied into every particle (parameters stored transposed so the inner loop runs
    /// over particles and vectorises). Rows are split into fixed blocks whose partial sums
    /// are added in block order, so the result does not depend on the thread count.
    fn l1_all(&self, pop: &[Vec<f64>]) -> Vec<f64> {
        const BLOCK: usize = 1024;
        let m = pop.len();
        let p = self.dim();
        self.evals.fetch_add(m, Ordering::Relaxed);
        let mut xt = vec![0.0; p * m];
        for (i, x) in pop.iter().enumerate() {
            for j in 0..p {
                xt[j * m + i] = x[j];
            }
        }
        let k = self.reg.rows();
        let partial: Vec<Vec<f64>> = (0..k.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut acc = vec![0.0; m];
                let rows = b * BLOCK..((b + 1) * BLOCK).min(k);
                l1_block(
                    &self.wphi[rows.start * p..rows.end * p],
                    &self.wy[rows],
                    &xt,
                    p,
                    &mut acc,
                );
                acc
            })
            .collect();
        let scale = (k.max(1) as f64).sqrt();
        (0..m)
            .map(|i| partial.iter().map(|a| a[i]).sum::<f64>() / scale)
            .collect()
    }

    fn clamp(&self, x: &mut [f64]) {
        for (j, v) in x.iter_mut().enumerate() {
            *v = v.clamp(self.lo[j], self.hi[j]);
        }
    }

    fn random_point(&self, rng: &mut Rng) -> Vec<f64> {
        (0..self.dim())
            .map(|j| self.lo[j] + (self.hi[j] - self.lo[j]) * rng.uniform())
            .collect()
    }
}

/// The state every population method keeps: positions, personal bests, the global best.
pub struct Swarm {
    pub x: Vec<Vec<f64>>,
    pub best: Vec<Vec<f64>>,
    pub best_cost: Vec<f64>,
    pub g: usize,
}

impl Swarm {
    fn new(problem: &Problem, n: usize, rng: &mut Rng) -> Swarm {
        let x: Vec<Vec<f64>> = (0..n).map(|_| problem.random_point(rng)).collect();
        let cost = problem.cost_all(&x);
        let g = argmin(&cost);
        Swarm {
            best: x.clone(),
            x,
            best_cost: cost,
            g,
        }
    }

    fn absorb(&mut self, cost: &[f64]) {
        for (i, c) in cost.iter().enumerate() {
            if *c < self.best_cost[i] {
                self.best_cost[i] = *c;
                self.best[i] = self.x[i].clone();
            }
        }
        self.g = argmin(&self.best_cost);
    }
}

fn argmin(v: &[f64]) -> usize {
    v.iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i)
}

/// One iteration of a population method.
pub trait Solver {
    fn init(&mut self, problem: &Problem, rng: &mut Rng, population: usize) -> Swarm;
    fn step(&mut self, problem: &Problem, swarm: &mut Swarm, rng: &mut Rng, progress: f64);
}

/// Runs a solver: `restarts` independent seeded runs (the spread of their answers is the
/// reported interval), each `iterations` long.
pub fn execute(
    name: &str,
    make: &dyn Fn() -> Box<dyn Solver>,
    reg: &Regression,
    rigid_mass: &[f64; 6],
    opts: &Options,
) -> Result<Fit, EstimateError> {
    super::ols::check_excitation(reg)?;
    let mut problem = Problem::new(reg, rigid_mass, opts.norm);
    if let Some((vehicle, responses)) = opts.output_error {
        problem = problem.with_output_error(OutputError::new(vehicle, responses));
    }
    let mut answers: Vec<(Vec<f64>, f64)> = Vec::new();
    let started = std::time::Instant::now();
    let mut stopped_early = None;
    for r in 0..opts.restarts.max(1) {
        let mut rng = Rng::derive(opts.seed, &format!("{name}/restart/{r}"));
        let mut solver = make();
        let mut swarm = solver.init(&problem, &mut rng, opts.population);
        for it in 0..opts.iterations {
            if crate::interrupt::requested() {
                return Err(EstimateError::Interrupted);
            }
            if let Some(limit) = opts
                .max_seconds
                .filter(|l| started.elapsed().as_secs_f64() > *l)
            {
                stopped_early = Some(format!(
                    "time limit of {limit} s reached in restart {} of {} after {it} of {} iterations",
                    r + 1,
                    opts.restarts.max(1),
                    opts.iterations
                ));
                break;
            }
            solver.step(
                &problem,
                &mut swarm,
                &mut rng,
                it as f64 / opts.iterations.max(1) as f64,
            );
            if let Some(p) = opts.progress {
                p((r * opts.iterations + it + 1) as f64
                    / (opts.restarts.max(1) * opts.iterations) as f64);
            }
        }
        answers.push((swarm.best[swarm.g].clone(), swarm.best_cost[swarm.g]));
        if stopped_early.is_some() {
            break;
        }
    }
    answers.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best = answers[0].0.clone();
    let p = best.len();
    // Output error: a local least-squares refinement from the best answer gives the final
    // values and, from its Jacobian, their standard errors.
    let refined = opts.output_error.map(|(vehicle, responses)| {
        let oe = OutputError::new(vehicle, responses);
        let r = super::refine::output_error_lm(&oe, &reg.layout, &best, 30);
        best = r.theta.clone();
        r
    });
    let parameters = (0..p)
        .map(|j| {
            let vals: Vec<f64> = answers.iter().map(|a| a.0[j]).collect();
            let (lo, hi) = vals
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(*v), h.max(*v))
                });
            let mean = vals.iter().sum::<f64>() / vals.len() as f64;
            let sd = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / (vals.len().max(2) - 1) as f64)
                .sqrt();
            let at_bound = (best[j] - problem.lo[j]).abs() < 1e-6 * problem.lo[j].abs().max(1.0)
                || best[j].abs() < 1e-9;
            // One search run has no spread to judge a value by.
            let single = vals.len() < 2;
            let stderr = match &refined {
                Some(r) => r.stderr[j],
                None if single => f64::NAN,
                None => sd,
            };
            let spread_ok = refined.is_some() || (!single && (hi - lo) < 0.5 * best[j].abs());
            let note = if at_bound {
                Some(
                    "pinned to its search bound: the data (or the search) did not determine it"
                        .to_string(),
                )
            } else if single && refined.is_none() {
                Some(
                    "one search run only (time limit): no spread across restarts to judge it by"
                        .to_string(),
                )
            } else {
                None
            };
            Estimate {
                name: reg.layout.name(j),
                value: best[j],
                unit: reg.layout.unit(j).to_string(),
                stderr,
                interval: Some([lo, hi]),
                // Wide disagreement between restarts, a standard error over half the value,
                // or a value pinned to a bound means the data (or the search) did not
                // determine it.
                identifiable: !at_bound
                    && spread_ok
                    && stderr.is_finite()
                    && stderr < 0.5 * best[j].abs(),
                note,
            }
        })
        .collect();
    let residual = super::ols::residual_sigma(reg, &best);
    // The regressor's conditioning does not depend on the method: take it from the LS summary.
    let condition_number = super::ols::summarise(reg, &best, &residual).condition_number;
    Ok(Fit {
        parameters,
        residual_sigma: residual
            .iter()
            .map(|(d, s)| (d.name().to_string(), *s))
            .collect(),
        samples: reg.rows(),
        condition_number,
        evaluations: Some(problem.evaluations()),
        objective_value: Some(refined.as_ref().map_or(answers[0].1, |r| r.cost_after)),
        stopped_early,
        trace: None,
    })
}

/// A population method as the registry holds it: one of the solvers, run by [`execute`].
pub struct Population {
    pub name: &'static str,
    pub make: fn() -> Box<dyn Solver>,
}

/// The settings every population method reads.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PopulationSettings {
    /// Seed of the random draws; part of the cache key and provenance.
    pub seed: u64,
    /// Population and iterations (seed 001 does not state its own).
    pub population: usize,
    pub iterations: usize,
    /// Independent seeded runs: their spread is the reported interval.
    pub restarts: usize,
    /// Norm of the equation error: l1 (seed 001 eq. 14) or l2.
    pub norm: Norm,
    /// Wall-clock limit, s; the best so far is kept and the report says the search was cut
    /// short. Not part of the numbers' identity: leave it unset for reproducible results.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_seconds: Option<f64>,
}

impl Default for PopulationSettings {
    fn default() -> Self {
        PopulationSettings {
            seed: 1,
            population: 40,
            iterations: 2000,
            restarts: 5,
            norm: Norm::L2,
            max_seconds: None,
        }
    }
}

impl PopulationSettings {
    fn of(settings: &serde_json::Value) -> PopulationSettings {
        serde_json::from_value(settings.clone()).expect("checked when parsed")
    }
}

impl super::Estimator for Population {
    fn name(&self) -> &'static str {
        self.name
    }

    fn stochastic(&self) -> bool {
        true
    }

    fn settings(
        &self,
        own: serde_json::Map<String, serde_json::Value>,
    ) -> Result<serde_json::Value, String> {
        super::own_settings::<PopulationSettings>(own)
    }

    fn apply(&self, settings: &serde_json::Value, opts: &mut Options) {
        let s = PopulationSettings::of(settings);
        opts.seed = s.seed;
        opts.population = s.population.max(2);
        opts.iterations = s.iterations.max(1);
        opts.restarts = s.restarts.max(1);
        opts.norm = s.norm;
        opts.max_seconds = s.max_seconds;
    }

    fn detail(&self, settings: &serde_json::Value) -> Option<String> {
        Some(format!("{:?}", PopulationSettings::of(settings).norm))
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        execute(self.name, &self.make, problem, &opts.rigid_mass, opts)
    }
}

#[cfg(test)]
mod tests;
