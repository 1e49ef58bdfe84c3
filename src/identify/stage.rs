//! `kind: fit` — identifies the hydrodynamic parameters from every CFD response it reads.

use crate::core::response;
use crate::identify::constants::Candidate;
use crate::identify::fit;
use crate::identify::result::{CaseRef, FitResult, Objective, RESULT, RunRef};
use crate::identify::settings::{Common, Settings};
use crate::pipeline::contract::{Artifact, Kind, RunCtx, StageImpl, parse_as};

pub static KIND: Kind = Kind {
    consumes: &[Artifact::Responses, Artifact::PoolRuns],
    requires_one_of: &[Artifact::Responses, Artifact::PoolRuns],
    ..Kind::new("fit", Artifact::Model, parse_as::<Settings>)
};

impl Settings {
    /// The body this fit identifies with the structure it identifies.
    fn vehicle(
        &self,
        pipeline: &crate::core::model::Vehicle,
    ) -> anyhow::Result<crate::core::model::Vehicle> {
        let mut v = self
            .common
            .vehicle
            .clone()
            .unwrap_or_else(|| pipeline.clone());
        if let Some(s) = self.common.structure {
            v.structure = s;
        }
        if self.common.custom_terms.is_some() {
            v.custom_terms = self.common.custom_terms.clone();
        }
        let problems = v.problems();
        anyhow::ensure!(
            problems.is_empty(),
            "this fit's model cannot be built: {}",
            problems.join("; ")
        );
        Ok(v)
    }
}

impl Settings {
    /// Whether this is a prediction-error fit of pool runs alone (no CFD case), the fit whose
    /// optional terms cross-validation chooses.
    fn recordings_alone(&self, ctx: &RunCtx, no_cfd: bool) -> bool {
        no_cfd
            && ctx.upstream_of(Artifact::PoolRuns).next().is_some()
            && self.method.estimator.minimises_output_error()
    }

    /// Recordings alone: every DOF is a candidate for a constant force, those the vehicle
    /// lists and the others. A real vehicle is never exactly neutral (buoyancy, a tether's
    /// pull, a thruster's offset, the controller's feed-forward in the command), and without
    /// the constant the simulation error is cut by pinning the DOF's velocity at zero with a
    /// stiff drag or by lowering its gain: on the TAUV runs (scripts/tauv) the sway offset of
    /// -3.7 N cost sway's held-out NMAE 1.01 against 0.86 with it. With `constants: chosen`
    /// (the default) the unlisted ones are kept only where cross-validation says they predict
    /// left-out runs better ([`crate::identify::constants`]). Returns the note and the
    /// unlisted DOFs given a candidate constant.
    fn constants_for_recordings(
        &self,
        ctx: &RunCtx,
        no_cfd: bool,
        vehicle: &mut crate::core::model::Vehicle,
    ) -> Option<(String, Vec<crate::core::dof::Dof>)> {
        use super::settings::Constants;
        let added: Vec<_> = (vehicle.dofs.iter())
            .filter(|d| !vehicle.constant_force.contains(d))
            .copied()
            .collect();
        if !(self.recordings_alone(ctx, no_cfd)
            && self.common.constants != Constants::Listed
            && !added.is_empty())
        {
            return None;
        }
        let listed = std::mem::replace(&mut vehicle.constant_force, vehicle.dofs.clone());
        let names = |ds: &[crate::core::dof::Dof]| {
            ds.iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let lists = match listed.is_empty() {
            true => "lists none".to_string(),
            false => format!("lists {}", names(&listed)),
        };
        let note = match self.common.constants {
            Constants::Chosen => format!(
                "constant forces: the vehicle's `constant_force` {lists}; {} are candidates too, since a vehicle in the water is never exactly neutral (a thruster's offset, a tether's pull, the controller's feed-forward), each kept only where it predicts runs left out of the fit better (`constants: every_dof` keeps them all, `constants: listed` only the list)",
                names(&added)
            ),
            _ => format!(
                "constant forces in every DOF: the vehicle's `constant_force` {lists}, and {} get one too, since a vehicle in the water is never exactly neutral there either (a thruster's offset, a tether's pull, the controller's feed-forward)",
                names(&added)
            ),
        };
        let optional = match self.common.constants {
            Constants::Chosen => added,
            _ => Vec::new(),
        };
        Some((note, optional))
    }
}

impl Settings {
    /// Recordings alone, in sway and yaw, with a diagonal model: the linear coupling N_v is a
    /// candidate too, kept where cross-validation says it predicts left-out runs better
    /// ([`crate::identify::constants`]); `couplings: none` leaves it out.
    fn couplings_for_recordings(
        &self,
        ctx: &RunCtx,
        no_cfd: bool,
        vehicle: &mut crate::core::model::Vehicle,
    ) -> Vec<Candidate> {
        let on = self.common.couplings == super::settings::Couplings::Chosen;
        match on && self.recordings_alone(ctx, no_cfd) {
            true => super::constants::with_couplings(vehicle),
            false => Vec::new(),
        }
    }

