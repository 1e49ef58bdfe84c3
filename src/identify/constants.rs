//! Which DOFs of a fit of recordings alone keep a constant force, and which couplings it
//! keeps (N_v; in six DOF K_v and M_u too): chosen by cross-validation across the training
//! runs, the way an engineer decides whether an offset is the vehicle's or one run's.
//!
//! A constant force the user did not list (`vehicle.constant_force`) is a candidate in every
//! DOF: a vehicle in the water is never exactly neutral. But a constant fitted to some runs
//! also takes up whatever those runs share by chance (a pilot who mostly drove forward, a
//! tether that pulled one way that day) and trades with the drag and the added mass; on a
//! run it was not fitted to it can predict worse than no constant at all. On the BlueROV2
//! Heavy's tank runs (scripts/smarc) the surge constant of 1.4 N raised the held-out surge
//! NMAE from 0.22 to 0.48, on the TAUV runs (scripts/tauv) from 0.77 to 0.79, while the TAUV's
//! sway constant of -3.7 N lowered sway's from 1.01 to 0.86.
//!
//! So before the fit, the training runs are split by run into folds; the model with every
//! candidate, and for each candidate the model without it, are refitted (Levenberg-Marquardt
//! on the output error, from the least-squares start refined on every run) on all folds but
//! one and simulated on the one left out. A DOF keeps its constant when the left-out runs'
//! NMAE in that DOF is lower with it by more than [`MARGIN`] and by more than the standard
//! error of the runs' differences; otherwise the simpler model predicts them as well, and the
//! fit is made without it.
//!
//! The folds are fitted at the command lag the fit asks for; with `auto` (the default) the lag
//! is searched once, on every run with every candidate, and the fit starts from the lag that
//! search found (the search is the fit's most costly part). A command lag left out of the
//! folds would have the constants make up for it: on twin runs with a 0.1 s lag and no yaw
//! constant, a yaw constant lowered the lag-free folds' yaw error by 8 %.
//!
//! The linear coupling from sway to yaw, N_v (a yaw moment from the sway velocity: a cross
//! term of Fossen 2011 sect. 6.5's linear manoeuvring model for a vehicle symmetric port and
//! starboard), is chosen the same way, judged in yaw. A diagonal model lacks it, and an open
//! frame's centre of lateral resistance is rarely at its origin: at `x_c` ahead of it the
//! sway drag gives N_v = x_c Y_v, comparable with the small yaw drag N_r. Its twin Y_r is
//! x_c Y_v too, negligible beside Y_v in sway (on four vehicles' runs the folds dropped it
//! every time, and on the BlueROV2 Heavy's it predicted held-out sway worse), so it is not a
//! candidate. On the BlueROV2 Heavy's tank runs N_v took held-out yaw NMAE from 0.71 to 0.59
//! in four DOF, the model with it ahead of the first-order baseline where it was behind.
//!
//! A six-DOF model also gets the translations' drag in roll and pitch as candidates, K_v
//! (sway to roll) and M_u (surge to pitch), each judged in the DOF it acts in and fitted after
//! the translations ([`super::attitude_rows`]), so that keeping one never moves the surge and
//! sway coefficients. On the BlueROV2 Heavy's tank runs in six DOF the folds kept both, and
//! held-out roll NMAE went from 1.00 (no better than predicting rest) to 0.88; pitch from
//! 0.99 to 1.00, the other DOFs within 0.012.

use super::lag::CommandLag;
use super::output_error::OutputError;
use super::refine::output_error_lm_within;
use crate::core::dof::Dof;
use crate::core::model::{ParamLayout, Structure, Term, Vehicle};
use crate::core::response::Response;
use std::collections::BTreeMap;

/// The relative drop of a DOF's left-out error a constant must bring to be kept: below it the
/// two models predict the left-out runs alike, and the one without the constant is simpler.
pub const MARGIN: f64 = 0.01;

/// The relative rise of another DOF's left-out error, without a dropped constant, that the
/// notes point out: the constant also stood in for something the model lacks there.
pub const ELSEWHERE: f64 = 0.1;

/// Folds at most; each holds every `FOLDS`-th run.
const FOLDS: usize = 4;

/// Fewest training runs the choice is made on (two folds of at least one run, and a model
/// fitted on more than one).
pub const MIN_RUNS: usize = 3;

/// Accepted Levenberg-Marquardt steps of each fold's refit of the model with every candidate
/// (half that for each model without one, which starts from it; twice it for the start).
const ITERATIONS: usize = 10;

