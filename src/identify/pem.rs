//! The prediction-error method (Ljung; what MATLAB's `pem` and `nlgreyest` do for a grey-box
//! model): a least-squares start on the equation error, then Levenberg-Marquardt on the output
//! error of the pool runs, each simulated under its logged command from its first fused state.
//!
//! The equation error regresses a differentiated, smoothed velocity on the command; on real
//! logs (a navigation filter's late, low-passed velocities, a command logged at receive times)
//! its answer predicts held-out runs poorly, sometimes worse than predicting rest. What a user
//! judges the model by is its simulation, so that is what this method minimises. The added
//! mass is kept inside a stated prior (0 to `added_mass_prior` times the rigid-body term of its
//! DOF, 2 by default, as for an open-frame vehicle): a value on that bound is reported as not
//! identifiable, with the reason, instead of a 15-fold added mass with a 3 % standard error.
//!
//! Without pool runs (CFD cases only) the least-squares answer is the answer: a CFD case is a
//! clean force-in, velocity-out record, where the equation error is what seed 001 minimises.

use super::lag::{CommandLag, LagEstimate};
use super::ols::{self, Ols};
use super::output_error::OutputError;
use super::per_run::{Kind, Kinds};
use super::refine::{Bounds, output_error_lm_within};
use super::{Estimate, EstimateError, Estimator, Fit, Options, Regression};
use crate::core::dof::Dof;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub struct Pem;

/// The method's own settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PemSettings {
    /// Accepted Levenberg-Marquardt steps at most.
    pub iterations: usize,
    /// Per DOF, the largest added mass (inertia) as a multiple of the rigid-body term; DOFs not
    /// listed take [`DEFAULT_PRIOR`].
    pub added_mass_prior: BTreeMap<Dof, f64>,
    /// The lag between a logged command and the force (see [`super::lag`]): `auto`
    /// (estimated, kept when the runs demand it), `none`, or seconds.
    pub command_lag: CommandLag,
    /// The per-run nuisance parameters estimated with the model (see [`super::per_run`]):
    /// any of `initial_state`, `force`, `sensor_bias`; none by default.
    pub per_run: Vec<Kind>,
}

/// An open-frame vehicle's added mass is of the order of its mass; twice it bounds the
/// plausible (the reference ROV's heave added mass is 2.4 times its mass, a streamlined hull's
/// surge added mass a tenth).
pub const DEFAULT_PRIOR: f64 = 2.0;

impl Default for PemSettings {
    fn default() -> Self {
        PemSettings {
            iterations: 50,
            added_mass_prior: BTreeMap::new(),
            command_lag: CommandLag::Auto,
            per_run: Vec::new(),
        }
    }
}

impl PemSettings {
    /// Puts the settings into `opts`.
    pub fn apply(&self, opts: &mut Options) {
        opts.iterations = self.iterations;
        opts.command_lag = self.command_lag;
        opts.per_run = Kinds::of(&self.per_run);
        opts.added_mass_prior = std::array::from_fn(|i| {
            self.added_mass_prior
                .get(&Dof::ALL[i])
                .copied()
                .unwrap_or(DEFAULT_PRIOR)
        });
    }
}

