//! Where the mismatch is: the residual's share in each regime of the runs (after a command
//! step, near a wall, ...) and its worst windows per run and DOF.

use super::Run;
use crate::core::dof::Dof;
use crate::diagnose::SLOTS;
use serde::{Deserialize, Serialize};

/// A regime of the runs: a condition per sample and DOF.
pub struct Regime {
    pub name: &'static str,
    pub label: &'static str,
}

pub static REGIMES: &[Regime] = &[
    Regime {
        name: "after_command_step",
        label: "within 1.5 s after a command step",
    },
    Regime {
        name: "reverse_command",
        label: "reverse command in the DOF",
    },
    Regime {
        name: "small_command",
        label: "small command in the DOF (< 15 % of its largest)",
    },
    Regime {
        name: "far_from_anchor",
        label: "far from the tether anchor (beyond the median length)",
    },
    Regime {
        name: "near_wall",
        label: "within 2 m of a wall",
    },
    Regime {
        name: "deep",
        label: "deeper than the run's median depth",
    },
    Regime {
        name: "near_surface",
        label: "within 0.5 m of the surface, where a vehicle breaking it loses buoyancy",
    },
    Regime {
        name: "heading_pool_x",
        label: "heading within 90 degrees of pool +x",
    },
    Regime {
        name: "cross_flow",
        label: "moving in surge and sway at once (|u||v| above its median)",
    },
    Regime {
        name: "heave",
        label: "heave DOF",
    },
];

/// Whether sample k of a run, DOF j, is in the regime; None when the run cannot tell.
fn in_regime(name: &str, run: &Run, k: usize, j: usize, med: &RunMedians) -> Option<bool> {
    let c = &run.cmd;
    Some(match name {
        "after_command_step" => {
            let lo = run.t[k] - 1.5;
            let mut i = k;
            let mut hit = false;
            while i > 0 && run.t[i - 1] >= lo {
                if (0..SLOTS).any(|q| (c[i][q] - c[i - 1][q]).abs() > 0.15 * med.cmd_max[q]) {
                    hit = true;
                    break;
                }
                i -= 1;
            }
            hit
        }
        "reverse_command" => c[k][j] < 0.0,
        "small_command" => c[k][j].abs() < 0.15 * med.cmd_max[j],
        "far_from_anchor" => run.tether_length(k)? > med.tether?,
        "near_wall" => run.wall_distance(k)? < 2.0,
        "deep" => run.pos[2][k] > med.depth,
        "near_surface" => {
            let z = run.pos[2][k];
            med.depth_logged
                .then_some(z.is_finite() && z < NEAR_SURFACE_M)?
        }
        "heading_pool_x" => run.psi[k].cos() > 0.0,
        "cross_flow" => cross(run, k)? > med.cross,
        "heave" => run.slots.dof(j) == Dof::Heave,
        _ => return None,
    })
}

/// Depth within which a vehicle is near the surface, m: about its own height, where a
/// BlueROV-sized frame starts to break it.
const NEAR_SURFACE_M: f64 = 0.5;

