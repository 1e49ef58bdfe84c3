//! Roll and pitch of a run, and their rates p and q, for a vehicle that moves in them: from
//! the IMU (attitude and gyro) or, without one, from the navigation log's AHRS columns, each
//! smoothed onto the output times with its noise told apart from its motion
//! ([`super::motion`]).

use super::motion;
use super::nav::{Noise, robust_std};
use super::numeric::wrap_pi;
use crate::pool::import::PoolRun;
use crate::pool::import::csvlog::Log;
use serde::{Deserialize, Serialize};

/// p and q with their standard deviations, and roll and pitch, on the fused time base.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct RollPitch {
    /// p, q (rad/s), when a sensor gave them.
    pub rate: [Option<Vec<f64>>; 2],
    pub rate_std: [Option<Vec<f64>>; 2],
    /// Roll and pitch (rad); empty when no sensor gave them.
    pub roll: Vec<f64>,
    pub pitch: Vec<f64>,
}

/// Floors of the noise levels: a fibre-optic gyro's 0.01 deg/s (seed 003 Table III) and an
/// AHRS's 0.01 deg.
const RATE_FLOOR_DPS: f64 = 0.01;
const ANGLE_FLOOR_DEG: f64 = 0.01;

/// Roll, pitch, p and q of `run` at the times `t`, from the IMU where it has them, else from
/// the navigation log; what came from where, and what is missing, in `notes`.
pub fn fuse(run: &PoolRun, t: &[f64], notes: &mut Vec<String>) -> RollPitch {
    // IMU columns: roll 0, pitch 1, yaw 2, p 3, q 4; navigation log: roll 3, pitch 4, yaw 5,
    // p 6, q 7.
    let sources: [(&str, Option<&Log>, [usize; 5]); 2] = [
        ("IMU", run.imu.as_ref(), [0, 1, 3, 4, 2]),
        ("navigation log", run.nav.as_ref(), [3, 4, 6, 7, 5]),
    ];
    // The first source with column `slot`: its name, its log, the column and the log's roll,
    // pitch and yaw columns (for the rates' bound).
    let pick = |slot: usize| {
        sources.iter().find_map(|(name, log, cols)| {
            let log = (*log)?;
            let z = log.col(cols[slot])?;
            Some((*name, log, z, [cols[0], cols[1], cols[4]]))
        })
    };
    let mut out = RollPitch::default();
    for (j, name) in ["p", "q"].iter().enumerate() {
        let Some((src, log, z, angles)) = pick(2 + j) else {
            notes.push(format!(
                "no {name}: neither an IMU nor the navigation log gives it"
            ));
            continue;
        };
        notes.push(format!("{name} from the {src}"));
        let noise = rate_noise(name, &log.t, z, Some((log, angles, j)), notes);
        let s = motion::smooth_with(&log.t, z, t, noise);
        out.rate[j] = Some(s.v);
        out.rate_std[j] = Some(s.std);
    }
    for (j, name) in ["roll", "pitch"].iter().enumerate() {
        let Some((_, log, z, _)) = pick(j) else {
            notes.push(format!(
                "no {name} angle: the buoyancy moment is taken at level trim"
            ));
            continue;
        };
        let v = motion::smooth(&log.t, z, t, ANGLE_FLOOR_DEG.to_radians()).v;
        if j == 0 { out.roll = v } else { out.pitch = v }
    }
    out
}

/// The body rates (`roll` for p, `pitch` for q) an IMU or the navigation log of `run` gives:
/// what a model in those DOFs could be fitted to, whether or not this one is.
pub fn logged_rates(run: &PoolRun) -> Vec<crate::core::dof::Dof> {
    let has = |log: Option<&Log>, c: usize| log.is_some_and(|l| l.col(c).is_some());
    [
        (crate::core::dof::Dof::Roll, 3, 6),
        (crate::core::dof::Dof::Pitch, 4, 7),
    ]
    .into_iter()
    .filter(|(_, imu, nav)| has(run.imu.as_ref(), *imu) || has(run.nav.as_ref(), *nav))
    .map(|(d, ..)| d)
    .collect()
}