/// A term a fit of recordings alone may do without.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Candidate {
    /// A constant force the user did not list.
    Constant(Dof),
    /// A linear drag term across DOFs (N_v), added to a diagonal model by name in its
    /// `custom_terms`.
    Coupling(Term),
}

impl Candidate {
    /// The DOFs whose left-out error judges it: the constant's, or those the coupling acts in
    /// (both of roll and pitch for z_g).
    pub fn dofs(self) -> Vec<Dof> {
        match self {
            Candidate::Constant(d) => vec![d],
            Candidate::Coupling(t) => t.equations(),
        }
    }

    /// `vehicle` without it.
    pub fn without(self, vehicle: &Vehicle) -> Vehicle {
        let mut v = vehicle.clone();
        match self {
            Candidate::Constant(d) => v.constant_force.retain(|e| *e != d),
            Candidate::Coupling(t) => {
                if let Some(c) = &mut v.custom_terms {
                    c.add.retain(|n| *n != t.name());
                }
            }
        }
        v
    }
}

impl std::fmt::Display for Candidate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Candidate::Constant(d) => write!(f, "{d}"),
            Candidate::Coupling(t) => write!(f, "{}", t.name()),
        }
    }
}

/// What cross-validation chose.
#[derive(Debug, Clone)]
pub struct Choice {
    /// The candidates dropped.
    pub dropped: Vec<Candidate>,
    /// Per candidate, the left-out runs' mean NMAE in its DOF with every candidate, and
    /// without that one.
    pub scores: BTreeMap<Candidate, (f64, f64)>,
    /// Per dropped candidate, each other DOF whose left-out NMAE is more than [`ELSEWHERE`]
    /// higher without it: (the candidate, that DOF, its NMAE with and without).
    pub elsewhere: Vec<(Candidate, Dof, f64, f64)>,
    pub folds: usize,
    /// The command lag the folds were fitted at, for the fit to start from (`auto` searched
    /// once: [`CommandLag::Found`], or [`CommandLag::None`] where the runs demand none).
    pub command_lag: CommandLag,
    /// The coefficients of the model with every candidate fitted at it on every run, in the
    /// order of its layout.
    pub theta: Vec<f64>,
}

impl Choice {
    /// The report's sentence.
    pub fn sentence(&self) -> String {
        let said = |coupling: bool| -> Vec<String> {
            (self.scores.iter())
                .filter(|(c, _)| matches!(c, Candidate::Coupling(_)) == coupling)
                .map(|(c, (with, without))| {
                    let verdict = match self.dropped.contains(c) {
                        true => "dropped",
                        false => "kept",
                    };
                    format!("{c} {verdict} ({with:.3} with, {without:.3} without)")
                })
                .collect()
        };
        let (constants, couplings) = (said(false), said(true));
        let mut parts = Vec::new();
        if !constants.is_empty() {
            parts.push(format!(
                "constant forces chosen by {}-fold cross-validation across the training runs (each fold's runs predicted by the model refitted on the others; a constant is kept where it lowers its DOF's left-out NMAE by more than {:.0} % and by more than the standard error of the runs' differences): {}",
                self.folds,
                100.0 * MARGIN,
                constants.join(", ")
            ));
        }
        if !couplings.is_empty() {
            let lever =
                (self.scores.keys()).any(|c| matches!(c, Candidate::Coupling(Term::Lever(_))));
            parts.push(format!(
                "the couplings chosen by the same {}-fold cross-validation, each judged in the DOF it acts in ({}`couplings: none` leaves them out): {}",
                self.folds,
                match lever {
                    true => "z_g, the centre of gravity's height from the thrusters' origin, by the mean of roll's and pitch's; ",
                    false => "",
                },
                couplings.join(", ")
            ));
        }
        let mut out = parts.join("; ");
        for (c, e, with, without) in &self.elsewhere {
            out += &match c {
                Candidate::Constant(d) => format!(
                    "; without {d}'s constant, {e} predicts the left-out runs worse ({with:.3} -> {without:.3}): it also stood in for something in {e} the model lacks (a coupling from {d}, through the added mass or drag it trades with; `constants: every_dof` keeps it)"
                ),
                Candidate::Coupling(_) => format!(
                    "; without {c}, {e} predicts the left-out runs worse ({with:.3} -> {without:.3})"
                ),
            };
        }
        out
    }
}

