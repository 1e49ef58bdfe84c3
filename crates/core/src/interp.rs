//! Series sampled at increasing times: linear interpolation between samples, held at the ends,
//! and their typical sampling step.

/// Linear interpolation of `y(t)` at `x` (clamped at the ends); `t` increasing.
pub fn interp(t: &[f64], y: &[f64], x: f64) -> f64 {
    interp_at(y, locate(t, x))
}

/// Where `x` falls in the increasing times `t`, for [`interp_at`]: the sample and, between two
/// samples, the weight of the next one. Locating once serves every series on the same times.
pub fn locate(t: &[f64], x: f64) -> (usize, Option<f64>) {
    match t.partition_point(|&v| v <= x) {
        0 => (0, None),
        i if i >= t.len() => (t.len() - 1, None),
        i => (i - 1, Some((x - t[i - 1]) / (t[i] - t[i - 1]))),
    }
}

/// The value of `y` at a location from [`locate`] (linear between samples, held at the ends).
pub fn interp_at(y: &[f64], (j, w): (usize, Option<f64>)) -> f64 {
    match w {
        None => y[j],
        Some(w) => y[j] + w * (y[j + 1] - y[j]),
    }
}

/// The median of the positive steps of `t` (0.1 s when it has none).
pub fn median_step(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.1)
}
