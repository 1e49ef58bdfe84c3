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
mod search;
mod select;
mod term;

use super::result::{Candidate, DiscoveredTerm, Found, pct};
use crate::core::dof::Dof;
pub use library::{Feature, Prepared};
pub use search::{beside, discover};
pub use select::{KEEP_SHARE, MAX_TERMS};
use std::collections::BTreeMap;
use std::fmt::Write as _;
pub use term::Discovered;

impl Candidate {
    /// Every part's expression, `; `-separated.
    pub fn expressions(&self) -> String {
        let all: Vec<&str> = self.parts().map(|c| c.expression.as_str()).collect();
        all.join("; ")
    }

    /// The `unexplained` entry with the closed form discovery proposed: named as the effect it is
    /// in disguise when it is one, its held-out errors after the term, its evidence said.
    /// The verdict's sentence for it.
    pub fn verdict_sentence(&self) -> String {
        let form = |c: &Candidate| {
            let named = c.named_as.as_ref();
            format!(
                "{}{}",
                c.expression,
                named.map_or(String::new(), |n| format!(" (the form of {n})"))
            )
        };
        if !self.also.is_empty() && self.validation_cost_after >= self.validation_cost_before {
            // One physics in several DOFs, found together: no part lowers the cost alone.
            let all: Vec<String> = self.parts().map(form).collect();
            return format!(
                " Discovery proposes a closed form for it in {} DOFs at once: {}, which together lower the held-out error cost from {:.4} to {:.4}.",
                all.len(),
                all.join("; "),
                self.validation_cost_before,
                self.cost_after_all()
            );
        }
        let mut out = format!(
            " Discovery proposes a closed form for it: {}, which lowers the held-out error cost from {:.4} to {:.4}",
            form(self),
            self.validation_cost_before,
            self.validation_cost_after
        );
        for c in &self.also {
            let _ = write!(
                out,
                "; beside it, {} {} {:.4}",
                form(c),
                if c.validation_cost_after < c.validation_cost_before {
                    "lowers it further to"
                } else {
                    // Found with the others at once: alone it may not lower the cost.
                    "takes it to"
                },
                c.validation_cost_after
            );
        }
        out + "."
    }

    /// `found` (the `unexplained` entry) with this candidate; renamed as the named effect it
    /// is in disguise, unless that effect is among `taken` (already named: the term then
    /// corrects it, as a lag-deficit term beside a thruster lag fitted long, and stays
    /// `unexplained` with its form said).
    pub fn into_found(self, mut found: Found, taken: &[&str]) -> Found {
        for c in self.parts() {
            c.write_evidence(&mut found.evidence);
        }
        // Named only when every part is the same named effect's form.
        let named = self.named_as.clone().filter(|n| {
            !taken.contains(&n.as_str())
                && self
                    .also
                    .iter()
                    .all(|c| c.named_as.as_deref() == Some(n.as_str()))
        });
        if let Some(n) = named {
            let _ = write!(
                found.evidence,
                " The term is the form of {n}: reported under that name."
            );
            found.name = n;
            found.parameters = self
                .parts()
                .flat_map(|c| &c.terms)
                .map(|t| (t.term.clone(), t.coefficient))
                .collect();
        }
        found.dofs = self.parts().map(|c| c.dof).collect();
        let last = self.also.last().unwrap_or(&self);
        found.validation_nmae_after = last.validation_nmae_after.clone();
        found.validation_cost_after = self.cost_after_all();
        found.candidate = Some(self);
        found
    }

    /// What this term is and what it does on the held-out runs, for the evidence.
    fn write_evidence(&self, evidence: &mut String) {
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
            evidence,
            " Discovery, a sparse regression of the residual force on {} candidate terms, proposes {} from {}; added to the model it {} the held-out error cost from {:.4} to {:.4} ({}).",
            self.library_terms,
            self.expression,
            terms.join(" and "),
            // A part found with others at once may not lower the cost alone.
            if self.validation_cost_after < self.validation_cost_before {
                "lowers"
            } else {
                "takes"
            },
            self.validation_cost_before,
            self.validation_cost_after,
            nmae_change(
                &self.validation_nmae_before,
                &self.validation_nmae_after,
                self.dof
            )
        );
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
pub(super) fn expression(dof: Dof, terms: &[DiscoveredTerm]) -> String {
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

/// The named effect a discovered term in slot `j` is in disguise (every feature the same
/// one), and the named effects whose form one of its features has.
pub(super) fn named_in(
    features: &[Feature],
    slots: &super::Slots,
    j: usize,
) -> (Option<String>, Vec<String>) {
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
        // u v, the Munk moment's form, though both are horizontal motions.
        assert_eq!(pool(Feature::Product(0, 1), 3), None);
        assert_eq!(Feature::Product(0, 0).label(&Slots::POOL), "u^2");
        assert_eq!(Feature::AnchorOffset(1).label(&Slots::POOL), "(p - p_a)_y");
        for f in [
            Feature::AnchorOffset(0),
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
