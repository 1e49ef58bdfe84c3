//! The whole diagnosis of a model on fused pool runs: drift or missing structure, the named
//! effects tested and chosen on held-out runs, what is left `unexplained`, and the figures
//! that show the evidence (see the module documentation of [`crate::diagnose`]).

use super::beside;
use super::drift::Drifted;
use super::figures;
use super::noise_rule::{above_noise, reestimate_within_noise};
use super::result::*;
use super::rival::{self, Bare};
use super::sentence::{Costs, verdict_sentence};
use super::settle::{Settled, settle};
use super::unexplained::{Structured, structured_left, unexplained_residual};
use super::{self as dx, Augmentation, Criteria, Data, Mismatch, Run, Slots};
use crate::core::dof::Dof;
use crate::core::model::Plant;
use crate::diagnose::SLOTS;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The whole diagnosis of `plant` (the model of fit stage `model`) on fused pool runs.
pub fn diagnose(
    vehicle: &crate::core::model::Vehicle,
    model: &str,
    plant: &Plant,
    fused: &[crate::pool::fusion::run::FusedRun],
    crit: &Criteria,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<(Diagnosis, Vec<Figure>)> {
    let start = std::time::Instant::now();
    let (fused, latency) = super::latency::taken_out(plant, fused);
    let fused = &fused[..];
    let (runs, skipped, stability) = prepare_runs(plant, fused, crit);
    let data = data_of(vehicle, runs, &skipped)?;
    let diverged = diverged_runs(plant, &data);
    if !diverged.is_empty() {
        let elapsed = start.elapsed().as_secs_f64();
        let mut d = Diagnosis::unsound(model, &data, diverged, crit, skipped, elapsed);
        d.stability = stability;
        return Ok((d, Vec::new()));
    }
    progress("baseline and re-estimated parameters");

    // 1. Drift: the same model structure, parameters re-estimated on the training runs.
    let base = data.eval(plant, &Augmentation::default(), true);
    let base_cost = base.cost(&data.scale);
    let drifted = Drifted::estimate(vehicle, fused, &data, plant)?;

    // 2. Locate the CFD model's held-out residual.
    let res_before = dx::residuals(plant, &Augmentation::default(), &data.validate);
    let mismatch = main_mismatches(&data, &res_before);
    let regimes = dx::regime_shares(&data.validate, &res_before, &data.scale);

    // 3. Hypotheses, greedily; 4. settled beside the model's own parameters re-estimated.
    let at = (base_cost, &drifted);
    let chosen = choose_effects(vehicle, plant, &data, crit, at, progress)?;
    let (search, settled, (before, after_effects), drift_won) = chosen;
    let used = (settled.as_ref().map(|s| &s.beside)).filter(|b| !b.selected.is_empty());
    let plant = used.map_or(plant, |b| &b.plant);
    let costs = Costs {
        base: base_cost,
        after_effects,
        reestimated: drifted.cost,
        noise: data.noise_cost,
    };
    let (effects, mut figures, mut conclusion) =
        conclude(plant, &data, crit, (&search, drift_won), &costs)?;
    let dropped = say_beside(&mut conclusion, settled.as_ref(), used.map(|b| (b, before)));
    let verdict = compose_verdict(crit, &effects, &conclusion, costs);
    let shown = (&mismatch[..], &res_before[..], &conclusion.selected);
    lead_figures(plant, &data, shown, model, &mut figures)?;
    let used = used.filter(|_| !conclusion.drift);
    let (reestimated, beside_used) = reestimated_record(vehicle, &data, crit, used, drifted);
    let diagnosis = Diagnosis {
        baseline: Baseline {
            model: model.to_string(),
            validation_nmae: dx::nmae_map(&base, &data.slots),
            validation_cost: base_cost,
            noise_cost: data.noise_cost,
            reestimated,
            parameters_reestimated: conclusion.drift || beside_used,
        },
        mismatch,
        effects,
        verdict,
        regimes,
        hypotheses: search.tested,
        criteria: crit.clone(),
        runs: Runs {
            latency_taken_out_s: latency,
            ..Runs::of(&data, skipped)
        },
        diverged: Vec::new(),
        untested: dx::untested(&data),
        dropped: [dropped, conclusion.dropped].concat(),
        started_from: Vec::new(),
        stability,
        elapsed_s: start.elapsed().as_secs_f64(),
    };
    Ok((diagnosis, figures))
}

/// Steps 3 and 4: the effects chosen greedily on the model as it is, then settled beside its
/// own parameters re-estimated ([`beside::settle`]). Returns the search with its selection
/// settled, what settling did, and the held-out cost of the effects on the model as it is
/// and of those the verdict goes on with (the model as it is when all were dropped), and
/// whether the re-estimated model won (drift: all dropped, or [`Drifted::clears_structure`]).
/// The settled effects meet discovery's closed form given the same re-estimate
/// ([`rival::contest`]).
type Chosen = (dx::Search, Option<beside::Settled>, (f64, f64), bool);
fn choose_effects(
    vehicle: &crate::core::model::Vehicle,
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    (base_cost, drifted): (f64, &Drifted),
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Chosen> {
    let mut search = dx::select(plant, data, crit, progress);
    let before = *search.costs.last().unwrap_or(&base_cost);
    let on_top = (&search.selected, before);
    let mut settled = beside::settle(vehicle, plant, data, crit, on_top, drifted.cost, progress);
    let contest = match &settled {
        Some(s) => rival::contest(
            vehicle,
            plant,
            data,
            crit,
            (&search, &mut Bare::default(), s),
        )?,
        None => rival::Contest::Stands,
    };
    match contest {
        rival::Contest::Beaten => settled = None,
        rival::Contest::Alike(sentence) => {
            if let Some(s) = &mut settled {
                s.said.push((false, sentence));
            }
        }
        rival::Contest::Stands => {}
    }
    let after = match &settled {
        Some(s) => {
            search.selected = s.beside.selected.clone();
            match s.beside.selected.is_empty() {
                true => base_cost,
                false => s.beside.cost,
            }
        }
        None => before,
    };
    // Every named effect dropped beside the re-estimated model, or the re-estimate alone
    // clearing a structure the pooled cost hides: that is drift.
    let drift_won = settled
        .as_ref()
        .is_some_and(|s| s.beside.selected.is_empty())
        || drifted.clears_structure(plant, data, crit, (base_cost, after));
    Ok((search, settled, (before, after), drift_won))
}

/// The overview figures in front: the model's held-out residual (`res_before`) with where it
/// misses, and its overlay with the effects kept (`selected`).
fn lead_figures(
    plant: &Plant,
    data: &Data,
    (mismatch, res_before, selected): (&[Mismatch], &[[Vec<f64>; SLOTS]], &dx::Selection),
    model: &str,
    figures: &mut Vec<Figure>,
) -> anyhow::Result<()> {
    if let Some(fig) = figures::overlay_figure(plant, data, mismatch, selected, model)? {
        figures.insert(0, fig);
    }
    if let Some(fig) = figures::residual_overview(data, res_before, mismatch)? {
        figures.insert(0, fig);
    }
    Ok(())
}

/// The changes made on the re-estimated model said in the verdict's notes, in their order,
/// then the note of the model re-estimated beside the effects kept (`used`, with the
/// effects' held-out cost on the model as it is); returns the sentences of the named
/// effects those changes dropped.
fn say_beside(
    conclusion: &mut Conclusion,
    settled: Option<&beside::Settled>,
    used: Option<(&beside::Beside, f64)>,
) -> Vec<String> {
    let note = used.map(|(b, before)| beside::note(b, before));
    let said: Vec<&(bool, String)> = settled.iter().flat_map(|s| s.said.iter()).collect();
    conclusion.notes.extend(said.iter().map(|(_, s)| s.clone()));
    conclusion.notes.extend(note);
    said.into_iter()
        .filter(|(dropped, _)| *dropped)
        .map(|(_, s)| s.clone())
        .collect()
}

/// The re-estimated model the report carries: the one the named effects are fitted on
/// (`used`), when re-estimated beside them, is the one to use; otherwise the model
/// re-estimated alone. With whether it was the former.
fn reestimated_record(
    vehicle: &crate::core::model::Vehicle,
    data: &Data,
    crit: &Criteria,
    used: Option<&beside::Beside>,
    drifted: Drifted,
) -> (Reestimated, bool) {
    match used {
        Some(b) => {
            let within = reestimate_within_noise(crit, data, b.cost);
            (super::drift::beside_record(vehicle, data, b, within), true)
        }
        None => {
            let within = reestimate_within_noise(crit, data, drifted.cost);
            (drifted.into_record(within), false)
        }
    }
}

/// The diagnosis's data from the runs it can use, with `vehicle`'s size ([`Data::size`]);
/// when it can use none for want of a DOF, the error names the runs and what each lacks
/// (`skipped`).
fn data_of(
    vehicle: &crate::core::model::Vehicle,
    runs: Vec<Run>,
    skipped: &[String],
) -> anyhow::Result<Data> {
    if runs.is_empty() && !skipped.is_empty() {
        anyhow::bail!(
            "no pool run can be diagnosed:\n  {}\n  help: the diagnosis compares the model in the DOFs it moves in; give the runs the sensors those need, or leave those DOFs out of the vehicle's `dofs`",
            skipped.join("\n  ")
        );
    }
    let mut data = Data::new(runs)?;
    data.size = vehicle.mass_kg / crate::core::model::Vehicle::reference().mass_kg;
    Ok(data)
}

/// The verdict: its sentence on the costs of what survived the selection, the discovered
/// term's, and one per named effect dropped.
fn compose_verdict(
    crit: &Criteria,
    effects: &[Found],
    conclusion: &Conclusion,
    costs: Costs,
) -> String {
    let costs = Costs {
        after_effects: conclusion.cost_after_drop.unwrap_or(costs.after_effects),
        ..costs
    };
    let mut verdict = verdict_sentence(
        effects,
        conclusion.unexplained.then_some(&conclusion.structured[..]),
        conclusion.drift,
        &costs,
        crit.within_noise,
    );
    if let Some(c) = effects.iter().find_map(|e| e.candidate.as_ref()) {
        verdict.push_str(&c.verdict_sentence());
    }
    for d in conclusion.dropped.iter().chain(&conclusion.notes) {
        let _ = write!(verdict, " {d}.");
    }
    verdict
}

/// The runs on which the model's simulation diverges, with the time it does.
pub(super) fn diverged_runs(plant: &Plant, data: &Data) -> Vec<String> {
    data.train
        .iter()
        .chain(&data.validate)
        .filter_map(|r| dx::divergence(plant, r).map(|t| format!("{} (at t = {t:.1} s)", r.name)))
        .collect()
}

/// Where the model's held-out residual is: the (at most eight) runs and DOFs holding at least
/// 2 % of it, largest first.
fn main_mismatches(data: &Data, residuals: &[[Vec<f64>; SLOTS]]) -> Vec<Mismatch> {
    let mut mismatch = dx::locate(&data.validate, residuals, &data.scale);
    mismatch.retain(|m| m.share_of_error >= 0.02);
    mismatch.truncate(8);
    mismatch
}

/// What the diagnosis concludes beyond the named effects.
struct Conclusion {
    /// Re-estimating the model's parameters explains the held-out runs better than effects.
    drift: bool,
    /// A structured residual well above the noise remains.
    unexplained: bool,
    /// The named effects that survive the joint selection with the discovered term.
    selected: dx::Selection,
    /// Named effects dropped once a discovered term explained what they were chosen for,
    /// each with the numbers that decided it.
    dropped: Vec<String>,
    /// Named effects taken back beside the discovered terms (`readmit`), and how the named
    /// effects kept moved when refitted beside them.
    notes: Vec<String>,
    /// The held-out cost of the effects kept, once some were dropped or refitted.
    cost_after_drop: Option<f64>,
    /// The DOFs whose residual after the effects kept is structured above its noise, with the
    /// figures that decided it: what the verdict quotes when the pooled cost is within noise.
    structured: Vec<Structured>,
}

/// The named effects and their figures, or none when drift explains better, plus an
/// `unexplained` entry when a structured residual well above the noise remains.
///
/// "Explained" is one rule: the held-out cost within `within_noise` times the noise floor
/// *and* no DOF whose residual is both structured and above `unexplained_noise_multiple`
/// times its own noise ([`super::unexplained::structured_left`]). A structured residual is never "within noise".
fn conclude(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    (search, drift_won): (&dx::Search, bool),
    costs: &Costs,
) -> anyhow::Result<(Vec<Found>, Vec<Figure>, Conclusion)> {
    // A fresh discovery: one run for the contest ([`rival::contest`]) would count as sought.
    let mut bare = Bare::default();
    let (drift, mut notes, beaten) =
        rival::drift_holds(plant, data, crit, (search, &mut bare), (costs, drift_won))?;
    let mut selected = if drift {
        Vec::new()
    } else {
        search.selected.clone()
    };
    let mut explained_cost = if drift {
        costs.reestimated
    } else {
        costs.after_effects
    };
    let mut left = if drift {
        Vec::new()
    } else {
        structured_left(plant, data, &dx::augmentation(&selected), crit)
    };
    let unexplained = |cost: f64, left: &[Structured], n_effects: usize| {
        !left.is_empty() || above_noise(crit, data, (costs, drift), cost, n_effects)
    };
    let mut dropped = Vec::new();
    let (mut found, mut terms, mut disc_figures) = (None, Vec::new(), Vec::new());
    // A closed form that beat drift is proposed though the named effects leave no structure:
    // they are what re-estimating the model beat (a loss to the inflow named `coupled_drag`).
    let must = unexplained(explained_cost, &left, selected.len());
    if must || beaten {
        let mut proposed = false;
        let mut f = unexplained_residual(plant, data, &selected, explained_cost, &left, crit);
        // Beyond the vocabulary: a closed form for what is left, kept only if the held-out
        // runs prove it. Not after drift: the model itself is then what is wrong.
        if !drift && crit.discover {
            let start = (search, &mut bare, explained_cost);
            let discovered = discover_left(plant, data, crit, start, &f.dofs)?;
            if let Some((kept, c, figs, (why, said))) = discovered {
                (selected, dropped, notes) = (kept, why, said);
                if !dropped.is_empty() || !notes.is_empty() {
                    let aug = dx::augmentation(&selected);
                    explained_cost = data.eval(plant, &aug, true).cost(&data.scale);
                    left = structured_left(plant, data, &aug, crit);
                    f = unexplained_residual(plant, data, &selected, explained_cost, &left, crit);
                }
                let taken: Vec<&str> = selected.iter().map(|(h, _)| h.name).collect();
                terms = c.model.clone();
                f = c.into_found(f, &taken);
                disc_figures = figs;
                proposed = true;
            }
        }
        found = (must || proposed).then_some(f);
    }
    let (mut effects, mut figures) = named_effects(plant, data, &selected)?;
    let beside = super::alike::alike_beside(plant, data, crit, &selected, &terms);
    super::alike::list_alike(&mut effects, (search, beside), crit, data);
    super::alike::list_possible(&mut effects, (search, &terms), crit, data);
    figures.extend(disc_figures);
    let unexplained = found.is_some();
    effects.extend(found);
    Ok((
        effects,
        figures,
        Conclusion {
            drift,
            unexplained,
            cost_after_drop: (!dropped.is_empty() || !notes.is_empty()).then_some(explained_cost),
            selected,
            dropped,
            notes,
            structured: if unexplained { left } else { Vec::new() },
        },
    ))
}

/// The closed form discovery proposes for what the named effects the search chose (at
/// held-out cost `effects_cost`) leave in `dofs`, or beside fewer of them where that proves
/// better ([`rival`]), settled with the named effects ([`settle`]).
fn discover_left(
    plant: &Plant,
    data: &Data,
    crit: &Criteria,
    (search, bare, effects_cost): (&dx::Search, &mut Bare, f64),
    dofs: &[Dof],
) -> anyhow::Result<Option<Settled>> {
    let selected = search.selected.clone();
    let top = bare.on_top(plant, data, crit, (search, dofs))?.cloned();
    let top_c = top.as_ref().map(|t| &t.0);
    // What the named effects chosen first leave, with the terms on top of them.
    let first = top_c.map_or(effects_cost, Candidate::cost_after_all);
    if (bare.sought() || rival::worth_a_rival(crit, data, top_c))
        && let Some(r) = bare.get(plant, data, crit, search)?
        && rival::beats(crit, data, r.candidate.cost_after_all(), first)
    {
        let (c, figs) = (&r.candidate, r.figures.clone());
        let all: Vec<Dof> = data.slots.on().map(|j| data.slots.dof(j)).collect();
        let start = (search.selected[..r.kept].to_vec(), &search.tested[..]);
        let (kept, settled, figs, (more, said)) =
            settle(plant, data, crit, start, &all, (c.clone(), figs))?;
        // An effect taken back beside the terms is not dropped.
        let gone: dx::Selection = (selected.into_iter())
            .filter(|(h, _)| !kept.iter().any(|(k, _)| k.name == h.name))
            .collect();
        let why = rival::replaced((&gone, &kept), c, (top_c, first));
        let why = why.into_iter().chain(more).collect();
        return Ok(Some((kept, settled, figs, (why, said))));
    }
    let Some((c, figs)) = top else {
        return Ok(None);
    };
    let on_top = (selected, &search.tested[..]);
    Ok(Some(settle(plant, data, crit, on_top, dofs, (c, figs))?))
}

/// The fused runs the diagnosis can use (every DOF the model moves in fused, [`Slots::of`]), each with the simulation window
/// its local stability asks for; the runs left out, and the stability along each run.
pub(super) fn prepare_runs(
    plant: &Plant,
    fused: &[crate::pool::fusion::run::FusedRun],
    crit: &Criteria,
) -> (
    Vec<Run>,
    Vec<String>,
    BTreeMap<String, crate::core::model::stability::Stability>,
) {
    let mut skipped = Vec::new();
    let Some(slots) = Slots::of(plant) else {
        return (Vec::new(), skipped, BTreeMap::new());
    };
    let runs: Vec<Run> = fused
        .iter()
        .filter_map(|r| {
            let run = Run::from_fused(r, slots);
            if run.is_none() {
                let missing: Vec<String> = slots
                    .missing(&r.fused)
                    .iter()
                    .map(|d| d.to_string())
                    .collect();
                skipped.push(format!(
                    "{}: no fused {} (the model moves there)",
                    r.meta.run,
                    missing.join(", ")
                ));
            }
            run
        })
        .collect();
    let mut runs = runs;
    let mut stability = BTreeMap::new();
    for r in &mut runs {
        let vel: Vec<[f64; SLOTS]> = (0..r.t.len())
            .map(|k| std::array::from_fn(|j| r.vel[j][k]))
            .collect();
        let s = crate::core::model::stability::along_in(
            plant,
            &r.t,
            &vel,
            &slots.nu_all(),
            crit.horizon_s,
        );
        r.anchors_s = s.anchors_s.clone();
        stability.insert(r.name.clone(), s);
    }
    (runs, skipped, stability)
}

/// Each effect kept by the search, with its held-out gain, its evidence sentence and figures
/// (judged on top of the effects kept before it).
fn named_effects(
    plant: &Plant,
    data: &Data,
    selected: &dx::Selection,
) -> anyhow::Result<(Vec<Found>, Vec<Figure>)> {
    let mut effects = Vec::new();
    let mut prefix: dx::Selection = Vec::new();
    let mut figures = Vec::new();
    for (h, p) in selected {
        let aug_before = dx::augmentation(&prefix);
        prefix.push((*h, p.clone()));
        let aug_after = dx::augmentation(&prefix);
        let (sb, sa) = (
            data.eval(plant, &aug_before, true),
            data.eval(plant, &aug_after, true),
        );
        let dofs = improved_dofs(&data.slots, &sb.nmae(), &sa.nmae());
        let (cb, ca) = (sb.cost(&data.scale), sa.cost(&data.scale));
        let params = dx::params_map(h, p);
        // The regime is read off the residual this effect was chosen to explain (after the
        // effects kept before it), where its signature is not masked by theirs.
        let res_prefix = dx::residuals(plant, &aug_before, &data.validate);
        let regime = dx::regime_shares(&data.validate, &res_prefix, &data.scale)
            .into_iter()
            .find(|r| r.regime == h.regime);
        let evidence = found_evidence(&params, (cb, ca), data.noise_cost, regime.as_ref());
        figures.extend(figures::evidence_figures(
            plant,
            data,
            h,
            &aug_before,
            &aug_after,
            &dofs,
        )?);
        effects.push(Found {
            name: h.name.into(),
            dofs,
            parameters: params,
            evidence,
            validation_nmae_before: dx::nmae_map(&sb, &data.slots),
            validation_nmae_after: dx::nmae_map(&sa, &data.slots),
            validation_cost_before: cb,
            validation_cost_after: ca,
            alike: Vec::new(),
            possibly_beside: Vec::new(),
            candidate: None,
        });
    }
    Ok((effects, figures))
}

/// The DOFs whose held-out NMAE an effect lowers by over a tenth (and by over 0.003).
fn improved_dofs(slots: &Slots, before: &[f64], after: &[f64]) -> Vec<Dof> {
    (0..SLOTS)
        .filter(|&j| before[j] - after[j] > 0.1 * before[j] && before[j] - after[j] > 0.003)
        .map(|j| slots.dof(j))
        .collect()
}

/// The evidence sentence of a named effect: its fitted parameters, the held-out cost before
/// and after it, and the regime of the residual it explains.
fn found_evidence(
    params: &BTreeMap<String, f64>,
    (cb, ca): (f64, f64),
    noise_cost: f64,
    regime: Option<&dx::RegimeShare>,
) -> String {
    let exponent = params.get("thrust_law_exponent").copied();
    let law = exponent.map_or(String::new(), |n| {
        format!(" ({})", dx::effects::law_in_words(n))
    });
    let mut evidence = format!(
        "Fitted on the training runs: {}{law}. On the held-out runs the error cost falls {} ({:.4} to {:.4}; noise floor {:.4})",
        fmt_params(params),
        pct((cb - ca) / cb),
        cb,
        ca,
        noise_cost
    );
    if let Some(r) = regime {
        let _ = write!(
            evidence,
            "; the residual it explains has {} of its error {} ({} of the time)",
            pct(r.share_of_error),
            r.label,
            pct(r.share_of_time)
        );
    }
    evidence.push('.');
    evidence.push_str(exponent.map_or("", dx::effects::alike_in_words));
    evidence
}