    /// What `fit::identify` is asked, with `progress` told the fraction done.
    fn request<'a>(
        &'a self,
        progress: &'a (dyn Fn(f64) + Sync),
        optional: &'a [Candidate],
    ) -> fit::Request<'a> {
        fit::Request {
            optional,
            method: &self.method,
            objective: self.common.objective,
            added_mass_window_s: self.common.added_mass_window_s,
            thrust_gain: self.common.thrust_gain,
            progress: Some(progress),
        }
    }
}

/// Why a diagonal model has the net weight W - B and no heave constant, when it has.
fn net_weight_note(vehicle: &crate::core::model::Vehicle) -> Option<String> {
    use crate::core::model::{ParamLayout, Term};
    let layout = ParamLayout::of(vehicle);
    let diagonal = vehicle.structure == crate::core::model::Structure::Diagonal;
    (diagonal && layout.terms.contains(&Term::NetWeight)).then(|| {
        "net buoyancy as the net weight W-B: vertical in the water, it tilts into surge and sway as the vehicle rolls and pitches, where a constant force fixed to the body cannot follow it; it takes the place of a constant heave force (level, the two are the same force)".to_string()
    })
}

impl StageImpl for Settings {
    /// Only the settings the chosen method reads, so tuning the swarm does not rerun a
    /// least-squares fit (and a deterministic method shows no seed).
    fn settings(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("settings serialise")
    }

