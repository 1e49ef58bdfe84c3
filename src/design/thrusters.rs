//! Per-thruster commands for a designed run, where `vehicle.thrusters` describes the
//! thrusters: each sample's wrench [X, Y, Z, 0, 0, N] (no roll or pitch moment) shared among
//! them by the allocation's minimum-norm inverse, f = B⁺ τ (Fossen 2011, section 11.2.2, the
//! unconstrained allocation), and each thrust turned into the command its curve needs (PWM,
//! normalised or rpm, as the vehicle logs them). What the thrusters cannot give (a thrust
//! beyond the curve's end, a DOF the layout cannot push) is counted and its wrench error
//! stated, so the engineer knows before the run whether the plan can be flown as designed.

use super::DOFS;
use crate::core::model::thrusters::{Allocation, Command};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// The commands of every thruster, sample by sample.
pub struct Mixed {
    /// Column names of `thrusters.csv` after `t`.
    pub columns: Vec<String>,
    /// One row per sample, one command per thruster (as logged).
    pub commands: Vec<Vec<f64>>,
    pub summary: ThrusterPlan,
}

/// What `design.json` says of the per-thruster commands.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThrusterPlan {
    pub file: String,
    pub command: Command,
    pub columns: Vec<String>,
    /// Samples at which a thruster would need more than its curve gives.
    pub clipped_samples: usize,
    pub samples: usize,
    /// Largest difference between the wrench the commands give and the designed one, per
    /// commanded DOF (X, Y, Z in N, N in N m).
    pub max_wrench_error: [f64; 4],
}

/// The per-thruster commands of the designed command `cmd` (X, Y, Z, N per sample).
pub fn mix(a: &Allocation, cmd: &[[f64; 4]]) -> Mixed {
    let n = a.columns.len();
    let b = DMatrix::from_fn(6, n, |i, j| a.columns[j][i]);
    let pinv = b
        .clone()
        .pseudo_inverse(1e-9)
        .expect("the pseudo-inverse of a finite matrix");
    let mut commands = Vec::with_capacity(cmd.len());
    let (mut clipped_samples, mut err) = (0, [0.0_f64; 4]);
    for c in cmd {
        let mut tau = DVector::zeros(6);
        for (i, d) in DOFS.iter().enumerate() {
            tau[d.index()] = c[i];
        }
        let f = &pinv * &tau;
        let (row, clipped): (Vec<f64>, Vec<bool>) = f.iter().map(|&x| a.command_for(x)).unzip();
        clipped_samples += usize::from(clipped.iter().any(|&x| x));
        let got = a.wrench(&row);
        for (i, d) in DOFS.iter().enumerate() {
            err[i] = err[i].max((got[d.index()] - c[i]).abs());
        }
        commands.push(row);
    }
    let unit = match a.command_kind() {
        Command::Pwm => "us",
        Command::Normalised => "normalised",
        Command::Rpm => "rpm",
        Command::Newtons => "N",
    };
    let columns: Vec<String> = a
        .units
        .iter()
        .enumerate()
        .map(|(i, u)| {
            let name = if u.name.is_empty() {
                (i + 1).to_string()
            } else {
                u.name.clone()
            };
            format!("thruster_{name}_{unit}")
        })
        .collect();
    Mixed {
        summary: ThrusterPlan {
            file: FILE.into(),
            command: a.command_kind(),
            columns: columns.clone(),
            clipped_samples,
            samples: cmd.len(),
            max_wrench_error: err,
        },
        columns,
        commands,
    }
}

/// The file the per-thruster commands are written to.
pub const FILE: &str = "thrusters.csv";

impl Mixed {
    /// `thrusters.csv`: `t` (s) and one column per thruster, in the order the vehicle logs
    /// them.
    pub fn csv(&self) -> String {
        let mut out = format!("t,{}\n", self.columns.join(","));
        let decimals = match self.summary.command {
            Command::Pwm | Command::Rpm => 1,
            Command::Normalised | Command::Newtons => 4,
        };
        for (k, row) in self.commands.iter().enumerate() {
            let _ = write!(out, "{:.2}", k as f64 * super::DT);
            for c in row {
                let _ = write!(out, ",{c:.decimals$}");
            }
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::thrusters::{Curve, Layout, NamedCurve, Thrusters};

    fn allocation(layout: Layout) -> Allocation {
        Thrusters {
            layout: Some(layout),
            units: vec![],
            command: Command::Pwm,
            neutral_us: 1500.0,
            half_range_us: 400.0,
            curve: Some(Curve::Named(NamedCurve::T200_16v)),
            gain: 1.0,
        }
        .allocation()
    }

    #[test]
    fn the_commands_give_back_the_designed_wrench() {
        let a = allocation(Layout::Bluerov2Heavy);
        let cmd: Vec<[f64; 4]> = (0..200)
            .map(|k| {
                let t = k as f64 * 0.05;
                [
                    40.0 * (0.7 * t).sin(),
                    -25.0 * (1.3 * t).cos(),
                    30.0 * (0.4 * t).sin(),
                    4.0 * (2.1 * t).sin(),
                ]
            })
            .collect();
        let m = mix(&a, &cmd);
        assert_eq!(m.summary.clipped_samples, 0);
        assert_eq!(m.commands.len(), 200);
        assert!(
            m.commands
                .iter()
                .flatten()
                .all(|c| (1100.0..=1900.0).contains(c))
        );
        // Within the curve's resolution: 1.5 % of the largest command per DOF.
        for (e, limit) in m
            .summary
            .max_wrench_error
            .iter()
            .zip([40.0, 25.0, 30.0, 4.0])
        {
            assert!(*e < 0.015 * limit, "{:?}", m.summary.max_wrench_error);
        }
        assert!(m.csv().starts_with("t,thruster_1_us,"));
    }

    #[test]
    fn a_wrench_beyond_the_thrusters_is_counted_and_its_error_stated() {
        let a = allocation(Layout::Bluerov2);
        let m = mix(&a, &[[0.0; 4], [400.0, 0.0, 0.0, 0.0]]);
        assert_eq!(m.summary.clipped_samples, 1);
        assert!(m.summary.max_wrench_error[0] > 100.0, "{:?}", m.summary);
    }
}
