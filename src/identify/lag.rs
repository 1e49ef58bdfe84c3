//! The lag between a logged command and the force the water sees: an ESC and a propeller
//! spinning up, a command logged before it is sent. On closed-loop runs of half-hertz
//! manoeuvres a tenth of a second of it is 20 degrees of phase, which a model without it makes
//! up with a wrong inertia and damping. The prediction-error method estimates one first-order
//! time constant for every DOF with the model (a line search on the output error, each point
//! a short Levenberg-Marquardt refit), and keeps it only when the runs demand it; the method
//! then steps the lag and the coefficients together (`pem::polish_lag`).

use super::output_error::OutputError;
use super::refine::{Bounds, output_error_lm_within};
use crate::core::model::ParamLayout;
use serde::{Deserialize, Serialize};

/// `command_lag` of a `pem` fit: `auto` (estimated; the default), `none`, or seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum CommandLag {
    #[default]
    Auto,
    None,
    Seconds(f64),
    /// `auto` whose search is done: the lag it found, and the output error of the model it
    /// was searched on without a lag ([`search`]'s `c0`) and with it. Not a setting: the
    /// constants' choice searches once, on the model with every candidate, for both of its
    /// fits ([`super::constants`]).
    Found {
        value_s: f64,
        cost_without: f64,
        cost_with: f64,
    },
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Repr {
    Word(String),
    Seconds(f64),
}

impl Serialize for CommandLag {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            CommandLag::Auto => Repr::Word("auto".into()),
            CommandLag::None => Repr::Word("none".into()),
            CommandLag::Seconds(x) => Repr::Seconds(*x),
            CommandLag::Found { value_s, .. } => Repr::Seconds(*value_s),
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for CommandLag {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<CommandLag, D::Error> {
        use serde::de::Error;
        match Repr::deserialize(d)? {
            Repr::Word(w) if w == "auto" => Ok(CommandLag::Auto),
            Repr::Word(w) if w == "none" => Ok(CommandLag::None),
            Repr::Seconds(x) if x.is_finite() && (0.0..=MAX_LAG_S).contains(&x) => {
                Ok(CommandLag::Seconds(x))
            }
            Repr::Seconds(x) => Err(D::Error::custom(format!(
                "command_lag: {x} s is not a lag hydrofit fits; give seconds from 0 to {MAX_LAG_S}, `auto` or `none`"
            ))),
            Repr::Word(w) => Err(D::Error::custom(format!(
                "command_lag: `{w}`; give `auto`, `none` or a number of seconds"
            ))),
        }
    }
}

/// The longest lag searched, s: beyond it a lag is not a thruster's but a missing dynamic.
pub const MAX_LAG_S: f64 = 0.5;

/// The relative drop of the output error a lag must bring to be kept: well above what
/// refitting one more parameter to noise gains.
pub const DEMAND: f64 = 0.01;

/// The width of the bracket at which the line search stops, s: a sample at 50 Hz. The
/// prediction-error method's Gauss-Newton steps of the lag take it from there.
pub const RESOLUTION_S: f64 = 0.02;

/// Levenberg-Marquardt steps of each point of the line search (warm-started).
const PROBE_STEPS: usize = 8;

/// The estimated lag of a fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LagEstimate {
    pub value_s: f64,
    /// With the lag counted as a parameter beside the coefficients, from the output error's
    /// Jacobian (residuals correlated from sample to sample as [`super::refine`] allows for).
    pub stderr_s: f64,
    /// The output error without the lag and with it (weighted mean square).
    pub cost_without: f64,
    pub cost_with: f64,
    /// Whether it was estimated (`auto`) or set.
    pub estimated: bool,
    /// Where the lag was searched on another model than this one (the model with every
    /// candidate constant and coupling, before the choice): its output error there without
    /// the lag and with it. `cost_without` is then not known for this model (NaN).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub searched_on_candidates: Option<[f64; 2]>,
    /// The coefficients refitted with the lag held at the lags either side of it that the
    /// training runs cannot tell from it ([`profile`]); empty where none is.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub profile: Vec<LagPoint>,
}

/// The fit with the command lag held at one value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LagPoint {
    pub lag_s: f64,
    /// The output error of the training runs (weighted mean square).
    pub cost: f64,
    /// The coefficients, in the layout's order (the per-run nuisance values left out).
    pub theta: Vec<f64>,
}

impl LagEstimate {
    /// Whether an estimated lag sits at the top of the searched range (within the line
    /// search's resolution of [`MAX_LAG_S`]): the runs ask for more lag than a thruster's
    /// command path has, so it stands in for something else (a delay in the log, a slower
    /// dynamic the model lacks) and is not a finding.
    pub fn at_search_end(&self) -> bool {
        self.estimated && self.value_s >= MAX_LAG_S - RESOLUTION_S
    }

    /// The range of coefficient `j` over the fit (`value`) and its profile: `None` without a
    /// profile.
    pub fn range_of(&self, j: usize, value: f64) -> Option<[f64; 2]> {
        self.spanned(value, |p| p.theta.get(j).copied())
    }

    /// The lags of the profile, with the fit's: `None` without a profile.
    pub fn lag_range(&self) -> Option<[f64; 2]> {
        self.spanned(self.value_s, |p| Some(p.lag_s))
    }

