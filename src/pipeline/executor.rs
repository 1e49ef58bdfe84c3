//! Runs the instances a build needs, in parallel, each at most once per key.
//! A failing instance stops only what depends on it; its temporary folder is removed.

use super::cache::{Cache, Record};
use super::contract::{RunCtx, Upstream};
use super::{Plan, explain};
use crate::progress::Progress;
use crate::provenance::InputFile;
use std::collections::HashMap;
use std::path::Path;
use std::sync::mpsc;
use std::time::Instant;

#[derive(Debug, Clone, Default)]
pub struct Options {
    pub targets: Vec<String>,
    pub jobs: usize,
    /// Print why each instance runs (the same text as `hydrofit status`).
    pub explain: bool,
}

#[derive(Debug, Default)]
pub struct Summary {
    pub ran: Vec<String>,
    pub up_to_date: usize,
    pub failed: Vec<(String, String)>,
    /// Instances not run because something they depend on failed.
    pub skipped: Vec<String>,
    pub published: Vec<String>,
    /// Ctrl-C stopped the build: instances not started are neither run nor failed.
    pub interrupted: bool,
}

#[derive(Clone, Copy, PartialEq)]
enum State {
    NotNeeded,
    Waiting,
    Running,
    Done,
    Failed,
}

pub fn build(plan: &Plan, opts: &Options, progress: &Progress) -> anyhow::Result<Summary> {
    let cache = plan.cache();
    let need = plan
        .graph
        .closure(&opts.targets)
        .map_err(anyhow::Error::msg)?;
    let n = plan.graph.instances.len();
    let mut state: Vec<State> = (0..n)
        .map(|i| match (need[i], cache.has(&plan.keys[i])) {
            (false, _) => State::NotNeeded,
            (true, true) => State::Done,
            (true, false) => State::Waiting,
        })
        .collect();
    let mut summary = Summary {
        up_to_date: state.iter().filter(|s| **s == State::Done).count(),
        ..Default::default()
    };
    let to_run = state.iter().filter(|s| **s == State::Waiting).count();
    let records = if opts.explain {
        cache.records()
    } else {
        HashMap::new()
    };
    let bar = progress.bar(to_run as u64, "building");
    let jobs = opts.jobs.max(1);
    let (tx, rx) = mpsc::channel::<(usize, Result<(), String>)>();
    std::thread::scope(|scope| {
        let mut running = 0;
        loop {
            let stop = crate::interrupt::requested();
            let ready: Vec<usize> = (0..n)
                .filter(|&i| {
                    !stop
                        && state[i] == State::Waiting
                        && plan.graph.instances[i].deps.iter().all(|&d| {
                            state[d] == State::Done
                                || (state[d] == State::Failed && tolerable(plan, d))
                        })
                })
                .take(jobs - running)
                .collect();
            for i in ready {
                if opts.explain {
                    let why =
                        explain::reasons(records.get(&plan.graph.instances[i].id), &plan.fields[i]);
                    progress.println(format!(
                        "{}: {}",
                        plan.graph.instances[i].id,
                        why.join("; ")
                    ));
                }
                state[i] = State::Running;
                running += 1;
                let failed_deps: Vec<(String, String)> = plan.graph.instances[i]
                    .deps
                    .iter()
                    .filter(|&&d| state[d] == State::Failed)
                    .map(|&d| {
                        let id = &plan.graph.instances[d].id;
                        (
                            id.clone(),
                            summary
                                .failed
                                .iter()
                                .find(|(f, _)| f == id)
                                .map_or_else(|| "not built".to_string(), |(_, e)| e.clone()),
                        )
                    })
                    .collect();
                let (tx, cache, spinner) = (
                    tx.clone(),
                    &cache,
                    progress.spinner(&plan.graph.instances[i].id),
                );
                scope.spawn(move || {
                    let r = run_one(plan, i, cache, &spinner, failed_deps)
                        .map_err(|e| format!("{e:#}"));
                    spinner.finish_and_clear();
                    let _ = tx.send((i, r));
                });
            }
            if running == 0 {
                break;
            }
            let (i, r) = rx.recv().expect("a worker always reports");
            running -= 1;
            bar.inc(1);
            let id = plan.graph.instances[i].id.clone();
            match r {
                Ok(()) => {
                    state[i] = State::Done;
                    summary.ran.push(id);
                }
                Err(_) if crate::interrupt::requested() => {
                    // Stopped by Ctrl-C, not a failure: it runs again next time.
                    state[i] = State::Failed;
                    progress.println(format!("{id}: stopped"));
                }
                Err(e) => {
                    state[i] = State::Failed;
                    progress.println(format!(
                        "error: stage {id} failed\n  {}",
                        e.replace('\n', "\n  ")
                    ));
                    summary.failed.push((id, e));
                    skip_dependents(plan, i, &mut state, &mut summary);
                }
            }
        }
    });
    bar.finish_and_clear();
    summary.interrupted = crate::interrupt::requested();
    for i in (0..n).filter(|&i| state[i] == State::Done) {
        summary.published.extend(publish(plan, i, &cache)?);
    }
    Ok(summary)
}