/// The noise of body rate `z` (named `name`, times `t`): told apart from its motion by its
/// own second differences ([`motion::noise_level`]), and at most its disagreement with the
/// rate its log's attitude gives (`attitude`: the log, its roll, pitch and yaw columns, and
/// 0 for p or 1 for q), said in `notes` when that bounds it. A rate that wanders with a
/// correlation time near the longest the noise fit allows (a vehicle's pitch as it surges,
/// at a 6-7 Hz log rate) reads to its second differences as correlated noise, and was
/// smoothed to a quarter of its logged amplitude on a real BlueROV2 Heavy's runs; the attitude
/// shows it is motion.
pub(crate) fn rate_noise(
    name: &str,
    t: &[f64],
    z: &[f64],
    attitude: Option<(&Log, [usize; 3], usize)>,
    notes: &mut Vec<String>,
) -> Noise {
    let floor = RATE_FLOOR_DPS.to_radians();
    let noise = motion::noise_level(t, z, floor);
    let bound = attitude.and_then(|(log, cols, j)| kinematic_spread(log, cols, j, z));
    let Some(b) = bound.filter(|b| *b < noise.sigma) else {
        return noise;
    };
    notes.push(format!(
        "{name}'s noise taken as its disagreement with the rate of the logged attitude, {:.2} deg/s, where its own spread read {:.2} deg/s ({:.1} samples correlated): a motion the spread took for correlated noise",
        b.to_degrees(),
        noise.sigma.to_degrees(),
        noise.correlated_samples
    ));
    Noise {
        sigma: b.max(floor),
        correlated_samples: 1.0,
        sigma_lag1: noise.sigma_lag1.min(b.max(floor)),
    }
}

/// The robust spread (1.4826 times the median absolute deviation) of a logged body rate
/// `z` (p for `j` 0, q for 1) about the rate its own log's attitude gives by the kinematics
/// of ZYX Euler angles (the inverse of Fossen 2011's T_Theta: p = phi' - psi' sin theta,
/// q = theta' cos phi + psi' sin phi cos theta), the angles differentiated centrally at each
/// sample. It holds the noise of
/// both and none of the motion, so it bounds the rate's noise where the motion is
/// slow against the samples; on a fast IMU it is the angles' noise over a short step, larger
/// than the gyro's, and bounds nothing. `None` without all three angles or with fewer than
/// 20 samples that have them.
fn kinematic_spread(log: &Log, cols: [usize; 3], j: usize, z: &[f64]) -> Option<f64> {
    let (roll, pitch, yaw) = (log.col(cols[0])?, log.col(cols[1])?, log.col(cols[2])?);
    let t = &log.t;
    let d: Vec<f64> = (1..t.len().saturating_sub(1))
        .filter_map(|k| {
            let h = t[k + 1] - t[k - 1];
            let rate = |a: &[f64]| wrap_pi(a[k + 1] - a[k - 1]) / h;
            let (phi, theta) = (roll[k], pitch[k]);
            let kin = match j {
                0 => rate(roll) - rate(yaw) * theta.sin(),
                _ => rate(pitch) * phi.cos() + rate(yaw) * phi.sin() * theta.cos(),
            };
            let e = z[k] - kin;
            (h > 0.0 && e.is_finite()).then_some(e)
        })
        .collect();
    (d.len() >= 20).then(|| robust_std(d))
}

/// Roll or pitch, RMS about its mean, beyond which a run's heading no longer turns at r: 5 deg
/// (a heading from an AHRS that does not integrate from its own rates then differs from r by
/// more than the geometry, as the ExjobbROV EKF's did by up to 45 deg/s on its attitude steps).
const TILTED_RMS_DEG: f64 = 5.0;

/// Whether `run` rolls or pitches (its IMU's or navigation log's attitude, RMS about its mean,
/// beyond [`TILTED_RMS_DEG`]): then its yaw rate is the gyro's body rate ([`yaw_rate`]),
/// whether or not the model has roll and pitch.
pub fn tilted(run: &PoolRun) -> bool {
    let sources = [(run.imu.as_ref(), [0, 1]), (run.nav.as_ref(), [3, 4])];
    let rms = |z: &[f64]| {
        let v: Vec<f64> = z.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len().max(1) as f64;
        let mean = v.iter().sum::<f64>() / n;
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt()
    };
    sources.iter().any(|(log, cols)| {
        log.is_some_and(|l| {
            cols.iter()
                .filter_map(|&c| l.col(c))
                .any(|z| rms(z) > TILTED_RMS_DEG.to_radians())
        })
    })
}

