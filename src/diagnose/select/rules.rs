//! The decision thresholds of the selection and the rules made of them: whether a gain is
//! corroborated on the training runs, significant beside the noise, and how a candidate
//! scores; the rows the report shows.

use crate::diagnose::effects::Limits;
use crate::diagnose::{Data, Hypothesis};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Decision thresholds, stated in the report.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Criteria {
    /// An effect is kept when it lowers the held-out cost by at least this fraction...
    pub min_gain: f64,
    /// ... plus this much per parameter it adds (the penalty for extra parameters) ...
    pub gain_per_parameter: f64,
    /// ... and by at least this multiple of the noise floor (it explains more than noise).
    pub min_noise_multiple: f64,
    /// The held-out cost counts as "within noise" below this multiple of the noise floor.
    pub within_noise: f64,
    /// Greedy rounds at most.
    pub max_effects: usize,
    /// A DOF whose held-out residual after the named effects exceeds this multiple of its
    /// noise and is structured (autocorrelated) is reported `unexplained`.
    pub unexplained_noise_multiple: f64,
    /// Simulation window (multiple shooting): `auto` (the default: re-anchored each time the
    /// model's local instability along the run would have doubled an error, so a whole-run
    /// simulation of an unstable model does not drift whatever the physics; stable stretches
    /// and stable runs are simulated whole, where slow effects stay visible), `whole_run`, or
    /// seconds.
    pub horizon_s: crate::core::model::stability::Horizon,
    /// Propose a closed form for a structured residual no named effect explains
    /// ([`super::discover`]); `false` leaves it `unexplained` without one.
    pub discover: bool,
}

impl Default for Criteria {
    fn default() -> Criteria {
        Criteria {
            min_gain: 0.08,
            gain_per_parameter: 0.02,
            min_noise_multiple: 0.5,
            within_noise: 2.5,
            max_effects: 3,
            unexplained_noise_multiple: 5.0,
            horizon_s: crate::core::model::stability::Horizon::Auto,
            discover: true,
        }
    }
}

/// One hypothesis tested in one greedy round.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Tested {
    pub round: usize,
    pub name: String,
    pub parameters: BTreeMap<String, f64>,
    pub train_cost: f64,
    pub validation_cost: f64,
    /// Fractional drop of the held-out cost from the round's starting model.
    pub gain: f64,
    /// ln(cost before / cost after) less the per-parameter penalty: what the winner is chosen
    /// by. For small gains it equals the gain less the penalty; when several effects explain
    /// nearly everything it still tells them apart by what they leave (0.006 vs 0.002 is a
    /// threefold difference, though both are "a 98 % gain").
    pub score: f64,
    pub accepted: bool,
    /// Parameters that ended on their search bound: the data want more than the effect can
    /// give, so it is not a finding whatever it gains.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_bound: Vec<String>,
}

/// The parameters of `h` at `p` that sit on a search bound (within 1 % of the range). A
/// physical bound (a tether's zero slack, a fraction's 0 or 1) is a value physics allows, not
/// a limit of the search ([`Limits`]). The range of a force-like parameter starting at 0 is
/// read at the vehicle's `size` ([`super::Data::size`]), as the search's grid is: on a vehicle
/// a third the reference's, within 1 % of a third of it from 0.
pub fn at_bound(h: &Hypothesis, p: &[f64], size: f64) -> Vec<String> {
    h.params
        .iter()
        .zip(p)
        .filter(|(q, v)| {
            let (lo, hi) = q.bounds(size);
            let tol = 0.01 * (hi - lo);
            let tol_lo = tol * q.share(size);
            let (lo_searched, hi_searched) = match q.limits {
                Limits::Search => (true, true),
                Limits::PhysicalFloor => (false, true),
                Limits::Physical => (false, false),
            };
            (hi_searched && (hi - **v).abs() <= tol) || (lo_searched && (**v - lo).abs() <= tol_lo)
        })
        .map(|(q, _)| q.name.to_string())
        .collect()
}

pub fn params_map(h: &Hypothesis, p: &[f64]) -> BTreeMap<String, f64> {
    h.params
        .iter()
        .zip(p)
        .map(|(q, v)| (q.name.to_string(), *v))
        .collect()
}

/// The winner's score: ln(before / after) less `gain_per_parameter` per parameter.
pub(super) fn score(criteria: &Criteria, before: f64, after: f64, params: f64) -> f64 {
    (before.max(1e-300) / after.max(1e-300)).ln() - criteria.gain_per_parameter * params
}

/// An effect is fitted on the training runs: when it is real it explains them too. A held-out
/// gain the training runs do not share is the held-out runs' sensitivity to any small change
/// (an open-loop simulation far from the data), not physics.
pub(super) fn corroborated(criteria: &Criteria, train_before: f64, train_after: f64) -> bool {
    (train_before - train_after) / train_before >= 0.5 * criteria.min_gain
}

/// Whether lowering the held-out cost from `before` to `after` with `params` more parameters
/// is worth naming: by `min_gain` plus the per-parameter penalty, and by more than noise.
pub fn significant(criteria: &Criteria, data: &Data, before: f64, after: f64, params: f64) -> bool {
    (before - after) / before - criteria.gain_per_parameter * params >= criteria.min_gain
        && before - after >= criteria.min_noise_multiple * data.noise_cost
}