    fn run(&self, ctx: &RunCtx) -> anyhow::Result<()> {
        let start = std::time::Instant::now();
        let mut vehicle = self.vehicle(ctx.vehicle)?;
        let (cases, responses) = cfd_cases(ctx)?;
        let mut notes = Vec::new();
        let (note, optional) =
            (self.constants_for_recordings(ctx, cases.is_empty(), &mut vehicle)).unzip();
        notes.extend(note);
        let mut optional: Vec<Candidate> = (optional.unwrap_or_default().into_iter())
            .map(Candidate::Constant)
            .collect();
        optional.extend(self.couplings_for_recordings(ctx, cases.is_empty(), &mut vehicle));
        notes.extend(net_weight_note(&vehicle));
        let vehicle = &vehicle;
        let (runs, pool_responses, run_notes) =
            training_runs(ctx, vehicle, self.common.median_filter.as_ref())?;
        notes.extend(run_notes);
        notes.extend(ctx.failed_notes());
        check_windows(ctx, &self.common, responses.iter().chain(&pool_responses))?;
        let labelled = cases
            .iter()
            .map(|c| c.source.path.clone())
            .zip(&responses)
            .chain(
                runs.iter()
                    .map(|r| format!("pool run {}", r.run))
                    .zip(&pool_responses),
            );
        check_finite(labelled, &vehicle.dofs, self.common.skip_start_s)?;
        let data = fit::Data {
            vehicle,
            cases: responses
                .iter()
                .zip(&cases)
                .map(|(r, c)| (r, c.mass_kg))
                .collect(),
            pool: pool_responses.iter().collect(),
            skip_start_s: self.common.skip_start_s,
        };
        ctx.progress
            .set_message(format!("fitting with {}", self.method.name()));
        let bar = ctx.progress;
        let report = move |f: f64| bar.set_message(format!("{:.0} %", 100.0 * f));
        let id = fit::identify(&data, &self.request(&report, &optional))?;
        notes.extend(id.notes);
        let fit = id.fit;
        let objective = match fit.refinement {
            Some(_) => Objective::OutputError,
            None => self.common.objective,
        };
        let mut fit = self.physical_mass(&data, (fit, &id.vehicle), &mut notes)?;
        if per_metre_of_span(&cases, runs.len())? {
            for p in &mut fit.parameters {
                p.unit = crate::core::model::params::per_metre_of_span(&p.unit);
            }
        }
        let result = FitResult {
            stage: ctx.stage.to_string(),
            method: self.method.name().to_string(),
            objective,
            settings: self.settings(),
            structure: id.vehicle.structure,
            custom_terms: id.vehicle.custom_terms.clone(),
            dofs: vehicle.dofs.clone(),
            constant_force: id.constant_force,
            fit,
            cases,
            runs,
            notes,
            elapsed_s: start.elapsed().as_secs_f64(),
            vehicle: self.common.vehicle.clone(),
            expected: self.common.expected.clone(),
            one_step: id.one_step,
            imported_from: None,
        };
        crate::core::fsutil::write_json(&ctx.out.join(RESULT), &result)
    }
}

/// Every sample a fit reads is finite: a NaN or an infinity in an input is named with its
/// source and time, not left to break an estimator.
fn check_finite<'a>(
    labelled: impl Iterator<Item = (String, &'a response::Response)>,
    dofs: &[crate::core::dof::Dof],
    skip_start_s: f64,
) -> anyhow::Result<()> {
    for (source, r) in labelled {
        if let Some(bad) = r.non_finite(dofs, skip_start_s) {
            anyhow::bail!(
                "{source}: {bad}: no estimator can use it\n  help: fix or remove that sample in the input (or start the fit after it with skip_start_s)"
            );
        }
    }
    Ok(())
}

impl Settings {
    /// The fit with a physical mass matrix: as identified; for total least squares with the
    /// DOFs it left without a positive mass taken from ordinary least squares, where they stand
    /// alone ([`crate::identify::fallback`]); otherwise refused with the reason.
    ///
    /// The fit is of `as_fitted`: `data.vehicle` with the optional terms it kept
    /// (cross-validation may have dropped some).
    fn physical_mass(
        &self,
        data: &fit::Data,
        (fit, as_fitted): (crate::identify::Fit, &crate::core::model::Vehicle),
        notes: &mut Vec<String>,
    ) -> anyhow::Result<crate::identify::Fit> {
        use crate::identify::fallback;
        let data = &data.of(as_fitted);
        let layout = crate::core::model::ParamLayout::of(data.vehicle);
        let tls = self.method.estimator.name() == "tls";
        let bad = fallback::unphysical_dofs(data.vehicle, &layout, &fit).unwrap_or_default();
        // Only TLS can keep a drag past its sign (OLS and the others hold it there).
        let runaway = if tls {
            let responses: Vec<_> = (data.pool.iter().copied())
                .chain(data.cases.iter().map(|c| c.0))
                .collect();
            fallback::runaway_dofs(&layout, &fit, &responses)
        } else {
            Vec::new()
        };
        let fit = if tls && !(bad.is_empty() && runaway.is_empty()) {
            let ols = crate::identify::Method::parse("ols", Default::default())
                .map_err(anyhow::Error::msg)?;
            let request = fit::Request {
                method: &ols,
                progress: None,
                ..self.request(&|_| {}, &[])
            };
            let from = fit::identify(data, &request)?.fit;
            let bad_dofs: Vec<_> = (bad.iter().map(|(d, _)| *d))
                .chain(runaway.iter().map(|r| r.0))
                .collect();
            let dofs = fallback::together(&layout, &bad_dofs);
            if !bad.is_empty() {
                notes.push(fallback::note(&bad, &dofs));
            }
            if !runaway.is_empty() {
                notes.push(fallback::runaway_note(&runaway, &dofs));
            }
            fallback::with_dofs_from(&layout, fit, &from, &dofs)
        } else {
            fit
        };
        check_mass(data.vehicle, &fit)?;
        Ok(fit)
    }
}

