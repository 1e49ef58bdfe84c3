//! `method: pso` — standard particle swarm optimisation.

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::{Population, Problem, Solver, Swarm};
use crate::core::rng::Rng;

/// The estimator `method: pso` names.
pub static ESTIMATOR: Population = Population {
    name: "pso",
    make: || Box::new(Pso::new()),
};

/// Standard PSO (global best): inertia falling from 0.9 to 0.4, cognitive and social weights
/// 1.49618 (Clerc's constriction values), velocities limited to a fifth of the box and
/// stopped at a bound (absorbing walls), so particles do not pile up on the box's faces.
pub struct Pso {
    v: Vec<Vec<f64>>,
}

impl Pso {
    pub fn new() -> Pso {
        Pso { v: Vec::new() }
    }
}

impl Default for Pso {
    fn default() -> Self {
        Pso::new()
    }
}

impl Solver for Pso {
    fn init(&mut self, problem: &Problem, rng: &mut Rng, population: usize) -> Swarm {
        let s = Swarm::new(problem, population, rng);
        self.v = (0..population)
            .map(|_| {
                (0..problem.dim())
                    .map(|j| 0.1 * (problem.hi[j] - problem.lo[j]) * (2.0 * rng.uniform() - 1.0))
                    .collect()
            })
            .collect();
        s
    }

    fn step(&mut self, problem: &Problem, s: &mut Swarm, rng: &mut Rng, progress: f64) {
        const C: f64 = 1.49618;
        let w = 0.9 - 0.5 * progress;
        let pg = s.best[s.g].clone();
        for i in 0..s.x.len() {
            for j in 0..problem.dim() {
                let vmax = 0.2 * (problem.hi[j] - problem.lo[j]);
                let v = w * self.v[i][j]
                    + C * rng.uniform() * (s.best[i][j] - s.x[i][j])
                    + C * rng.uniform() * (pg[j] - s.x[i][j]);
                self.v[i][j] = v.clamp(-vmax, vmax);
                s.x[i][j] += self.v[i][j];
                if s.x[i][j] < problem.lo[j] || s.x[i][j] > problem.hi[j] {
                    self.v[i][j] = 0.0;
                }
            }
            let mut xi = std::mem::take(&mut s.x[i]);
            problem.clamp(&mut xi);
            s.x[i] = xi;
        }
        let cost = problem.cost_all(&s.x);
        s.absorb(&cost);
    }
}