impl Estimator for Pem {
    fn name(&self) -> &'static str {
        "pem"
    }

    fn minimises_output_error(&self) -> bool {
        true
    }

    fn settings(
        &self,
        own: serde_json::Map<String, serde_json::Value>,
    ) -> Result<super::OwnSettings, String> {
        let s = super::own_settings::<PemSettings>(own)?;
        if let Some((d, x)) = s
            .added_mass_prior
            .iter()
            .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
        {
            return Err(format!(
                "added_mass_prior.{d} = {x}: the prior is a multiple of the rigid-body term, a finite number >= 0"
            ));
        }
        Ok(super::OwnSettings::Pem(s))
    }

    fn fit(&self, problem: &Regression, opts: &Options) -> Result<Fit, EstimateError> {
        let start = Ols.fit(
            problem,
            &Options {
                output_error: None,
                ..opts.clone_opts()
            },
        )?;
        let Some((vehicle, responses)) = opts.output_error else {
            return Ok(start);
        };
        let layout = &problem.layout;
        let bounds = plausible(layout, &opts.rigid_mass, &opts.added_mass_prior);
        // Each run and DOF counts by its relative error (1 / its mean square velocity), as the
        // held-out NMAE scores it; weighting a DOF over all runs together let the runs that move
        // most in it decide, and the real vehicle's held-out roll NMAE doubled.
        let ls: Vec<f64> = start.parameters.iter().map(|p| p.value).collect();
        let warm = opts.start.filter(|t| t.len() == layout.len());
        let theta0 = warm.map_or_else(|| ls.clone(), <[f64]>::to_vec);
        let (mut lag, mut r, polished) =
            with_lag(vehicle, responses, layout, &theta0, &bounds, opts);
        let oe = OutputError::with_lag(vehicle, responses, lag.as_ref().map_or(0.0, |l| l.value_s))
            .with_per_run(opts.per_run);
        if warm.is_some() {
            r.cost_before = oe.cost(layout, &ls); // the report compares the least-squares start
        }
        let (demanded, wide) = free_prior(problem, &oe, &bounds, opts, &mut r);
        let freed = wide.is_some();
        // The lag was found by a line search, the coefficients at it: counted as a parameter,
        // its trade with the inertia and damping widens their errors. The polish's last joint
        // view is of this very fit unless the prior was freed since.
        if let Some(l) = lag.as_mut().filter(|l| l.estimated) {
            let j = match polished {
                Some(j) if !freed => j,
                _ => joint(vehicle, responses, layout, opts.per_run, l.value_s, &r),
            };
            l.stderr_s = with_joint_errors(j, &mut r);
            // A freed prior's fit is not the one the profile's bounds would hold.
            if !freed {
                let from = [r.theta.as_slice(), &r.nuisance].concat();
                let on = (layout, opts.per_run);
                let at = (l.value_s, r.cost_after);
                l.profile = super::lag::profile(vehicle, responses, on, at, &from, &bounds);
            }
        }
        // A freed fit's coefficients are judged against the bounds it was fitted in.
        let judged = (wide.as_ref().unwrap_or(&bounds), demanded.as_slice());
        let parameters = estimates(problem, judged, &r, opts, lag.as_ref());
        let residual = ols::residual_sigma(problem, &r.theta);
        Ok(Fit {
            parameters,
            residual_sigma: residual
                .iter()
                .map(|(d, s)| (d.name().to_string(), *s))
                .collect(),
            samples: problem.rows(),
            condition_number: start.condition_number,
            evaluations: None,
            objective_value: Some(r.cost_after),
            stopped_early: None,
            trace: None,
            refinement: Some(super::Refinement {
                start_cost: r.cost_before,
                steps: r.steps,
                names: layout
                    .names()
                    .into_iter()
                    .chain(
                        lag.iter()
                            .filter(|l| l.estimated)
                            .map(|_| "T_cmd".to_string()),
                    )
                    .collect(),
                correlation: r.correlation,
                per_run: super::per_run::summarise(&oe.nuisance, &r.nuisance, responses.len()),
            }),
            command_lag: lag,
            thrust_gain: None,
        })
    }
}

/// Every coefficient of the refined answer `r` judged against `bounds`, with the values the
/// runs `demanded` beyond their prior and the range each takes over the command lags.
fn estimates(
    problem: &Regression,
    (bounds, demanded): (&Bounds, &[(usize, f64, f64)]),
    r: &super::refine::Refined,
    opts: &Options,
    lag: Option<&LagEstimate>,
) -> Vec<Estimate> {
    (0..r.theta.len())
        .map(|j| {
            let beyond = demanded.iter().find(|d| d.0 == j).map(|d| (d.1, d.2));
            let e = estimate(problem, bounds, r, j, opts, beyond);
            over_the_lag(e, lag, j, problem)
        })
        .collect()
}

