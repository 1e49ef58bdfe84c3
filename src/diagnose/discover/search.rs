//! The search for closed forms: the best proven term in one DOF, or terms in several DOFs at
//! once, then again in the DOFs left with what was found in the model.
//!
//! One physics can act in several DOFs at once (a battery's sag in every DOF a thruster
//! drives). Added one DOF at a time its term can look wrong: on a twin whose every thrust
//! fell 15 % a minute, the exact surge term alone raised the held-out cost (0.0568 -> 0.0579:
//! the yaw it couples into was still unmodelled), and the search took a named look-alike
//! instead. Each step therefore also tries every DOF's kept terms together, and keeps
//! whichever proves better after the per-parameter penalty. A weaker sag stands out in one DOF
//! only; the thruster forms found there are then tried in the other DOFs too, in that set.

use super::library::prepare;
use super::rows::{Rows, residual_rows};
use super::select::{Proposal, Variant, propose};
use super::{Candidate, Feature, Prepared, expression, figures, named_in};
use crate::core::dof::Dof;
use crate::core::model::Plant;
use crate::diagnose::result::Figure;
use crate::diagnose::{Augmentation, Criteria, Data, Sums};
use std::sync::Arc;

/// The discovery for the DOFs `dofs` where a structured residual is left after `aug`: the
/// proven candidate, if any, and its figures. With a term found, the search goes on in the
/// other DOFs with it in the model, each further term in [`Candidate::also`] and proved from
/// the cost the terms before it left.
pub fn discover(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    dofs: &[Dof],
    crit: &Criteria,
) -> anyhow::Result<Option<(Candidate, Vec<Figure>)>> {
    let pre: Vec<Prepared> = data.train.iter().map(prepare).collect();
    let Some(first) = step(plant, data, aug, &pre, dofs, crit) else {
        return Ok(None);
    };
    let (c0, v0) = &first.parts[0];
    let figures = figures::figures(data, &first.rows, &pre, c0, &first.proposal, v0)?;
    // A first term that is a named effect's form (a command's lag deficit is `thruster_lag`)
    // is reported under that name, alone, as it was found: neither terms in other DOFs added
    // with it nor terms found after it are part of the effect, and beside it they would hide
    // its name (a yaw `|r| r` making up for the lag's remainder did, on a twin).
    let named = first.parts[0].0.named_as.is_some() && first.parts.len() == 1;
    let mut with = aug.clone();
    let mut left = dofs.to_vec();
    let mut parts: Vec<Candidate> = Vec::new();
    let mut next = Some(first);
    while let Some(s) = next {
        for (c, v) in s.parts {
            left.retain(|d| *d != c.dof);
            with.discovered.push(Arc::new(v.term));
            parts.push(c);
        }
        next = if named {
            None
        } else {
            step(plant, data, &with, &pre, &left, crit)
        };
    }
    let mut candidate = parts.remove(0);
    candidate.also = parts;
    candidate.model = with.discovered[aug.discovered.len()..].to_vec();
    Ok(Some((candidate, figures)))
}

/// `c` with its terms as they were found, in a model with `aug` in place of what they were
/// found beside: each part's held-out costs and errors recomputed in order, the terms and
/// their coefficients unchanged. What a named effect found before discovery must beat: its
/// terms without it, as well as the terms discovered again without it. `None` for a
/// candidate whose model does not hold one term per part (not one [`discover`] returned).
pub fn beside(plant: &Plant, data: &Data, aug: &Augmentation, c: &Candidate) -> Option<Candidate> {
    if c.model.len() != c.parts().count() {
        return None;
    }
    let mut with = aug.clone();
    let mut before = data.eval(plant, &with, true);
    let mut parts: Vec<Candidate> = Vec::new();
    for (part, term) in c.parts().zip(&c.model) {
        with.discovered.push(term.clone());
        let after = data.eval(plant, &with, true);
        let mut p = part.clone();
        p.also = Vec::new();
        p.model = Vec::new();
        p.validation_nmae_before = crate::diagnose::nmae_map(&before, &data.slots);
        p.validation_nmae_after = crate::diagnose::nmae_map(&after, &data.slots);
        p.validation_cost_before = before.cost(&data.scale);
        p.validation_cost_after = after.cost(&data.scale);
        parts.push(p);
        before = after;
    }
    let mut out = parts.remove(0);
    out.also = parts;
    out.model = c.model.clone();
    Some(out)
}

/// One step of the search: the terms kept (one DOF's, or several DOFs' together), each with
/// its held-out costs as added in order; the residual rows and the first term's proposal.
struct Step {
    parts: Vec<(Candidate, Variant)>,
    rows: Rows,
    proposal: Proposal,
}

