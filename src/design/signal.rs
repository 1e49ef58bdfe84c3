//! The candidate command profiles of a designed run: steps, pseudo-random binary sequences and
//! multisines, one per commanded DOF (X, Y, Z in N, N in N m), each with its amplitude and
//! time scale. Every family is built to come back where it started (zero mean over its
//! periods, or a sequence that leans against its own running sum), so an open-loop run stays
//! in a pool.

use crate::core::rng::Rng;
use serde::{Deserialize, Serialize};

/// The commanded DOFs of a pool run's `thrust.csv`, in its column order.
pub const LABELS: [&str; 4] = ["X_N", "Y_N", "Z_N", "N_Nm"];

/// One candidate command profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "family", rename_all = "snake_case")]
pub enum Profile {
    /// A square wave per DOF, `+a, -a`, with its own period and a quarter-period offset
    /// between DOFs.
    Steps {
        period_s: [f64; 4],
        amplitude: [f64; 4],
    },
    /// A random binary level per DOF held `hold_s` (0.5 to 1.5 times), its sign leaning
    /// against the running sum of the levels so far (a run that comes back).
    Prbs {
        hold_s: f64,
        amplitude: [f64; 4],
        seed: u64,
    },
    /// A sum of sines per DOF at log-spaced frequencies between `f_lo_hz` and `f_hi_hz`, the
    /// DOFs on interleaved frequencies (uncorrelated), Schroeder phases (a low peak factor),
    /// scaled to the amplitude at its peak.
    Multisine {
        f_lo_hz: f64,
        f_hi_hz: f64,
        amplitude: [f64; 4],
    },
}

impl Profile {
    pub fn family(&self) -> &'static str {
        match self {
            Profile::Steps { .. } => "steps",
            Profile::Prbs { .. } => "prbs",
            Profile::Multisine { .. } => "multisine",
        }
    }

    pub fn amplitude(&self) -> [f64; 4] {
        match self {
            Profile::Steps { amplitude, .. }
            | Profile::Prbs { amplitude, .. }
            | Profile::Multisine { amplitude, .. } => *amplitude,
        }
    }

    /// The same profile with the amplitudes of the DOFs in `which` times `k`.
    pub fn scaled(&self, k: f64, which: [bool; 4]) -> Profile {
        let mut p = self.clone();
        let a = match &mut p {
            Profile::Steps { amplitude, .. }
            | Profile::Prbs { amplitude, .. }
            | Profile::Multisine { amplitude, .. } => amplitude,
        };
        for (x, w) in a.iter_mut().zip(which) {
            if w {
                *x *= k;
            }
        }
        p
    }

    /// One line for the report: the family and its numbers.
    pub fn describe(&self) -> String {
        let a = self.amplitude();
        let amp = format!(
            "amplitudes X {:.0} N, Y {:.0} N, Z {:.0} N, N {:.1} N m",
            a[0], a[1], a[2], a[3]
        );
        match self {
            Profile::Steps { period_s, .. } => format!(
                "steps (square waves) with periods {:.1}, {:.1}, {:.1}, {:.1} s; {amp}",
                period_s[0], period_s[1], period_s[2], period_s[3]
            ),
            Profile::Prbs { hold_s, .. } => {
                format!("PRBS holding each level about {hold_s:.1} s; {amp}")
            }
            Profile::Multisine {
                f_lo_hz, f_hi_hz, ..
            } => format!("multisine from {f_lo_hz:.3} to {f_hi_hz:.3} Hz; {amp}"),
        }
    }

    /// The command at every `dt` for `duration_s`, [X, Y, Z, N].
    pub fn commands(&self, duration_s: f64, dt: f64) -> Vec<[f64; 4]> {
        let n = (duration_s / dt).round() as usize + 1;
        let t = |k: usize| k as f64 * dt;
        match self {
            Profile::Steps {
                period_s,
                amplitude,
            } => (0..n)
                .map(|k| {
                    std::array::from_fn(|d| {
                        let phase = t(k) / period_s[d] + 0.25 * d as f64;
                        let up = phase.fract() < 0.5;
                        if up { amplitude[d] } else { -amplitude[d] }
                    })
                })
                .collect(),
            Profile::Prbs {
                hold_s,
                amplitude,
                seed,
            } => prbs(*hold_s, *amplitude, *seed, n, dt),
            Profile::Multisine {
                f_lo_hz,
                f_hi_hz,
                amplitude,
            } => multisine(*f_lo_hz, *f_hi_hz, *amplitude, n, dt),
        }
    }
}

fn prbs(hold_s: f64, amplitude: [f64; 4], seed: u64, n: usize, dt: f64) -> Vec<[f64; 4]> {
    let mut rng = Rng::derive(seed, "design/prbs");
    let mut level = [0.0f64; 4];
    let mut next = [0.0f64; 4];
    let mut sum = [0.0f64; 4];
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * dt;
        for d in 0..4 {
            if t >= next[d] {
                // Lean against the running sum: the run comes back towards where it began.
                let back = -sum[d].signum();
                let sign = if sum[d] == 0.0 || rng.uniform() < 0.25 {
                    if rng.uniform() < 0.5 { 1.0 } else { -1.0 }
                } else {
                    back
                };
                level[d] = sign * amplitude[d];
                next[d] = t + hold_s * (0.5 + rng.uniform());
            }
            sum[d] += level[d] * dt;
        }
        out.push(level);
    }
    out
}