struct RunMedians {
    cmd_max: [f64; SLOTS],
    tether: Option<f64>,
    depth: f64,
    /// Whether the run's depth was measured (a dead-reckoned track without a depth sensor
    /// holds it at 0).
    depth_logged: bool,
    cross: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn medians(run: &Run) -> RunMedians {
    let n = run.t.len();
    RunMedians {
        cmd_max: std::array::from_fn(|q| run.cmd.iter().fold(1e-9f64, |a, c| a.max(c[q].abs()))),
        tether: run
            .anchor
            .map(|_| median((0..n).filter_map(|k| run.tether_length(k)).collect())),
        depth: median(run.pos[2].clone()),
        depth_logged: run.pos[2].iter().any(|z| z.is_finite() && *z != 0.0),
        cross: median((0..n).filter_map(|k| cross(run, k)).collect()),
    }
}

/// |u| |v| at sample k, when the run is compared in surge and sway.
fn cross(run: &Run, k: usize) -> Option<f64> {
    let (a, b) = (run.slots.slot(Dof::Surge)?, run.slots.slot(Dof::Sway)?);
    Some((run.vel[a][k] * run.vel[b][k]).abs())
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RegimeShare {
    pub regime: String,
    pub label: String,
    pub share_of_error: f64,
    pub share_of_time: f64,
}

/// Share of the normalised squared residual, and of the samples, in each regime (over DOFs).
pub fn regime_shares(
    runs: &[Run],
    residuals: &[[Vec<f64>; SLOTS]],
    scale: &[f64; SLOTS],
) -> Vec<RegimeShare> {
    REGIMES
        .iter()
        .filter_map(|g| {
            let (mut err_in, mut err_all, mut n_in, mut n_all) = (0.0, 0.0, 0.0, 0.0);
            for (run, e) in runs.iter().zip(residuals) {
                let med = medians(run);
                for j in 0..SLOTS {
                    for (k, x) in e[j].iter().enumerate() {
                        if !x.is_finite() {
                            continue;
                        }
                        let inside = in_regime(g.name, run, k, j, &med)?;
                        let w = x * x / scale[j];
                        err_all += w;
                        n_all += 1.0;
                        if inside {
                            err_in += w;
                            n_in += 1.0;
                        }
                    }
                }
            }
            (n_all > 0.0 && err_all > 0.0).then(|| RegimeShare {
                regime: g.name.into(),
                label: g.label.into(),
                share_of_error: err_in / err_all,
                share_of_time: n_in / n_all,
            })
        })
        .collect()
}

/// Where a residual is: per run and DOF, the share of the error and its worst windows.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Mismatch {
    pub run: String,
    pub dof: Dof,
    pub windows_s: Vec<[f64; 2]>,
    pub share_of_error: f64,
}

/// Windows where the 1-s moving mean of the squared residual exceeds twice its run mean (and
/// the noise), merged across gaps under 1 s, the five with the most error.
pub fn locate(
    runs: &[Run],
    residuals: &[[Vec<f64>; SLOTS]],
    scale: &[f64; SLOTS],
) -> Vec<Mismatch> {
    let mut total = 0.0;
    let mut parts = Vec::new();
    for (run, e) in runs.iter().zip(residuals) {
        for j in run.slots.on() {
            let sq: Vec<f64> = e[j]
                .iter()
                .map(|x| if x.is_finite() { x * x } else { 0.0 })
                .collect();
            let energy: f64 = sq.iter().sum::<f64>() / scale[j];
            total += energy;
            let windows = error_windows(run, j, &sq, scale[j]);
            parts.push((run.name.clone(), run.slots.dof(j), windows, energy));
        }
    }
    let mut out: Vec<Mismatch> = parts
        .into_iter()
        .map(|(run, dof, windows_s, e)| Mismatch {
            run,
            dof,
            windows_s,
            share_of_error: if total > 0.0 { e / total } else { 0.0 },
        })
        .collect();
    out.sort_by(|a, b| b.share_of_error.total_cmp(&a.share_of_error));
    out
}

/// The (at most five, largest) windows of DOF `j` of a run where the squared residual `sq`,
/// averaged over a second, stays above twice its mean and four times the fused variance;
/// windows less than 1 s apart merge and those shorter than 0.5 s are dropped. In time order.
fn error_windows(run: &Run, j: usize, sq: &[f64], scale: f64) -> Vec<[f64; 2]> {
    let n = sq.len();
    let dt = if n > 1 {
        (run.t[n - 1] - run.t[0]) / (n - 1) as f64
    } else {
        0.05
    };
    let half = ((0.5 / dt).round() as usize).max(1);
    let mut pre = vec![0.0; n + 1];
    for k in 0..n {
        pre[k + 1] = pre[k] + sq[k];
    }
    let mean = pre[n] / n.max(1) as f64;
    let noise = run.noise_sum(j) / n.max(1) as f64;
    let thr = (2.0 * mean).max(4.0 * noise);
    let mov = |k: usize| {
        let (a, b) = (k.saturating_sub(half), (k + half + 1).min(n));
        (pre[b] - pre[a]) / (b - a) as f64
    };
    let mut windows: Vec<(f64, f64, f64)> = Vec::new();
    let mut k = 0;
    while k < n {
        if mov(k) > thr {
            let start = k;
            while k < n && mov(k) > thr {
                k += 1;
            }
            let (t0, t1) = (run.t[start], run.t[k - 1]);
            let en = (pre[k] - pre[start]) / scale;
            match windows.last_mut() {
                Some(w) if t0 - w.1 < 1.0 => {
                    w.1 = t1;
                    w.2 += en;
                }
                _ => windows.push((t0, t1, en)),
            }
        } else {
            k += 1;
        }
    }
    windows.retain(|w| w.1 - w.0 >= 0.5);
    windows.sort_by(|a, b| b.2.total_cmp(&a.2));
    windows.truncate(5);
    windows.sort_by(|a, b| a.0.total_cmp(&b.0));
    windows.iter().map(|w| [round2(w.0), round2(w.1)]).collect()
}

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::{Hydro, Plant, Vehicle};

    /// A run of `n` samples at 10 Hz at depth `depth(k)`, moving in heave only.
    fn run(n: usize, depth: impl Fn(usize) -> f64) -> Run {
        let plant = Plant::new(&Vehicle::reference(), Hydro::reference());
        let slots = super::super::Slots::of(&plant).unwrap();
        let zeros = vec![0.0; n];
        Run {
            name: "r".into(),
            validate: true,
            t: (0..n).map(|k| k as f64 * 0.1).collect(),
            slots,
            cmd: vec![[0.0, 0.0, 10.0, 0.0, 0.0, 0.0]; n],
            vel: std::array::from_fn(|_| zeros.clone()),
            std: std::array::from_fn(|_| vec![0.01; n]),
            noise_share: [1.0; SLOTS],
            pos: [zeros.clone(), zeros.clone(), (0..n).map(depth).collect()],
            psi: zeros.clone(),
            pool: None,
            anchor: None,
            dead_reckoned: false,
            att: Default::default(),
            anchors_s: Vec::new(),
        }
    }

    /// A held-out run that rises to the surface and stops there, the model's heave going on:
    /// the error is where the run is within half a metre of the surface; a run whose depth
    /// is not known (held at 0) tells nothing of it.
    #[test]
    fn an_error_at_the_surface_concentrates_there() {
        let n = 200;
        let r = run(n, |k| (2.0 - 0.01 * k as f64).max(0.1));
        let heave = r.slots.slot(Dof::Heave).unwrap();
        let mut e: [Vec<f64>; SLOTS] = std::array::from_fn(|_| vec![0.0; n]);
        for (k, x) in e[heave].iter_mut().enumerate() {
            *x = if r.pos[2][k] < 0.3 { 0.2 } else { 0.01 };
        }
        let shares = regime_shares(std::slice::from_ref(&r), &[e.clone()], &[1.0; SLOTS]);
        let s = shares.iter().find(|s| s.regime == "near_surface").unwrap();
        assert!(
            s.share_of_error > 0.9 && s.share_of_time < 0.25 * 1.1,
            "{s:?}"
        );
        let unknown = run(n, |_| 0.0);
        let shares = regime_shares(&[unknown], &[e], &[1.0; SLOTS]);
        assert!(shares.iter().all(|s| s.regime != "near_surface"));
    }
}