/// `vehicle` without `dropped`; a diagonal model again where no coupling is left.
pub fn without_all(vehicle: &Vehicle, dropped: &[Candidate]) -> Vehicle {
    let mut v = vehicle.clone();
    for c in dropped {
        v = c.without(&v);
    }
    let plain = |c: &crate::core::model::CustomTerms| {
        c.base == Structure::Diagonal && c.add.is_empty() && c.remove.is_empty()
    };
    if v.structure == Structure::Custom && v.custom_terms.as_ref().is_some_and(plain) {
        (v.structure, v.custom_terms) = (Structure::Diagonal, None);
    }
    v
}

/// The couplings a diagonal model of `vehicle` is given as candidates, each where the vehicle
/// moves in both its DOFs: N_v (sway to yaw), and K_v (sway to roll) and M_u (surge to
/// pitch), fitted as [`super::attitude_rows`] says; `vehicle` then has them in its
/// `custom_terms`.
pub fn with_couplings(vehicle: &mut Vehicle) -> Vec<Candidate> {
    let moves = |d: Dof| vehicle.dofs.contains(&d);
    let plain = vehicle.structure == Structure::Diagonal && vehicle.custom_terms.is_none();
    let pairs = [
        (Dof::Sway, Dof::Yaw),
        (Dof::Sway, Dof::Roll),
        (Dof::Surge, Dof::Pitch),
    ];
    let mut terms: Vec<Term> = (pairs.iter())
        .filter(|(from, to)| plain && moves(*from) && moves(*to))
        .map(|(from, to)| Term::Linear(to.index(), from.index()))
        .collect();
    // The height of the centre of gravity from the thrusters' origin, z_g, where the vehicle
    // rolls with its sway force or pitches with its surge force: their moments hang on it. (A
    // run holds the forces of the vehicle's DOFs only: without sway and surge, z_g has no
    // force to act through.)
    let hangs = (moves(Dof::Roll) && moves(Dof::Sway)) || (moves(Dof::Pitch) && moves(Dof::Surge));
    if plain && hangs {
        terms.push(Term::Lever(2));
    }
    if terms.is_empty() {
        return Vec::new();
    }
    vehicle.structure = Structure::Custom;
    vehicle.custom_terms = Some(crate::core::model::CustomTerms {
        base: Structure::Diagonal,
        add: terms.iter().map(|t| t.name()).collect(),
        remove: Vec::new(),
    });
    terms.into_iter().map(Candidate::Coupling).collect()
}

/// How the candidates are judged: the vehicle with every candidate, and what the fit is
/// asked (the skip of its least-squares start, its bounds, its command lag and steps).
pub struct Full<'a> {
    pub vehicle: &'a Vehicle,
    pub skip_start_s: f64,
    pub rigid_mass: [f64; 6],
    pub added_mass_prior: [f64; 6],
    pub command_lag: CommandLag,
    pub iterations: usize,
}