/// The best proven step in `dofs` with `aug` in the model: the best single DOF's term (its
/// variant of least penalised held-out cost, the DOF of least cost among the proven), or every
/// proposing DOF's kept terms together, with the same thruster forms in the model's other DOFs
/// ([`siblings`]), when that proves better after the penalty.
fn step(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    pre: &[Prepared],
    dofs: &[Dof],
    crit: &Criteria,
) -> Option<Step> {
    let rows = residual_rows(plant, aug, data);
    if rows.at.len() < 100 {
        return None;
    }
    let before = data.eval(plant, aug, true);
    let cb = before.cost(&data.scale);
    let penalty = |params: usize| crit.gain_per_parameter * cb * params as f64;
    let proven = |ca: f64, params: usize| {
        (cb - ca) / cb.max(1e-300) >= crit.min_gain + crit.gain_per_parameter * params as f64
            && cb - ca >= crit.min_noise_multiple * data.noise_cost
    };
    let proposals: Vec<Proposal> = data
        .slots
        .among(dofs)
        .into_iter()
        .filter_map(|j| propose(data, pre, &rows, j))
        .collect();
    let single = best_single(plant, data, aug, &proposals, (&penalty, &proven));
    let single = single.map(|(i, v, after)| {
        let var = &proposals[i].variants[v];
        let c = candidate(data, &proposals[i], var, (&before, &after));
        (i, vec![(c, var.clone())])
    });
    // A single term that is a named effect's form stands alone (see [`discover`]).
    if let Some((first, parts)) = single.as_ref().filter(|s| s.1[0].0.named_as.is_some()) {
        let (first, parts) = (*first, parts.clone());
        let mut proposals = proposals;
        return Some(Step {
            parts,
            rows,
            proposal: proposals.swap_remove(first),
        });
    }
    let siblings = siblings(data, pre, &rows, dofs, &proposals);
    let joint = together(
        plant,
        data,
        aug,
        (&proposals, &siblings),
        (&before, &penalty),
    )
    .filter(|parts| {
        let params: usize = parts.iter().map(|(_, v)| v.term.params()).sum();
        proven(parts[parts.len() - 1].0.validation_cost_after, params)
    });
    let score = |parts: &Vec<(Candidate, Variant)>| {
        let params: usize = parts.iter().map(|(_, v)| v.term.params()).sum();
        parts[parts.len() - 1].0.validation_cost_after + penalty(params)
    };
    let (first, parts) = match (single, joint) {
        (Some(s), Some(j)) if score(&j) >= score(&s.1) => s,
        (_, Some(j)) => (0, j),
        (Some(s), None) => s,
        (None, None) => return None,
    };
    let mut proposals = proposals;
    let proposal = proposals.swap_remove(first);
    Some(Step {
        parts,
        rows,
        proposal,
    })
}

/// The held-out cost a closed form with this many coefficients pays.
type Penalty<'a> = dyn Fn(usize) -> f64 + 'a;
/// Whether a held-out cost after a closed form with this many coefficients proves it.
type Proven<'a> = dyn Fn(f64, usize) -> bool + 'a;

/// The single DOF's term of least held-out cost among the proven: (proposal, variant, held-out
/// sums after), each proposal's variant the one of least penalised cost.
fn best_single(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    proposals: &[Proposal],
    (penalty, proven): (&Penalty<'_>, &Proven<'_>),
) -> Option<(usize, usize, Sums)> {
    let mut single: Option<(usize, usize, Sums)> = None;
    for (i, p) in proposals.iter().enumerate() {
        let Some((v, after)) = p
            .variants
            .iter()
            .enumerate()
            .map(|(v, var)| (v, with_terms(plant, data, aug, [var])))
            .min_by(|a, b| {
                let pa = a.1.cost(&data.scale) + penalty(p.variants[a.0].term.params());
                let pb = b.1.cost(&data.scale) + penalty(p.variants[b.0].term.params());
                pa.total_cmp(&pb)
            })
        else {
            continue;
        };
        let ca = after.cost(&data.scale);
        let better = single.as_ref().is_none_or(|s| ca < s.2.cost(&data.scale));
        if proven(ca, p.variants[v].term.params()) && better {
            single = Some((i, v, after));
        }
    }
    single
}

