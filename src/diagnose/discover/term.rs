//! A discovered closed form as the diagnosis's simulator adds it: the features kept and their
//! coefficients, evaluated along a run.

use super::library::{Feature, Prepared, prepare};
use crate::core::model::Vec6;
use crate::diagnose::Run;
use crate::diagnose::effects::State;

/// A discovered term: its DOF, the features kept and their coefficients (per column).
#[derive(Debug, Clone, PartialEq)]
pub struct Discovered {
    pub dof: usize,
    pub features: Vec<Feature>,
    pub coef: Vec<f64>,
}

impl Discovered {
    pub fn prepare(&self, run: &Run) -> Prepared {
        prepare(run)
    }

    /// Its coefficients, a sine's amplitude and phase counting two.
    pub fn params(&self) -> usize {
        self.features.iter().map(|f| f.columns()).sum()
    }

    /// The term's generalised force at sample `k` of `run`, with the model's state `s`.
    pub fn force(&self, run: &Run, pre: &Prepared, k: usize, s: &State) -> Vec6 {
        let mut cols = Vec::with_capacity(self.coef.len());
        for f in &self.features {
            f.eval(run, pre, k, &s.nu, &mut cols);
        }
        let mut out = [0.0; 6];
        out[self.dof] = cols.iter().zip(&self.coef).map(|(x, c)| x * c).sum();
        out
    }
}
