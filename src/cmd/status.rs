//! `hydrofit status`: what a build would run, and why; `up to date` when nothing.

use crate::pipeline::{Plan, explain};
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path, show_fields: bool) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let cache = plan.cache();
    let records = cache.records();
    let mut stale = 0;
    // Results rebuilt because a file they read changed, and so everything reading them.
    let mut rebuilt = vec![false; plan.graph.instances.len()];
    for (i, inst) in plan.graph.instances.iter().enumerate() {
        let key = &plan.keys[i];
        let damaged = cache.has(key).then(|| cache.verify(key).err()).flatten();
        let changed = (cache.has(key) && damaged.is_none())
            .then(|| {
                cache
                    .watched_change(key, root)
                    .map(|c| format!("{c} since its result was read"))
                    .or_else(|| {
                        inst.deps.iter().find(|&&d| rebuilt[d]).map(|&d| {
                            format!(
                                "it reads {}, which is built again",
                                plan.graph.instances[d].id
                            )
                        })
                    })
            })
            .flatten();
        rebuilt[i] = changed.is_some();
        if cache.has(key) && damaged.is_none() && changed.is_none() {
            continue;
        }
        stale += 1;
        let why = match (damaged, changed) {
            (Some(d), _) => vec![format!("its cached result is damaged ({d})")],
            (None, Some(c)) => vec![c],
            _ => explain::reasons(records.get(&inst.id), &plan.fields[i]),
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
