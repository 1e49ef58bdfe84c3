//! The per-DOF sums a diagnosis scores a simulation by: residuals against the recording, the
//! robust cost, NMAE and the noise floor.

use super::Run;
use crate::diagnose::SLOTS;

/// Per-DOF sums of a simulation against a run's recording.
#[derive(Debug, Clone, Copy, Default)]
pub struct Sums {
    pub sse: [f64; SLOTS],
    /// Huber loss: squared error up to the DOF's threshold, linear beyond it.
    pub huber: [f64; SLOTS],
    pub sae: [f64; SLOTS],
    pub sam: [f64; SLOTS],
    pub n: [f64; SLOTS],
}

impl Sums {
    pub(super) fn add(&mut self, o: &Sums) {
        for j in 0..SLOTS {
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
    pub fn cost(&self, scale: &[f64; SLOTS]) -> f64 {
        (0..SLOTS)
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
    pub fn mse_cost(&self, scale: &[f64; SLOTS]) -> f64 {
        (0..SLOTS)
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
    pub fn nmae(&self) -> [f64; SLOTS] {
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
/// noise and pass for an improvement). Samples before the simulation starts, and every sample
/// of a slot the model leaves out, are NaN.
pub fn residual(sim: &[[f64; SLOTS]], run: &Run, delay: f64) -> [Vec<f64>; SLOTS] {
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
                if !run.slots.active[j] || ts < start - 1e-9 {
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
pub fn sums(sim: &[[f64; SLOTS]], run: &Run, delay: f64, delta: &[f64; SLOTS]) -> Sums {
    let mut s = Sums::default();
    let mut add = |j: usize, k: usize, x: f64| {
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
    };
    if delay == 0.0 {
        // The residual of [`residual`] without a delay, summed as it is formed (the search
        // scores thousands of simulations; the same sums, in the same order).
        for j in (0..SLOTS).filter(|&j| run.slots.active[j]) {
            for (k, (x, v)) in sim.iter().zip(&run.vel[j]).enumerate() {
                add(j, k, x[j] - v);
            }
        }
        return s;
    }
    let e = residual(sim, run, delay);
    for (j, e) in e.iter().enumerate() {
        for (k, x) in e.iter().enumerate() {
            add(j, k, *x);
        }
    }
    s
}

/// Per DOF, the noise floor of the normalised cost on `runs`: their mean noise variance
/// ([`Run::noise_sum`]) over the DOF's scale. The diagnosis's floor is the sum over DOFs.
pub fn noise_per_dof(runs: &[Run], scale: &[f64; SLOTS]) -> [f64; SLOTS] {
    std::array::from_fn(|j| {
        let n: usize = runs.iter().map(|r| r.std[j].len()).sum();
        runs.iter().map(|r| r.noise_sum(j)).sum::<f64>() / n.max(1) as f64 / scale[j]
    })
}
