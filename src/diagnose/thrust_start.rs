//! Where a simulation of a run starts its thrusters' lag: settled at the first command, or
//! at rest, chosen with the model when the vehicle is at rest (docs/diagnosis.md, "Where a
//! simulation starts").

use super::record::Shifted;
use super::{Augmentation, Run, SLOTS, simulate_from, world_for};
use crate::core::model::{Plant, Vec6};

/// A DOF is at rest at a run's start when its first fused velocity is within this many times
/// its noise ([`Run::still_at_start`]).
const AT_REST_SIGMAS: f64 = 3.0;
/// Or within this share of its root mean square over the run.
const AT_REST_SHARE: f64 = 0.1;
/// The two thruster start states of a run that starts at rest are compared over this many of
/// the lag's time constants ([`thrust_at_start`]), ...
const START_WINDOW_LAGS: f64 = 5.0;
/// ... and at least and at most these times, s.
const START_WINDOW_S: [f64; 2] = [1.0, 5.0];

impl Run {
    /// Whether the vehicle is at rest at the run's start: every DOF's first fused velocity
    /// within three times its noise, or within a tenth of its root mean square over the run.
    pub fn still_at_start(&self) -> bool {
        !self.t.is_empty()
            && (0..SLOTS).all(|j| {
                let v = self.vel[j][0];
                let sigma = self.std[j].first().copied().unwrap_or(0.0);
                // The run's RMS (a pass over it) only where the noise alone does not decide.
                let rms = || {
                    let finite = self.vel[j].iter().filter(|x| x.is_finite());
                    let (sum, n) = finite.fold((0.0, 0.0), |(s, c), x| (s + x * x, c + 1.0));
                    (sum / f64::max(n, 1.0)).sqrt()
                };
                !v.is_finite()
                    || v.abs() <= AT_REST_SIGMAS * sigma
                    || v.abs() <= AT_REST_SHARE * rms()
            })
    }
}

/// The thrusters' state a simulation of `run` with `aug` starts from ([`thrust_at_start`]).
pub(crate) fn start_of(plant: &Plant, aug: &Augmentation, run: &Run) -> Vec6 {
    thrust_at_start(plant, aug, run, &Shifted::new(&run.t, aug.delay_s))
}

/// The thrusters' state a simulation of `run` starts from. Settled at the first command, as
/// for a vehicle already under way or holding station (against its buoyancy, a tether) where
/// a log was cut from a longer one; or at rest, as for a pool run that starts with the vehicle
/// still and the thrusters spun up only then. Under a lag, with the vehicle at rest
/// ([`Run::still_at_start`]) and a first command that is not nothing, whichever of the two
/// the model follows better over the run's first five time constants (1-5 s): the run's
/// initial state estimated with the model, as a nuisance parameter. Started settled from a
/// standing start, a thruster lag of 0.2 s left the twin's true model a yaw residual 20 times
/// its noise, nine tenths of it in the runs' first 3 s (a first command of 1.7-1.8 N m
/// delivered at once), and a right lag was reported with an unexplained yaw.
pub(super) fn thrust_at_start(plant: &Plant, aug: &Augmentation, run: &Run, rec: &Shifted) -> Vec6 {
    let w = world_for(plant, aug, run);
    let settled = w.settled_thrust(&run.cmd6(0));
    let rest = w.settled_thrust(&[0.0; 6]);
    let Some(lag) = w.lag() else {
        return settled;
    };
    if rest == settled || run.t.len() < 2 || !run.still_at_start() {
        return settled;
    }
    let [shortest, longest] = START_WINDOW_S;
    let window = (START_WINDOW_LAGS * lag.time_constant_s).clamp(shortest, longest);
    let until = (run.t.partition_point(|&t| t <= run.t[0] + window)).max(2);
    // The squared misfit in units of the fused noise (floored at 1 mm/s), over the window.
    let misfit = |start: Vec6| -> f64 {
        let (sim, _) = simulate_from(plant, aug, run, rec, (start, until));
        let each = (0..SLOTS).filter(|&j| run.slots.active[j]);
        each.flat_map(|j| (0..sim.len()).map(move |k| (j, k)))
            .map(|(j, k)| {
                let e = (sim[k][j] - rec.at(&run.vel[j], k)) / run.std[j][k].max(1e-3);
                if e.is_finite() { e * e } else { 0.0 }
            })
            .sum()
    };
    if misfit(rest) < misfit(settled) {
        rest
    } else {
        settled
    }
}