/// The identified model's mass matrix is physical (positive definite), or the fit is refused.
fn check_mass(
    vehicle: &crate::core::model::Vehicle,
    fit: &crate::identify::Fit,
) -> anyhow::Result<()> {
    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
    let layout = crate::core::model::ParamLayout::of(vehicle);
    let plant = crate::core::model::Plant::new(vehicle, layout.to_hydro(&theta));
    if let Some(why) = plant.mass_problem() {
        let help = match vehicle.structure {
            crate::core::model::Structure::Diagonal => {
                "runs that accelerate the vehicle in that DOF (its acceleration is what tells its mass), or the default fit (no `method`), which holds added mass within its prior"
            }
            _ => {
                "a structure with fewer mass terms (diag_mass, diag_all), or runs that excite the coupled DOFs more, give a physical mass matrix"
            }
        };
        anyhow::bail!(
            "the identified {} model is refused: {why}\n  help: {help}",
            vehicle.structure.label()
        );
    }
    Ok(())
}

/// There must be something to fit, and `skip_start_s` (and the added-mass window after it)
/// must leave samples of it: a time beyond every run is a setting to fix, said at its line.
/// With every input failed upstream the error names them, not an empty fit.
fn check_windows<'r>(
    ctx: &RunCtx,
    common: &Common,
    responses: impl Iterator<Item = &'r crate::core::response::Response>,
) -> anyhow::Result<()> {
    let ends: Vec<f64> = responses.filter_map(|r| r.t.last().copied()).collect();
    if ends.is_empty() && !ctx.failed_upstream.is_empty() {
        let failed: Vec<String> = ctx
            .failed_upstream
            .iter()
            .map(|(id, _)| id.to_string())
            .collect();
        anyhow::bail!(
            "nothing to fit: every input failed upstream ({}); see their errors above",
            failed.join(", ")
        );
    }
    let end = ends.into_iter().fold(f64::NEG_INFINITY, f64::max);
    if end.is_finite() && common.skip_start_s >= end {
        return Err(ctx.setting_error(
            "skip_start_s",
            format!(
                "skip_start_s = {} s leaves no sample to fit: the longest run ends at {end} s",
                common.skip_start_s
            ),
            "set skip_start_s below the runs' length (it drops each run's first seconds, the start-up transient)",
        ));
    }
    if let Some(w) = common.added_mass_window_s
        && (w.is_nan() || w <= 0.0)
    {
        return Err(ctx.setting_error(
            "added_mass_window_s",
            format!("added_mass_window_s = {w} s: the window must be longer than 0"),
            "set the seconds after skip_start_s in which the body accelerates from rest",
        ));
    }
    Ok(())
}

/// Whether the coefficients are per metre of span: every case is 2D. A 2D case's forces and
/// masses are per metre, a 3D case's and a pool run's are not, and one fit cannot mix them.
fn per_metre_of_span(cases: &[CaseRef], pool_runs: usize) -> anyhow::Result<bool> {
    let two_d = cases.iter().filter(|c| c.per_metre_of_span).count();
    if two_d == 0 {
        return Ok(false);
    }
    anyhow::ensure!(
        two_d == cases.len() && pool_runs == 0,
        "this fit reads {two_d} 2D cases (forces and masses per metre of span) together with {} 3D cases and {pool_runs} pool runs; their coefficients are in different units\n  help: fit the 2D cases in a stage of their own (`from: [openfoam]`)",
        cases.len() - two_d
    );
    Ok(true)
}

