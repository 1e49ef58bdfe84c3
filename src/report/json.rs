//! `parameters.json` and `validation.json`, exactly in the shape docs/formats.md gives.

use crate::core::provenance::InputFile;
use crate::identify::result::FitResult;
use crate::validate::Metrics;
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Serialize)]
pub struct Parameter {
    pub name: String,
    pub value: f64,
    pub unit: String,
    /// `null` when the method gives none.
    #[serde(serialize_with = "crate::core::finite::nan_as_null")]
    pub stderr: f64,
    /// Range over seeded restarts (qpso, pso, ga).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interval: Option<[f64; 2]>,
    pub identifiable: bool,
    /// Why it is not identifiable, when there is more to say than its uncertainty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// The model (fit stage) this value belongs to.
    pub model: String,
    pub stage: String,
    pub method: String,
    pub settings: serde_json::Value,
    pub inputs: Vec<InputFile>,
}

#[derive(Debug, Serialize)]
pub struct Parameters {
    pub parameters: Vec<Parameter>,
}

pub fn parameters(fits: &[FitResult]) -> Parameters {
    let mut out = Vec::new();
    for f in fits {
        let inputs: Vec<InputFile> = f.input_files();
        let mut settings = f.settings.clone();
        // Deterministic methods have no seed; say so rather than leave the reader guessing.
        if let Some(obj) = settings.as_object_mut() {
            obj.entry("seed").or_insert(serde_json::Value::Null);
        }
        for p in &f.fit.parameters {
            out.push(Parameter {
                name: p.name.clone(),
                value: p.value,
                unit: p.unit.clone(),
                stderr: p.stderr,
                interval: p.interval,
                identifiable: p.identifiable,
                note: p.note.clone(),
                model: f.stage.clone(),
                stage: f.stage.clone(),
                method: f.method.clone(),
                settings: settings.clone(),
                inputs: inputs.clone(),
            });
        }
        // The command path's parameters, identified with the model.
        let mut extra = |name: &str, value, unit: &str, stderr, interval, identifiable, note| {
            out.push(Parameter {
                name: name.into(),
                value,
                unit: unit.into(),
                stderr,
                interval,
                identifiable,
                note: Some(note),
                model: f.stage.clone(),
                stage: f.stage.clone(),
                method: f.method.clone(),
                settings: settings.clone(),
                inputs: inputs.clone(),
            });
        };
        if let Some(l) = &f.fit.command_lag {
            let (stderr, note) = lag_note(l);
            let range = l.lag_range();
            let spread = range.map_or(0.0, |[a, b]| b - a);
            let sure = l.estimated
                && stderr.is_finite()
                && stderr < 0.5 * l.value_s
                && spread <= l.value_s
                && !l.at_search_end();
            extra("T_cmd", l.value_s, "s", stderr, range, sure, note);
        }
        if let Some(g) = &f.fit.thrust_gain {
            let sure = g.consistent && g.stderr < 0.1 * g.value.abs();
            extra("k_thrust", g.value, "-", g.stderr, None, sure, g.sentence());
        }
    }
    Parameters { parameters: out }
}

/// The command lag's standard error (0 when it was set, not estimated) and what it is.
fn lag_note(l: &crate::identify::lag::LagEstimate) -> (f64, String) {
    if !l.estimated {
        return (0.0, "the lag between the logged command and the force, set in the fit's settings (command_lag), not identified".into());
    }
    let stderr = if l.stderr_s.is_finite() {
        l.stderr_s
    } else {
        l.value_s
    };
    let how = match l.searched_on_candidates {
        Some([without, with]) => format!(
            "searched once on the model with every candidate constant and coupling, before they were chosen, where it lowered the output error of the training runs from {without:.4} to {with:.4}; this model's at it is {:.4}",
            l.cost_with
        ),
        None => format!(
            "it lowered the output error of the training runs from {:.4} to {:.4}",
            l.cost_without, l.cost_with
        ),
    };
    let mut note = format!(
        "the first-order lag between the logged command and the force (thrusters, command path), identified with the model: {how}; its standard error counts it as a parameter beside the coefficients, whose errors include what they trade with it"
    );
    if let Some([a, b]) = l.lag_range() {
        note.push_str(&format!(
            "; refitted with the lag held from {a:.2} to {b:.2} s the output error stays within {:.0} % of this fit's, so the runs do not tell those lags apart (the interval; the coefficients' intervals are their values over those lags)",
            100.0 * crate::identify::lag::DEMAND
        ));
    }
    if l.at_search_end() {
        note.push_str(&format!(
            "; it sits at the end of the searched range ({} s), so the runs ask for more lag than a thruster's command path has: it stands in for something else (a delay in the velocity log, such as a navigation filter's latency, or a slower dynamic the model lacks), and is not identifiable",
            crate::identify::lag::MAX_LAG_S
        ));
    }
    (stderr, note)
}

