//! A dead-reckoned position for runs without a position sensor: a navigation log's body
//! velocity (a DVL's) turned by its heading and summed from where the run started
//! (`start_m` in run.yaml). The effects that need a position (the tether's length, the
//! distance to a wall) are then tested on it instead of being listed as untested. Its
//! error grows with time: a velocity bias of 1 cm/s moves it 0.6 m a minute, which
//! [`drift_m`] states for the run.

/// The horizontal track [x, y] from `start`, integrating `u cos psi - v sin psi` and
/// `u sin psi + v cos psi` by the trapezoid rule; `None` when a velocity or the heading is
/// not finite somewhere (a gap cannot be bridged without inventing motion).
pub fn track(
    t: &[f64],
    u: &[f64],
    v: &[f64],
    psi: &[f64],
    start: [f64; 2],
) -> Option<[Vec<f64>; 2]> {
    let n = t.len();
    if n == 0 || u.len() != n || v.len() != n || psi.len() != n {
        return None;
    }
    let finite = |s: &[f64]| s.iter().all(|x| x.is_finite());
    if !(finite(u) && finite(v) && finite(psi) && finite(t)) {
        return None;
    }
    let world = |k: usize| {
        let (s, c) = psi[k].sin_cos();
        [u[k] * c - v[k] * s, u[k] * s + v[k] * c]
    };
    let mut x = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    let (mut px, mut py) = (start[0], start[1]);
    x.push(px);
    y.push(py);
    for k in 1..n {
        let (a, b) = (world(k - 1), world(k));
        let dt = t[k] - t[k - 1];
        px += 0.5 * dt * (a[0] + b[0]);
        py += 0.5 * dt * (a[1] + b[1]);
        x.push(px);
        y.push(py);
    }
    Some([x, y])
}

/// The drift a 1 cm/s velocity bias gives over the run, m: what the track's error may grow to.
pub fn drift_m(t: &[f64]) -> f64 {
    match (t.first(), t.last()) {
        (Some(a), Some(b)) => 0.01 * (b - a),
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_circle_flown_at_constant_speed_and_turn_rate_closes() {
        // 0.5 m/s forward, turning at 0.1 rad/s: a circle of radius 5 m in 2 pi / 0.1 s.
        let n = 6284;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
        let psi: Vec<f64> = t.iter().map(|t| 0.1 * t).collect();
        let u = vec![0.5; n];
        let v = vec![0.0; n];
        let [x, y] = track(&t, &u, &v, &psi, [2.0, 3.0]).unwrap();
        // A quarter turn in: 5 m along x and 5 m along y from the start.
        let q = 1571;
        assert!(
            (x[q] - 7.0).abs() < 0.01 && (y[q] - 8.0).abs() < 0.01,
            "{} {}",
            x[q],
            y[q]
        );
        assert!((x[n - 1] - 2.0).abs() < 0.01 && (y[n - 1] - 3.0).abs() < 0.01);
        // A sideways velocity at heading 0 moves along y.
        let [_, y] = track(&t[..101], &[0.0; 101], &[0.2; 101], &[0.0; 101], [0.0, 0.0]).unwrap();
        assert!((y[100] - 0.2).abs() < 1e-9);
        assert!(
            track(
                &t[..3],
                &[0.0, f64::NAN, 0.0],
                &[0.0; 3],
                &[0.0; 3],
                [0.0; 2]
            )
            .is_none()
        );
    }
}
