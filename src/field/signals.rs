//! The signals of a fused pool run by name, as the field-trial stages' settings write them:
//! body velocities `u v w p q r`, attitude `roll pitch yaw`, pool-frame position `x y depth`,
//! the depth rate `depth_rate` (the fused depth differentiated, as seed 002 computed it),
//! commanded forces `X Y Z K M N`, and every actuator of `actuators.csv` by its name.

use crate::pool::fusion::run::FusedRun;

/// The names a run may offer besides its actuators.
pub const NAMES: [&str; 17] = [
    "u",
    "v",
    "w",
    "p",
    "q",
    "r",
    "roll",
    "pitch",
    "yaw",
    "x",
    "y",
    "depth",
    "depth_rate",
    "X",
    "Y",
    "Z",
    "N",
];

/// The unit of signal `name` (SI; an actuator's as stored).
pub fn unit(name: &str) -> &'static str {
    match name {
        "u" | "v" | "w" | "depth_rate" => "m/s",
        "p" | "q" | "r" => "rad/s",
        "roll" | "pitch" | "yaw" => "rad",
        "x" | "y" | "depth" => "m",
        "X" | "Y" | "Z" => "N",
        "K" | "M" | "N" => "N m",
        "1" => "1",
        _ => "SI",
    }
}

/// Signal `name` of `run` on its fused time base, or an error naming what the run offers.
pub fn signal(run: &FusedRun, name: &str) -> anyhow::Result<Vec<f64>> {
    use crate::core::dof::Dof;
    let f = &run.fused;
    let vel = |d: Dof| run.velocity(d).cloned();
    let cmd = |j: usize| Some(run.thrust.iter().map(|r| r[j]).collect());
    let found: Option<Vec<f64>> = match name {
        "u" => vel(Dof::Surge),
        "v" => vel(Dof::Sway),
        "w" => vel(Dof::Heave),
        "p" => vel(Dof::Roll),
        "q" => vel(Dof::Pitch),
        "r" => vel(Dof::Yaw),
        "roll" => Some(&f.roll_pitch.roll).filter(|v| !v.is_empty()).cloned(),
        "pitch" => Some(&f.roll_pitch.pitch).filter(|v| !v.is_empty()).cloned(),
        "yaw" => Some(f.psi.clone()),
        "x" => Some(f.x.clone()),
        "y" => Some(f.y.clone()),
        "depth" => Some(f.z.clone()),
        "depth_rate" => Some(derivative(&f.t, &f.z)),
        "X" | "Y" | "Z" | "N" if run.meta.force_logged => cmd(["X", "Y", "Z", "N"]
            .iter()
            .position(|n| *n == name)
            .expect("listed")),
        "K" | "M" if !run.moments.is_empty() => {
            let j = usize::from(name == "M");
            Some(run.moments.iter().map(|r| r[j]).collect())
        }
        _ => run.actuator(name).cloned(),
    };
    let v = found.ok_or_else(|| {
        let mut offered: Vec<&str> = NAMES
            .iter()
            .copied()
            .filter(|n| *n != name && signal(run, n).is_ok())
            .collect();
        offered.extend(run.meta.actuators.iter().map(String::as_str));
        anyhow::anyhow!(
            "pool run `{}` has no signal `{name}`; it offers {}",
            run.meta.run,
            offered.join(", ")
        )
    })?;
    anyhow::ensure!(
        v.iter().all(|x| x.is_finite()),
        "pool run `{}`: signal `{name}` is not finite everywhere (a sensor that covered only part of the run)",
        run.meta.run
    );
    Ok(v)
}

/// Central differences of `y(t)` (one-sided at the ends).
pub fn derivative(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if b > a {
                (y[b] - y[a]) / (t[b] - t[a])
            } else {
                0.0
            }
        })
        .collect()
}

/// `y(t)` linearly interpolated at each of `at` (held at the ends).
pub fn interpolate(t: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    let mut j = 0usize;
    at.iter()
        .map(|&x| {
            while j + 2 < t.len() && t[j + 1] <= x {
                j += 1;
            }
            if x <= t[0] {
                return y[0];
            }
            if x >= t[t.len() - 1] {
                return y[t.len() - 1];
            }
            let s = (x - t[j]) / (t[j + 1] - t[j]);
            y[j] + s * (y[j + 1] - y[j])
        })
        .collect()
}

pub use crate::core::interp::median_step;

/// A uniform grid of step `h` over `[t0, t1]`.
pub fn grid(t0: f64, t1: f64, h: f64) -> Vec<f64> {
    let n = ((t1 - t0) / h + 1e-9).floor() as usize + 1;
    (0..n).map(|k| t0 + k as f64 * h).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_and_derivative_are_exact_on_lines() {
        let t: Vec<f64> = (0..11).map(|k| k as f64 * 0.3).collect();
        let y: Vec<f64> = t.iter().map(|x| 2.0 * x - 1.0).collect();
        let at = grid(0.0, 3.0, 0.25);
        assert_eq!(at.len(), 13);
        for (x, v) in at.iter().zip(interpolate(&t, &y, &at)) {
            assert!((v - (2.0 * x - 1.0)).abs() < 1e-12);
        }
        assert!(derivative(&t, &y).iter().all(|d| (d - 2.0).abs() < 1e-12));
    }
}
