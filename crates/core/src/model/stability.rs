//! Local stability of an identified model along a recorded run, and the simulation horizon it
//! allows.
//!
//! An open-frame vehicle at speed is often directionally unstable: the Munk moment
//! `(Y_vdot - X_udot) u v` outweighs the yaw damping, and the sway-yaw pair gets an eigenvalue
//! with a positive real part. Real runs are flown by a pilot or an autopilot that keeps the
//! vehicle on course, so a 60 s open-loop simulation of such a run drifts apart from the
//! recording whatever the model; that drift is not missing physics. Where the linearised model
//! grows along the run, validation and diagnosis re-anchor the simulation to the fused state
//! (multiple shooting) each time an error would have grown [`GROWTH_PER_WINDOW`]-fold since
//! the last anchor; where it is stable no anchor is set, so a stable stretch (or a stable run)
//! is simulated in one piece and a slow effect stays visible there.

use super::{Plant, Vec6};
use serde::{Deserialize, Serialize};

/// How much a simulation error may grow over one window before it is re-anchored.
pub const GROWTH_PER_WINDOW: f64 = 2.0;
/// Shortest window, s: shorter ones would hide a thruster's lag or a sensor's delay.
pub const MIN_HORIZON_S: f64 = 0.5;
/// Growth rates below this (1/s) are treated as neutral: a 60 s run grows less than e^1.2.
const NEUTRAL_PER_S: f64 = 0.02;

/// The pool DOFs' places in a 6-vector: u, v, w, r.
const NU: [usize; 4] = [0, 1, 2, 5];

/// How the model behaves along one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stability {
    /// The 90th percentile over the run of the largest real part of the linearised model's
    /// eigenvalues at the recorded velocity, 1/s (positive: a perturbation grows).
    pub growth_per_s: f64,
    /// The largest such real part anywhere on the run, 1/s.
    pub peak_growth_per_s: f64,
    /// Share of the run's samples where the model is locally unstable.
    pub share_unstable: f64,
    /// The shortest window between re-anchorings, s; `None`: the whole run is simulated in
    /// one piece.
    #[serde(default)]
    pub horizon_s: Option<f64>,
    /// Times at which the simulation is re-anchored to the fused state, s (the run's start
    /// always is, and is not listed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub anchors_s: Vec<f64>,
}

/// What the user asked for in `horizon_s`: `auto` (from the model's stability along each run),
/// `whole_run`, or a window in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Horizon {
    #[default]
    Auto,
    WholeRun,
    Seconds(f64),
}

impl Serialize for Horizon {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Horizon::Auto => s.serialize_str("auto"),
            Horizon::WholeRun => s.serialize_str("whole_run"),
            Horizon::Seconds(x) => s.serialize_f64(*x),
        }
    }
}

impl<'de> Deserialize<'de> for Horizon {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Horizon, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Seconds(f64),
            Word(String),
        }
        match Raw::deserialize(d)? {
            Raw::Seconds(x) if x.is_finite() && x > 0.0 => Ok(Horizon::Seconds(x)),
            Raw::Seconds(x) => Err(serde::de::Error::custom(format!(
                "horizon_s must be a positive number of seconds, `auto` or `whole_run`, not {x}"
            ))),
            Raw::Word(w) if w == "auto" => Ok(Horizon::Auto),
            Raw::Word(w) if w == "whole_run" => Ok(Horizon::WholeRun),
            Raw::Word(w) => Err(serde::de::Error::custom(format!(
                "horizon_s must be `auto`, `whole_run` or a number of seconds, not `{w}`"
            ))),
        }
    }
}

