//! One identification, as `fit` and `compare` both run it: the problem from CFD cases (each
//! with the body mass it states, if any) and pool runs (each source weighted by its own
//! residual level), the method with its settings, the objective, and the optional two-step
//! added-mass window.

use super::constants::Candidate;
use super::gain::{self, ThrustGain};
use super::result::Objective;
use super::sources::combine;
use super::two_step::{truncate, two_step};
use super::{Estimate, Fit, Method, Options, Regression};
use crate::core::model::Vehicle;
use crate::core::response::Response;

/// What is identified from.
pub struct Data<'a> {
    pub vehicle: &'a Vehicle,
    /// CFD responses, with the body mass a case states (an OpenFOAM case) when it does.
    pub cases: Vec<(&'a Response, Option<f64>)>,
    /// Pool runs as responses (logged command, fused velocity and its derivative).
    pub pool: Vec<&'a Response>,
    /// Samples before this time in each response are left out.
    pub skip_start_s: f64,
}

/// How it is identified.
pub struct Request<'a> {
    pub method: &'a Method,
    pub objective: Objective,
    /// Two-step least squares: the added mass from this window after `skip_start_s`.
    pub added_mass_window_s: Option<f64>,
    /// Whether the logged command's gain is identified against the CFD cases (see [`gain`]).
    pub thrust_gain: ThrustGain,
    pub progress: Option<&'a (dyn Fn(f64) + Sync)>,
    /// The terms of `vehicle` the user did not ask for (constant forces, couplings):
    /// a prediction-error fit of pool runs keeps each only where cross-validation across the
    /// runs says it predicts them better (see [`super::constants`]).
    pub optional: &'a [Candidate],
}

impl<'a> Request<'a> {
    /// `method` on its default objective, with no added-mass window, the logged command as
    /// the force and no progress, the terms of `optional` chosen.
    pub fn plain(method: &'a Method, optional: &'a [Candidate]) -> Request<'a> {
        Request {
            method,
            objective: Objective::default(),
            added_mass_window_s: None,
            thrust_gain: ThrustGain::default(),
            progress: None,
            optional,
        }
    }
}

/// The identified parameters and what the identification did besides.
pub struct Identified {
    pub fit: Fit,
    /// With an added-mass window: what the one-step fit over whole runs gives, for contrast.
    pub one_step: Option<Vec<Estimate>>,
    /// The problem's layout (which DOFs carry a constant force).
    pub constant_force: Vec<crate::core::dof::Dof>,
    /// The vehicle as fitted: without the optional terms cross-validation dropped.
    pub vehicle: Vehicle,
    pub rows: usize,
    pub notes: Vec<String>,
}

impl Data<'_> {
    /// The same responses, of `vehicle` (the data's vehicle with other terms).
    pub fn of<'b>(&'b self, vehicle: &'b Vehicle) -> Data<'b> {
        Data {
            vehicle,
            cases: self.cases.clone(),
            pool: self.pool.clone(),
            skip_start_s: self.skip_start_s,
        }
    }

    /// The vehicle with the body mass of case-stated masses, when they are one.
    fn with_mass(&self, mass: Option<f64>) -> Vehicle {
        let mut v = self.vehicle.clone();
        if let Some(m) = mass {
            v.mass_kg = m;
        }
        v
    }

    /// One problem from the CFD cases and the pool runs (see [`combine`]), and the body mass
    /// each source was regressed with. Cases that state their own body mass (OpenFOAM) are
    /// regressed with it.
    fn problem(&self, notes: &mut Vec<String>) -> (Regression, Vec<f64>) {
        let cfd = self.cfd_rows();
        let mut masses: Vec<f64> = self
            .cases
            .iter()
            .map(|(_, mass)| self.with_mass(*mass).mass_kg)
            .collect();
        let pool = Regression::build(self.vehicle, &self.pool, self.skip_start_s);
        if !self.pool.is_empty() {
            masses.push(self.vehicle.mass_kg);
        }
        (combine(cfd, pool, notes), masses)
    }

    /// The CFD cases' rows, each case regressed with the body mass it states.
    pub(crate) fn cfd_rows(&self) -> Regression {
        let mut cfd = Regression::build(self.vehicle, &[], self.skip_start_s);
        for (r, mass) in &self.cases {
            cfd.append(Regression::build(
                &self.with_mass(*mass),
                &[r],
                self.skip_start_s,
            ));
        }
        cfd
    }

    /// The CFD cases' rows up to `window` after `skip_start_s`: the accelerations from rest.
    fn early(&self, window: f64) -> Regression {
        let mut early = Regression::build(self.vehicle, &[], self.skip_start_s);
        for (r, mass) in &self.cases {
            early.append(Regression::build(
                &self.with_mass(*mass),
                &[&truncate(r, self.skip_start_s + window)],
                self.skip_start_s,
            ));
        }
        early
    }

    /// Every response, the CFD cases first.
    fn responses(&self) -> Vec<&Response> {
        self.cases
            .iter()
            .map(|(r, _)| *r)
            .chain(self.pool.iter().copied())
            .collect()
    }
}

