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

    /// The term without its features of named effect `name`'s form (their coefficients as
    /// fitted, the rest kept as they are); `None` when nothing is left.
    pub fn without_form(&self, name: &str, slots: &crate::diagnose::Slots) -> Option<Discovered> {
        let (mut features, mut coef) = (Vec::new(), Vec::new());
        let mut at = 0;
        for f in &self.features {
            let n = f.columns();
            if f.named(slots, self.dof) != Some(name) {
                features.push(*f);
                coef.extend_from_slice(&self.coef[at..at + n]);
            }
            at += n;
        }
        (!features.is_empty()).then_some(Discovered {
            dof: self.dof,
            features,
            coef,
        })
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