/// Sines per DOF: 6 log-spaced frequencies for each, the four DOFs' sets interleaved.
fn multisine(f_lo: f64, f_hi: f64, amplitude: [f64; 4], n: usize, dt: f64) -> Vec<[f64; 4]> {
    const PER_DOF: usize = 6;
    let total = PER_DOF * 4;
    let ratio = (f_hi / f_lo).max(1.0);
    let freq = |i: usize| f_lo * ratio.powf(i as f64 / (total - 1) as f64);
    let mut out = vec![[0.0; 4]; n];
    for d in 0..4 {
        let ks: Vec<usize> = (0..PER_DOF).map(|j| j * 4 + d).collect();
        let raw: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * dt;
                ks.iter()
                    .enumerate()
                    .map(|(j, &i)| {
                        let phase = -std::f64::consts::PI * (j * (j + 1)) as f64 / PER_DOF as f64;
                        (2.0 * std::f64::consts::PI * freq(i) * t + phase).sin()
                    })
                    .sum()
            })
            .collect();
        let peak = raw.iter().fold(0.0f64, |a, x| a.max(x.abs())).max(1e-12);
        for (row, x) in out.iter_mut().zip(raw) {
            row[d] = amplitude[d] * x / peak;
        }
    }
    out
}

/// A random candidate of `family` within `limits` (amplitudes from 30 % to 100 % of them).
pub fn random(family: &str, limits: [f64; 4], rng: &mut Rng) -> Profile {
    let amplitude = std::array::from_fn(|d| limits[d] * (0.3 + 0.7 * rng.uniform()));
    match family {
        "steps" => Profile::Steps {
            period_s: std::array::from_fn(|_| 2.0 + 18.0 * rng.uniform()),
            amplitude,
        },
        "prbs" => Profile::Prbs {
            hold_s: 0.5 + 4.5 * rng.uniform(),
            amplitude,
            seed: (rng.uniform() * 1e9) as u64,
        },
        _ => {
            let lo = 0.02 + 0.08 * rng.uniform();
            Profile::Multisine {
                f_lo_hz: lo,
                f_hi_hz: lo * (3.0 + 17.0 * rng.uniform()),
                amplitude,
            }
        }
    }
}

/// A small random change of `p` (its time scales and amplitudes by up to ±20 %), for the
/// local search after the random one.
pub fn perturb(p: &Profile, limits: [f64; 4], rng: &mut Rng) -> Profile {
    let mut jiggle = |x: f64| x * (1.0 + 0.4 * (rng.uniform() - 0.5));
    let amp = |a: [f64; 4], j: &mut dyn FnMut(f64) -> f64| {
        std::array::from_fn(|d| j(a[d]).clamp(0.05 * limits[d], limits[d]))
    };
    match p {
        Profile::Steps {
            period_s,
            amplitude,
        } => Profile::Steps {
            period_s: std::array::from_fn(|d| jiggle(period_s[d]).clamp(1.0, 40.0)),
            amplitude: amp(*amplitude, &mut jiggle),
        },
        Profile::Prbs {
            hold_s,
            amplitude,
            seed,
        } => Profile::Prbs {
            hold_s: jiggle(*hold_s).clamp(0.3, 10.0),
            amplitude: amp(*amplitude, &mut jiggle),
            seed: *seed,
        },
        Profile::Multisine {
            f_lo_hz,
            f_hi_hz,
            amplitude,
        } => {
            let lo = jiggle(*f_lo_hz).clamp(0.005, 1.0);
            Profile::Multisine {
                f_lo_hz: lo,
                f_hi_hz: jiggle(*f_hi_hz).max(1.5 * lo).min(2.0),
                amplitude: amp(*amplitude, &mut jiggle),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_family_keeps_within_its_amplitude_and_comes_back() {
        let limits = [60.0, 50.0, 40.0, 8.0];
        let mut rng = Rng::new(3);
        for family in ["steps", "prbs", "multisine"] {
            for _ in 0..5 {
                let p = random(family, limits, &mut rng);
                let a = p.amplitude();
                let cmd = p.commands(120.0, 0.05);
                assert_eq!(cmd.len(), 2401);
                for d in 0..4 {
                    let peak = cmd.iter().fold(0.0f64, |m, c| m.max(c[d].abs()));
                    assert!(peak <= a[d] + 1e-9 && peak > 0.5 * a[d], "{family} {d}");
                    // The mean command is a small part of its amplitude: no steady push.
                    let mean = cmd.iter().map(|c| c[d]).sum::<f64>() / cmd.len() as f64;
                    assert!(mean.abs() < 0.2 * a[d], "{family} {d}: mean {mean}");
                }
            }
        }
    }
}