/// The CFD responses among the upstream, with what the result says of each case.
fn cfd_cases(ctx: &RunCtx) -> anyhow::Result<(Vec<CaseRef>, Vec<crate::core::response::Response>)> {
    let mut cases = Vec::new();
    let mut responses = Vec::new();
    for up in ctx.upstream_of(Artifact::Responses) {
        let (meta, r) = response::load(&up.dir)?;
        cases.push(CaseRef {
            id: up.id.clone(),
            case: meta.case,
            source: meta.source,
            inputs: meta.all_inputs,
            mass_kg: meta.body_mass_kg,
            per_metre_of_span: meta.per_metre_of_span,
        });
        responses.push(r);
    }
    Ok((cases, responses))
}

/// The `role: train` pool runs among the upstream, as response tables (logged command, fused
/// velocity and its derivative). Runs without every DOF of the vehicle are left out and said.
fn training_runs(
    ctx: &RunCtx,
    vehicle: &crate::core::model::Vehicle,
    filter: Option<&crate::core::median::MedianFilter>,
) -> anyhow::Result<(
    Vec<RunRef>,
    Vec<crate::core::response::Response>,
    Vec<String>,
)> {
    let (mut refs, mut responses, mut notes) = (Vec::new(), Vec::new(), Vec::new());
    // The DOFs every training run's logs give a velocity in, whatever the vehicle declares.
    let mut gives = crate::core::dof::Dof::ALL.to_vec();
    let mut latencies = Vec::new();
    for up in ctx.upstream_of(Artifact::PoolRuns) {
        let run = crate::pool::fusion::run::load_for(&up.dir, vehicle)?;
        latencies.push(run.meta.stats.nav_latency);
        if run.meta.role != crate::pool::import::Role::Train {
            continue;
        }
        gives.retain(|d| run.velocity(*d).is_some() || run.meta.stats.rates_unfused.contains(d));
        match run.as_response(vehicle, filter) {
            Some(r) => {
                refs.push(RunRef {
                    id: up.id.clone(),
                    run: run.meta.run.clone(),
                    inputs: run.meta.sources.clone(),
                });
                responses.push(r);
            }
            None => {
                let dofs = run.missing_dofs(vehicle);
                let missing: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
                notes.push(format!(
                    "pool run {} left out: its sensors gave no {} velocity",
                    run.meta.run,
                    missing.join(", ")
                ));
            }
        }
    }
    if ctx.upstream_of(Artifact::PoolRuns).next().is_some() && refs.is_empty() {
        if notes.is_empty() {
            anyhow::bail!(
                "no pool run with `role: train` to fit on\n  help: mark the runs to identify from `role: train` in their run.yaml; the others are held out for validation"
            );
        }
        let has: Vec<String> = gives.iter().map(|d| d.to_string()).collect();
        let fit_in = match has.is_empty() {
            true => "the training runs' logs give no velocity in any DOF:".to_string(),
            false => format!(
                "the training runs' logs give a velocity in {0}: fit in those (`dofs: [{0}]` under `vehicle` in pipeline.yaml), or",
                has.join(", ")
            ),
        };
        anyhow::bail!(
            "no pool run with `role: train` and every DOF fused to fit on: {}\n  help: {fit_in} log what gives the others (a DVL's navigation log, UWB, a sonar track)",
            notes.join("; "),
        );
    }
    let latency = crate::pool::fusion::latency::Summary::of(latencies.iter().map(Option::as_ref));
    notes.extend(latency.map(|s| s.sentence()));
    Ok((refs, responses, notes))
}