/// The body yaw rate r of `run` at the times `t`, with its standard deviation, from the IMU's
/// gyro or the navigation log's r column, smoothed as p and q are; `None` when neither logs
/// it. For a vehicle that rolls and pitches this, not the heading's rate, is r: the heading
/// turns at (q sin(phi) + r cos(phi)) / cos(theta), which a roll step makes differ from r by
/// more than r itself.
pub fn yaw_rate(run: &PoolRun, t: &[f64], notes: &mut Vec<String>) -> Option<(Vec<f64>, Vec<f64>)> {
    // IMU column 5, navigation log column 8: r.
    let (src, log, z) = [
        ("IMU", run.imu.as_ref(), 5),
        ("navigation log", run.nav.as_ref(), 8),
    ]
    .into_iter()
    .find_map(|(name, log, c)| {
        let log = log?;
        log.col(c).map(|z| (name, log, z))
    })?;
    let s = motion::smooth(&log.t, z, t, RATE_FLOOR_DPS.to_radians());
    notes.push(format!(
        "r from the {src}'s body rate (the heading's rate differs from it when the vehicle rolls or pitches)"
    ));
    Some((s.v, s.std))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pitch rate that wanders as a vehicle's pitch does while it surges (a first-order
    /// random process, 0.8 s correlation time, 0.2 rad/s RMS: the very shape of correlated
    /// noise) in a 6-7 Hz navigation log with its attitude: its own second differences take
    /// much of it for noise and the smoother keeps under 90 % of it; bounded by the attitude's
    /// rate, the fused rate keeps its amplitude within 10 % and states its error honestly
    /// (RMS of error/sigma 0.5-2).
    #[test]
    fn a_wandering_rate_is_kept_by_its_attitude() {
        let mut rng = crate::core::rng::Rng::new(7);
        // The truth on a 10 ms grid: q first-order random, theta its integral.
        let (h, tau, rms): (f64, f64, f64) = (0.01, 0.8, 0.2);
        let a = (-h / tau).exp();
        let (mut qs, mut thetas) = (vec![0.0], vec![0.0]);
        for _ in 0..12_500 {
            let q = a * qs.last().unwrap() + rms * (1.0 - a * a).sqrt() * rng.normal();
            thetas.push(thetas.last().unwrap() + h * 0.5 * (q + qs.last().unwrap()));
            qs.push(q);
        }
        let at = |v: &[f64], t: f64| {
            let k = ((t / h) as usize).min(v.len() - 2);
            let f = t / h - k as f64;
            v[k] * (1.0 - f) + v[k + 1] * f
        };
        let q = |t: f64| at(&qs, t);
        let theta = |t: f64| at(&thetas, t);
        let mut t = vec![0.0];
        while *t.last().unwrap() < 120.0 {
            let last = *t.last().unwrap();
            t.push(last + 1.0 / (6.0 + rng.uniform()));
        }
        let noisy = |v: f64, s: f64, rng: &mut crate::core::rng::Rng| v + s * rng.normal();
        let zero = vec![0.0; t.len()];
        let mut cols = vec![zero.clone(); 8];
        cols[4] = t
            .iter()
            .map(|&x| noisy(theta(x), 0.05f64.to_radians(), &mut rng))
            .collect();
        cols[7] = t
            .iter()
            .map(|&x| noisy(q(x), 0.3f64.to_radians(), &mut rng))
            .collect();
        let log = Log {
            t: t.clone(),
            cols,
            notes: Vec::new(),
            present: vec![true; 8],
        };
        let out: Vec<f64> = (100..5900).map(|k| k as f64 * 0.02).collect();
        let truth: Vec<f64> = out.iter().map(|&x| q(x)).collect();
        let mean_abs = |v: &[f64]| v.iter().map(|x| x.abs()).sum::<f64>() / v.len() as f64;
        let z = &log.cols[7];
        let alone = motion::smooth(&t, z, &out, RATE_FLOOR_DPS.to_radians());
        let flattened = mean_abs(&alone.v) / mean_abs(&truth);
        let mut notes = Vec::new();
        let noise = rate_noise("q", &t, z, Some((&log, [3, 4, 5], 1)), &mut notes);
        let s = motion::smooth_with(&t, z, &out, noise);
        let kept = mean_abs(&s.v) / mean_abs(&truth);
        let z_rms = (out.iter().enumerate())
            .map(|(k, _)| ((s.v[k] - truth[k]) / s.std[k]).powi(2))
            .sum::<f64>()
            / out.len() as f64;
        eprintln!(
            "alone {flattened:.3} ({:?}), bounded {kept:.3} ({noise:?}), error/sigma {:.2}; {notes:?}",
            alone.noise,
            z_rms.sqrt()
        );
        assert!(
            flattened < 0.9,
            "the spread alone kept {flattened}: not the case"
        );
        assert!((0.9..1.1).contains(&kept), "amplitude kept {kept}");
        assert!(
            (0.5..2.0).contains(&z_rms.sqrt()),
            "error/sigma {}",
            z_rms.sqrt()
        );
        assert!(
            notes.iter().any(|n| n.contains("disagreement")),
            "{notes:?}"
        );
    }
}
