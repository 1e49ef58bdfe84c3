//! The diagnosis as the `diagnose` stage stores it (`diagnosis.json`, `figures.json`): the
//! verdict, what was tested and where the mismatch lies, and the evidence figures.

use super::{Criteria, Data, Mismatch, RegimeShare, Tested, Untested};
use crate::core::dof::Dof;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Reestimated {
    pub parameters: Vec<crate::identify::Estimate>,
    pub validation_nmae: BTreeMap<Dof, f64>,
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub validation_cost: f64,
    pub within_noise: bool,
    /// The named effects the parameters were re-estimated beside (held in the simulation):
    /// empty for the model re-estimated alone (drift).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub beside: Vec<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Baseline {
    pub model: String,
    pub validation_nmae: BTreeMap<Dof, f64>,
    /// Normalised cost on the held-out runs (sum over DOFs of MSE / mean square velocity).
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub validation_cost: f64,
    /// The same cost of the measurement noise alone: what no model can beat.
    pub noise_cost: f64,
    /// The model's parameters re-estimated on the training runs (parameter drift).
    pub reestimated: Reestimated,
    /// True when the verdict is "the parameters drifted": use `reestimated.parameters`.
    pub parameters_reestimated: bool,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Found {
    pub name: String,
    pub dofs: Vec<Dof>,
    pub parameters: BTreeMap<String, f64>,
    pub evidence: String,
    pub validation_nmae_before: BTreeMap<Dof, f64>,
    pub validation_nmae_after: BTreeMap<Dof, f64>,
    pub validation_cost_before: f64,
    pub validation_cost_after: f64,
    /// Effects of the same round that fit the held-out runs within noise of this one: the
    /// runs cannot tell them apart (a lagged thrust and a late, filtered velocity log look
    /// alike on a linear enough vehicle).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub alike: Vec<Alike>,
    /// Effects that, fitted together with this one, fit the held-out runs better by the share
    /// a named effect must gain but by less than the noise margin: possibly there beside it,
    /// too small on these runs to name (a thruster lag beside a sensor delay).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub possibly_beside: Vec<PossiblyBeside>,
    /// For what no named effect explains: the closed form discovery proposed and proved on the
    /// held-out runs ([`super::discover`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub candidate: Option<Candidate>,
}

/// A candidate as good as a named effect on the held-out runs, to within their noise.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Alike {
    pub name: String,
    pub parameters: BTreeMap<String, f64>,
    pub validation_cost: f64,
}

/// An effect possibly present beside a named one ([`Found::possibly_beside`]), with its
/// parameters from the joint fit and the held-out costs of the named effects without and with it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PossiblyBeside {
    pub name: String,
    pub parameters: BTreeMap<String, f64>,
    /// The named effects' parameters in the joint fit, by name (what a run that tells the two
    /// hypotheses apart flies them with).
    #[serde(default)]
    pub beside_parameters: BTreeMap<String, BTreeMap<String, f64>>,
    pub validation_cost_without: f64,
    pub validation_cost_with: f64,
}

impl Found {
    /// The time by which a lag or a sensor delay makes the record late, s: a thruster lag's
    /// time constant, a sensor delay's delay plus its filter. `None` for other effects.
    pub fn lateness_s(&self) -> Option<f64> {
        let at = |k: &str| self.parameters.get(k).copied();
        match self.name.as_str() {
            "thruster_lag" => at("time_constant_s"),
            "sensor_delay" => Some(at("delay_s")? + at("filter_s").unwrap_or(0.0)),
            _ => None,
        }
    }

    /// An effect's name, with the effects the runs cannot tell from it and those possibly
    /// beside it: "thruster_lag (or sensor_delay: these runs cannot tell them apart)",
    /// "sensor_delay (thruster_lag possibly beside it, too small on these runs to name)".
    pub fn name_with_alike(&self) -> String {
        let names = |v: Vec<&str>, sep: &str| v.join(sep);
        let mut said = Vec::new();
        if !self.alike.is_empty() {
            let others = names(self.alike.iter().map(|a| a.name.as_str()).collect(), " or ");
            said.push(format!("or {others}: these runs cannot tell them apart"));
        }
        if !self.possibly_beside.is_empty() {
            let others = (self.possibly_beside.iter()).map(|a| a.name.as_str());
            said.push(format!(
                "{} possibly beside it, too small on these runs to name",
                names(others.collect(), " and ")
            ));
        }
        match said.is_empty() {
            true => self.name.clone(),
            false => format!("{} ({})", self.name, said.join("; ")),
        }
    }

    /// " Fitted together with it, thruster_lag (time_constant_s = 0.148, ...) lowers the
    /// held-out cost from 0.0067 to 0.0050 (26 %), under the 0.0021 ..."
    pub fn possibly_beside_sentence(&self, margin: f64) -> String {
        let each: Vec<String> = (self.possibly_beside.iter())
            .map(|b| {
                let (without, with) = (b.validation_cost_without, b.validation_cost_with);
                format!(
                    " Fitted together with it, {} ({}) lowers the held-out cost from {without:.4} to {with:.4} ({} lower), by more than the share a named effect must gain but under the {margin:.4} by which it must beat the noise: it may be there beside it, too small on these runs to name. A longer run, or one that excites it alone, would tell.",
                    b.name,
                    fmt_params(&b.parameters),
                    pct((without - with) / without),
                )
            })
            .collect();
        each.concat()
    }

