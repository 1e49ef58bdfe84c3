//! Model-vs-measurement metrics: MAE, normalised MAE (seed 003) and RMSE as a percentage of
//! the run's peak speed (seed 001).

use crate::dof::Dof;
use crate::io::Response;
use crate::model::{Plant, Vec6};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Mean absolute error, in the DOF's velocity unit.
    pub mae: f64,
    /// mean |v_model - v_meas| / mean |v_meas| (seed 003).
    pub nmae: f64,
    /// 100 * RMSE / max |v_meas| (seed 001 states its velocity error this way).
    pub rmse_pct: f64,
}

pub fn metrics(measured: &[f64], simulated: &[f64]) -> Metrics {
    let n = measured.len().min(simulated.len()).max(1) as f64;
    let pairs = || measured.iter().zip(simulated);
    let mae = pairs().map(|(m, s)| (s - m).abs()).sum::<f64>() / n;
    let mean_abs = measured.iter().map(|m| m.abs()).sum::<f64>() / n;
    let rmse = (pairs().map(|(m, s)| (s - m).powi(2)).sum::<f64>() / n).sqrt();
    let peak = measured.iter().fold(0.0f64, |a, m| a.max(m.abs()));
    Metrics {
        mae,
        nmae: if mean_abs > 0.0 { mae / mean_abs } else { f64::NAN },
        rmse_pct: if peak > 0.0 { 100.0 * rmse / peak } else { f64::NAN },
    }
}

/// The model's velocities under the response's applied force, from its first measured state.
pub fn simulate_response(plant: &Plant, r: &Response) -> Vec<Vec6> {
    let tau: Vec<Vec6> = (0..r.len()).map(|k| r.tau(k)).collect();
    plant.simulate(&r.t, &tau, r.nu(0), 0.01)
}

/// Metrics per DOF of the response.
pub fn score(r: &Response, simulated: &[Vec6]) -> Vec<(Dof, Metrics)> {
    r.dofs
        .iter()
        .map(|(d, s)| {
            let sim: Vec<f64> = simulated.iter().map(|nu| nu[d.index()]).collect();
            (*d, metrics(&s.velocity, &sim))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_metrics() {
        let m = metrics(&[1.0, -2.0, 3.0, 2.0], &[1.5, -2.0, 2.0, 2.0]);
        assert!((m.mae - 0.375).abs() < 1e-12);
        assert!((m.nmae - 0.375 / 2.0).abs() < 1e-12);
        assert!((m.rmse_pct - 100.0 * (1.25f64 / 4.0).sqrt() / 3.0).abs() < 1e-12);
    }
}
