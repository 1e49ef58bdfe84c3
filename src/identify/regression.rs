//! The equation-error problem of seed 001 eq. 14: with mass and inertia known, eq. 2 is linear
//! in the added-mass and drag coefficients, `tau - M_RB nu_dot - C_RB(nu) nu = Phi(nu, nu_dot) theta`.

use crate::core::dof::Dof;
use crate::core::model::dynamics::{gravity_body, term_column};
use crate::core::model::{ParamLayout, Plant, Vehicle};
use crate::core::response::Response;

/// Stacked regression rows (one per sample and DOF), row-major.
#[derive(Debug, Clone)]
pub struct Regression {
    pub layout: ParamLayout,
    /// n x p regressor, row-major.
    pub phi: Vec<f64>,
    pub y: Vec<f64>,
    /// The DOF (equation) of each row: rows of different DOFs have different units and noise.
    pub row_dof: Vec<Dof>,
}

impl Regression {
    pub fn rows(&self) -> usize {
        self.y.len()
    }

    pub fn cols(&self) -> usize {
        self.layout.len()
    }

    /// Appends the rows of `other` (same parameter layout).
    pub fn append(&mut self, other: Regression) {
        assert_eq!(self.layout.len(), other.layout.len(), "same parameters");
        self.phi.extend(other.phi);
        self.y.extend(other.y);
        self.row_dof.extend(other.row_dof);
    }

    /// Divides every row by its DOF's `sigma` (a source's own residual level), so rows of
    /// sources with different noise can be stacked.
    pub fn scale_rows(&mut self, sigma: &std::collections::BTreeMap<Dof, f64>) {
        let p = self.cols();
        for i in 0..self.rows() {
            let w = 1.0 / sigma.get(&self.row_dof[i]).copied().unwrap_or(1.0);
            self.y[i] *= w;
            self.phi[i * p..(i + 1) * p]
                .iter_mut()
                .for_each(|x| *x *= w);
        }
    }

    pub fn row(&self, i: usize) -> &[f64] {
        let p = self.cols();
        &self.phi[i * p..(i + 1) * p]
    }

    /// Builds the rows from every sample of every response (after `skip_start_s` seconds), for
    /// the DOFs each response has, with the vehicle's structure.
    pub fn build(vehicle: &Vehicle, responses: &[&Response], skip_start_s: f64) -> Regression {
        Regression::build_with(&ParamLayout::of(vehicle), vehicle, responses, skip_start_s)
    }

    /// [`Regression::build`] for the terms of `layout`. The force is linear in every term, so
    /// column j is the force of term j alone at 1 (`term_column`).
    pub fn build_with(
        layout: &ParamLayout,
        vehicle: &Vehicle,
        responses: &[&Response],
        skip_start_s: f64,
    ) -> Regression {
        let rigid = Plant::new(vehicle, Default::default());
        let mut r = Regression {
            layout: layout.clone(),
            phi: Vec::new(),
            y: Vec::new(),
            row_dof: Vec::new(),
        };
        let mut cols = vec![[0.0; 6]; layout.len()];
        for resp in responses {
            let dofs: Vec<Dof> = resp
                .dofs
                .keys()
                .copied()
                .filter(|d| vehicle.dofs.contains(d))
                .collect();
            for k in (0..resp.len()).filter(|&k| resp.t[k] >= skip_start_s) {
                let (nu, nu_dot, tau) = (resp.nu(k), resp.nu_dot(k), resp.tau(k));
                let [phi, theta] = resp.attitude(k);
                let g = gravity_body(phi, theta);
                let known = rigid.rigid_force(&nu, &nu_dot);
                for (c, t) in cols.iter_mut().zip(&layout.terms) {
                    *c = term_column(*t, &nu, &nu_dot, &g, &tau);
                }
                for d in &dofs {
                    let i = d.index();
                    r.y.push(tau[i] - known[i]);
                    r.phi.extend(cols.iter().map(|c| c[i]));
                    r.row_dof.push(*d);
                }
            }
        }
        r
    }
}
