//! `hydrofit graph`: the stage instances and their edges, as text or DOT.

use crate::pipeline::Plan;
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path, dot: bool) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let g = &plan.graph;
    if dot {
        crate::outln!(
            "digraph hydrofit {{\n  rankdir=LR;\n  node [shape=box, fontname=\"sans-serif\"];"
        );
        for (i, inst) in g.instances.iter().enumerate() {
            crate::outln!(
                "  \"{}\" [label=\"{}\\n({})\"];",
                inst.id,
                inst.id,
                g.stage_of(i).kind.name
            );
            for f in &inst.inputs {
                crate::outln!("  \"{f}\" [shape=note];\n  \"{f}\" -> \"{}\";", inst.id);
            }
            for &d in &inst.deps {
                crate::outln!("  \"{}\" -> \"{}\";", g.instances[d].id, inst.id);
            }
        }
        crate::outln!("}}");
        return Ok(ExitCode::SUCCESS);
    }
    for (i, inst) in g.instances.iter().enumerate() {
        let from: Vec<String> = inst
            .inputs
            .iter()
            .cloned()
            .chain(inst.deps.iter().map(|&d| g.instances[d].id.clone()))
            .collect();
        crate::outln!(
            "{} ({}) <- {}",
            inst.id,
            g.stage_of(i).kind.name,
            if from.is_empty() {
                "-".into()
            } else {
                from.join(", ")
            }
        );
    }
    Ok(ExitCode::SUCCESS)
}
