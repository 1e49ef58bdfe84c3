//! Discovery beyond the vocabulary: when a structured residual remains after the named effects,
//! propose its closed form (sparse regression over a library of physically readable terms, in
//! the spirit of SINDy and its discrepancy-modelling variants) and keep it only if it holds up.
//!
//! 1. **The residual generalised force** on the training runs: the model's equation error on
//!    the fused state, `M (a_measured - a_model)`, per DOF, with the named effects already kept
//!    inside the model, in integrated form (seed 000's idea): over windows of `WINDOW_S`, the
//!    measured velocity change against the model's acceleration integrated at the measured
//!    state, and every library term averaged over the same window. No noisy velocity is
//!    differentiated, and no smoothing shifts one side against the other. Each row is
//!    weighted by its uncertainty from the fusion (the fused velocities' variances at the
//!    window's ends, through the difference quotient and the mass).
//! 2. **A library** for the DOF: velocities, `|x| x` and cross products, the commands, each
//!    command's first-order lag deficit (`lowpass(X) - X`), the own command's sign, products of
//!    commands across DOFs, pool-frame position, depth and depth-shaped drag, distance to the
//!    nearest wall, tether length, heading (sin, cos: a current) and a constant, and a sine
//!    pair (amplitude and phase) at each frequency where the residual's pooled periodogram has
//!    a significant peak (over `PEAK_RATIO` times its median).
//! 3. **Sparse selection that holds up**: forward stepwise least squares (a term enters only if
//!    it lowers the residual's sum of squares by `MIN_DROP` of what is left; at most
//!    `MAX_TERMS`), repeated on `RESAMPLES` block-bootstrap resamples of the training runs and
//!    on each training run alone. A term is kept only if selected on `KEEP_SHARE` of the
//!    resamples and on most of the runs where it varies. Coefficients carry the resamples' 95 %
//!    interval.
//! 4. **Proof on held-out runs**: the term is added to the simulator as a force and must lower
//!    the held-out error cost by the margin a named effect must (`Criteria`), or nothing is
//!    reported.
//! 5. **Names where they fit**: a constant heave force is `net_buoyancy`, a command's lag
//!    deficit `thruster_lag`, a `|u| v` cross term `coupled_drag`, heading terms
//!    `water_current`, the command's sign `thruster_deadband`, the wall distance `wall_effect`,
//!    the tether length `tether_drag`; anything else stays `unexplained`, with its expression.

mod figures;
mod library;
mod rows;
mod select;
mod term;

use super::result::{Candidate, DiscoveredTerm, Figure, Found, pct};
use super::{Augmentation, Criteria, Data};
use crate::core::dof::Dof;
use crate::core::model::Plant;
use library::prepare;
pub use library::{Feature, Prepared};
use rows::residual_rows;
pub use select::{KEEP_SHARE, MAX_TERMS};
use select::{Proposal, Variant, propose};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::Arc;
pub use term::Discovered;

impl Candidate {
    /// The `unexplained` entry with the closed form discovery proposed: named as the effect it is
    /// in disguise when it is one, its held-out errors after the term, its evidence said.
    /// The verdict's sentence for it.
    pub fn verdict_sentence(&self) -> String {
        format!(
            " Discovery proposes a closed form for it: {}{}, which lowers the held-out error cost from {:.4} to {:.4}.",
            self.expression,
            self.named_as
                .as_ref()
                .map_or(String::new(), |n| format!(" (the form of {n})")),
            self.validation_cost_before,
            self.validation_cost_after
        )
    }

    pub fn into_found(self, mut found: Found) -> Found {
        let terms: Vec<String> = self
            .terms
            .iter()
            .map(|t| {
                format!(
                    "{} (95 % interval {:.4} to {:.4}; kept on {} of the resamples and {} of {} runs)",
                    t.term,
                    t.interval[0],
                    t.interval[1],
                    pct(t.selected_share),
                    t.runs_selected[0],
                    t.runs_selected[1]
                )
            })
            .collect();
        let _ = write!(
            found.evidence,
            " Discovery, a sparse regression of the residual force on {} candidate terms, proposes {} from {}; added to the model it lowers the held-out error cost from {:.4} to {:.4} ({}).",
            self.library_terms,
            self.expression,
            terms.join(" and "),
            self.validation_cost_before,
            self.validation_cost_after,
            nmae_change(
                &self.validation_nmae_before,
                &self.validation_nmae_after,
                self.dof
            )
        );
        if let Some(n) = &self.named_as {
            let _ = write!(
                found.evidence,
                " The term is the form of {n}: reported under that name."
            );
            found.name = n.clone();
            found.parameters = self
                .terms
                .iter()
                .map(|t| (t.term.clone(), t.coefficient))
                .collect();
        }
        found.dofs = vec![self.dof];
        found.validation_nmae_after = self.validation_nmae_after.clone();
        found.validation_cost_after = self.validation_cost_after;
        found.candidate = Some(self);
        found
    }
}

