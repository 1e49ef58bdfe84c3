//! `hydrofit verify`: every cached result against its manifest, and every published report
//! file against the result it was published from.

use crate::pipeline::{Plan, STATE_DIR, lock};
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path) -> anyhow::Result<ExitCode> {
    let _lock = lock::acquire(&root.join(STATE_DIR), |holder| {
        eprintln!("hydrofit: waiting for a build of this project to finish ({holder})");
    })?;
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let cache = plan.cache();
    let mut problems = Vec::new();
    let mut objects = 0usize;
    let dir = cache.dir().join("objects");
    let mut keys: Vec<String> = match std::fs::read_dir(&dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    };
    keys.sort();
    for key in &keys {
        objects += 1;
        if let Err(why) = cache.verify(key) {
            let who = plan
                .keys
                .iter()
                .position(|k| k == key)
                .map_or("a result of an earlier configuration".to_string(), |i| {
                    format!("the result of {}", plan.graph.instances[i].id)
                });
            problems.push(format!(
                ".hydrofit/objects/{}...: {who} is damaged: {why} (the next build moves it aside and rebuilds it)",
                &key[..key.len().min(16)]
            ));
        }
    }
    let published = check_published(&plan, &cache, &mut problems)?;
    for p in &problems {
        crate::outln!("{p}");
    }
    crate::outln!(
        "hydrofit: checked {objects} cached results and {published} published files: {}",
        if problems.is_empty() {
            "all intact".to_string()
        } else {
            format!(
                "{} problem{}",
                problems.len(),
                if problems.len() == 1 { "" } else { "s" }
            )
        }
    );
    Ok(if problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Each published file of each publishing instance compared with its cached result's manifest;
/// how many were checked.
fn check_published(
    plan: &Plan,
    cache: &crate::pipeline::cache::Cache,
    problems: &mut Vec<String>,
) -> anyhow::Result<usize> {
    let mut n = 0;
    for i in 0..plan.graph.instances.len() {
        let Some(dest) = plan.graph.stage_of(i).kind.publishes_to else {
            continue;
        };
        let key = &plan.keys[i];
        if !cache.has(key) || cache.verify(key).is_err() {
            continue;
        }
        let text = std::fs::read_to_string(
            cache
                .object(key)
                .join(crate::pipeline::cache::MANIFEST_FILE),
        )?;
        let manifest: std::collections::BTreeMap<String, String> = serde_json::from_str(&text)?;
        for (rel, hash) in manifest.iter().filter(|(r, _)| !r.starts_with('.')) {
            n += 1;
            let path = plan.root.join(dest).join(rel);
            match crate::core::fsutil::hash_file(&path) {
                Ok(h) if h == *hash => {}
                Ok(_) => problems.push(format!(
                    "{dest}/{rel} differs from the build's result (edited or damaged): `hydrofit build` publishes it again"
                )),
                Err(_) => problems.push(format!(
                    "{dest}/{rel} is missing: `hydrofit build` publishes it"
                )),
            }
        }
    }
    Ok(n)
}