    /// " sensor_delay (delay_s = 0.270; ...) fits the held-out runs within noise of it, or the
    /// training runs prefer it: these runs cannot tell them apart. `hydrofit design` proposes
    /// a run that does ..."
    pub fn alike_sentence(&self, noise: f64) -> String {
        let others: Vec<String> = self
            .alike
            .iter()
            .map(|a| {
                let p: Vec<String> = a
                    .parameters
                    .iter()
                    .map(|(k, v)| format!("{k} = {v:.3}"))
                    .collect();
                format!(
                    "{} ({}; held-out cost {:.4})",
                    a.name,
                    p.join(", "),
                    a.validation_cost
                )
            })
            .collect();
        format!(
            " {} fits the held-out runs within noise of it ({:.4}; noise floor {noise:.4}), or the training runs prefer it: these runs cannot tell them apart. `hydrofit design` proposes a run that does (fly it twice, once to train and once held out).",
            others.join(" and "),
            self.validation_cost_after
        )
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Runs {
    pub train: Vec<String>,
    pub validate: Vec<String>,
    pub skipped: Vec<String>,
    /// Runs whose position (for the tether's length, the distance to a wall) is dead-reckoned
    /// from the navigation log's velocity and heading, each with the drift it may carry.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dead_reckoned: Vec<String>,
    /// The navigation log's latency against the depth gauge that the runs measured, taken out
    /// before the diagnosis (a property of the log, not physics to name), s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latency_taken_out_s: Option<f64>,
}

impl Runs {
    /// The record of `data`'s runs, with those left out.
    pub fn of(data: &super::Data, skipped: Vec<String>) -> Runs {
        let all = || data.train.iter().chain(&data.validate);
        Runs {
            train: data.train.iter().map(|r| r.name.clone()).collect(),
            validate: data.validate.iter().map(|r| r.name.clone()).collect(),
            skipped,
            dead_reckoned: all()
                .filter(|r| r.dead_reckoned)
                .map(|r| {
                    format!(
                        "{}: from start_m over {:.0} s; a velocity bias of 1 cm/s would move it {:.1} m",
                        r.name,
                        r.t.last().unwrap_or(&0.0) - r.t.first().unwrap_or(&0.0),
                        super::reckon::drift_m(&r.t)
                    )
                })
                .collect(),
            latency_taken_out_s: None,
        }
    }
}

/// `diagnosis.json` (docs/formats.md), with the evidence behind it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Diagnosis {
    pub baseline: Baseline,
    pub mismatch: Vec<Mismatch>,
    pub effects: Vec<Found>,
    pub verdict: String,
    /// Shares of the CFD model's held-out error per regime.
    pub regimes: Vec<RegimeShare>,
    /// Every hypothesis tested, per greedy round.
    pub hypotheses: Vec<Tested>,
    pub criteria: Criteria,
    pub runs: Runs,
    /// Runs on which the model's simulation diverged: then nothing is diagnosed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub diverged: Vec<String>,
    /// Hypotheses that could not be tested, with what the runs lack (docs/formats.md).
    #[serde(default)]
    pub untested: Vec<Untested>,
    /// Named effects chosen first and dropped once a discovered term explained what they
    /// were chosen for, each with the numbers that decided it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dropped: Vec<String>,
    /// The fits of the vehicle among `from` the diagnosis chose between (when the stage names
    /// no `model` and there are several), each with its held-out error; the chosen one is
    /// `baseline.model`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub started_from: Vec<Start>,
    /// The model's local stability along each run, and the simulation window it led to.
    #[serde(default)]
    pub stability: BTreeMap<String, crate::core::model::stability::Stability>,
    pub elapsed_s: f64,
}

/// An SVG figure with its caption.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Figure {
    pub caption: String,
    pub svg: String,
}

/// One model the diagnosis could start from, with its held-out error.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Start {
    pub model: String,
    pub method: String,
    /// Identified from CFD cases (alone or with pool runs).
    pub from_cfd: bool,
    /// The held-out error cost (as the diagnosis's baseline); NaN when the model's
    /// simulation diverged.
    #[serde(deserialize_with = "crate::core::fsutil::f64_or_nan")]
    pub validation_cost: f64,
    pub validation_nmae: BTreeMap<Dof, f64>,
    /// The one diagnosed.
    pub chosen: bool,
    /// Why it could not be scored, when it could not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

pub const RESULT: &str = "diagnosis.json";