/// The `candidates` (constants the user did not ask for, couplings) kept or dropped by
/// cross-validation across `runs`; `None` with fewer than [`MIN_RUNS`] runs.
///
/// Each candidate is judged alone, against the model with every candidate: its DOF's
/// left-out error with the constant and without it, the others kept (dropping all at once
/// let one DOF's change move another's error, through the added mass the two share). A
/// dropped constant whose absence raises another DOF's left-out error is said in the notes:
/// on the BlueROV2 Heavy's runs, yaw's rose from 0.62 to 0.77 without the surge constant,
/// which the held-out runs bear out (0.61 to 0.71), while surge's fell from 0.33 to 0.29
/// (held out: 0.50 to 0.26). Judged on the sum over the DOFs the constant would stay, and
/// surge would not beat the first-order baseline.
pub fn choose(full: &Full, runs: &[&Response], candidates: &[Candidate]) -> Option<Choice> {
    let layout = ParamLayout::of(full.vehicle);
    let candidates: Vec<(Candidate, Vehicle)> = (candidates.iter())
        .map(|c| (*c, c.without(full.vehicle)))
        .filter(|(_, v)| ParamLayout::of(v).terms != layout.terms)
        .collect();
    if runs.len() < MIN_RUNS || candidates.is_empty() {
        return None;
    }
    use rayon::prelude::*;
    let (command_lag, from) = start(full, runs, &layout);
    let lag_s = match command_lag {
        CommandLag::Seconds(x) | CommandLag::Found { value_s: x, .. } => x,
        CommandLag::Auto | CommandLag::None => 0.0,
    };
    let folds = runs.len().min(FOLDS);
    let per_fold: Vec<Vec<Scored>> = (0..folds)
        .into_par_iter()
        .map(|f| fold((full, lag_s), runs, (f, folds), &from, &candidates))
        .collect();
    // A candidate's DOFs that the model has: the left-out error it is judged by is their mean.
    let judged = |c: &Candidate| -> Vec<Dof> {
        let mut d = c.dofs();
        d.retain(|e| full.vehicle.dofs.contains(e));
        d
    };
    let over = |m: &BTreeMap<Dof, f64>, dofs: &[Dof]| -> Option<f64> {
        let v: Vec<f64> = dofs
            .iter()
            .map(|d| m.get(d).copied())
            .collect::<Option<_>>()?;
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let mean = |pick: &dyn Fn(&Scored) -> Option<f64>| {
        let v: Vec<f64> = per_fold.iter().flatten().filter_map(pick).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let with = |e: &[Dof]| mean(&|s: &Scored| over(&s.with, e));
    let alone = |i: usize, e: &[Dof]| mean(&|s: &Scored| over(&s.without[i], e));
    let scores: BTreeMap<Candidate, (f64, f64)> = (candidates.iter().enumerate())
        .map(|(i, (c, _))| (*c, (with(&judged(c)), alone(i, &judged(c)))))
        .collect();
    let pairs = |i: usize, d: &[Dof]| -> Vec<(f64, f64)> {
        (per_fold.iter().flatten())
            .filter_map(|s| Some((over(&s.with, d)?, over(&s.without[i], d)?)))
            .collect()
    };
    let dropped: Vec<Candidate> = (candidates.iter().enumerate())
        .filter(|(i, (c, _))| !kept(&pairs(*i, &judged(c))))
        .map(|(_, (c, _))| *c)
        .collect();
    let elsewhere = (candidates.iter().enumerate())
        .filter(|(_, (c, _))| dropped.contains(c))
        .flat_map(|(i, (c, _))| {
            let own = judged(c);
            let others = (full.vehicle.dofs.iter()).filter(move |e| !own.contains(e));
            others.map(move |e| (*c, *e, with(&[*e]), alone(i, &[*e])))
        })
        .filter(|(_, _, w, wo)| *wo > (1.0 + ELSEWHERE) * w)
        .collect();
    Some(Choice {
        dropped,
        scores,
        elsewhere,
        folds,
        command_lag,
        theta: from,
    })
}

/// Whether a constant is kept, from its DOF's left-out NMAE on each run with it and without
/// it: lower with it on average by more than [`MARGIN`], and by more than the standard error
/// of the runs' differences (a mean gain that one run makes and the others do not is not
/// one a new run can count on). Not with fewer than two runs, nor where a value is not a
/// number.
fn kept(pairs: &[(f64, f64)]) -> bool {
    let n = pairs.len() as f64;
    if pairs.len() < 2 {
        return false;
    }
    let with = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let without = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let gain = without - with;
    let spread = pairs
        .iter()
        .map(|(a, b)| (b - a - gain).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    with < (1.0 - MARGIN) * without && gain > (spread / n).sqrt()
}

/// One left-out run's relative errors per DOF: with every candidate, and without each.
struct Scored {
    with: BTreeMap<Dof, f64>,
    without: Vec<BTreeMap<Dof, f64>>,
}

/// Fold `f` of `folds`: the full model refitted on the other folds' runs from `from`, and
/// from it each model without one candidate; each scored on the fold's runs.
fn fold(
    (full, lag_s): (&Full, f64),
    runs: &[&Response],
    (f, folds): (usize, usize),
    from: &[f64],
    candidates: &[(Candidate, Vehicle)],
) -> Vec<Scored> {
    let (test, train): (Vec<_>, Vec<_>) =
        (runs.iter().enumerate()).partition(|(c, _)| c % folds == f);
    let train: Vec<&Response> = train.into_iter().map(|(_, r)| *r).collect();
    let test: Vec<&Response> = test.into_iter().map(|(_, r)| *r).collect();
    let (with, theta) = refit(
        (full, lag_s),
        full.vehicle,
        (&train, &test),
        from,
        ITERATIONS,
    );
    let layout = ParamLayout::of(full.vehicle);
    let without: Vec<Vec<BTreeMap<Dof, f64>>> = candidates
        .iter()
        .map(|(_, v)| {
            let from = mapped(&layout, &theta, &ParamLayout::of(v));
            refit((full, lag_s), v, (&train, &test), &from, ITERATIONS / 2).0
        })
        .collect();
    (with.into_iter().enumerate())
        .map(|(c, with)| Scored {
            with,
            without: without.iter().map(|w| w[c].clone()).collect(),
        })
        .collect()
}

/// `vehicle`'s model refitted on `train` from `from` in `iterations` steps at most: each
/// `test` run's relative errors per DOF, and the coefficients.
fn refit(
    (full, lag_s): (&Full, f64),
    vehicle: &Vehicle,
    (train, test): (&[&Response], &[&Response]),
    from: &[f64],
    iterations: usize,
) -> (Vec<BTreeMap<Dof, f64>>, Vec<f64>) {
    let layout = ParamLayout::of(vehicle);
    let bounds = super::pem::plausible(&layout, &full.rigid_mass, &full.added_mass_prior);
    let oe = OutputError::with_lag(vehicle, train, lag_s);
    let fitted = output_error_lm_within(&oe, &layout, from, iterations, &bounds);
    let oe = OutputError::with_lag(vehicle, test, lag_s);
    let errors = (0..test.len())
        .map(|c| relative_errors(test[c], &oe.case_residuals(&layout, &fitted.theta, c)))
        .collect();
    (errors, fitted.theta)
}

/// Where the folds start: the least-squares fit of every run refined on their output error,
/// at the command lag the fit asks for; `auto` searched as the fit would search it
/// ([`super::lag::search`]). The lag, and the coefficients at it.
fn start(full: &Full, runs: &[&Response], layout: &ParamLayout) -> (CommandLag, Vec<f64>) {
    use super::Estimator as _;
    let problem = super::Regression::build(full.vehicle, runs, full.skip_start_s);
    let mut theta: Vec<f64> = match super::ols::Ols.fit(&problem, &Default::default()) {
        Ok(f) => f.parameters.iter().map(|p| p.value).collect(),
        Err(_) => Vec::new(),
    };
    theta.resize(layout.len(), 0.0);
    let bounds = super::pem::plausible(layout, &full.rigid_mass, &full.added_mass_prior);
    let at = |lag: f64, from: &[f64]| {
        let oe = OutputError::with_lag(full.vehicle, runs, lag);
        output_error_lm_within(&oe, layout, from, full.iterations, &bounds)
    };
    match full.command_lag {
        CommandLag::Auto => {
            let r0 = at(0.0, &theta);
            let on = (layout, Default::default());
            let c0 = r0.cost_after;
            match super::lag::search(full.vehicle, runs, on, &r0.theta, c0, &bounds) {
                Some((est, theta)) => {
                    let value_s = est.value_s;
                    let found = CommandLag::Found {
                        value_s,
                        cost_without: c0,
                        cost_with: est.cost_with,
                    };
                    (found, theta[..layout.len()].to_vec())
                }
                None => (CommandLag::None, r0.theta),
            }
        }
        CommandLag::Seconds(x) | CommandLag::Found { value_s: x, .. } => {
            (full.command_lag, at(x, &theta).theta)
        }
        CommandLag::None => (CommandLag::None, at(0.0, &theta).theta),
    }
}

/// `theta` of layout `from` on the terms of `to`; zero where `to` has a term `from` lacks
/// (a restoring moment's offset that a constant moment stood in for).
pub fn mapped(from: &ParamLayout, theta: &[f64], to: &ParamLayout) -> Vec<f64> {
    (to.terms.iter())
        .map(|t| {
            (from.terms.iter().position(|u| u == t))
                .and_then(|j| theta.get(j).copied())
                .unwrap_or(0.0)
        })
        .collect()
}
/// Per DOF of `run`, its normalised mean absolute error (mean |error| over mean |velocity|,
/// as the validation scores a run) from `residuals` as [`OutputError::case_residuals`]
/// weights and orders them: each error times the square root of the run's mean square
/// velocity in its DOF, DOF by DOF within each sample.
fn relative_errors(run: &Response, residuals: &[f64]) -> BTreeMap<Dof, f64> {
    let series: Vec<(Dof, &[f64])> = (run.dofs.iter())
        .map(|(d, s)| (*d, s.velocity.as_slice()))
        .collect();
    let mut sum = vec![(0.0, 0usize); series.len()];
    for (i, e) in residuals.iter().enumerate() {
        let s = &mut sum[i % series.len()];
        *s = (s.0 + e.abs(), s.1 + 1);
    }
    let mean =
        |v: &[f64], f: fn(f64) -> f64| v.iter().map(|x| f(*x)).sum::<f64>() / v.len().max(1) as f64;
    (series.into_iter().zip(sum))
        .filter_map(|((d, v), (s, n))| {
            let (rms, mean_abs) = (mean(v, |x| x * x).sqrt(), mean(v, f64::abs));
            (n > 0 && mean_abs > 0.0).then(|| (d, s / n as f64 * rms / mean_abs))
        })
        .collect()
}

#[cfg(test)]
mod tests;
