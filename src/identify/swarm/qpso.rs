//! `method: qpso` — quantum-behaved particle swarm optimisation (seed 001 section 3.5): mbest,
//! the learning-tendency point p_d = phi p_i + (1 - phi) p_g, and x = p_d ± beta |mbest - x|
//! ln(1/u), beta falling linearly from 1.0 to 0.5.

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

use super::{Population, Problem, Solver, Swarm};
use crate::core::rng::Rng;

/// The estimator `method: qpso` names.
pub static ESTIMATOR: Population = Population {
    name: "qpso",
    make: || Box::new(Qpso),
};

/// Quantum-behaved PSO (seed 001 section 3.5), beta decreasing linearly from 1.0 to 0.5.
pub struct Qpso;

impl Solver for Qpso {
    fn init(&mut self, problem: &Problem, rng: &mut Rng, population: usize) -> Swarm {
        Swarm::new(problem, population, rng)
    }

    fn step(&mut self, problem: &Problem, s: &mut Swarm, rng: &mut Rng, progress: f64) {
        let beta = 1.0 - 0.5 * progress;
        let n = s.x.len();
        let dim = problem.dim();
        let mbest: Vec<f64> = (0..dim)
            .map(|j| s.best.iter().map(|p| p[j]).sum::<f64>() / n as f64)
            .collect();
        let pg = s.best[s.g].clone();
        for i in 0..n {
            for j in 0..dim {
                let phi = rng.uniform();
                let pd = phi * s.best[i][j] + (1.0 - phi) * pg[j];
                let u = rng.uniform_open();
                let step = beta * (mbest[j] - s.x[i][j]).abs() * (1.0 / u).ln();
                s.x[i][j] = if rng.uniform() < 0.5 {
                    pd + step
                } else {
                    pd - step
                };
            }
            let mut xi = std::mem::take(&mut s.x[i]);
            problem.clamp(&mut xi);
            s.x[i] = xi;
        }
        let cost = problem.cost_all(&s.x);
        s.absorb(&cost);
    }
}