/// Every proposing DOF's kept terms added together, when more than one DOF proposes: each
/// DOF's full variant, then each replaced by a smaller variant of its proposal where that
/// lowers the held-out cost after `penalty` (backward elimination within the set), or left out
/// where that does (a DOF's term that only rode along with the others: a tether's pull found
/// in surge and sway took a yaw lag term with it that raised the held-out cost). Each part is
/// a candidate whose held-out costs are those before and after it is added to the ones before
/// it.
fn together(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    (proposals, siblings): (&[Proposal], &[Proposal]),
    (before, penalty): (&Sums, &Penalty<'_>),
) -> Option<Vec<(Candidate, Variant)>> {
    let all: Vec<&Proposal> = proposals.iter().chain(siblings).collect();
    if all.len() < 2 {
        return None;
    }
    // Per proposal its variant, or none (a sibling left out).
    let mut chosen: Vec<Option<usize>> = all.iter().map(|p| Some(p.variants.len() - 1)).collect();
    let vars = |chosen: &[Option<usize>]| -> Vec<&Variant> {
        (all.iter().zip(chosen))
            .filter_map(|(p, v)| v.map(|v| &p.variants[v]))
            .collect()
    };
    let scored = |chosen: &[Option<usize>]| {
        let vs = vars(chosen);
        let params: usize = vs.iter().map(|v| v.term.params()).sum();
        with_terms(plant, data, aug, vs).cost(&data.scale) + penalty(params)
    };
    let params = |i: usize, v: Option<usize>| v.map_or(0, |v| all[i].variants[v].term.params());
    let mut best = scored(&chosen);
    for i in 0..all.len() {
        let options = (0..all[i].variants.len()).map(Some);
        for v in options.chain([None]) {
            if params(i, v) >= params(i, chosen[i]) {
                continue;
            }
            let mut trial = chosen.clone();
            trial[i] = v;
            if trial.iter().flatten().count() < 2 {
                continue;
            }
            let s = scored(&trial);
            if s < best {
                (best, chosen) = (s, trial);
            }
        }
    }
    let mut with = aug.clone();
    let mut last = *before;
    let mut parts = Vec::new();
    for (p, v) in all.iter().zip(&chosen) {
        let Some(v) = *v else { continue };
        let var = &p.variants[v];
        with.discovered.push(Arc::new(var.term.clone()));
        let after = data.eval(plant, &with, true);
        parts.push((candidate(data, p, var, (&last, &after)), var.clone()));
        last = after;
    }
    Some(parts)
}

/// The forms a DOF's terms may share with the terms of another: what the thrusters do (a
/// command times the clock, a command's lag deficit, its sign, its clip, its loss to the
/// inflow), which acts in every DOF a thruster drives.
fn shared_form(f: &Feature) -> bool {
    matches!(
        f,
        Feature::CommandTime(_)
            | Feature::LagDeficit(..)
            | Feature::CommandSign(_)
            | Feature::Clip(..)
            | Feature::Inflow(_)
    )
}

/// Proposals in the model's DOFs outside `dofs`, cut to their variants made only of the
/// thruster forms ([`shared_form`]) that `proposals` keep: one physics acting in every DOF a
/// thruster drives is structured enough to stand out in one DOF, and below the mark in the
/// others, where its term is still owed (on a twin whose thrust fell 5 % a minute, the
/// exact yaw term alone did not lower the held-out cost: surge, sway and heave still faded).
/// They are tried only together with the proposals ([`together`]).
fn siblings(
    data: &Data,
    pre: &[Prepared],
    rows: &Rows,
    dofs: &[Dof],
    proposals: &[Proposal],
) -> Vec<Proposal> {
    let kinds: Vec<std::mem::Discriminant<Feature>> = (proposals.iter())
        .filter_map(|p| p.variants.last())
        .flat_map(|v| v.term.features.iter())
        .filter(|f| shared_form(f))
        .map(std::mem::discriminant)
        .collect();
    if kinds.is_empty() {
        return Vec::new();
    }
    let others: Vec<usize> = (data.slots.on())
        .filter(|&j| !dofs.contains(&data.slots.dof(j)))
        .collect();
    others
        .into_iter()
        .filter_map(|j| propose(data, pre, rows, j))
        .filter_map(|mut p| {
            p.variants.retain(|v| {
                (v.term.features.iter())
                    .all(|f| shared_form(f) && kinds.contains(&std::mem::discriminant(f)))
            });
            (!p.variants.is_empty()).then_some(p)
        })
        .collect()
}

/// The held-out sums with `vars`' terms added to `aug`.
fn with_terms<'a>(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    vars: impl IntoIterator<Item = &'a Variant>,
) -> Sums {
    let mut with = aug.clone();
    with.discovered
        .extend(vars.into_iter().map(|v| Arc::new(v.term.clone())));
    data.eval(plant, &with, true)
}

/// The candidate of `var` from proposal `p`, with the held-out sums before and after it.
fn candidate(
    data: &Data,
    p: &Proposal,
    var: &Variant,
    (before, after): (&Sums, &Sums),
) -> Candidate {
    let j = p.dof;
    let (named_as, named_terms) = named_in(&var.term.features, &data.slots, j);
    Candidate {
        dof: data.slots.dof(j),
        expression: expression(data.slots.dof(j), &var.terms),
        terms: var.terms.clone(),
        named_as,
        named_terms,
        library_terms: p.library_terms,
        spectrum_peaks_hz: p.peaks.clone(),
        validation_nmae_before: crate::diagnose::nmae_map(before, &data.slots),
        validation_nmae_after: crate::diagnose::nmae_map(after, &data.slots),
        validation_cost_before: before.cost(&data.scale),
        validation_cost_after: after.cost(&data.scale),
        also: Vec::new(),
        model: Vec::new(),
    }
}
