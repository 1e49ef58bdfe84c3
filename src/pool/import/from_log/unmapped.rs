//! What a log gives with nothing mapped, for `hydrofit inspect`.

use super::super::log_spec::{LogSpec, Source, Stack};
use super::{Chosen, aiding, default_stack, read_signals, sources, span};
use hydrofit_logs::Log as VehicleLog;

/// What a run folder reading `log` with nothing mapped would read (for `hydrofit inspect`):
/// the stack, each signal's topic and fields, and notes: the defaults the log lacks, and
/// whether the autopilot's velocity was aided over the whole log ([`aiding`]).
pub fn unmapped(log: &VehicleLog) -> (Stack, Vec<(String, Source)>, Vec<String>) {
    let spec = LogSpec::default();
    let stack = default_stack(log);
    let mut notes = Vec::new();
    let mut chosen = sources(log, &spec, None, &mut notes);
    let shown = log.path.display().to_string();
    // The velocity's aiding: its topic and its status read over the whole log.
    let checked: Vec<(&'static str, Chosen)> = (chosen.iter())
        .filter(|(k, _)| *k == "velocity" || aiding::is_status(k))
        .map(|(k, c)| (*k, c.clone()))
        .collect();
    if checked.len() == 2 {
        let all: Vec<usize> = (0..log.topics.len()).collect();
        let read = span(log, &all, &spec, &shown)
            .and_then(|(a, b)| read_signals(log, &checked, spec.time, a, b, &shown));
        let before = notes.len();
        match read {
            Ok(mut samples) => {
                let n = samples.get("velocity").map_or(0, |v| v.t.len());
                aiding::keep_aided(&mut samples, &shown, &mut notes);
                if notes.len() == before {
                    notes.push(format!(
                        "the autopilot's filter status says all {n} velocity samples were aided"
                    ));
                }
            }
            Err(e) => notes.push(format!("the velocity's aiding could not be read: {e}")),
        }
    }
    chosen.retain(|(k, _)| !aiding::is_status(k));
    let signals = (chosen.into_iter())
        .map(|(k, c)| (k.to_string(), c.source))
        .collect();
    (stack, signals, notes)
}
