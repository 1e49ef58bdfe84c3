//! Which hypotheses the runs can test, and for those they cannot, what they lack
//! (docs/formats.md: listed apart, never skipped silently).

use super::{Data, Hypothesis};
use serde::{Deserialize, Serialize};

/// A hypothesis the runs cannot test, and what they lack for it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Untested {
    pub name: String,
    pub missing: String,
}

/// Every hypothesis some run lacks the data for, with what is missing and where (docs/formats.md:
/// listed apart, never skipped silently).
pub fn untested(data: &Data) -> Vec<Untested> {
    let all: Vec<&super::Run> = data.train.iter().chain(&data.validate).collect();
    data.effects
        .iter()
        .filter(|h| !applicable(h, data))
        .map(|h| {
            if !acts_in_slots(h, data) {
                let dofs: Vec<String> = h.acts_in.iter().map(|d| d.to_string()).collect();
                return Untested {
                    name: h.name.to_string(),
                    missing: format!(
                        "a model that moves in {}, where the table's form of the effect acts (this one is compared in {} only; discovery still looks for other forms there)",
                        dofs.join(" or "),
                        compared(data)
                    ),
                };
            }
            // Grouped by what is missing, runs named under each.
            let mut lacking: Vec<(&str, Vec<&str>)> = Vec::new();
            for r in all.iter().filter(|r| !h.needs.met_by(r)) {
                let what = h.needs.missing_in(r);
                match lacking.iter_mut().find(|(w, _)| *w == what) {
                    Some((_, runs)) => runs.push(r.name.as_str()),
                    None => lacking.push((what, vec![r.name.as_str()])),
                }
            }
            let missing: Vec<String> = lacking
                .iter()
                .map(|(what, runs)| format!("{what} is missing in {}", runs.join(", ")))
                .collect();
            Untested {
                name: h.name.to_string(),
                missing: missing.join("; "),
            }
        })
        .collect()
}

pub(super) fn applicable(h: &Hypothesis, data: &Data) -> bool {
    let all = || data.train.iter().chain(&data.validate);
    acts_in_slots(h, data) && all().all(|r| h.needs.met_by(r))
}

/// Whether the effect acts in a DOF the model is compared in.
fn acts_in_slots(h: &Hypothesis, data: &Data) -> bool {
    h.acts_in.is_empty() || h.acts_in.iter().any(|d| data.slots.slot(*d).is_some())
}

/// The DOFs the model is compared in, in words.
fn compared(data: &Data) -> String {
    let on: Vec<String> = data
        .slots
        .on()
        .map(|j| data.slots.dof(j).to_string())
        .collect();
    on.join(", ")
}
