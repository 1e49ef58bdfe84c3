//! The output-error objective (seed 001 eq. 9): every candidate model simulated under each
//! case's force and compared with the recorded velocities. The population methods minimise
//! its cost; the local refinement ([`super::refine`]) its residuals.
//!
//! A model's coefficients are followed, where the prediction-error method asks, by per-run
//! nuisance parameters ([`super::per_run`]): a vector longer than the layout carries them.

use super::per_run::{self, Nuisance, Offsets};
use crate::core::model::lanes::{LANES, LanePlants};
use crate::core::model::lanes_coupled::CoupledLanes;
use crate::core::model::{Plant, Vec6};

/// The cases an output-error objective simulates, and the plant's rigid-body side.
pub struct OutputError<'a> {
    pub vehicle: &'a crate::core::model::Vehicle,
    pub responses: &'a [&'a crate::core::response::Response],
    /// Per case and DOF, 1 / its mean square velocity: every case counts by its relative
    /// error, so the slow cases that pin the linear drag weigh as much as the fast ones.
    pub weight: Vec<[f64; 6]>,
    /// Per case, the applied force at each sample (read once, simulated many times).
    taus: Vec<Vec<Vec6>>,
    /// The per-run nuisance parameters that follow the model's coefficients.
    pub nuisance: Vec<Nuisance>,
}

/// Integration step bound of the objective's simulations, s.
const MAX_STEP: f64 = 0.01;

