//! The noise of a channel that moves fast against its sample rate (a roll or pitch rate, an
//! attitude), told apart from the motion, and the smoother for such a channel.
//!
//! [`super::nav::noise_level`] takes the largest spread of second differences over lags up to
//! 0.8 s for the noise. That is right for a navigation log's velocities, whose manoeuvres
//! change little within 0.8 s, and the regression differentiates those velocities, so their
//! smoothing stays as it is. An attitude swinging at 0.3-1 Hz changes by its whole amplitude
//! within that lag, and was taken for correlated noise: the smoother flattened the manoeuvre
//! itself (fused rates down to 1 % of the logged ones on a real vehicle's 0.5 Hz attitude
//! sines). Here the spread at each lag is modelled as noise plus a slow and a fast motion.

use super::nav::{Noise, SecondDifferences, Smoothed, smooth_ml_over};

/// Longest lag of the second differences that measure the noise, s: a few times the time
/// constant of any filter a log is written through, so the noise's saturation shows (the motion
/// at these lags is modelled apart, [`noise_and_motion`]), and enough lags for the fit on a
/// 5 Hz log.
const MAX_LAG_S: f64 = 2.0;

/// Longest correlation time of a log's errors the fit considers, s: the time constant of the
/// slowest filter a log is written through, and half [`MAX_LAG_S`], so that such noise
/// saturates within the lags.
const MAX_CORRELATION_S: f64 = 1.0;

/// Jerk densities tried by [`smooth`], ((unit/s^3)^2 s): the navigation log's, and above them
/// what a vehicle's fastest attitude manoeuvres need (a rate swinging at 1 Hz with 1 rad/s
/// amplitude: about (A w^2)^2 / w = 250).
const JERKS: [f64; 12] = [
    0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 3e3,
];

/// Channel `z` (times `t`, NaN rows skipped) smoothed onto `out_t` with its noise measured
/// apart from its motion and the jerk density chosen from the data.
pub fn smooth(t: &[f64], z: &[f64], out_t: &[f64], floor: f64) -> Smoothed {
    smooth_with(t, z, out_t, noise_level(t, z, floor))
}

/// Channel `z` smoothed onto `out_t` under a noise known otherwise (a bound from another
/// sensor of the same motion), the jerk density chosen from the data.
pub fn smooth_with(t: &[f64], z: &[f64], out_t: &[f64], noise: Noise) -> Smoothed {
    smooth_ml_over(t, z, out_t, noise, &JERKS).0
}

/// The noise of samples `z` at times `t` (NaN rows left out), told apart from the motion.
///
/// For lags L up to [`MAX_LAG_S`], the robust variance of the second differences
/// z[k+L] - 2 z[k] + z[k-L] is modelled as noise plus motion:
/// `2 sigma^2 (3 - 4 rho^L + rho^2L) + motion(L)`, the motion a slow and a fast part. First-order (Gauss-Markov) noise of variance
/// sigma^2 and per-sample correlation rho saturates at 6 sigma^2 (white noise: at once, a
/// low-passed log's: beyond its filter's time constant); a smooth motion grows as the fourth
/// power of the lag, and a fast one turns back within the lags ([`noise_and_motion`]). The
/// noise is fitted apart from the motion in relative terms, and `correlated_samples` is
/// (1 + rho) / (1 - rho).
///
/// Taking the largest spread over the lags as the noise, as [`super::nav::noise_level`] does
/// for velocities, took a roll or pitch rate swinging at 0.3-1 Hz (which changes by its whole
/// amplitude within the longest lag) for correlated noise, and the smoother then flattened the
/// manoeuvre itself: fused rates down to 1 % of the logged ones on a real vehicle's 0.5 Hz
/// attitude sines.
pub fn noise_level(t: &[f64], z: &[f64], floor: f64) -> Noise {
    let Some(d) = SecondDifferences::of(t, z) else {
        return Noise::at_floor(floor);
    };
    let dt = d.dt;
    let max_lag = d.max_lag(MAX_LAG_S);
    let var_at = |l: usize| d.spread(l).powi(2);
    let lags = lag_ladder(max_lag);
    let v: Vec<f64> = lags.iter().map(|&l| var_at(l)).collect();
    let s1 = (v[0] / 6.0).sqrt();
    let (a, rho) = noise_and_motion(&lags, &v, dt);
    let sigma = (a / 2.0).sqrt().max(floor);
    Noise {
        sigma,
        correlated_samples: ((1.0 + rho) / (1.0 - rho)).clamp(1.0, 1e3),
        sigma_lag1: s1.max(floor),
    }
}

/// Length of the windows in which [`sensor_noise`] measures the noise, s: five times
/// [`MAX_LAG_S`], so each window has the lags the fit needs.
const WINDOW_S: f64 = 10.0;