    /// The least and greatest of `at` the fit and of `of` over the profile's points.
    fn spanned(&self, at: f64, of: impl Fn(&LagPoint) -> Option<f64>) -> Option<[f64; 2]> {
        if self.profile.is_empty() {
            return None;
        }
        let xs = self.profile.iter().filter_map(of);
        Some(xs.fold([at, at], |[lo, hi], x| [lo.min(x), hi.max(x)]))
    }
}

/// The lag the runs demand: a golden-section search over [0, MAX_LAG_S] of the output error,
/// each point refitted from `theta0` (the model fitted without a lag, whose output error is
/// `c0`) by the same few steps, so the points compare. `None` when no lag lowers the output
/// error by [`DEMAND`]; otherwise the estimate and the coefficients refitted at it (followed by
/// the per-run nuisance values of `per_run`, which `theta0` may carry too).
pub fn search(
    vehicle: &crate::core::model::Vehicle,
    responses: &[&crate::core::response::Response],
    (layout, per_run): (&ParamLayout, super::per_run::Kinds),
    theta0: &[f64],
    c0: f64,
    bounds: &Bounds,
) -> Option<(LagEstimate, Vec<f64>)> {
    let mut best_theta = theta0.to_vec();
    let mut best_cost = f64::INFINITY;
    let mut cost = |lag: f64| {
        let oe = OutputError::with_lag(vehicle, responses, lag).with_per_run(per_run);
        let r = output_error_lm_within(&oe, layout, theta0, PROBE_STEPS, bounds);
        if r.cost_after < best_cost {
            best_cost = r.cost_after;
            best_theta = [r.theta.as_slice(), &r.nuisance].concat();
        }
        r.cost_after
    };
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (0.0, MAX_LAG_S);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    while b - a > RESOLUTION_S {
        if crate::core::interrupt::requested() {
            return None;
        }
        if f1 < f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - g * (b - a);
            f1 = cost(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + g * (b - a);
            f2 = cost(x2);
        }
    }
    let (best, c) = if f1 < f2 { (x1, f1) } else { (x2, f2) };
    if c.is_nan() || c >= (1.0 - DEMAND) * c0 {
        return None;
    }
    let estimate = LagEstimate {
        cost_with: c,
        ..LagEstimate::found(best, c0)
    };
    Some((estimate, best_theta))
}

impl LagEstimate {
    /// The lag `value_s` a search found, where the output error without a lag was
    /// `cost_without`; its standard error is counted with the coefficients once they are
    /// refitted at it (see `pem::with_joint_errors`).
    pub fn found(value_s: f64, cost_without: f64) -> LagEstimate {
        LagEstimate {
            value_s,
            stderr_s: f64::NAN,
            cost_without,
            cost_with: f64::NAN,
            estimated: true,
            searched_on_candidates: None,
            profile: Vec::new(),
        }
    }
}

/// The spacing of the lags of [`profile`], s.
const PROFILE_STEP_S: f64 = 0.05;

/// Levenberg-Marquardt steps of each point of [`profile`] (warm-started from its neighbour).
const PROFILE_STEPS: usize = 16;

/// The coefficients over the lags the training runs cannot tell from `lag`: refitted with the
/// lag held at steps of [`PROFILE_STEP_S`] either side of it (each from its neighbour's fit,
/// `from` at `lag`: coefficients then nuisance values), outward while the output error stays
/// within [`DEMAND`] of `cost` (the margin at which a lag is kept at all) and inside
/// 0-[`MAX_LAG_S`].
///
/// The Jacobian's standard errors see only the curvature at the fit. On a real vehicle's
/// closed-loop attitude runs the output error was within 1 % from 0.05 to 0.3 s of lag while
/// the yaw damping went from -1.2 to -2.6: several shallow minima along the lag, each with a
/// small standard error. The profile shows that spread.
pub fn profile(
    vehicle: &crate::core::model::Vehicle,
    responses: &[&crate::core::response::Response],
    (layout, per_run): (&ParamLayout, super::per_run::Kinds),
    (lag, cost): (f64, f64),
    from: &[f64],
    bounds: &Bounds,
) -> Vec<LagPoint> {
    let mut points = Vec::new();
    for dir in [-1.0, 1.0] {
        let mut x = from.to_vec();
        let mut last = lag;
        for k in 1.. {
            let l = (lag + dir * k as f64 * PROFILE_STEP_S).clamp(0.0, MAX_LAG_S);
            if (l - last).abs() < 1e-9 || crate::core::interrupt::requested() {
                break;
            }
            let oe = OutputError::with_lag(vehicle, responses, l).with_per_run(per_run);
            let r = output_error_lm_within(&oe, layout, &x, PROFILE_STEPS, bounds);
            if r.cost_after.is_nan() || r.cost_after > (1.0 + DEMAND) * cost {
                break;
            }
            x = [r.theta.as_slice(), &r.nuisance].concat();
            points.push(LagPoint {
                lag_s: l,
                cost: r.cost_after,
                theta: r.theta,
            });
            last = l;
        }
    }
    points.sort_by(|a, b| a.lag_s.total_cmp(&b.lag_s));
    points
}