impl<'a> OutputError<'a> {
    pub fn new(
        vehicle: &'a crate::core::model::Vehicle,
        responses: &'a [&'a crate::core::response::Response],
    ) -> OutputError<'a> {
        OutputError::with_lag(vehicle, responses, 0.0)
    }

    /// The objective with every command passed through a first-order lag of `lag_s` (the
    /// thrusters' and the command path's), as the model it fits will be simulated.
    pub fn with_lag(
        vehicle: &'a crate::core::model::Vehicle,
        responses: &'a [&'a crate::core::response::Response],
        lag: f64,
    ) -> OutputError<'a> {
        let weight = responses
            .iter()
            .map(|r| {
                let mut w = [0.0; 6];
                for (d, s) in &r.dofs {
                    let ms = s.velocity.iter().map(|v| v * v).sum::<f64>()
                        / s.velocity.len().max(1) as f64;
                    w[d.index()] = if ms > 1e-12 { 1.0 / ms } else { 0.0 };
                }
                w
            })
            .collect();
        let taus = responses
            .iter()
            .map(|r| {
                let tau: Vec<Vec6> = (0..r.len()).map(|k| r.tau(k)).collect();
                crate::core::model::dynamics::lagged(&r.t, &tau, lag)
            })
            .collect();
        OutputError {
            vehicle,
            responses,
            weight,
            taus,
            nuisance: Vec::new(),
        }
    }

    /// The objective with the per-run nuisance parameters of `kinds` after the coefficients.
    pub fn with_per_run(mut self, kinds: per_run::Kinds) -> OutputError<'a> {
        let dofs: Vec<Vec<_>> = self
            .responses
            .iter()
            .map(|r| r.dofs.keys().copied().collect())
            .collect();
        self.nuisance = per_run::layout(kinds, &dofs);
        self
    }

    /// Per case, its offsets from the nuisance values that follow the `layout`'s coefficients
    /// in `theta` (none when `theta` has none).
    fn offsets(&self, layout: &crate::core::model::ParamLayout, theta: &[f64]) -> Vec<Offsets> {
        let x = theta.get(layout.len()..).unwrap_or(&[]);
        per_run::offsets(&self.nuisance, x, self.responses.len())
    }

    /// The residuals of case `c` alone, in the order [`OutputError::residuals`] gives them.
    pub fn case_residuals(
        &self,
        layout: &crate::core::model::ParamLayout,
        theta: &[f64],
        c: usize,
    ) -> Vec<f64> {
        let mut out = Vec::new();
        self.errors(layout, &[theta], Some(c), &mut |e| {
            out.push(finite_or_diverged(e[0]))
        });
        out
    }

    /// Where each case's residuals start in [`OutputError::residuals`], and their total.
    pub fn case_starts(&self) -> Vec<usize> {
        let mut at = 0;
        let mut out = Vec::with_capacity(self.responses.len() + 1);
        for r in self.responses {
            out.push(at);
            at += r.len() * r.dofs.len();
        }
        out.push(at);
        out
    }

    /// Mean weighted squared velocity error of the model `theta` in `dof` alone.
    pub(crate) fn dof_cost(
        &self,
        layout: &crate::core::model::ParamLayout,
        theta: &[f64],
        dof: crate::core::dof::Dof,
    ) -> f64 {
        let e = self.residuals(layout, theta);
        let starts = self.case_starts();
        let (mut s, mut n) = (0.0, 0usize);
        for (c, r) in self.responses.iter().enumerate() {
            let Some(at) = r.dofs.keys().position(|&d| d == dof) else {
                continue;
            };
            for x in e[starts[c]..starts[c + 1]]
                .iter()
                .skip(at)
                .step_by(r.dofs.len())
            {
                s += x * x;
                n += 1;
            }
        }
        s / n.max(1) as f64
    }

    /// Integration steps and recorded values one evaluation simulates and compares.
    pub fn work(&self) -> (usize, usize) {
        let mut steps = 0;
        let mut values = 0;
        for r in self.responses {
            for k in 0..r.len().saturating_sub(1) {
                steps += crate::core::model::dynamics::substeps(r.t[k + 1] - r.t[k], MAX_STEP);
            }
            values += r.dofs.values().map(|s| s.velocity.len()).sum::<usize>();
        }
        (steps, values)
    }

    /// Whether the kernel integrates all six DOFs (roll or pitch free) for these cases.
    pub fn six_dof(&self) -> bool {
        crate::core::model::lanes::needs_six_dof(&self.vehicle.active())
    }

    /// The kernel that simulates up to [`LANES`] models of `layout` at once: the lane kernel
    /// for a diagonal model (weight and buoyancy included), else the coupled one (full mass
    /// matrix, any cross drag, [`crate::core::model::lanes_coupled`]), which gives the same
    /// errors in the same order.
    fn kernel(&self, layout: &crate::core::model::ParamLayout, thetas: &[&[f64]]) -> Kernel {
        let plants: Vec<Plant> = thetas
            .iter()
            .map(|t| Plant::new(self.vehicle, layout.to_hydro(&t[..layout.len()])))
            .collect();
        if layout.is_diagonal_model() {
            Kernel::Diagonal(Box::new(LanePlants::new(&plants)))
        } else {
            Kernel::Coupled(Box::new(CoupledLanes::new(&plants)))
        }
    }

    /// Every case (or case `only`) simulated for up to [`LANES`] models at once; `visit` gets
    /// each recorded value's error per lane, weighted by the square root of its weight. The
    /// models share the first one's nuisance values.
    fn errors(
        &self,
        layout: &crate::core::model::ParamLayout,
        thetas: &[&[f64]],
        only: Option<usize>,
        visit: &mut dyn FnMut(&[f64; LANES]),
    ) {
        let kernel = self.kernel(layout, thetas);
        let offsets = self.offsets(layout, thetas[0]);
        for (c, o) in offsets.iter().enumerate() {
            if only.is_none_or(|x| x == c) {
                self.case_errors(&kernel, o, c, visit);
            }
        }
    }

    /// [`OutputError::errors`] of case `c` with its offsets `o`.
    fn case_errors(
        &self,
        kernel: &Kernel,
        o: &Offsets,
        c: usize,
        visit: &mut dyn FnMut(&[f64; LANES]),
    ) {
        let (r, cols) = (
            self.responses[c],
            columns(self.responses[c], &self.weight[c]),
        );
        let taus = forced(&self.taus[c], o);
        let mut seen = |k: usize, nu: &[[f64; LANES]; 6]| {
            for (i, sw, v) in &cols {
                let e: [f64; LANES] = std::array::from_fn(|l| sw * (nu[*i][l] + o.bias[*i] - v[k]));
                visit(&e);
            }
        };
        let nu0 = plus(r.nu(0), o.start);
        match kernel {
            Kernel::Diagonal(lp) => {
                lp.simulate(&r.t, &taus, (nu0, r.attitude(0)), MAX_STEP, &mut seen)
            }
            Kernel::Coupled(lp) => {
                lp.simulate(&r.t, &taus, (nu0, r.attitude(0)), MAX_STEP, &mut seen)
            }
        }
    }

    /// The weighted velocity errors of the model `theta`, sample by sample, DOF by DOF within
    /// a sample, case by case (a diverged simulation counts as a large error).
    pub fn residuals(&self, layout: &crate::core::model::ParamLayout, theta: &[f64]) -> Vec<f64> {
        self.residuals_many(layout, &[theta]).swap_remove(0)
    }

    /// [`OutputError::residuals`] of up to [`LANES`] models, simulated together.
    pub fn residuals_many(
        &self,
        layout: &crate::core::model::ParamLayout,
        thetas: &[&[f64]],
    ) -> Vec<Vec<f64>> {
        use rayon::prelude::*;
        let kernel = self.kernel(layout, thetas);
        let offsets = self.offsets(layout, thetas[0]);
        let starts = self.case_starts();
        // The cases simulated side by side, each into its own segment, joined in order.
        let per_case: Vec<Vec<Vec<f64>>> = (offsets.par_iter().enumerate())
            .map(|(c, o)| {
                let n = starts[c + 1] - starts[c];
                let mut out: Vec<Vec<f64>> = thetas.iter().map(|_| Vec::with_capacity(n)).collect();
                self.case_errors(&kernel, o, c, &mut |e| {
                    for (o, x) in out.iter_mut().zip(e) {
                        o.push(finite_or_diverged(*x));
                    }
                });
                out
            })
            .collect();
        (0..thetas.len())
            .map(|l| {
                per_case
                    .iter()
                    .map(|c| c[l].as_slice())
                    .collect::<Vec<_>>()
                    .concat()
            })
            .collect()
    }

    /// Mean weighted squared velocity error of the model `theta` over every case.
    pub(crate) fn cost(&self, layout: &crate::core::model::ParamLayout, theta: &[f64]) -> f64 {
        self.cost_many(layout, &[theta])[0]
    }

    /// [`OutputError::cost`] of up to [`LANES`] models, simulated together.
    pub(crate) fn cost_many(
        &self,
        layout: &crate::core::model::ParamLayout,
        thetas: &[&[f64]],
    ) -> Vec<f64> {
        let mut s = [0.0; LANES];
        let mut n = 0usize;
        self.errors(layout, thetas, None, &mut |e| {
            for l in 0..LANES {
                s[l] += if e[l].is_finite() { e[l] * e[l] } else { 1e6 };
            }
            n += 1;
        });
        (0..thetas.len()).map(|l| s[l] / n.max(1) as f64).collect()
    }
}

/// The simulation kernel of a population of models.
enum Kernel {
    Diagonal(Box<LanePlants>),
    Coupled(Box<CoupledLanes>),
}

/// A residual, or a large error where the simulation diverged.
fn finite_or_diverged(x: f64) -> f64 {
    if x.is_finite() { x } else { 1e3 }
}

/// `a + b`.
fn plus(a: Vec6, b: Vec6) -> Vec6 {
    std::array::from_fn(|i| a[i] + b[i])
}

/// A case's forces with its per-run force offset (borrowed when it has none).
fn forced<'t>(taus: &'t [Vec6], o: &Offsets) -> std::borrow::Cow<'t, [Vec6]> {
    if o.force == [0.0; 6] {
        std::borrow::Cow::Borrowed(taus)
    } else {
        taus.iter().map(|t| plus(*t, o.force)).collect()
    }
}

/// Per DOF of a case: its index, the square root of its weight and its recorded velocity.
fn columns<'r>(
    r: &'r crate::core::response::Response,
    w: &[f64; 6],
) -> Vec<(usize, f64, &'r [f64])> {
    r.dofs
        .iter()
        .map(|(d, s)| (d.index(), w[d.index()].sqrt(), s.velocity.as_slice()))
        .collect()
}