/// Fewest finite samples in a window that [`sensor_noise`] measures.
const WINDOW_MIN_SAMPLES: usize = 30;

/// The sensor's own noise in samples `z` at times `t` (sorted; NaN rows left out): the
/// median over half-overlapping windows of [`WINDOW_S`] of [`noise_level`] in each, or
/// [`noise_level`] of the whole when fewer than three windows have enough samples.
///
/// A step manoeuvre (a depth change, a turn) is a kink in the velocity that every second
/// difference spanning it sees, and with lags up to [`MAX_LAG_S`] a few steps reach a large
/// share of a run's differences: over a whole run they read as noise (up to twice a
/// navigation log's true noise on the field twin's depth steps and transects). In a window
/// between the steps the motion is smooth, and the median over the windows is taken from
/// those.
pub fn sensor_noise(t: &[f64], z: &[f64], floor: f64) -> Noise {
    let whole = || noise_level(t, z, floor);
    let (Some(&t0), Some(&t1)) = (t.first(), t.last()) else {
        return whole();
    };
    let mut found = Vec::new();
    let mut start = t0;
    while start + WINDOW_S <= t1 + 1e-9 {
        let i0 = t.partition_point(|&x| x < start);
        let i1 = t.partition_point(|&x| x < start + WINDOW_S);
        if z[i0..i1].iter().filter(|v| v.is_finite()).count() >= WINDOW_MIN_SAMPLES {
            found.push(noise_level(&t[i0..i1], &z[i0..i1], floor));
        }
        start += WINDOW_S / 2.0;
    }
    if found.len() < 3 {
        return whole();
    }
    found.sort_by(|a, b| a.sigma.total_cmp(&b.sigma));
    found[found.len() / 2]
}

/// Lags 1, 2, 3, 4, 6, 8, 11, 16 .. (about sqrt 2 apart) up to `max_lag`.
fn lag_ladder(max_lag: usize) -> Vec<usize> {
    let mut lags = vec![1];
    while let Some(&l) = lags.last() {
        let next = ((l as f64 * std::f64::consts::SQRT_2).round() as usize).max(l + 1);
        if next > max_lag {
            break;
        }
        lags.push(next);
    }
    lags
}

/// The fit of `v[i] = a g_rho(L) + c0 m_0(L) + c m_w(L)` (L = lags[i], a, c0, c >= 0) in
/// relative terms: `a` (twice the noise variance) and rho, the per-sample correlation of the
/// noise. Two motions at once: a slow one, `m_0 = (L dt)^4` (slow against every lag), and a
/// fast one, the second difference of a sine of angular frequency `w`, `4 sin^4(w L dt / 2)`,
/// which saturates and turns back where its period is within the lags; both grow as L^4 at
/// first, where noise grows as L at most. A closed-loop manoeuvre and a periodic force come
/// together on a real run: with one motion term the fit took one of them for noise (the
/// heave noise up to 3.3 times the DVL's under a 0.545 Hz wave on the runs that also move in
/// heave).
fn noise_and_motion(lags: &[usize], v: &[f64], dt: f64) -> (f64, f64) {
    let g = |rho: f64, l: usize| {
        let r = rho.powi(l as i32);
        3.0 - 4.0 * r + r * r
    };
    let motion = |w: f64, l: usize| {
        let x = l as f64 * dt;
        if w == 0.0 {
            x.powi(4)
        } else {
            4.0 * (w * x / 2.0).sin().powi(4)
        }
    };
    // Correlation per sample: white, then correlation times up to [`MAX_CORRELATION_S`]
    // (noise correlated for longer would not saturate within the lags: it is told from a
    // motion by nothing, and taking a manoeuvre for it flattens the manoeuvre).
    let rho_max = (-dt / MAX_CORRELATION_S).exp();
    let rhos: Vec<f64> = (0..=40)
        .map(|k| if k == 0 { 0.0 } else { 1.0 - 0.8f64.powi(k) })
        .filter(|r| *r <= rho_max)
        .chain(std::iter::once(rho_max))
        .collect();
    // Manoeuvres from 0.05 Hz to a quarter of the sample rate.
    let top = std::f64::consts::PI / (2.0 * dt);
    let ws: Vec<f64> = std::iter::once(0.0)
        .chain((0..40).map(|k| 0.3 * (top / 0.3).powf(k as f64 / 39.0)))
        .collect();
    let rel = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        lags.iter()
            .zip(v)
            .map(|(&l, &y)| f(l) / y.max(1e-300))
            .collect()
    };
    // The motion columns do not depend on rho: built once.
    let slow = rel(&|l| motion(0.0, l));
    let fast: Vec<Vec<f64>> = ws.iter().map(|&w| rel(&|l| motion(w, l))).collect();
    let mut best = (f64::INFINITY, v[0] / 3.0, 0.0);
    for &rho in &rhos {
        // Weighted by 1 / v: relative errors, so the small lags count as the large.
        let x1 = rel(&|l| g(rho, l));
        for (&w, fast) in ws.iter().zip(&fast) {
            let cols: Vec<&[f64]> = if w == 0.0 {
                vec![&x1, &slow]
            } else {
                vec![&x1, &slow, fast]
            };
            let (coef, sse) = nnls(&cols);
            if sse < best.0 {
                best = (sse, coef[0], rho);
            }
        }
    }
    (best.1, best.2)
}

