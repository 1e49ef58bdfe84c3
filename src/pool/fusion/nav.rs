//! A navigation log's velocity channels (docs/formats.md `nav.csv`: body velocity over ground from a
//! DVL or a vehicle's own navigation filter, 4-15 Hz, irregular, often already low-passed)
//! smoothed onto the command's time base, with an uncertainty that stays honest when the log
//! was filtered before it was written.
//!
//! Each channel is a Kalman filter with state [velocity, acceleration] driven by white jerk,
//! smoothed backwards (Rauch-Tung-Striebel). Two things make its sigma honest on real logs:
//! - the measurement noise is the largest robust spread of second differences over lags up to
//!   a second ([`noise_level`]): a low-passed log has small lag-1 differences (the MAD of
//!   those alone would call it nearly noise-free) but its error shows at the lags beyond the
//!   filter's time constant;
//! - the errors of such a log are correlated over `m` samples: they are carried as a
//!   first-order Gauss-Markov state of the filter (coloured measurement noise), which keeps
//!   the smoother from averaging correlated errors as if they were independent.

use super::kalman::{Filter, Mat, Vector, white_accel_and};
use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

/// Longest lag of the second differences that measure the noise, s: longer than the time
/// constant of any filter a navigation log is written through, shorter than the time over which
/// a vehicle's acceleration changes much.
const MAX_LAG_S: f64 = 0.8;

/// How one channel's noise was measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Noise {
    /// Measurement noise (its standard deviation), in the channel's unit.
    pub sigma: f64,
    /// Samples over which the errors are correlated (1 for white noise).
    pub correlated_samples: f64,
    /// The lag-1 estimate alone, as a white-noise estimator would state it.
    pub sigma_lag1: f64,
}