/// The prior is soft: an added mass on it is freed (up to the population methods' search
/// bound) and kept beyond it only when the runs demand it; then `r` is the freed fit. Returns
/// the parameters the runs took beyond their prior, with the output error held on it and
/// freed, and the bounds of the freed fit when `r` was replaced by it.
fn free_prior(
    problem: &Regression,
    oe: &OutputError,
    bounds: &Bounds,
    opts: &Options,
    r: &mut super::refine::Refined,
) -> (Vec<(usize, f64, f64)>, Option<Bounds>) {
    let on_prior: Vec<usize> = (0..r.theta.len())
        .filter(|&j| is_added_mass(problem, j) && bounds.at_prior(j, r.theta[j]))
        .collect();
    if on_prior.is_empty() {
        return (Vec::new(), None);
    }
    // The freed DOFs' drag may be as stiff as their heavier mass allows: a mass beyond its
    // prior with its drag held to the lighter mass's bound would be a slower vehicle at the
    // same gain only if the gain were wrong.
    let mut prior = opts.added_mass_prior;
    for &j in &on_prior {
        let i = dof_of(problem, j);
        prior[i] = prior[i].max(BEYOND_PRIOR);
    }
    let wide = plausible(&problem.layout, &opts.rigid_mass, &prior);
    let from = [r.theta.as_slice(), &r.nuisance].concat();
    let freed = output_error_lm_within(oe, &problem.layout, &from, opts.iterations, &wide);
    if freed.cost_after.is_nan() || freed.cost_after >= (1.0 - DEMAND) * r.cost_after {
        return (Vec::new(), None);
    }
    let (freed, wide) = past_search_bound(problem, oe, opts, prior, freed, wide);
    let demanded = on_prior
        .iter()
        .filter(|&&j| freed.theta[j] < bounds.lo[j])
        .map(|&j| (j, r.cost_after, freed.cost_after))
        .collect();
    *r = freed;
    (demanded, Some(wide))
}

/// A freed inertia that ran to the search bound, freed once more (to [`FARTHEST`] times its
/// rigid-body term), one DOF at a time, and kept there when the runs demand it of that DOF: a
/// per-DOF first-order model, whose gain is free, then no longer predicts that DOF better than
/// the fit (a real AUV's yaw, whose command delivered a fraction of what it asked). The
/// demand is judged on the DOF's own output error, which the others' would dilute. Returns
/// the fit and its bounds.
fn past_search_bound(
    problem: &Regression,
    oe: &OutputError,
    opts: &Options,
    mut prior: [f64; 6],
    mut freed: super::refine::Refined,
    mut wide: Bounds,
) -> (super::refine::Refined, Bounds) {
    let layout = &problem.layout;
    let on_bound: Vec<usize> = (0..freed.theta.len())
        .filter(|&j| is_added_mass(problem, j) && prior[dof_of(problem, j)] >= BEYOND_PRIOR)
        .filter(|&j| wide.at_prior(j, freed.theta[j]))
        .collect();
    for j in on_bound {
        let dof = layout.terms[j].dof();
        let mut wider_prior = prior;
        wider_prior[dof.index()] = FARTHEST;
        let wider = plausible(layout, &opts.rigid_mass, &wider_prior);
        let from = [freed.theta.as_slice(), &freed.nuisance].concat();
        let farther = output_error_lm_within(oe, layout, &from, opts.iterations, &wider);
        let own = |r: &super::refine::Refined| {
            oe.dof_cost(layout, &[r.theta.as_slice(), &r.nuisance].concat(), dof)
        };
        let gained =
            farther.cost_after < freed.cost_after && own(&farther) < (1.0 - DEMAND) * own(&freed);
        if gained {
            (freed, wide, prior) = (farther, wider, wider_prior);
        }
    }
    (freed, wide)
}

