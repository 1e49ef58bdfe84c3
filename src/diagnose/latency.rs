//! A navigation log's own latency, taken out before the diagnosis. The pool runs measure how
//! late the log's velocity is against the depth gauge ([`crate::pool::fusion::latency`]);
//! that lateness is the log's, not physics the model leaves out, yet the diagnosis would name
//! it a thruster lag or a sensor delay, or add it to a real thruster lag (on the twin's
//! navigation logs a hidden 0.2 s lag came out 0.29 s). Where the model has no command lag of
//! its own, the runs are read with their command passed through a first-order lag of the
//! measured latency: as the late, low-passed recording shows it (for a linear vehicle a lag
//! on the command and one on the recording are the same). A pure delay of the same length
//! left structure the diagnosis called unexplained on the twin's effect-free navigation logs,
//! whose rows carry DVL pings of every age from 0 to 125 ms, a spread more than a delay. A
//! model with a command lag has already taken the log's latency into it, and is diagnosed as
//! it is (the stage says so beside any lag it names).

use crate::core::model::Plant;
use crate::pool::fusion::latency::Summary;
use crate::pool::fusion::run::FusedRun;

/// The smallest measured latency taken out, s: below it the log's timing is within a sample of
/// the command log's.
const LEAST_S: f64 = 0.02;

/// The latency to take out of `fused` before diagnosing `plant`: the runs' median, where they
/// measured one and the model has no command lag.
fn known(plant: &Plant, fused: &[FusedRun]) -> Option<f64> {
    let lagged = plant.command_lag_s.is_finite() && plant.command_lag_s > 0.0;
    if lagged {
        return None;
    }
    let s = Summary::of_runs(fused)?;
    (s.median_s >= LEAST_S).then_some(s.median_s)
}

/// `fused` as the diagnosis of `plant` reads it: with the latency [`known`] taken out (each
/// run's command through a first-order lag of it), and that latency; as it is without one.
pub fn taken_out<'a>(
    plant: &Plant,
    fused: &'a [FusedRun],
) -> (std::borrow::Cow<'a, [FusedRun]>, Option<f64>) {
    match known(plant, fused) {
        Some(l) => {
            let lagged = fused.iter().map(|r| r.clone().with_command_lagged(l));
            (std::borrow::Cow::Owned(lagged.collect()), Some(l))
        }
        None => (std::borrow::Cow::Borrowed(fused), None),
    }
}