/// The Jacobian of the model's acceleration with respect to the velocities of the DOFs among
/// the `slots` (indices into nu; u, v, w, r for [`along`]) that the model moves in, at
/// `nu`, the other DOFs at rest (central differences; the thrust adds a constant and drops
/// out). A DOF the model leaves out has no dynamics to grow or decay, and is not in it.
pub fn jacobian<const S: usize>(
    plant: &Plant,
    nu: &[f64; S],
    slots: &[usize; S],
) -> nalgebra::DMatrix<f64> {
    let mut base: Vec6 = [0.0; 6];
    for (c, &i) in slots.iter().enumerate() {
        base[i] = nu[c];
    }
    let on: Vec<(usize, usize)> = slots
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, i)| plant.active[i])
        .collect();
    let mut jac = nalgebra::DMatrix::zeros(on.len(), on.len());
    for (c, &(slot, i)) in on.iter().enumerate() {
        let h = 1e-5 * (1.0 + nu[slot].abs());
        let (mut plus, mut minus) = (base, base);
        plus[i] += h;
        minus[i] -= h;
        let (ap, am) = (
            plant.accel(&plus, &[0.0; 6]),
            plant.accel(&minus, &[0.0; 6]),
        );
        for (r, &(_, k)) in on.iter().enumerate() {
            jac[(r, c)] = (ap[k] - am[k]) / (2.0 * h);
        }
    }
    jac
}

/// The largest real part of the linearised model's eigenvalues at `nu` (velocities of the DOFs
/// `slots`), 1/s; 0 for a model that moves in none of them.
pub fn growth_rate<const S: usize>(plant: &Plant, nu: &[f64; S], slots: &[usize; S]) -> f64 {
    let jac = jacobian(plant, nu, slots);
    if jac.iter().any(|x| !x.is_finite()) {
        return f64::INFINITY;
    }
    if jac.nrows() == 0 {
        return 0.0;
    }
    crate::numerics::complex_eigenvalues(jac).map_or(f64::INFINITY, |ev| {
        ev.iter().map(|e| e.re).fold(f64::NEG_INFINITY, f64::max)
    })
}

/// The model's stability along a run: recorded velocities `vel` (u, v, w, r per sample at
/// times `t`, NaN where unknown, then taken as 0), and the horizon `setting` resolves to.
pub fn along(plant: &Plant, t: &[f64], vel: &[[f64; 4]], setting: Horizon) -> Stability {
    along_in(plant, t, vel, &NU, setting)
}

/// [`along`] with `vel` the velocities of the DOFs `slots` (indices into nu): a model in
/// heave, roll, pitch and yaw is judged on its own motion.
pub fn along_in<const S: usize>(
    plant: &Plant,
    t: &[f64],
    vel: &[[f64; S]],
    slots: &[usize; S],
    setting: Horizon,
) -> Stability {
    let n = t.len().min(vel.len());
    let duration_s = if n > 1 { t[n - 1] - t[0] } else { 0.0 };
    // Every sample is not needed: the velocity changes little between neighbours.
    let stride = (n / 600).max(1);
    let idx: Vec<usize> = (0..n).step_by(stride).collect();
    let rates: Vec<f64> = idx
        .iter()
        .map(|&k| {
            growth_rate(
                plant,
                &vel[k].map(|x| if x.is_finite() { x } else { 0.0 }),
                slots,
            )
        })
        .collect();
    let mut sorted = rates.clone();
    sorted.sort_by(f64::total_cmp);
    let m = sorted.len().max(1);
    let growth = sorted
        .get((0.9 * (m - 1) as f64).round() as usize)
        .copied()
        .unwrap_or(0.0);
    let peak = sorted.last().copied().unwrap_or(0.0);
    let share_unstable = rates.iter().filter(|r| **r > NEUTRAL_PER_S).count() as f64 / m as f64;
    let times: Vec<f64> = idx.iter().map(|&k| t[k]).collect();
    let start = t.first().copied().unwrap_or(0.0);
    let anchors_s = match setting {
        Horizon::WholeRun => Vec::new(),
        Horizon::Seconds(x) if x < duration_s => (1..)
            .map(|i| start + i as f64 * x)
            .take_while(|a| *a < start + duration_s)
            .collect(),
        Horizon::Seconds(_) => Vec::new(),
        Horizon::Auto => auto_anchors(&times, &rates),
    };
    let horizon_s = std::iter::once(start)
        .chain(anchors_s.iter().copied())
        .collect::<Vec<f64>>()
        .windows(2)
        .map(|w| w[1] - w[0])
        .min_by(f64::total_cmp);
    Stability {
        growth_per_s: growth,
        peak_growth_per_s: peak,
        share_unstable,
        horizon_s,
        anchors_s,
    }
}

