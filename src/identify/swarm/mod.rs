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
use super::{EstimateError, Fit, Options, Regression};
use crate::core::model::params::Group;
use crate::core::rng::Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

mod executor;
pub mod ga;
pub mod pso;
pub mod qpso;
#[cfg(test)]
mod tests;

pub use executor::execute;

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
    /// top speed, quadratic drag by 3 max|tau| / max|nu|^2; a bound that leaves out the
    /// weighted least-squares value (the equation error's own minimum, where its sign is
    /// physical) is widened to 3 x it.
    pub fn new(reg: &'a Regression, rigid_mass: &[f64; 6], norm: Norm) -> Problem<'a> {
        let p = reg.cols();
        let scales = Scales::of(reg);
        let w = scales.weights(reg);
        let (mut lo, hi) = scales.bounds(reg, rigid_mass);
        // The weighted normal equations, summed serially so that nothing below depends on the
        // thread count: the L2 objective's quadratic form, the least-squares answer and the
        // regression's standard errors.
        let (a, b, c) = quadratic_form(reg, &w);
        // Steady samples bound the linear drag only where nothing but drag balances the force;
        // a real run's restoring moment, constant offset or noise can make one such sample's
        // force / speed nearly 0, which pinned a real vehicle's roll, pitch and yaw damping at
        // a hundredth of their least-squares values (held-out yaw NMAE 4).
        if let Some(ls) = normal_solve(&a, &b, p) {
            for (j, l) in lo.iter_mut().enumerate() {
                let g = reg.layout.slot(j).0;
                let hydro = matches!(
                    g,
                    Group::AddedMass | Group::LinearDrag | Group::QuadraticDrag
                );
                // Only a box that leaves the minimum out is widened; one that holds it keeps
                // the tighter bound the search converges in.
                if hydro && ls[j] < *l {
                    *l = 3.0 * ls[j];
                }
            }
        }
        let (wphi, wy) = if norm == Norm::L1 {
            weighted_rows(reg, &w)
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

    /// The weighted equation error's standard errors at `theta`: s_d^2 (A^T W A)^-1, with s_d^2
    /// the weighted residual variance of the DOF whose equation the coefficient is in (the
    /// normal matrix is block-diagonal by equation but for a term two equations share, as the
    /// moment of weight, which takes its first DOF's); infinite where the normal matrix cannot
    /// be inverted. Summed serially.
    pub fn regression_stderr(&self, theta: &[f64]) -> Vec<f64> {
        let (reg, p) = (self.reg, theta.len());
        let (mut ss, mut rows, mut terms) = ([0.0f64; 6], [0usize; 6], [0usize; 6]);
        for i in 0..reg.rows() {
            let fit: f64 = reg.row(i).iter().zip(theta).map(|(x, t)| x * t).sum();
            let d = reg.row_dof[i].index();
            ss[d] += (self.w[i] * (reg.y[i] - fit)).powi(2);
            rows[d] += 1;
        }
        for j in 0..p {
            terms[reg.layout.slot(j).1.index()] += 1;
        }
        let normal = nalgebra::DMatrix::from_row_slice(p, p, &self.a);
        let Some(inv) = normal.try_inverse() else {
            return vec![f64::INFINITY; p];
        };
        (0..p)
            .map(|j| {
                let d = reg.layout.slot(j).1.index();
                let s2 = ss[d] / rows[d].saturating_sub(terms[d]).max(1) as f64;
                (s2 * inv[(j, j)]).sqrt()
            })
            .collect()
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
        if let Some(o) = &self.output {
            // Candidates share the cases' forces and time grid: simulated a lane group at a time.
            self.evals.fetch_add(pop.len(), Ordering::Relaxed);
            return pop
                .par_chunks(crate::core::model::lanes::LANES)
                .flat_map_iter(|group| {
                    let refs: Vec<&[f64]> = group.iter().map(Vec::as_slice).collect();
                    o.cost_many(&self.reg.layout, &refs)
                })
                .collect();
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

/// Scales read from the rows, per DOF, that weight the rows and bound the coefficients.
struct Scales {
    /// Largest |force|.
    fmax: [f64; 6],
    /// Largest speed (the linear-drag column is -nu).
    vmax: [f64; 6],
    /// Sum of squared forces and the number of rows.
    sum_sq: [f64; 6],
    count: [usize; 6],
}

impl Scales {
    fn of(reg: &Regression) -> Scales {
        let p = reg.cols();
        let mut s = Scales {
            fmax: [0.0; 6],
            vmax: [0.0; 6],
            sum_sq: [0.0; 6],
            count: [0; 6],
        };
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            s.fmax[d] = s.fmax[d].max(reg.y[i].abs());
            s.sum_sq[d] += reg.y[i] * reg.y[i];
            s.count[d] += 1;
            // The linear-drag column of this row is -nu: its magnitude is the speed.
            for j in 0..p {
                let (g, dof) = reg.layout.slot(j);
                if dof.index() == d && g == Group::LinearDrag {
                    s.vmax[d] = s.vmax[d].max(reg.row(i)[j].abs());
                }
            }
        }
        s
    }

    /// Row weights: 1 / the RMS force of the row's DOF, so newtons and newton-metres compare.
    fn weights(&self, reg: &Regression) -> Vec<f64> {
        reg.row_dof
            .iter()
            .map(|d| {
                1.0 / (self.sum_sq[d.index()] / self.count[d.index()].max(1) as f64)
                    .sqrt()
                    .max(1e-9)
            })
            .collect()
    }

    /// Per DOF, the smallest force / speed over steady samples (acceleration under 2 % of its
    /// peak) moving at >= 5 % of the top speed; infinite where there are none.
    ///
    /// Linear drag can be no larger than force / speed at any moving sample near steady
    /// state; the smallest such ratio (the slowest steady case) bounds it far tighter than
    /// max force / max speed.
    fn linear_drag_bound(&self, reg: &Regression) -> [f64; 6] {
        let mut amax = [0.0f64; 6];
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            if let Some(j) = column(reg, Group::AddedMass, d) {
                amax[d] = amax[d].max(reg.row(i)[j].abs());
            }
        }
        let mut lin_bound = [f64::INFINITY; 6];
        for i in 0..reg.rows() {
            let d = reg.row_dof[i].index();
            let (Some(jl), Some(ja)) = (
                column(reg, Group::LinearDrag, d),
                column(reg, Group::AddedMass, d),
            ) else {
                continue;
            };
            let (v, a) = (reg.row(i)[jl].abs(), reg.row(i)[ja].abs());
            // Steady samples only (acceleration under 2 % of its peak): there force = drag.
            if v >= 0.05 * self.vmax[d] && v > 0.0 && a <= 0.02 * amax[d] {
                lin_bound[d] = lin_bound[d].min(reg.y[i].abs() / v);
            }
        }
        lin_bound
    }

    /// The search box (lo, hi): see [`Problem::new`].
    fn bounds(&self, reg: &Regression, rigid_mass: &[f64; 6]) -> (Vec<f64>, Vec<f64>) {
        let p = reg.cols();
        let (fmax, lin_bound) = (&self.fmax, self.linear_drag_bound(reg));
        let mut lo = vec![0.0; p];
        let mut hi = vec![0.0; p];
        for j in 0..p {
            let (g, dof) = reg.layout.slot(j);
            let d = dof.index();
            let v = self.vmax[d].max(1e-3);
            lo[j] = -match g {
                Group::AddedMass => 5.0 * rigid_mass[d],
                Group::LinearDrag => 3.0 * lin_bound[d].min(fmax[d] / v),
                Group::QuadraticDrag => 3.0 * fmax[d] / (v * v),
                // A constant force (or buoyancy) no larger than the largest force the rows need.
                Group::Constant | Group::Buoyancy => fmax[d],
                // The centre of gravity near the thrusters' origin.
                Group::Lever => crate::core::model::terms::LEVER_BOUND_M,
            };
            if g == Group::Lever {
                hi[j] = crate::core::model::terms::LEVER_BOUND_M;
            } else if matches!(g, Group::Constant | Group::Buoyancy)
                || !reg.layout.terms[j].is_diagonal()
            {
                hi[j] = fmax[d];
            }
        }
        (lo, hi)
    }
}

/// The minimum of the weighted equation error from its normal equations `a theta = b` (`a`
/// p x p, row-major), columns equilibrated; `None` where they cannot be solved.
fn normal_solve(a: &[f64], b: &[f64], p: usize) -> Option<Vec<f64>> {
    let s: Vec<f64> = (0..p).map(|j| a[j * p + j].sqrt().max(1e-300)).collect();
    let m = nalgebra::DMatrix::from_fn(p, p, |r, c| a[r * p + c] / (s[r] * s[c]));
    let rhs = nalgebra::DVector::from_fn(p, |r, _| b[r] / s[r]);
    let z = m.cholesky()?.solve(&rhs);
    let theta: Vec<f64> = (0..p).map(|j| z[j] / s[j]).collect();
    theta.iter().all(|x| x.is_finite()).then_some(theta)
}

/// The diagonal column of group `g` in DOF `d`, if the layout has one.
fn column(reg: &Regression, g: Group, d: usize) -> Option<usize> {
    use crate::core::model::Term;
    let t = match g {
        Group::AddedMass => Term::Added(d, d),
        Group::LinearDrag => Term::Linear(d, d),
        _ => return None,
    };
    reg.layout.index_of(t)
}

/// The weighted L2 objective as a quadratic form (A, b, c): f = c - 2 b.theta + theta' A theta.
fn quadratic_form(reg: &Regression, w: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
    let p = reg.cols();
    let (mut a, mut b, mut c) = (vec![0.0; p * p], vec![0.0; p], 0.0);
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
    (a, b, c)
}

/// The rows and targets multiplied by their weights, for the L1 objective.
fn weighted_rows(reg: &Regression, w: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let p = reg.cols();
    // The weights are positive, so |w (y - row . x)| = |(w row) . x - w y|.
    let wphi = reg
        .phi
        .chunks(p.max(1))
        .zip(w)
        .flat_map(|(row, wi)| row.iter().map(move |v| wi * v))
        .collect();
    (wphi, reg.y.iter().zip(w).map(|(y, wi)| wi * y).collect())
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
    /// Puts the settings into `opts`.
    pub fn apply(&self, opts: &mut Options) {
        opts.seed = self.seed;
        opts.population = self.population.max(2);
        opts.iterations = self.iterations.max(1);
        opts.restarts = self.restarts.max(1);
        opts.norm = self.norm;
        opts.max_seconds = self.max_seconds;
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
    ) -> Result<super::OwnSettings, String> {
        super::own_settings::<PopulationSettings>(own).map(super::OwnSettings::Population)
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        execute(self.name, &self.make, problem, &opts.rigid_mass, opts)
    }
}