/// Identifies the model of `data.vehicle` as `req` asks.
pub fn identify(data: &Data, req: &Request) -> anyhow::Result<Identified> {
    if req.thrust_gain == ThrustGain::Fit {
        let gain = gain::estimate(&gain::Sources {
            vehicle: data.vehicle,
            cfd: data.cfd_rows(),
            pool: &data.pool,
            skip_start_s: data.skip_start_s,
        })?;
        let scaled: Vec<Response> = data
            .pool
            .iter()
            .map(|r| gain::scaled(r, gain.value))
            .collect();
        let data = Data {
            pool: scaled.iter().collect(),
            cases: data.cases.clone(),
            ..*data
        };
        let mut id = identify_as_logged(&data, req)?;
        id.notes.insert(0, gain.sentence());
        id.fit.thrust_gain = Some(gain);
        return Ok(id);
    }
    identify_as_logged(data, req)
}

/// [`identify`] with the pool runs' command taken as the force, without the optional
/// terms cross-validation drops.
fn identify_as_logged(data: &Data, req: &Request) -> anyhow::Result<Identified> {
    let Some(choice) = choose_optional(data, req) else {
        return identify_unchosen(data, req);
    };
    use crate::core::model::ParamLayout;
    let vehicle = super::constants::without_all(data.vehicle, &choice.dropped);
    let chosen = data.of(&vehicle);
    let all = ParamLayout::of(data.vehicle);
    let start = super::constants::mapped(&all, &choice.theta, &ParamLayout::of(&vehicle));
    let mut id = identify_once(&chosen, req, Some((choice.command_lag, &start)))?;
    id.notes.insert(0, choice.sentence());
    Ok(id)
}

/// [`identify_as_logged`] where nothing was chosen: with too few runs to choose on, the
/// optional constants kept and the couplings left out (the simpler model the user asked for).
fn identify_unchosen(data: &Data, req: &Request) -> anyhow::Result<Identified> {
    let couplings: Vec<Candidate> = (req.optional.iter())
        .filter(|c| matches!(c, Candidate::Coupling(_)))
        .copied()
        .collect();
    let vehicle = super::constants::without_all(data.vehicle, &couplings);
    let data = data.of(&vehicle);
    let mut id = identify_once(&data, req, None)?;
    let n = data.pool.len();
    if !req.optional.is_empty() && n < super::constants::MIN_RUNS {
        id.notes.insert(0, format!(
            "{n} training run(s): too few to choose the constant forces and couplings by cross-validation (it needs {}), so every candidate constant is kept and the couplings are left out",
            super::constants::MIN_RUNS
        ));
    }
    Ok(id)
}

/// Which of the request's optional terms cross-validation keeps, for a prediction-error fit
/// of pool runs alone (`None` for any other fit, or too few runs to choose on).
fn choose_optional(data: &Data, req: &Request) -> Option<super::constants::Choice> {
    let pem = req.method.estimator.minimises_output_error();
    if !pem || !data.cases.is_empty() || req.optional.is_empty() {
        return None;
    }
    let opts = req.method.options(Options::default());
    let full = super::constants::Full {
        vehicle: data.vehicle,
        skip_start_s: data.skip_start_s,
        rigid_mass: data.vehicle.rigid_mass(),
        added_mass_prior: opts.added_mass_prior,
        command_lag: opts.command_lag,
        iterations: opts.iterations,
    };
    super::constants::choose(&full, &data.pool, req.optional)
}