/// Where to re-anchor a simulation along a run whose linearised model grows at `rates` (1/s,
/// at `times`): each time an error would have grown [`GROWTH_PER_WINDOW`]-fold since the last
/// anchor, and never sooner than [`MIN_HORIZON_S`] after it. A stable stretch gets no anchor.
pub fn auto_anchors(times: &[f64], rates: &[f64]) -> Vec<f64> {
    let n = times.len().min(rates.len());
    let budget = GROWTH_PER_WINDOW.ln();
    let mut out = Vec::new();
    let (mut since, mut last) = (0.0, times.first().copied().unwrap_or(0.0));
    for k in 1..n {
        let r = 0.5 * (rates[k - 1].max(0.0) + rates[k].max(0.0));
        since += if r.is_finite() { r } else { 1e3 } * (times[k] - times[k - 1]);
        if since >= budget && times[k] - last >= MIN_HORIZON_S {
            out.push(times[k]);
            (since, last) = (0.0, times[k]);
        }
    }
    out
}

/// The sample indices at which a simulation over times `t` is re-anchored to the recording:
/// the first sample, then the first sample at or after each of `anchors_s`.
pub fn anchors(t: &[f64], anchors_s: &[f64]) -> Vec<usize> {
    let mut out = vec![0];
    for &a in anchors_s {
        let k = t.partition_point(|&tk| tk < a);
        if k < t.len() && k > *out.last().expect("starts with 0") {
            out.push(k);
        }
    }
    out
}