/// The parameters of the field-trial identifiers (ARX coefficients, integrated-regressor and
/// adaptive estimates), each with its stage's provenance; `model` is `<stage>.<structure>`
/// where a stage compares several models.
pub fn field_parameters(results: &[crate::field::Field]) -> Vec<Parameter> {
    let mut out = Vec::new();
    for r in results.iter().map(|f| &f.result) {
        for p in &r.parameters {
            out.push(Parameter {
                name: p.name.clone(),
                value: p.value,
                unit: p.unit.clone(),
                stderr: p.stderr,
                interval: None,
                identifiable: p.stderr.is_finite(),
                note: None,
                model: p
                    .model
                    .as_ref()
                    .map_or(r.stage.clone(), |m| format!("{}.{m}", r.stage)),
                stage: r.stage.clone(),
                method: r.method.clone(),
                settings: r.settings.clone(),
                inputs: r.inputs.clone(),
            });
        }
    }
    out
}

/// docs/formats.md's per-DOF metrics, plus the residual whiteness where it was measured (pool runs).
#[derive(Debug, Clone, Serialize)]
pub struct DofMetrics {
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Share of residual autocorrelation lags outside the 95 % band (seed 000).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_acf_outside_band: Option<f64>,
    /// Pool runs: NMAE of the prediction 1, 10 and 100 samples ahead from the fused state.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub nmae_ahead: BTreeMap<usize, f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RunScore {
    pub run: String,
    pub role: String,
    pub dofs: BTreeMap<String, DofMetrics>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ModelScore {
    pub model: String,
    pub runs: Vec<RunScore>,
    /// The DOFs in which the model does not beat both baselines on the held-out pool runs.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub below_baselines: Vec<crate::validate::pool::Shortfall>,
    /// A model read from a simulator's file: the DOFs in which it predicts the held-out runs
    /// worse than the identified model.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub behind_identified: Vec<crate::validate::pool::Behind>,
    /// The DOFs in which the model predicts a few samples ahead clearly worse than the
    /// first-order baseline on the held-out pool runs.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub short_horizon: Vec<crate::validate::pool::ShortHorizon>,
}

#[derive(Debug, Serialize)]
pub struct Validation {
    pub models: Vec<ModelScore>,
    /// What every model must beat on held-out pool runs besides predicting rest (NMAE 1): the
    /// first-order model per DOF, scored on every run like the models.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub baselines: Vec<ModelScore>,
}

#[cfg(test)]
mod tests {
    use crate::identify::lag::LagEstimate;

    /// A lag searched on the model with every candidate is said with that model's two output
    /// errors, and this model's beside them: the note never claims the lag lowered an error
    /// from one model's figure to another's (on the BlueROV2 Heavy's runs it read "lowered
    /// from 0.2876 to 0.3010").
    #[test]
    fn the_lag_note_compares_one_model_with_itself() {
        let searched = LagEstimate {
            cost_with: 0.3012,
            searched_on_candidates: Some([0.2950, 0.2876]),
            ..LagEstimate::found(0.16, f64::NAN)
        };
        let (_, note) = super::lag_note(&searched);
        assert!(note.contains("with every candidate"), "{note}");
        assert!(note.contains("from 0.2950 to 0.2876"), "{note}");
        assert!(note.contains("this model's at it is 0.3012"), "{note}");
        assert!(!note.contains("NaN"), "{note}");
        let own = LagEstimate {
            cost_with: 0.5,
            ..LagEstimate::found(0.2, 0.6)
        };
        let (_, note) = super::lag_note(&own);
        assert!(note.contains("from 0.6000 to 0.5000"), "{note}");
        assert!(!note.contains("end of the searched range"), "{note}");
    }

    /// A lag at the top of the searched range (0.49 s on the TAUV's runs, polished up against
    /// 0.5 s) is not a finding: flagged with the reason.
    #[test]
    fn a_lag_at_the_end_of_its_search_is_not_identifiable() {
        let top = LagEstimate {
            cost_with: 0.52,
            stderr_s: 0.012,
            ..LagEstimate::found(0.493, 0.69)
        };
        assert!(top.at_search_end());
        let (_, note) = super::lag_note(&top);
        assert!(note.contains("end of the searched range (0.5 s)"), "{note}");
        let inside = LagEstimate {
            stderr_s: 0.012,
            ..LagEstimate::found(0.45, 0.69)
        };
        assert!(!inside.at_search_end());
    }
}
