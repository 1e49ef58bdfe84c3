//! Model-vs-measurement metrics: MAE, normalised MAE (seed 003) and RMSE as a percentage of
//! the run's peak speed (seed 001).

pub mod baseline;
pub mod cases;
pub mod models;
pub mod pool;
pub mod report;
pub mod sets;
pub mod stage;

use crate::core::dof::Dof;
use crate::core::model::Vec6;
use crate::core::response::Response;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Mean absolute error, in the DOF's velocity unit.
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub mae: f64,
    /// mean |v_model - v_meas| / mean |v_meas| (seed 003).
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub nmae: f64,
    /// 100 * RMSE / max |v_meas| (seed 001 states its velocity error this way).
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
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
        nmae: if mean_abs > 0.0 {
            mae / mean_abs
        } else {
            f64::NAN
        },
        rmse_pct: if peak > 0.0 {
            100.0 * rmse / peak
        } else {
            f64::NAN
        },
    }
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

/// Sample autocorrelation of a residual (seed 000's whiteness check), lags 0..=max_lag, with the
/// 95 % band +-1.96/sqrt(N) a white sequence stays inside.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Whiteness {
    /// Lag spacing, s.
    pub lag_step_s: f64,
    pub acf: Vec<f64>,
    pub band: f64,
    /// Share of lags 1..=max_lag outside the band (about 5 % for white residuals).
    pub outside: f64,
}

pub fn autocorrelation(e: &[f64], max_lag: usize) -> Vec<f64> {
    let n = e.len();
    if n < 2 {
        return vec![];
    }
    let mean = e.iter().sum::<f64>() / n as f64;
    let c0: f64 = e.iter().map(|x| (x - mean).powi(2)).sum();
    (0..=max_lag.min(n - 1))
        .map(|k| {
            if c0 > 0.0 {
                (0..n - k)
                    .map(|i| (e[i] - mean) * (e[i + k] - mean))
                    .sum::<f64>()
                    / c0
            } else {
                0.0
            }
        })
        .collect()
}

pub fn whiteness(e: &[f64], dt: f64, max_lag: usize) -> Whiteness {
    let acf = autocorrelation(e, max_lag);
    let band = 1.96 / (e.len().max(1) as f64).sqrt();
    let lags = acf.len().saturating_sub(1).max(1) as f64;
    let outside = acf.iter().skip(1).filter(|r| r.abs() > band).count() as f64 / lags;
    Whiteness {
        lag_step_s: dt,
        acf,
        band,
        outside,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn autocorrelation_by_hand_and_whiteness_of_noise() {
        // e = [1, -1, 1, -1]: mean 0, c0 = 4, lag 1: -3/4, lag 2: 2/4.
        let r = autocorrelation(&[1.0, -1.0, 1.0, -1.0], 2);
        assert_eq!(r, vec![1.0, -0.75, 0.5]);
        let mut rng = crate::core::rng::Rng::new(5);
        let white: Vec<f64> = (0..4000).map(|_| rng.normal()).collect();
        let w = whiteness(&white, 0.05, 40);
        assert!(w.outside < 0.15, "white noise: {}", w.outside);
        let mut x = 0.0;
        let red: Vec<f64> = white
            .iter()
            .map(|e| {
                x = 0.95 * x + e;
                x
            })
            .collect();
        assert!(
            whiteness(&red, 0.05, 40).outside > 0.8,
            "a structured residual is flagged"
        );
    }

    #[test]
    fn hand_computed_metrics() {
        let m = metrics(&[1.0, -2.0, 3.0, 2.0], &[1.5, -2.0, 2.0, 2.0]);
        assert!((m.mae - 0.375).abs() < 1e-12);
        assert!((m.nmae - 0.375 / 2.0).abs() < 1e-12);
        assert!((m.rmse_pct - 100.0 * (1.25f64 / 4.0).sqrt() / 3.0).abs() < 1e-12);
    }
}