impl Diagnosis {
    /// The answer for a model whose simulation diverges: it is not diagnosed at all.
    pub(crate) fn unsound(
        model: &str,
        data: &Data,
        diverged: Vec<String>,
        crit: &Criteria,
        skipped: Vec<String>,
        elapsed_s: f64,
    ) -> Diagnosis {
        let verdict = format!(
            "Not diagnosed: model `{model}` diverges when simulated under the logged command of {}. A model that leaves the range a vehicle can reach is unsound (a drag term with the wrong sign, a lost DOF, an unstable identification); any effect fitted on top of it would only patch the divergence. Fix the model first (see its parameters' notes), then diagnose again.",
            diverged.join(", ")
        );
        Diagnosis {
            baseline: Baseline {
                model: model.to_string(),
                validation_nmae: BTreeMap::new(),
                validation_cost: f64::NAN,
                noise_cost: data.noise_cost,
                reestimated: Reestimated {
                    parameters: Vec::new(),
                    validation_nmae: BTreeMap::new(),
                    validation_cost: f64::NAN,
                    within_noise: false,
                    beside: Vec::new(),
                },
                parameters_reestimated: false,
            },
            mismatch: Vec::new(),
            effects: Vec::new(),
            verdict,
            regimes: Vec::new(),
            hypotheses: Vec::new(),
            criteria: crit.clone(),
            runs: Runs::of(data, skipped),
            diverged,
            untested: Vec::new(),
            dropped: Vec::new(),
            started_from: Vec::new(),
            stability: BTreeMap::new(),
            elapsed_s,
        }
    }
}

pub const FIGURES: &str = "figures.json";

/// What a diagnose stage writes in place of [`RESULT`] when the model is in DOFs the diagnosis
/// does not simulate: the reason, which the report shows.
pub const NOT_RUN: &str = "not_diagnosed.json";

/// Why the diagnose stage whose output is `dir` diagnosed nothing, when it did not.
pub fn not_run(dir: &Path) -> Option<String> {
    #[derive(Deserialize)]
    struct NotRun {
        reason: String,
    }
    crate::core::fsutil::read_json::<NotRun>(&dir.join(NOT_RUN))
        .ok()
        .map(|n| n.reason)
}

pub fn load(dir: &Path) -> anyhow::Result<(Diagnosis, Vec<Figure>)> {
    Ok((
        crate::core::fsutil::read_json(&dir.join(RESULT))?,
        crate::core::fsutil::read_json(&dir.join(FIGURES))?,
    ))
}

pub(crate) fn pct(x: f64) -> String {
    format!("{:.0} %", 100.0 * x)
}

pub(crate) fn fmt_params(p: &BTreeMap<String, f64>) -> String {
    p.iter()
        .map(|(k, v)| format!("{k} = {v:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One kept term of a discovered closed form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscoveredTerm {
    pub term: String,
    /// Coefficient (for a sine: its amplitude), in the DOF's force unit per unit of the term.
    pub coefficient: f64,
    /// 95 % interval over the bootstrap resamples.
    pub interval: [f64; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequency_hz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_rad: Option<f64>,
    /// Share of the resamples that selected it.
    pub selected_share: f64,
    /// Training runs that selected it alone, of those where it varies.
    pub runs_selected: [usize; 2],
}

/// The closed form proposed for what the named effects leave, proven on held-out runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub dof: Dof,
    /// e.g. `Z += 11.8 sin(2 pi 0.420 t + 0.30) N`.
    pub expression: String,
    pub terms: Vec<DiscoveredTerm>,
    /// The named effect it is in disguise, if it is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub named_as: Option<String>,
    /// The named effects whose form one of its terms has (a constant heave force is
    /// `net_buoyancy`), though the whole may be more.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub named_terms: Vec<String>,
    /// Terms in the library it was chosen from.
    pub library_terms: usize,
    /// Significant peaks of the residual's spectrum, Hz.
    pub spectrum_peaks_hz: Vec<f64>,
    pub validation_nmae_before: BTreeMap<Dof, f64>,
    pub validation_nmae_after: BTreeMap<Dof, f64>,
    pub validation_cost_before: f64,
    pub validation_cost_after: f64,
    /// Terms found after this one in other DOFs, each with the terms before it in the model
    /// (a battery's sag acts in every DOF a thruster drives): each proved on the held-out
    /// runs by the same margin, its costs from the cost the terms before it left.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub also: Vec<Candidate>,
    /// Every term of the candidate (this one's and the `also`s'), as the simulation adds them.
    #[serde(skip)]
    pub model: Vec<std::sync::Arc<crate::diagnose::discover::Discovered>>,
}

impl Candidate {
    /// The held-out error cost after every term of the candidate.
    pub fn cost_after_all(&self) -> f64 {
        self.also
            .last()
            .map_or(self.validation_cost_after, |c| c.validation_cost_after)
    }

    /// The coefficients of every term the simulation adds (a sine's amplitude and phase
    /// counting two), as the search's per-parameter penalty counts them.
    pub fn params(&self) -> f64 {
        self.model.iter().map(|t| t.params() as f64).sum()
    }

    /// This candidate and the ones after it.
    pub fn parts(&self) -> impl Iterator<Item = &Candidate> {
        std::iter::once(self).chain(&self.also)
    }
}