/// Non-negative least squares of `1 = sum_j c_j cols[j]` (two or three columns): the best
/// unconstrained fit over every subset of the columns whose coefficients are all
/// non-negative. Returns the coefficients and the sum of squared errors.
fn nnls(cols: &[&[f64]]) -> (Vec<f64>, f64) {
    let k = cols.len();
    let n = cols[0].len();
    let mut best = (vec![0.0; k], n as f64);
    for mask in 1u32..(1 << k) {
        let idx: Vec<usize> = (0..k).filter(|j| mask & (1 << j) != 0).collect();
        let m = idx.len();
        let a = nalgebra::DMatrix::from_fn(n, m, |i, j| cols[idx[j]][i]);
        let b = nalgebra::DVector::from_element(n, 1.0);
        let Some(c) = (a.transpose() * &a)
            .cholesky()
            .map(|ch| ch.solve(&(a.transpose() * &b)))
        else {
            continue;
        };
        if c.iter().any(|x| *x < 0.0 || !x.is_finite()) {
            continue;
        }
        let sse = (&a * &c - &b).norm_squared();
        if sse < best.1 {
            let mut full = vec![0.0; k];
            for (j, &i) in idx.iter().enumerate() {
                full[i] = c[j];
            }
            best = (full, sse);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Roll and pitch rates swinging at 0.3-1 Hz, as attitude sines on a real vehicle, logged
    /// by a 120 Hz gyro with white noise, a 50 Hz AHRS whose errors are low-passed, and by a
    /// 10-15 Hz irregular log with white errors: the smoothed rate keeps the true amplitude within 10 % and its
    /// stated sigma stays honest (RMS of error/sigma between 0.5 and 2).
    #[test]
    fn attitude_sines_keep_their_amplitude() {
        // (frequency Hz, amplitude rad/s, log rate Hz, noise time constant s, seed)
        let cases = [
            (0.3, 0.2, 120.0, 0.0, 11),
            (0.5, 0.5, 120.0, 0.0, 12),
            (1.0, 0.3, 120.0, 0.0, 13),
            (0.5, 0.3, 10.0, 0.0, 14),
            (0.3, 0.3, 50.0, 0.2, 16),
            (0.5, 0.15, 15.0, 0.0, 15),
        ];
        for (f, amp, rate, tau, seed) in cases {
            let w = 2.0 * std::f64::consts::PI * f;
            // A sine with a slower swell on top, so the amplitude is not one number.
            let truth = |t: f64| amp * (w * t).sin() * (1.0 + 0.3 * (0.2 * t).sin());
            let mut rng = crate::core::rng::Rng::new(seed);
            let mut t = vec![0.0];
            while *t.last().unwrap() < 60.0 {
                let last = *t.last().unwrap();
                t.push(last + (0.8 + 0.4 * rng.uniform()) / rate);
            }
            let z = super::super::nav::tests::logged(&t, &truth, 0.015, tau, &mut rng);
            let t = &t[1..];
            let out: Vec<f64> = (100..2900).map(|k| k as f64 * 0.02).collect();
            let s = smooth(t, &z, &out, 1e-4);
            let mean_abs = |v: &mut dyn Iterator<Item = f64>| {
                let (sum, n) = v.fold((0.0, 0usize), |(a, n), x| (a + x.abs(), n + 1));
                sum / n as f64
            };
            let kept =
                mean_abs(&mut s.v.iter().copied()) / mean_abs(&mut out.iter().map(|&x| truth(x)));
            let z_rms = (out
                .iter()
                .enumerate()
                .map(|(k, &tk)| ((s.v[k] - truth(tk)) / s.std[k]).powi(2))
                .sum::<f64>()
                / out.len() as f64)
                .sqrt();
            eprintln!(
                "{f} Hz at {rate} Hz: amplitude kept {kept:.3}, error/sigma RMS {z_rms:.2} ({:?})",
                s.noise
            );
            assert!(
                (0.9..1.1).contains(&kept),
                "{f} Hz at {rate} Hz: amplitude {kept}"
            );
            assert!(
                (0.5..2.0).contains(&z_rms),
                "{f} Hz at {rate} Hz: error/sigma {z_rms}"
            );
        }
    }
}