/// Robust standard deviation (1.4826 MAD about the median).
pub(crate) fn robust_std(mut d: Vec<f64>) -> f64 {
    if d.len() < 5 {
        return 0.0;
    }
    let n = d.len();
    d.sort_by(f64::total_cmp);
    let med = d[n / 2];
    let mut dev: Vec<f64> = d.iter().map(|v| (v - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    1.4826 * dev[n / 2]
}

/// The noise of samples `z` at times `t` (NaN rows left out): for each lag L whose span is at
/// most [`MAX_LAG_S`], the robust spread of z[k+L] - 2 z[k] + z[k-L] over sqrt(6) (exact for
/// white noise; a smooth motion adds little to a robust spread); the largest over L is the
/// noise, and the ratio of its variance to the lag-1 variance is the correlation length.
pub fn noise_level(t: &[f64], z: &[f64], floor: f64) -> Noise {
    let Some(d) = SecondDifferences::of(t, z) else {
        return Noise::at_floor(floor);
    };
    let at_lag = |l: usize| d.spread(l) / 6f64.sqrt();
    let s1 = at_lag(1);
    let smax = (1..=d.max_lag(MAX_LAG_S)).map(at_lag).fold(s1, f64::max);
    let sigma = smax.max(floor);
    let ratio = (sigma / s1.max(floor * 1e-3)).powi(2);
    Noise {
        sigma,
        correlated_samples: ratio.clamp(1.0, 1e3),
        sigma_lag1: s1.max(floor),
    }
}

impl Noise {
    /// What a channel with too few samples to measure is given: the floor, white.
    pub fn at_floor(floor: f64) -> Noise {
        Noise {
            sigma: floor,
            correlated_samples: 1.0,
            sigma_lag1: floor,
        }
    }
}

/// A channel's finite samples, for the robust spread of its second differences at a lag.
pub(super) struct SecondDifferences {
    z: Vec<f64>,
    /// Mean sample interval, s.
    pub dt: f64,
}

impl SecondDifferences {
    /// The finite samples of `z` (times `t`); `None` with fewer than 10.
    pub fn of(t: &[f64], z: &[f64]) -> Option<SecondDifferences> {
        let (t, z): (Vec<f64>, Vec<f64>) = t
            .iter()
            .zip(z)
            .filter(|(_, v)| v.is_finite())
            .map(|(a, b)| (*a, *b))
            .unzip();
        let n = z.len();
        (n >= 10).then(|| SecondDifferences {
            dt: (t[n - 1] - t[0]) / (n - 1) as f64,
            z,
        })
    }

    /// The longest lag in samples spanning at most `span_s`, and at most a quarter of them.
    pub fn max_lag(&self, span_s: f64) -> usize {
        ((span_s / self.dt.max(1e-6)).round() as usize).clamp(1, self.z.len() / 4)
    }

    /// Robust standard deviation of z[k+l] - 2 z[k] + z[k-l].
    pub fn spread(&self, l: usize) -> f64 {
        let z = &self.z;
        robust_std(
            (l..z.len() - l)
                .map(|k| z[k + l] - 2.0 * z[k] + z[k - l])
                .collect(),
        )
    }
}

/// One velocity channel smoothed onto `out_t`: value and standard deviation per output time,
/// and the smoothed derivative (the acceleration state).
pub struct Smoothed {
    pub v: Vec<f64>,
    pub std: Vec<f64>,
    pub accel: Vec<f64>,
    pub noise: Noise,
}

/// Smooths channel `z` (times `t`, NaN rows skipped) onto `out_t`. `jerk` is the spectral
/// density of the white jerk that drives the acceleration ((unit/s^3)^2 s).
///
/// The measurement error is modelled as it is: first-order (Gauss-Markov) noise of variance
/// `sigma^2` whose correlation spans `correlated_samples` samples, carried as a third state
/// (state augmentation for coloured measurement noise). White noise is the limit of one
/// sample; a low-passed log is neither over-trusted nor, as a variance inflation would do,
/// distrusted beyond what its correlation warrants.
pub fn smooth(t: &[f64], z: &[f64], out_t: &[f64], noise: Noise, jerk: f64) -> Smoothed {
    smooth_with(t, z, out_t, noise, jerk).0
}

/// Jerk densities tried by [`smooth_ml`], ((unit/s^3)^2 s).
const JERKS: [f64; 9] = [0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0];

/// [`smooth`] with the jerk density chosen from the data: the one under which the channel's
/// innovations are most likely. A heave channel moves gently, a surge channel in steps; one
/// density for all would overstate the first's uncertainty or understate the second's.
pub fn smooth_ml(t: &[f64], z: &[f64], out_t: &[f64], noise: Noise) -> (Smoothed, f64) {
    smooth_ml_over(t, z, out_t, noise, &JERKS)
}

/// [`smooth_ml`] over the jerk densities `jerks`.
pub fn smooth_ml_over(
    t: &[f64],
    z: &[f64],
    out_t: &[f64],
    noise: Noise,
    jerks: &[f64],
) -> (Smoothed, f64) {
    let best = jerks
        .iter()
        .map(|&j| (j, smooth_with(t, z, &[], noise, j).1))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(20.0, |b| b.0);
    (smooth_with(t, z, out_t, noise, best).0, best)
}

/// One channel's filter model: the measurement variance, the correlation time of its errors
/// (first-order Gauss-Markov, 0 when white) and the jerk density.
struct Model {
    var: f64,
    tau_c: f64,
    jerk: f64,
}

impl Model {
    /// The model of channel `z` (times `t`, NaN rows skipped) with noise `noise`.
    fn of(t: &[f64], z: &[f64], noise: Noise, jerk: f64) -> Model {
        let var = noise.sigma.powi(2);
        // Correlation per sample from the correlation length m = (1 + rho) / (1 - rho), and its
        // time constant from the mean sample interval.
        let m = noise.correlated_samples.max(1.0);
        let rho = (m - 1.0) / (m + 1.0);
        let finite: Vec<f64> = t
            .iter()
            .zip(z)
            .filter(|(_, v)| v.is_finite())
            .map(|(a, _)| *a)
            .collect();
        let mean_dt = if finite.len() > 1 {
            (finite[finite.len() - 1] - finite[0]) / (finite.len() - 1) as f64
        } else {
            0.1
        };
        let tau_c = if rho > 1e-6 { -mean_dt / rho.ln() } else { 0.0 };
        Model { var, tau_c, jerk }
    }

    /// The filter at the first finite sample of `z`, acceleration and error unknown.
    fn initial(&self, z: &[f64]) -> Filter<3> {
        let first = z.iter().copied().find(|v| v.is_finite()).unwrap_or(0.0);
        Filter::<3>::new(
            Vector::<3>::new(first, 0.0, 0.0),
            Mat::<3>::from_diagonal(&Vector::<3>::new(self.var + 1e-6, 1.0, self.var)),
        )
    }

    /// Transition and process noise over `dt`.
    fn step(&self, dt: f64) -> (Mat<3>, Mat<3>) {
        let a = if self.tau_c > 0.0 {
            (-dt / self.tau_c).exp()
        } else {
            0.0
        };
        let fm = Mat::<3>::new(1.0, dt, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, a);
        let qm = white_accel_and(self.jerk, dt, self.var * (1.0 - a * a));
        (fm, qm)
    }
}

/// The measurement times (finite samples only, kind 0) and output times (kind 1) merged in
/// time order, measurements first at equal times: (time, kind, index).
fn merged_events(t: &[f64], z: &[f64], out_t: &[f64]) -> Vec<(f64, u8, usize)> {
    let mut events: Vec<(f64, u8, usize)> = t
        .iter()
        .enumerate()
        .filter(|(k, _)| z[*k].is_finite())
        .map(|(k, &tk)| (tk, 0, k))
        .collect();
    events.extend(out_t.iter().enumerate().map(|(k, &tk)| (tk, 1, k)));
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    events
}

/// Minus the log likelihood (less a constant) of measurement `z` under the filter's prediction.
fn innovation_cost(f: &Filter<3>, h: &SMatrix<f64, 1, 3>, r: f64, z: f64) -> f64 {
    let (x, p) = f.state();
    let s = (h * p * h.transpose())[(0, 0)] + r;
    let nu = z - (h * x)[(0, 0)];
    0.5 * (s.ln() + nu * nu / s)
}

/// [`smooth`], and the log likelihood of the innovations.
fn smooth_with(t: &[f64], z: &[f64], out_t: &[f64], noise: Noise, jerk: f64) -> (Smoothed, f64) {
    let model = Model::of(t, z, noise, jerk);
    let mut loglik = 0.0;
    let mut updates = 0usize;
    // A small white part keeps the update well conditioned.
    let r = SMatrix::<f64, 1, 1>::new(1e-4 * model.var + 1e-12);
    let mut f = model.initial(z);
    let events = merged_events(t, z, out_t);
    let mut out_step = vec![0usize; out_t.len()];
    let mut last = events.first().map_or(0.0, |e| e.0);
    let h = SMatrix::<f64, 1, 3>::new(1.0, 0.0, 1.0);
    for (tk, kind, k) in events {
        let dt = tk - last;
        if dt > 0.0 {
            let (fm, qm) = model.step(dt);
            f.predict(fm, Vector::<3>::zeros(), qm);
            last = tk;
        }
        if kind == 0 {
            if updates > 0 {
                loglik -= innovation_cost(&f, &h, r[(0, 0)], z[k]);
            }
            updates += 1;
            f.update(SVector::<f64, 1>::new(z[k]), h, r, f64::INFINITY, |_| {});
        } else {
            out_step[k] = f.len() - 1;
        }
    }
    if out_t.is_empty() {
        let none = Smoothed {
            v: vec![],
            std: vec![],
            accel: vec![],
            noise,
        };
        return (none, loglik);
    }
    (at_outputs(&f.smooth(), &out_step, noise), loglik)
}

/// The smoothed channel at the output times, whose filter steps are `out_step`.
fn at_outputs(sm: &[(Vector<3>, Mat<3>)], out_step: &[usize], noise: Noise) -> Smoothed {
    Smoothed {
        v: out_step.iter().map(|&s| sm[s].0[0]).collect(),
        std: out_step
            .iter()
            .map(|&s| sm[s].1[(0, 0)].max(0.0).sqrt())
            .collect(),
        accel: out_step.iter().map(|&s| sm[s].0[1]).collect(),
        noise,
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// `truth` logged at each of `t[1..]` with noise of standard deviation `sigma`, white or
    /// first-order low-passed with time constant `tau` (exact discretisation, scaled to keep
    /// the variance).
    pub(in crate::pool::fusion) fn logged(
        t: &[f64],
        truth: &dyn Fn(f64) -> f64,
        sigma: f64,
        tau: f64,
        rng: &mut crate::core::rng::Rng,
    ) -> Vec<f64> {
        let mut e = 0.0;
        t.windows(2)
            .map(|w| {
                let white = sigma * rng.normal();
                e = if tau > 0.0 {
                    let a = (-(w[1] - w[0]) / tau).exp();
                    a * e + (1.0 - a * a).sqrt() * white
                } else {
                    white
                };
                truth(w[1]) + e
            })
            .collect()
    }

    /// A vehicle's surge velocity (steps through a first-order response) logged at an irregular
    /// 5-15 Hz. White noise, then the same noise low-passed (time constant 0.5 s) before
    /// logging: in both cases the stated sigma must match the actual error (RMS of error/sigma
    /// between 0.5 and 2), where a lag-1 estimate understates the filtered log's noise.
    #[test]
    fn sigma_stays_honest_on_white_and_prefiltered_logs() {
        let truth = |t: f64| {
            let step = |t0: f64, a: f64| {
                if t > t0 {
                    a * (1.0 - (-(t - t0) / 1.2).exp())
                } else {
                    0.0
                }
            };
            step(5.0, 0.8) + step(20.0, -1.1) + step(35.0, 0.5)
        };
        for (tau, seed) in [(0.0, 1), (0.5, 2)] {
            let mut rng = crate::core::rng::Rng::new(seed);
            let mut t = vec![0.0];
            while *t.last().unwrap() < 60.0 {
                let last = *t.last().unwrap();
                t.push(last + 1.0 / (5.0 + 10.0 * rng.uniform()));
            }
            let z = logged(&t, &truth, 0.02, tau, &mut rng);
            let t = &t[1..];
            let out: Vec<f64> = (100..2900).map(|k| k as f64 * 0.02).collect();
            let noise = noise_level(t, &z, 1e-4);
            let (s, _) = smooth_ml(t, &z, &out, noise);
            let ratio = (out
                .iter()
                .enumerate()
                .map(|(k, &tk)| ((s.v[k] - truth(tk)) / s.std[k]).powi(2))
                .sum::<f64>()
                / out.len() as f64)
                .sqrt();
            assert!(
                (0.6..1.6).contains(&ratio),
                "tau {tau}: error/sigma RMS {ratio} ({noise:?})"
            );
            eprintln!("tau {tau}: error/sigma RMS {ratio:.3}");
            if tau > 0.0 {
                assert!(
                    noise.correlated_samples > 2.0 && noise.sigma > 1.5 * noise.sigma_lag1,
                    "{noise:?}"
                );
            }
        }
    }
}