/// Marks everything downstream of a failure as not runnable. Instances are in dependency
/// order, so one forward pass reaches the whole downstream closure.
fn skip_dependents(plan: &Plan, failed: usize, state: &mut [State], summary: &mut Summary) {
    for j in failed + 1..state.len() {
        if state[j] == State::Waiting
            && plan.graph.instances[j]
                .deps
                .iter()
                .any(|&d| state[d] == State::Failed && !tolerable(plan, d))
        {
            state[j] = State::Failed;
            summary.skipped.push(plan.graph.instances[j].id.clone());
        }
    }
}

/// Whether a failed instance leaves its dependents runnable: one pool run among many (a broken
/// run folder must not take the validation and report of the others down with it). Its
/// dependents list it and are rebuilt by the next build.
fn tolerable(plan: &Plan, failed: usize) -> bool {
    let kind = plan.graph.stage_of(failed).kind;
    kind.fan_out
        && kind.produces == super::contract::Artifact::PoolRuns
        && !crate::interrupt::requested()
}

fn run_one(
    plan: &Plan,
    i: usize,
    cache: &Cache,
    spinner: &indicatif::ProgressBar,
    failed_upstream: Vec<(String, String)>,
) -> anyhow::Result<()> {
    let inst = &plan.graph.instances[i];
    let st = plan.graph.stage_of(i);
    let key = &plan.keys[i];
    let tmp = cache.begin(key)?;
    let inputs: Vec<InputFile> = inst
        .inputs
        .iter()
        .map(|p| InputFile {
            path: p.clone(),
            blake3: plan.hashes[p].clone(),
        })
        .collect();
    let upstream = inst
        .deps
        .iter()
        .filter(|&&d| {
            !failed_upstream
                .iter()
                .any(|(id, _)| *id == plan.graph.instances[d].id)
        })
        .map(|&d| Upstream {
            id: plan.graph.instances[d].id.clone(),
            stage: plan.graph.stage_of(d).name.clone(),
            produces: plan.graph.stage_of(d).kind.produces,
            dir: cache.object(&plan.keys[d]),
        })
        .collect();
    let ctx = RunCtx {
        id: &inst.id,
        stage: &st.name,
        root: &plan.root,
        vehicle: &plan.graph.spec.vehicle,
        inputs: &inputs,
        upstream,
        failed_upstream: failed_upstream.clone(),
        out: &tmp,
        progress: spinner,
    };
    let start = Instant::now();
    // A panic is a bug, but it must not take the other stages (or the cache) down with it.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| st.imp.run(&ctx)))
        .unwrap_or_else(|p| {
            Err(anyhow::anyhow!(
                "internal error (please report): {}",
                panic_text(&p)
            ))
        });
    match result {
        Ok(()) => {
            let missing: Vec<String> = failed_upstream.into_iter().map(|(id, _)| id).collect();
            cache.commit_partial(
                &tmp,
                &Record {
                    id: inst.id.clone(),
                    key: key.clone(),
                    fields: plan.fields[i].clone(),
                },
                &missing,
            )?;
            log_time(spinner, &inst.id, start);
            Ok(())
        }
        Err(e) => {
            cache.abandon(&tmp);
            Err(e)
        }
    }
}

fn log_time(spinner: &indicatif::ProgressBar, id: &str, start: Instant) {
    let s = start.elapsed().as_secs_f64();
    if s > 1.0 {
        spinner.println(format!("  {id} took {s:.1} s"));
    }
}

fn panic_text(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "panic".into())
}

/// Copies a finished instance's artifacts to the folder its kind publishes to, where they are
/// missing or differ; returns the files written.
fn publish(plan: &Plan, i: usize, cache: &Cache) -> anyhow::Result<Vec<String>> {
    let Some(dest) = plan.graph.stage_of(i).kind.publishes_to else {
        return Ok(vec![]);
    };
    let obj = cache.object(&plan.keys[i]);
    let mut written = Vec::new();
    let mut names: Vec<_> = std::fs::read_dir(&obj)?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name())
        .collect();
    names.sort();
    for name in names {
        let name = name.to_string_lossy().into_owned();
        if name.starts_with('.') || !obj.join(&name).is_file() {
            continue;
        }
        let target = plan.root.join(dest).join(&name);
        if !same_contents(&obj.join(&name), &target) {
            let bytes = std::fs::read(obj.join(&name))?;
            crate::fsutil::write_atomic(&target, &bytes)?;
            written.push(format!("{dest}/{name}"));
        }
    }
    Ok(written)
}

fn same_contents(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) if x.len() == y.len() => {
            crate::fsutil::hash_file(a).ok() == crate::fsutil::hash_file(b).ok()
        }
        _ => false,
    }
}
