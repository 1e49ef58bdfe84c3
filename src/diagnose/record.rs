//! How a simulation meets the recording: the record read late by a sensor delay, the state a
//! window starts from, and the recording's own low-pass applied to the simulated velocities.

use super::effects::State;
use super::{Run, SLOTS};

/// A run's recording read `delay` seconds late (a sensor delay), each sample's shifted time
/// located once for every series; without a delay, the samples themselves.
pub(super) struct Shifted {
    delay: f64,
    loc: Vec<(usize, Option<f64>)>,
}

impl Shifted {
    pub(super) fn new(t: &[f64], delay: f64) -> Shifted {
        let loc = if delay == 0.0 {
            Vec::new()
        } else {
            t.iter()
                .map(|&tk| crate::pool::fusion::locate(t, tk + delay))
                .collect()
        };
        Shifted { delay, loc }
    }

    pub(super) fn at(&self, series: &[f64], k: usize) -> f64 {
        if self.delay == 0.0 {
            series[k]
        } else {
            crate::pool::fusion::interp_at(series, self.loc[k])
        }
    }
}

/// The fused velocities at sample `k` as the centred mean over five samples: a window started
/// from one noisy sample would carry that sample's noise through it (and a time shift that
/// interpolates between samples would look like an improvement). Behind a sensor's low-pass
/// of time constant `lead` the vehicle is ahead of its record by `lead` times the record's
/// rate of change, taken as the window's least-squares slope.
pub(super) fn anchor_velocity(run: &Run, rec: &Shifted, k: usize, lead: f64, s: &mut State) {
    let n = run.t.len();
    let (a, b) = (k.saturating_sub(2), (k + 2).min(n - 1));
    let m = (b - a + 1) as f64;
    let t_mean = (a..=b).map(|q| run.t[q]).sum::<f64>() / m;
    let spread: f64 = (a..=b).map(|q| (run.t[q] - t_mean).powi(2)).sum();
    for j in 0..SLOTS {
        let v: Vec<f64> = (a..=b).map(|q| rec.at(&run.vel[j], q)).collect();
        let mean = v.iter().sum::<f64>() / m;
        let slope = match lead > 0.0 && spread > 0.0 {
            true => {
                (a..=b)
                    .zip(&v)
                    .map(|(q, x)| (run.t[q] - t_mean) * (x - mean))
                    .sum::<f64>()
                    / spread
            }
            false => 0.0,
        };
        s.nu[j] = mean + lead * slope;
    }
}

/// The recorded roll and pitch at sample k (read as the sensor delay says), where the run has
/// them: a simulation starts from them and carries them with its own body rates (Fossen 2011
/// eq. 2.29), as the validation does, so the restoring moments turn with the motion the model
/// makes. `None`: level throughout.
pub(super) fn recorded_attitude(run: &Run, rec: &Shifted, k: usize) -> Option<[f64; 2]> {
    if run.att[0].is_empty() {
        return None;
    }
    let a = [rec.at(&run.att[0], k), rec.at(&run.att[1], k)];
    Some(a.map(|x| if x.is_finite() { x } else { 0.0 }))
}

/// The simulated velocities as a sensor with a first-order low-pass of time constant `tau`
/// records them, in place. The filter starts again where the simulation does (the run's
/// anchors), from the record there (the simulation itself starts ahead of it, see
/// [`anchor_velocity`]).
pub(super) fn record_filter(out: &mut [[f64; SLOTS]], run: &Run, rec: &Shifted, tau: f64) {
    let anchors = crate::core::model::stability::anchors(&run.t, &run.anchors_s);
    let mut y = State::default();
    for (k, x) in out.iter_mut().enumerate() {
        if anchors.contains(&k) {
            anchor_velocity(run, rec, k, 0.0, &mut y);
        } else {
            let a = 1.0 - (-(run.t[k] - run.t[k - 1]) / tau).exp();
            for (yj, xj) in y.nu.iter_mut().zip(x.iter()) {
                *yj += a * (xj - *yj);
            }
        }
        *x = y.nu;
    }
}