/// One identification of `data.vehicle` as `req` asks, with the constants the vehicle has;
/// a prediction-error fit at the command lag and from the coefficients of `warm` when given
/// (a lag searched, and a model fitted near it, already).
fn identify_once(
    data: &Data,
    req: &Request,
    warm: Option<(super::lag::CommandLag, &[f64])>,
) -> anyhow::Result<Identified> {
    let mut notes = Vec::new();
    let (problem, masses) = data.problem(&mut notes);
    let one_mass = masses.windows(2).all(|w| w[0] == w[1]);
    let pem = req.method.estimator.minimises_output_error();
    anyhow::ensure!(
        !(pem && req.objective == Objective::OutputError && data.pool.is_empty()),
        "method pem minimises the output error of pool runs, and this fit reads none; use method: qpso, pso or ga for the output error of CFD cases"
    );
    anyhow::ensure!(
        one_mass || pem || req.objective == Objective::EquationError,
        "the output error simulates one body: these cases state different body masses ({masses:?} kg); use objective: equation_error"
    );
    let mut sim_vehicle = data.vehicle.clone();
    if let Some(m) = masses.first() {
        sim_vehicle.mass_kg = *m;
    }
    // The prediction-error method simulates the pool runs only (a CFD case's equation error is
    // already what seed 001 minimises); without pool runs it is least squares.
    let refs = match pem {
        true => data.pool.clone(),
        false => data.responses(),
    };
    let simulate = (req.objective == Objective::OutputError || pem) && !refs.is_empty();
    if pem && !refs.is_empty() {
        sim_vehicle = data.vehicle.clone();
    }
    let mut opts = req.method.options(Options {
        rigid_mass: sim_vehicle.rigid_mass(),
        progress: req.progress,
        output_error: simulate.then_some((&sim_vehicle, &refs[..])),
        ..Default::default()
    });
    if let Some((lag, start)) = warm {
        (opts.command_lag, opts.start) = (lag, Some(start));
    }
    let (mut fit, one_step) = match req.added_mass_window_s {
        None => (req.method.estimator.fit(&problem, &opts)?, None),
        Some(window) => two_step_fit(data, req, &problem, &opts, window)?,
    };
    super::check_signs(&problem.layout, &mut fit.parameters);
    if let Some(r) = &fit.refinement {
        notes.push(format!(
            "prediction-error fit: the least-squares start leaves a weighted mean square velocity error of {:.4} on the training runs' simulations, {} Levenberg-Marquardt steps take it to {:.4}",
            r.start_cost,
            r.steps,
            fit.objective_value.unwrap_or(f64::NAN)
        ));
        if !r.per_run.is_empty() {
            let said: Vec<String> = r.per_run.iter().map(|s| s.sentence()).collect();
            notes.push(format!(
                "per-run nuisance parameters estimated with the model: {}",
                said.join("; ")
            ));
        }
    }
    Ok(Identified {
        fit,
        one_step,
        constant_force: problem.layout.constant.clone(),
        vehicle: data.vehicle.clone(),
        rows: problem.rows(),
        notes,
    })
}

/// Two-step least squares with the added mass from `window` (see [`two_step`]), and what the
/// method's one-step fit of `problem` gives, for contrast.
fn two_step_fit(
    data: &Data,
    req: &Request,
    problem: &Regression,
    opts: &Options,
    window: f64,
) -> anyhow::Result<(Fit, Option<Vec<Estimate>>)> {
    anyhow::ensure!(
        matches!(req.method.name(), "ols" | "pem") && req.objective == Objective::EquationError,
        "added_mass_window_s is a two-step least-squares fit: use method: ols, objective: equation_error"
    );
    anyhow::ensure!(window > 0.0, "added_mass_window_s must be positive");
    anyhow::ensure!(
        data.pool.is_empty(),
        "added_mass_window_s is for CFD runs from rest; remove the pool stage from this fit's `from`"
    );
    let early = data.early(window);
    let one = req
        .method
        .estimator
        .fit(problem, opts)
        .ok()
        .map(|f| f.parameters);
    Ok((two_step(&early, problem)?, one))
}