/// `held-out heave NMAE 0.310 -> 0.070`.
fn nmae_change(before: &BTreeMap<Dof, f64>, after: &BTreeMap<Dof, f64>, d: Dof) -> String {
    match (before.get(&d), after.get(&d)) {
        (Some(b), Some(a)) => format!("held-out {d} NMAE {b:.3} -> {a:.3}"),
        _ => "no held-out NMAE".into(),
    }
}

/// `Z += 11.8 sin(2 pi 0.420 t + 0.30) N`.
fn expression(dof: Dof, terms: &[DiscoveredTerm]) -> String {
    let sym = dof.force();
    let parts: Vec<String> = terms
        .iter()
        .map(|t| match (t.frequency_hz, t.phase_rad) {
            (Some(f), Some(ph)) => format!(
                "{:.3} sin(2 pi {f:.3} t {} {:.2})",
                t.coefficient,
                if ph < 0.0 { "-" } else { "+" },
                ph.abs()
            ),
            _ if t.term == "1" => format!("{:.4}", t.coefficient),
            _ => format!("{:.4} {}", t.coefficient, t.term),
        })
        .collect();
    format!(
        "{sym} += {} {}",
        parts.join(" + ").replace("+ -", "- "),
        dof.force_unit()
    )
}

/// The discovery for the DOFs `dofs` where a structured residual is left after `aug`: the
/// proven candidate, if any, and its figures.
pub fn discover(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    dofs: &[Dof],
    crit: &Criteria,
) -> anyhow::Result<Option<(Candidate, Vec<Figure>)>> {
    let rows = residual_rows(plant, aug, data);
    if rows.at.len() < 100 {
        return Ok(None);
    }
    let pre: Vec<Prepared> = data.train.iter().map(prepare).collect();
    let before = data.eval(plant, aug, true);
    let cb = before.cost(&data.scale);
    let mut best: Option<(Candidate, Proposal, Variant)> = None;
    for j in data.slots.among(dofs) {
        let Some(p) = propose(data, &pre, &rows, j) else {
            continue;
        };
        // The variant with the lowest held-out cost after the per-parameter penalty.
        let scored: Vec<(usize, f64, super::Sums)> = p
            .variants
            .iter()
            .enumerate()
            .map(|(v, var)| {
                let mut with = aug.clone();
                with.discovered = Some(Arc::new(var.term.clone()));
                let after = data.eval(plant, &with, true);
                let penalised = after.cost(&data.scale)
                    + crit.gain_per_parameter * cb * var.term.params() as f64;
                (v, penalised, after)
            })
            .collect();
        let Some((v, _, after)) = scored.into_iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
            continue;
        };
        let var = p.variants[v].clone();
        let ca = after.cost(&data.scale);
        let gain = (cb - ca) / cb.max(1e-300);
        let proven = gain >= crit.min_gain + crit.gain_per_parameter * var.term.params() as f64
            && cb - ca >= crit.min_noise_multiple * data.noise_cost;
        if !proven
            || best
                .as_ref()
                .is_some_and(|b| b.0.validation_cost_after <= ca)
        {
            continue;
        }
        let (named_as, named_terms) = named_in(&var.term.features, &data.slots, j);
        let candidate = Candidate {
            dof: data.slots.dofs[j],
            expression: expression(data.slots.dofs[j], &var.terms),
            terms: var.terms.clone(),
            named_as,
            named_terms,
            library_terms: p.library_terms,
            spectrum_peaks_hz: p.peaks.clone(),
            validation_nmae_before: super::nmae_map(&before, &data.slots),
            validation_nmae_after: super::nmae_map(&after, &data.slots),
            validation_cost_before: cb,
            validation_cost_after: ca,
        };
        best = Some((candidate, p, var));
    }
    let Some((candidate, p, var)) = best else {
        return Ok(None);
    };
    let figures = figures::figures(data, &rows, &pre, &candidate, &p, &var)?;
    Ok(Some((candidate, figures)))
}