/// One sentence for the report.
pub fn describe(s: &Stability) -> String {
    let state = if s.share_unstable > 0.0 {
        format!(
            "locally unstable on {:.0} % of the run (largest eigenvalue real part {:+.2} /s at the 90th percentile, {:+.2} /s at worst)",
            100.0 * s.share_unstable,
            s.growth_per_s,
            s.peak_growth_per_s
        )
    } else {
        format!(
            "stable along the run (largest eigenvalue real part {:+.2} /s at worst)",
            s.peak_growth_per_s
        )
    };
    match s.horizon_s {
        Some(h) => format!(
            "the model is {state}: re-anchored to the fused state {} times where it grows (windows of {h:.1} s at the shortest), simulated in one piece elsewhere",
            s.anchors_s.len()
        ),
        None => format!("the model is {state}: simulated over the whole run"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Hydro, Vehicle};

    /// The reference vehicle (seed 001 Table 1) at rest is stable (eigenvalues are the damping
    /// over the mass), and at 1.3 m/s forward its Munk moment outweighs the yaw damping: the
    /// sway-yaw pair grows. The rate must match the hand-derived 2x2 sway-yaw linearisation.
    #[test]
    fn the_reference_vehicle_is_directionally_unstable_at_speed() {
        let v = Vehicle::reference();
        let h = Hydro::reference();
        let plant = Plant::new(&v, h);
        let at_rest = growth_rate(&plant, &[0.0; 4], &NU);
        assert!(at_rest < 0.0, "{at_rest}");
        // Surge at rest: -X_u / (m - X_udot), the slowest pole at rest is surge or sway.
        let surge_pole = h.lin[0][0] / (v.mass_kg - h.added[0][0]);
        let sway_pole = h.lin[1][1] / (v.mass_kg - h.added[1][1]);
        let yaw_pole = h.lin[5][5] / (v.inertia_kg_m2.zz - h.added[5][5]);
        let slowest = surge_pole.max(sway_pole).max(yaw_pole);
        assert!((at_rest - slowest).abs() < 1e-4, "{at_rest} vs {slowest}");

        let u = 1.3;
        let fast = growth_rate(&plant, &[u, 0.0, 0.0, 0.0], &NU);
        // Sway-yaw block at (u, 0, 0, 0): v_dot = (Y_v v - (m - X_udot) u r) / (m - Y_vdot),
        // r_dot = ((X_udot - Y_vdot) u v + N_r r) / (I - N_rdot), both sides' Coriolis from
        // eq. 6-7 with the added mass.
        let (m, iz) = (v.mass_kg, v.inertia_kg_m2.zz);
        let a = nalgebra::Matrix2::new(
            h.lin[1][1] / (m - h.added[1][1]),
            -(m - h.added[0][0]) * u / (m - h.added[1][1]),
            (h.added[1][1] - h.added[0][0]) * u / (iz - h.added[5][5]),
            h.lin[5][5] / (iz - h.added[5][5]),
        );
        let expect = a
            .complex_eigenvalues()
            .iter()
            .map(|e| e.re)
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(expect > 1.0, "hand linearisation {expect}");
        assert!((fast - expect).abs() < 0.05 * expect, "{fast} vs {expect}");

        // A run that holds 1.3 m/s for 20 s in the middle of a 60 s run at rest: windows
        // short enough for a 4-fold growth at that rate; a run at rest is simulated whole.
        let t: Vec<f64> = (0..=600).map(|k| k as f64 * 0.1).collect();
        let vel: Vec<[f64; 4]> = t
            .iter()
            .map(|&tk| {
                [
                    if (20.0..40.0).contains(&tk) { u } else { 0.0 },
                    0.0,
                    0.0,
                    0.0,
                ]
            })
            .collect();
        let s = along(&plant, &t, &vel, Horizon::Auto);
        let expect_h = (GROWTH_PER_WINDOW.ln() / fast).max(MIN_HORIZON_S);
        assert!(
            (s.horizon_s.unwrap() - expect_h).abs() < 0.15,
            "{s:?} vs {expect_h}"
        );
        // Anchors only where the model grows (20-40 s), none in the stable stretches.
        assert!(
            s.anchors_s.iter().all(|a| (20.0..=40.5).contains(a)) && s.anchors_s.len() > 5,
            "{:?}",
            s.anchors_s
        );
        assert!((s.share_unstable - 1.0 / 3.0).abs() < 0.02, "{s:?}");
        let rest = along(&plant, &t, &vec![[0.0; 4]; t.len()], Horizon::Auto);
        assert_eq!(rest.horizon_s, None);
        assert_eq!(along(&plant, &t, &vel, Horizon::WholeRun).horizon_s, None);
        assert_eq!(
            along(&plant, &t, &vel, Horizon::Seconds(5.0)).horizon_s,
            Some(5.0)
        );
    }

    #[test]
    fn anchors_split_the_run_into_windows() {
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        assert_eq!(anchors(&t, &[]), vec![0]);
        assert_eq!(
            anchors(&t, &[2.5, 5.0, 7.5, 10.0]),
            vec![0, 25, 50, 75, 100]
        );
        assert_eq!(anchors(&t, &[2.51, 2.52, 11.0]), vec![0, 26]);
    }

    #[test]
    fn the_setting_reads_words_and_seconds() {
        let h: Horizon = serde_yaml_ng::from_str("auto").unwrap();
        assert_eq!(h, Horizon::Auto);
        let h: Horizon = serde_yaml_ng::from_str("whole_run").unwrap();
        assert_eq!(h, Horizon::WholeRun);
        let h: Horizon = serde_yaml_ng::from_str("5").unwrap();
        assert_eq!(h, Horizon::Seconds(5.0));
        assert!(serde_yaml_ng::from_str::<Horizon>("-1").is_err());
        assert!(serde_yaml_ng::from_str::<Horizon>("sometimes").is_err());
    }
}
