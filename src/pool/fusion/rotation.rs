//! Roll and pitch of a run, and their rates p and q, for a vehicle that moves in them: from
//! the IMU (attitude and gyro) or, without one, from the navigation log's AHRS columns, each
//! smoothed onto the output times with its noise told apart from its motion
//! ([`super::motion`]).

use super::motion;
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
    // IMU columns: roll 0, pitch 1, p 3, q 4; navigation log: roll 3, pitch 4, p 6, q 7.
    let sources: [(&str, Option<&Log>, [usize; 4]); 2] = [
        ("IMU", run.imu.as_ref(), [0, 1, 3, 4]),
        ("navigation log", run.nav.as_ref(), [3, 4, 6, 7]),
    ];
    let pick = |slot: usize| {
        sources.iter().find_map(|(name, log, cols)| {
            let log = (*log)?;
            log.col(cols[slot]).map(|z| (*name, &log.t, z))
        })
    };
    let mut out = RollPitch::default();
    for (j, name) in ["p", "q"].iter().enumerate() {
        let Some((src, ts, z)) = pick(2 + j) else {
            notes.push(format!(
                "no {name}: neither an IMU nor the navigation log gives it"
            ));
            continue;
        };
        let s = motion::smooth(ts, z, t, RATE_FLOOR_DPS.to_radians());
        notes.push(format!("{name} from the {src}"));
        out.rate[j] = Some(s.v);
        out.rate_std[j] = Some(s.std);
    }
    for (j, name) in ["roll", "pitch"].iter().enumerate() {
        let Some((_, ts, z)) = pick(j) else {
            notes.push(format!(
                "no {name} angle: the buoyancy moment is taken at level trim"
            ));
            continue;
        };
        let v = motion::smooth(ts, z, t, ANGLE_FLOOR_DEG.to_radians()).v;
        if j == 0 { out.roll = v } else { out.pitch = v }
    }
    out
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