/// The named effect a discovered term in slot `j` is in disguise (every feature the same
/// one), and the named effects whose form one of its features has.
fn named_in(features: &[Feature], slots: &super::Slots, j: usize) -> (Option<String>, Vec<String>) {
    let named: Vec<Option<&str>> = features.iter().map(|f| f.named(slots, j)).collect();
    let named_as = match named.first() {
        Some(Some(n)) if named.iter().all(|x| *x == Some(n)) => Some(n.to_string()),
        _ => None,
    };
    let mut named_terms: Vec<String> = named.iter().flatten().map(|n| n.to_string()).collect();
    named_terms.dedup();
    (named_as, named_terms)
}

#[cfg(test)]
mod tests {
    use super::rows::window_mean;
    use super::*;
    use crate::diagnose::Slots;

    #[test]
    fn named_effects_in_disguise_are_named_and_the_rest_are_not() {
        assert_eq!(
            Feature::Constant.named(&Slots::POOL, 2),
            Some("net_buoyancy")
        );
        assert_eq!(
            Feature::Constant.named(&Slots::POOL, 0),
            None,
            "a body-frame constant surge force"
        );
        assert_eq!(
            Feature::LagDeficit(1, 0.3).named(&Slots::POOL, 1),
            Some("thruster_lag")
        );
        assert_eq!(
            Feature::LagDeficit(0, 0.3).named(&Slots::POOL, 3),
            None,
            "another DOF's lag"
        );
        assert_eq!(
            Feature::AbsProduct(0, 1).named(&Slots::POOL, 1),
            Some("coupled_drag")
        );
        assert_eq!(
            Feature::SinHeading.named(&Slots::POOL, 0),
            Some("water_current")
        );
        assert_eq!(
            Feature::CommandSign(3).named(&Slots::POOL, 3),
            Some("thruster_deadband")
        );
        // Off-diagonal quadratic drag, in any DOF; a DOF's own quadratic drag is drift, and a
        // signed product of two motions a Coriolis term.
        let pool = |f: Feature, j: usize| f.named(&Slots::POOL, j);
        assert_eq!(pool(Feature::Quadratic(1), 3), Some("coupled_drag"));
        assert_eq!(pool(Feature::Quadratic(3), 3), None);
        assert_eq!(pool(Feature::AbsProduct(3, 2), 2), Some("coupled_drag"));
        assert_eq!(pool(Feature::Product(1, 3), 1), None);
        for f in [
            Feature::Sine(0.42),
            Feature::Command(0),
            Feature::NearSurfaceDrag(0, 0.5),
            Feature::CommandProduct(0, 3),
        ] {
            assert_eq!(f.named(&Slots::POOL, 3), None, "{}", f.label(&Slots::POOL));
        }
    }

    #[test]
    fn a_sine_reads_as_amplitude_and_phase() {
        let t = DiscoveredTerm {
            term: Feature::Sine(0.42).label(&Slots::POOL),
            coefficient: 11.8,
            interval: [11.0, 12.5],
            frequency_hz: Some(0.42),
            phase_rad: Some(0.3),
            selected_share: 1.0,
            runs_selected: [4, 4],
        };
        assert_eq!(
            expression(Dof::Heave, &[t]),
            "Z += 11.800 sin(2 pi 0.420 t + 0.30) N"
        );
        let x = DiscoveredTerm {
            term: "X".into(),
            coefficient: -0.06,
            interval: [-0.07, -0.05],
            frequency_hz: None,
            phase_rad: None,
            selected_share: 0.9,
            runs_selected: [3, 3],
        };
        assert_eq!(expression(Dof::Yaw, &[x]), "N += -0.0600 X N m");
    }

    #[test]
    fn a_window_mean_is_the_trapezoid_over_the_window() {
        let t: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        // The mean of t over [0, 1] is 0.5; of t^2 it is about 1/3.
        assert!((window_mean(&t, 0, 10, |k| t[k]) - 0.5).abs() < 1e-12);
        assert!((window_mean(&t, 0, 10, |k| t[k] * t[k]) - 1.0 / 3.0).abs() < 2e-3);
    }
}