/// The output-error fit from `theta0` with the command lag `opts` asks for: none, the one set,
/// or (`auto`) the one the runs demand, searched from the fit without a lag (or found by such
/// a search already); with the joint view of the fit and the lag where the search's polish
/// left one at that fit.
fn with_lag(
    vehicle: &crate::core::model::Vehicle,
    responses: &[&crate::core::response::Response],
    layout: &crate::core::model::ParamLayout,
    theta0: &[f64],
    bounds: &Bounds,
    opts: &Options,
) -> (
    Option<LagEstimate>,
    super::refine::Refined,
    Option<super::refine::Joint>,
) {
    let fit = |lag: f64, from: &[f64]| {
        let oe = OutputError::with_lag(vehicle, responses, lag).with_per_run(opts.per_run);
        output_error_lm_within(&oe, layout, from, opts.iterations, bounds)
    };
    // The fit at a lag found, polished with the lag counted beside the coefficients.
    let at_found = |est: LagEstimate, from: &[f64]| {
        let joint_at = |lag: f64, r: &super::refine::Refined| {
            joint(vehicle, responses, layout, opts.per_run, lag, r)
        };
        let r = fit(est.value_s, from);
        let (value_s, r, last) = polish_lag(&fit, &joint_at, est.value_s, r);
        let est = LagEstimate {
            value_s,
            cost_with: r.cost_after,
            ..est
        };
        (Some(est), r, last)
    };
    match opts.command_lag {
        CommandLag::None => (None, fit(0.0, theta0), None),
        CommandLag::Seconds(x) => {
            let r = fit(x, theta0);
            let set = LagEstimate {
                value_s: x,
                stderr_s: f64::NAN,
                cost_without: f64::NAN,
                cost_with: r.cost_after,
                estimated: false,
                searched_on_candidates: None,
                profile: Vec::new(),
            };
            (Some(set), r, None)
        }
        CommandLag::Auto => {
            let r0 = fit(0.0, theta0);
            let from = [r0.theta.as_slice(), &r0.nuisance].concat();
            let on = (layout, opts.per_run);
            match super::lag::search(vehicle, responses, on, &from, r0.cost_after, bounds) {
                Some((est, theta)) => at_found(est, &theta),
                None => (None, r0, None),
            }
        }
        CommandLag::Found {
            value_s,
            cost_without,
            cost_with,
        } => {
            // Fitted at the lag first, from `theta0`, as `auto` fits before its search.
            let r = fit(value_s, theta0);
            let from = [r.theta.as_slice(), &r.nuisance].concat();
            let found = LagEstimate {
                searched_on_candidates: Some([cost_without, cost_with]),
                ..LagEstimate::found(value_s, f64::NAN)
            };
            at_found(found, &from)
        }
    }
}

/// The step of the command lag's finite difference, s.
const LAG_STEP_S: f64 = 0.005;

/// The joint view of `r`, fitted at the command lag `lag`, with the lag counted as a parameter
/// beside the coefficients (the derivative of the residuals by the lag, a central difference).
fn joint(
    vehicle: &crate::core::model::Vehicle,
    responses: &[&crate::core::response::Response],
    layout: &crate::core::model::ParamLayout,
    per_run: Kinds,
    lag: f64,
    r: &super::refine::Refined,
) -> super::refine::Joint {
    let theta = [r.theta.as_slice(), &r.nuisance].concat();
    let at = |l: f64| {
        OutputError::with_lag(vehicle, responses, l)
            .with_per_run(per_run)
            .residuals(layout, &theta)
    };
    let (lo, hi) = ((lag - LAG_STEP_S).max(0.0), lag + LAG_STEP_S);
    let column = at(hi)
        .iter()
        .zip(at(lo))
        .map(|(a, b)| (a - b) / (hi - lo))
        .collect();
    let oe = OutputError::with_lag(vehicle, responses, lag).with_per_run(per_run);
    super::refine::errors_with(&oe, layout, r, column)
}

/// The coefficients' standard errors and correlations of `r` from `j`, its joint view with the
/// estimated command lag counted as a parameter: a lag traded against inertia and damping on
/// the runs leaves those uncertain, which errors conditional on the lag would hide. The
/// correlations then have the lag as their last row and column; returns its standard error.
fn with_joint_errors(mut j: super::refine::Joint, r: &mut super::refine::Refined) -> f64 {
    let lag_stderr = j.stderr.pop().unwrap_or(f64::NAN);
    r.stderr = j.stderr;
    r.correlation = j.correlation;
    lag_stderr
}

