//! `method: ga` — a real-coded genetic algorithm.

use super::{Population, Problem, Solver, Swarm, argmin};
use crate::core::rng::Rng;

/// The estimator `method: ga` names.
pub static ESTIMATOR: Population = Population {
    name: "ga",
    make: || Box::new(Ga),
};

/// Real-coded GA: tournament selection (size 3), blend crossover (BLX-0.5, rate 0.9),
/// Gaussian mutation (rate 1/dim, 10 % of the box shrinking geometrically to 0.01 %), two elites.
pub struct Ga;

impl Solver for Ga {
    fn init(&mut self, problem: &Problem, rng: &mut Rng, population: usize) -> Swarm {
        Swarm::new(problem, population, rng)
    }

    fn step(&mut self, problem: &Problem, s: &mut Swarm, rng: &mut Rng, progress: f64) {
        let n = s.x.len();
        let dim = problem.dim();
        // The current generation is `best` (a GA keeps no memory beyond its population).
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|a, b| s.best_cost[*a].total_cmp(&s.best_cost[*b]));
        let pick = |rng: &mut Rng| {
            (0..3)
                .map(|_| rng.below(n))
                .min_by(|a, b| s.best_cost[*a].total_cmp(&s.best_cost[*b]))
                .unwrap_or(0)
        };
        let sigma = 0.1 * 1e-3f64.powf(progress);
        let mut next: Vec<Vec<f64>> = order.iter().take(2).map(|&i| s.best[i].clone()).collect();
        while next.len() < n {
            let (a, b) = (pick(rng), pick(rng));
            let mut child: Vec<f64> = (0..dim)
                .map(|j| {
                    let (x, y) = (s.best[a][j], s.best[b][j]);
                    if rng.uniform() < 0.9 {
                        let (lo, hi) = (x.min(y), x.max(y));
                        let d = hi - lo;
                        lo - 0.5 * d + 2.0 * d * rng.uniform()
                    } else {
                        x
                    }
                })
                .collect();
            for (j, c) in child.iter_mut().enumerate() {
                if rng.uniform() < 1.0 / dim as f64 {
                    *c += sigma * (problem.hi[j] - problem.lo[j]) * rng.normal();
                }
            }
            problem.clamp(&mut child);
            next.push(child);
        }
        let cost = problem.cost_all(&next);
        s.x = next.clone();
        s.best = next;
        s.best_cost = cost;
        s.g = argmin(&s.best_cost);
    }
}
