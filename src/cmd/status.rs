//! `hydrofit status`: what a build would run, and why; `up to date` when nothing.

use crate::pipeline::{Plan, explain};
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path, show_fields: bool) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::stage::KINDS)?;
    let cache = plan.cache();
    let records = cache.records();
    let mut stale = 0;
    for (i, inst) in plan.graph.instances.iter().enumerate() {
        let key = &plan.keys[i];
        let damaged = cache.has(key).then(|| cache.verify(key).err()).flatten();
        if cache.has(key) && damaged.is_none() {
            continue;
        }
        stale += 1;
        let why = match damaged {
            Some(d) => vec![format!("its cached result is damaged ({d})")],
            None => explain::reasons(records.get(&inst.id), &plan.fields[i]),
        };
        crate::outln!("{}: {}", inst.id, why.join("; "));
        if show_fields {
            for line in plan.fields[i].text().lines() {
                crate::outln!("    {line}");
            }
        }
    }
    if stale == 0 {
        crate::outln!("up to date");
    }
    Ok(ExitCode::SUCCESS)
}