/// A Gauss-Newton step of the lag and the coefficients together from the line search's best
/// (its bracket and short probe fits leave the lag a few hundredths of a second off), the
/// coefficients refitted at the new lag, kept when the output error falls. Returns the lag, the
/// fit, and the joint view of the two where the last one computed is of them.
fn polish_lag(
    fit: &dyn Fn(f64, &[f64]) -> super::refine::Refined,
    joint_at: &dyn Fn(f64, &super::refine::Refined) -> super::refine::Joint,
    mut lag: f64,
    mut r: super::refine::Refined,
) -> (f64, super::refine::Refined, Option<super::refine::Joint>) {
    for _ in 0..LAG_POLISH_STEPS {
        // Every way out of the loop but the last step leaves `j` the view of (lag, r).
        let j = joint_at(lag, &r);
        let Some((&dlag, rest)) = j.step.split_last().filter(|(d, _)| d.is_finite()) else {
            return (lag, r, Some(j));
        };
        let next = lag + dlag;
        // A step well inside the lag's standard error changes nothing a user reads; one out
        // of the searched range is the line search's to refuse.
        let stderr = j.stderr.last().copied().unwrap_or(f64::NAN);
        let small = stderr.is_nan() || dlag.abs() < POLISHED * stderr;
        if small || !(0.0..=super::lag::MAX_LAG_S).contains(&next) {
            return (lag, r, Some(j));
        }
        let from: Vec<f64> = r
            .theta
            .iter()
            .chain(&r.nuisance)
            .zip(rest)
            .map(|(x, d)| x + d)
            .collect();
        let tried = fit(next, &from);
        if tried.cost_after.is_nan() || tried.cost_after >= r.cost_after {
            return (lag, r, Some(j));
        }
        (lag, r) = (next, tried);
    }
    (lag, r, None)
}

/// Estimate `e` of coefficient `j` with its range over the command lags the runs cannot tell
/// apart (`lag`'s profile) as its interval; where that range reaches beyond two standard
/// errors, said in its note, and where it is wider than the value itself, not identifiable
/// (the rule a standard error over half the value follows).
fn over_the_lag(
    mut e: Estimate,
    lag: Option<&LagEstimate>,
    j: usize,
    problem: &Regression,
) -> Estimate {
    let Some(l) = lag else {
        return e;
    };
    let (Some([lo, hi]), Some([a, b])) = (l.range_of(j, e.value), l.lag_range()) else {
        return e;
    };
    e.interval = Some([lo, hi]);
    let spread = hi - lo;
    if spread <= 4.0 * e.stderr {
        return e;
    }
    let dof = acts_in(problem.layout.terms[j]);
    let said = format!(
        "{} is {lo:.4} to {hi:.4} over the command lags {a:.2}-{b:.2} s, whose output errors are within {:.0} % of the fit's: the runs cannot tell this coefficient's share from the lag's, whatever its standard error says; steps of the command in {dof}, which a lag delays and an inertia or damping shapes, would tell them apart",
        e.name,
        100.0 * super::lag::DEMAND,
    );
    e.note = Some(match e.note.take() {
        Some(n) => format!("{n}; {said}"),
        None => said,
    });
    if spread > e.value.abs() {
        e.identifiable = false;
    }
    e
}

/// Gauss-Newton steps of the lag at most, and the step, in standard errors of the lag, below
/// which it is left as it is.
const LAG_POLISH_STEPS: usize = 2;
const POLISHED: f64 = 0.25;

/// How far an added mass that runs to [`BEYOND_PRIOR`] may go when freed once more: a
/// command that delivers a seventeenth of what it asks, with the added mass on a prior of 2.
const FARTHEST: f64 = 50.0;

/// The relative drop of the output error at which the runs demand an added mass beyond its
/// prior: well above what refitting noise gains.
const DEMAND: f64 = 0.01;

/// Parameter `j` of the refined answer `r`: its standard error from the output error's
/// Jacobian, not identifiable when that is over half the value or the value sits on the prior
/// (or, freed, on the search bound). `beyond`: the output error with the value held on the
/// prior and freed, when the runs demanded a value beyond it.
fn estimate(
    problem: &Regression,
    bounds: &Bounds,
    r: &super::refine::Refined,
    j: usize,
    opts: &Options,
    beyond: Option<(f64, f64)>,
) -> Estimate {
    let (value, stderr) = (r.theta[j], r.stderr[j]);
    let name = problem.layout.name(j);
    let (note, flagged) = note(problem, bounds, (j, value), opts, beyond);
    Estimate {
        name,
        value,
        unit: problem.layout.unit(j).to_string(),
        stderr,
        interval: None,
        identifiable: !flagged && stderr.is_finite() && stderr < 0.5 * value.abs(),
        note,
    }
}

mod bounds;
mod notes;
use bounds::{BEYOND_PRIOR, dof_of, is_added_mass};
pub use bounds::{FASTEST_S, plausible};
use notes::{acts_in, note};

#[cfg(test)]
pub(crate) mod tests;
