//! Numerical helpers of the fusion: quantiles for the outlier gates, angle wrapping, and
//! interpolation on increasing time bases.

pub(crate) fn chi2_quantile(p: f64, dof: usize) -> f64 {
    // Wilson-Hilferty: accurate to ~1 % for the few degrees of freedom used here.
    let z = normal_quantile(p);
    let k = dof as f64;
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

pub(crate) fn normal_quantile(p: f64) -> f64 {
    // Acklam's rational approximation (|error| < 1.2e-9).
    let a = [
        -39.696_830_286_653_76,
        220.946_098_424_520_5,
        -275.928_510_446_969,
        138.357_751_867_269,
        -30.664_798_066_147_16,
        2.506_628_277_459_239,
    ];
    let b = [
        -54.476_098_798_224_06,
        161.585_836_858_040_9,
        -155.698_979_859_886_6,
        66.801_311_887_719_72,
        -13.280_681_552_885_72,
    ];
    let c = [
        -0.007_784_894_002_430_293,
        -0.322_396_458_041_136_4,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    let d = [
        0.007_784_695_709_041_462,
        0.322_467_129_070_039_8,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let tail = |q: f64| {
        (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    }
}

pub(crate) fn wrap_pi(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

/// Angles `a` (rad) with the jumps of a full turn taken out, turns counted; NaN samples stay
/// NaN and do not break the count.
pub fn unwrap_angles(a: &[f64]) -> Vec<f64> {
    let tau = std::f64::consts::TAU;
    let (mut turns, mut last) = (0.0, f64::NAN);
    a.iter()
        .map(|&x| {
            if !x.is_finite() {
                return x;
            }
            if last.is_finite() {
                turns -= tau * ((x - last) / tau).round();
            }
            last = x;
            x + turns
        })
        .collect()
}

pub use crate::core::interp::{interp, interp_at, locate};
