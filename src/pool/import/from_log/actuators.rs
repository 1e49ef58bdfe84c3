//! The actuator commands of a vehicle steered by fins and propeller speed, read from its log
//! (`log.actuators`): one field per actuator, each headed by its `columns` entry as
//! `actuators.csv`'s header would head it (`fin_top_deg`, `prop_rpm`), and converted to SI as
//! that file is, so the field-trial stages cannot tell the log from the file.

use super::super::actuators::{Actuators, heads};
use super::super::csvlog::Log;
use super::super::log_spec::Source;
use super::Samples;
use crate::core::diag::InputError;

/// Checks a signal's `columns`: only the actuators have them, one per field, each with a unit
/// suffix and a name of its own.
pub(super) fn check_columns(
    name: &str,
    s: &Source,
    fields: usize,
    shown: &str,
) -> Result<(), InputError> {
    if name != "actuators" {
        if s.columns.is_empty() {
            return Ok(());
        }
        return Err(InputError::file(
            shown,
            format!("the {name} on `{}` has `columns`", s.topic),
            format!("`columns` names actuators (`log.actuators`); leave it out of `log.{name}`"),
        ));
    }
    if s.columns.len() != fields {
        return Err(InputError::file(
            shown,
            format!(
                "the actuators on `{}` name {fields} fields and {} columns",
                s.topic,
                s.columns.len()
            ),
            "give each field its column, in order: `columns: [fin_top_deg, prop_rpm]` (name and unit: _deg, _rad, _rpm, _rad_s, _pct, _N, _Nm)",
        ));
    }
    heads(&s.columns).map(|_| ()).map_err(|e| {
        InputError::file(
            shown,
            format!("the actuators on `{}`: {}", s.topic, e.what),
            e.fix,
        )
    })
}

/// The actuator log from the signal's samples, in SI units. A message that lacks a field
/// (an array shorter than the fields named) is left out, and the notes say how many.
pub(super) fn lay_out(s: &Samples, source: &Source, shown: &str) -> Result<Actuators, InputError> {
    // Checked when the signal was compiled.
    let mut a = heads(&source.columns).map_err(|e| InputError::file(shown, e.what, e.fix))?;
    let whole: Vec<usize> = (0..s.t.len())
        .filter(|&k| s.rows[k].iter().all(|x| x.is_finite()))
        .collect();
    if whole.len() < 2 {
        return Err(InputError::file(
            shown,
            format!(
                "the actuators on `{}` have {} whole messages in the run's span",
                s.topic,
                whole.len()
            ),
            "check `log.actuators` against `hydrofit inspect` of the log, and the run's `span_s`",
        ));
    }
    a.log = Log {
        t: whole.iter().map(|&k| s.t[k]).collect(),
        cols: (a.factors.iter().enumerate())
            .map(|(j, f)| whole.iter().map(|&k| s.rows[k][j] * f).collect())
            .collect(),
        notes: Vec::new(),
        present: vec![true; a.names.len()],
    };
    let left = s.t.len() - whole.len();
    if left > 0 {
        a.log.notes.push(format!(
            "{shown}: {left} of {} actuator messages on `{}` lack a field named, left out",
            s.t.len(),
            s.topic
        ));
    }
    a.log.dedupe_times(&format!("{shown}:{}", s.topic));
    Ok(a)
}
