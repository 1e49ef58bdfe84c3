//! The median outlier filter of seed 003 (section IV): a sample farther than `width` from the
//! median of the `length` samples around it is an outlier and is replaced by that median.
//! Seed 003 used length 9 with 0.03 m/s on DVL velocities and 0.3 deg/s^2 on angular
//! accelerations differentiated from the gyro.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MedianFilter {
    /// Samples in the window (odd; an even length is widened by one).
    pub length: usize,
    /// Largest distance from the median of a translational velocity, m/s.
    pub width_m_s: f64,
    /// Largest distance from the median of an angular acceleration, deg/s^2.
    pub width_deg_s2: f64,
}

impl Default for MedianFilter {
    fn default() -> Self {
        MedianFilter {
            length: 9,
            width_m_s: 0.03,
            width_deg_s2: 0.3,
        }
    }
}

/// `x` with each outlier replaced by its window's median, and how many there were.
pub fn reject(x: &[f64], length: usize, width: f64) -> (Vec<f64>, usize) {
    let half = length / 2;
    let mut out = x.to_vec();
    let mut replaced = 0;
    let mut window = Vec::with_capacity(2 * half + 1);
    for k in 0..x.len() {
        let (a, b) = (k.saturating_sub(half), (k + half + 1).min(x.len()));
        window.clear();
        window.extend(x[a..b].iter().copied().filter(|v| v.is_finite()));
        if window.is_empty() {
            continue;
        }
        window.sort_by(f64::total_cmp);
        let m = window.len();
        let median = if m % 2 == 1 {
            window[m / 2]
        } else {
            0.5 * (window[m / 2 - 1] + window[m / 2])
        };
        if (x[k] - median).abs() > width {
            out[k] = median;
            replaced += 1;
        }
    }
    (out, replaced)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spikes_go_and_a_smooth_signal_stays() {
        let smooth: Vec<f64> = (0..400).map(|k| (k as f64 * 0.01).sin()).collect();
        let (same, n) = reject(&smooth, 9, 0.03);
        assert_eq!(n, 0);
        assert_eq!(same, smooth);
        let mut spiky = smooth.clone();
        spiky[50] += 0.5;
        spiky[320] -= 0.2;
        let (fixed, n) = reject(&spiky, 9, 0.03);
        assert_eq!(n, 2);
        assert!((fixed[50] - smooth[50]).abs() < 0.03, "{}", fixed[50]);
        assert!((fixed[320] - smooth[320]).abs() < 0.03);
    }
}
