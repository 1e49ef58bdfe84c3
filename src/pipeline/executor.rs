//! Runs the instances a build needs, in parallel, each at most once per key.
//! A failing instance stops only what depends on it; its temporary folder is removed.

use super::cache::{Cache, Record};
use super::contract::{RunCtx, Upstream};
use super::spec::StageSpec;
use super::{Plan, explain};
use crate::core::progress::Progress;
use crate::core::provenance::InputFile;
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
    /// Stop at a damaged cache object instead of moving it aside and rerunning its stage.
    pub strict_cache: bool,
}

/// A cached result of instance `i` is served only when its files match its manifest; a
/// damaged one is said, moved aside and rerun (or, strictly, stops the build). One read from
/// a project file that changed since is rerun, and says so (`true`: its content may change).
fn served(
    plan: &Plan,
    i: usize,
    cache: &Cache,
    progress: &Progress,
    strict: bool,
) -> anyhow::Result<(State, bool)> {
    let key = &plan.keys[i];
    let id = &plan.graph.instances[i].id;
    let Err(why) = cache.verify(key) else {
        if let Some(change) = cache.watched_change(key, &plan.root) {
            progress.println(format!(
                "{id}: {change} since its result was read: built again"
            ));
            cache.discard(key)?;
            return Ok((State::Waiting, true));
        }
        return Ok((State::Done, false));
    };
    let short = &key[..key.len().min(16)];
    anyhow::ensure!(
        !strict,
        "the cached result of {id} (.hydrofit/objects/{short}...) is damaged: {why}; run without --strict-cache to rebuild it, or `hydrofit verify` to check the whole cache"
    );
    progress.println(format!(
        "warning: the cached result of {id} (.hydrofit/objects/{short}...) is damaged ({why}): moved to .hydrofit/damaged/ and rebuilt"
    ));
    cache.quarantine(key)?;
    Ok((State::Waiting, false))
}

/// A result rebuilt because a file it read changed (see [`Cache::watched_change`]) keeps its
/// key but not its content: everything downstream of it that was served is rebuilt too.
/// Instances are in dependency order, so one forward pass reaches the whole closure.
fn rebuild_readers_of_changed(
    plan: &Plan,
    cache: &Cache,
    state: &mut [State],
    mut changed: Vec<bool>,
) -> anyhow::Result<()> {
    for j in 0..state.len() {
        if state[j] == State::Done && plan.graph.instances[j].deps.iter().any(|&d| changed[d]) {
            cache.discard(&plan.keys[j])?;
            state[j] = State::Waiting;
            changed[j] = true;
        }
    }
    Ok(())
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

/// Runs every needed instance that has no cached result, up to `opts.jobs` at once, then
/// publishes the finished ones.
pub fn build(plan: &Plan, opts: &Options, progress: &Progress) -> anyhow::Result<Summary> {
    let cache = plan.cache();
    let mut schedule = Schedule::new(plan, opts, progress, &cache)?;
    let batches = prepare_batches(plan, &schedule.state, progress);
    let bar = progress.bar(schedule.waiting() as u64, "building");
    let jobs = opts.jobs.max(1);
    let (tx, rx) = mpsc::channel::<(usize, Result<(), Failure>)>();
    std::thread::scope(|scope| {
        let mut running = 0;
        loop {
            for i in schedule.ready(jobs - running) {
                let failed_deps = schedule.start(i);
                running += 1;
                let (tx, cache, spinner) = (
                    tx.clone(),
                    &cache,
                    progress.spinner(&plan.graph.instances[i].id),
                );
                scope.spawn(move || {
                    let r = run_one(plan, i, cache, &spinner, failed_deps).map_err(|e| Failure {
                        msg: format!("{e:#}"),
                        executor_unavailable: e
                            .chain()
                            .any(|c| c.is::<crate::core::diag::ExecutorUnavailable>()),
                    });
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
            schedule.finish(i, r);
        }
    });
    bar.finish_and_clear();
    // After every worker: a batch's guard may cancel what was not waited for (Ctrl-C).
    drop(batches);
    let Schedule {
        state, mut summary, ..
    } = schedule;
    summary.interrupted = crate::core::interrupt::requested();
    for i in (0..state.len()).filter(|&i| state[i] == State::Done) {
        summary.published.extend(publish(plan, i, &cache)?);
    }
    Ok(summary)
}

/// Lets each stage see its instances that are about to run together, before any runs (a
/// series of CFD cases goes to Slurm as one array job). A stage that cannot batch them says
/// why and its instances run one by one. Returns what the stages keep until the build ends.
fn prepare_batches(
    plan: &Plan,
    state: &[State],
    progress: &Progress,
) -> Vec<Box<dyn std::any::Any + Send + Sync>> {
    let mut kept = Vec::new();
    for (si, st) in plan.graph.spec.stages.iter().enumerate() {
        let pending: Vec<super::contract::Pending> = (0..state.len())
            .filter(|&i| state[i] == State::Waiting && plan.graph.instances[i].stage == si)
            .map(|i| super::contract::Pending {
                id: &plan.graph.instances[i].id,
                stage: &st.name,
                root: &plan.root,
                inputs: input_files(plan, i),
                params: &plan.graph.instances[i].params,
            })
            .collect();
        if pending.is_empty() {
            continue;
        }
        match st.imp.prepare(&pending) {
            Ok(Some(p)) => {
                progress.println(format!("{}: {}", st.name, p.message));
                kept.push(p.keep);
            }
            Ok(None) => {}
            Err(e) => progress.println(format!(
                "warning: {}: its instances could not be prepared together ({e:#}); each runs on its own",
                st.name
            )),
        }
    }
    kept
}

/// Why a worker's instance failed.
struct Failure {
    msg: String,
    /// Its executor cannot run here (a cluster that does not answer).
    executor_unavailable: bool,
}

/// A build in progress: where each instance stands and what has been counted so far.
struct Schedule<'a> {
    plan: &'a Plan,
    opts: &'a Options,
    progress: &'a Progress,
    state: Vec<State>,
    summary: Summary,
    /// What each instance was last built with, to say why one runs again (`--explain`,
    /// and when its executor is not there); read when first needed.
    records: std::cell::OnceCell<HashMap<String, Record>>,
}

impl<'a> Schedule<'a> {
    /// The instances `opts.targets` need: those with a cached result done, the others waiting.
    fn new(
        plan: &'a Plan,
        opts: &'a Options,
        progress: &'a Progress,
        cache: &Cache,
    ) -> anyhow::Result<Schedule<'a>> {
        let need = plan
            .graph
            .closure(&opts.targets)
            .map_err(anyhow::Error::msg)?;
        let mut changed = vec![false; plan.graph.instances.len()];
        let mut state: Vec<State> = (0..plan.graph.instances.len())
            .map(|i| match (need[i], cache.has(&plan.keys[i])) {
                (false, _) => Ok(State::NotNeeded),
                (true, true) => {
                    served(plan, i, cache, progress, opts.strict_cache).map(|(s, c)| {
                        changed[i] = c;
                        s
                    })
                }
                (true, false) => Ok(State::Waiting),
            })
            .collect::<anyhow::Result<_>>()?;
        rebuild_readers_of_changed(plan, cache, &mut state, changed)?;
        let summary = Summary {
            up_to_date: state.iter().filter(|s| **s == State::Done).count(),
            ..Default::default()
        };
        Ok(Schedule {
            plan,
            opts,
            progress,
            state,
            summary,
            records: std::cell::OnceCell::new(),
        })
    }

    /// How many instances wait to run.
    fn waiting(&self) -> usize {
        self.state.iter().filter(|s| **s == State::Waiting).count()
    }

    /// Up to `free` waiting instances whose dependencies are done (or failed and tolerable);
    /// none once Ctrl-C is pressed.
    fn ready(&self, free: usize) -> Vec<usize> {
        let stop = crate::core::interrupt::requested();
        let (plan, state) = (self.plan, &self.state);
        (0..state.len())
            .filter(|&i| {
                !stop
                    && state[i] == State::Waiting
                    && plan.graph.instances[i].deps.iter().all(|&d| {
                        state[d] == State::Done || (state[d] == State::Failed && tolerable(plan, d))
                    })
            })
            .take(free)
            .collect()
    }

    /// Why instance `i` runs: what differs from its last build.
    fn why(&self, i: usize) -> Vec<String> {
        let id = &self.plan.graph.instances[i].id;
        let records = self.records.get_or_init(|| self.plan.cache().records());
        explain::reasons(records.get(id), &self.plan.fields[i])
    }

    /// Marks instance `i` running (saying why, with `--explain`); its failed dependencies
    /// with their errors, which it goes on without.
    fn start(&mut self, i: usize) -> Vec<(String, String)> {
        let instances = &self.plan.graph.instances;
        if self.opts.explain {
            let why = self.why(i);
            self.progress
                .println(format!("{}: {}", instances[i].id, why.join("; ")));
        }
        self.state[i] = State::Running;
        instances[i]
            .deps
            .iter()
            .filter(|&&d| self.state[d] == State::Failed)
            .map(|&d| {
                let id = &instances[d].id;
                (
                    id.clone(),
                    self.summary
                        .failed
                        .iter()
                        .find(|(f, _)| f == id)
                        .map_or_else(|| "not built".to_string(), |(_, e)| e.clone()),
                )
            })
            .collect()
    }

    /// Records what a worker reported for instance `i`: done, stopped by Ctrl-C, or failed
    /// (which stops what depends on it).
    fn finish(&mut self, i: usize, r: Result<(), Failure>) {
        let id = self.plan.graph.instances[i].id.clone();
        match r {
            Ok(()) => {
                self.state[i] = State::Done;
                self.summary.ran.push(id);
            }
            Err(_) if crate::core::interrupt::requested() => {
                // Stopped by Ctrl-C, not a failure: it runs again next time.
                self.state[i] = State::Failed;
                self.progress.println(format!("{id}: stopped"));
            }
            Err(f) => {
                // Whether a run its executor cannot make here can be avoided depends on why
                // it was needed.
                let e = if f.executor_unavailable {
                    format!(
                        "{}\n  it had to run because: {}",
                        f.msg,
                        self.why(i).join("; ")
                    )
                } else {
                    f.msg
                };
                self.state[i] = State::Failed;
                self.progress.println(format!(
                    "error: stage {id} failed\n  {}",
                    e.replace('\n', "\n  ")
                ));
                self.summary.failed.push((id, e));
                skip_dependents(self.plan, i, &mut self.state, &mut self.summary);
            }
        }
    }
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
        && !crate::core::interrupt::requested()
}

/// Runs instance `i` into a fresh folder and commits it to the cache, or removes the folder
/// when it fails. `failed_upstream`: its failed dependencies, which it goes on without.
fn run_one(
    plan: &Plan,
    i: usize,
    cache: &Cache,
    spinner: &indicatif::ProgressBar,
    failed_upstream: Vec<(String, String)>,
) -> anyhow::Result<()> {
    let inst = &plan.graph.instances[i];
    let st = plan.graph.stage_of(i);
    let tmp = cache.begin(&plan.keys[i])?;
    let inputs = input_files(plan, i);
    let ctx = RunCtx {
        id: &inst.id,
        stage: &st.name,
        root: &plan.root,
        vehicle: &plan.graph.spec.vehicle,
        inputs: &inputs,
        params: &inst.params,
        upstream: upstream(plan, i, cache, &failed_upstream),
        failed_upstream: failed_upstream.clone(),
        out: &tmp,
        progress: spinner,
    };
    let start = Instant::now();
    match run_guarded(st, &ctx) {
        Ok(()) => {
            let missing: Vec<String> = failed_upstream.into_iter().map(|(id, _)| id).collect();
            cache.commit_partial(
                &tmp,
                &Record {
                    id: inst.id.clone(),
                    key: plan.keys[i].clone(),
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

/// Instance `i`'s input files with their hashes.
fn input_files(plan: &Plan, i: usize) -> Vec<InputFile> {
    plan.graph.instances[i]
        .inputs
        .iter()
        .map(|p| InputFile::new(p.clone(), plan.hashes[p].clone()))
        .collect()
}

/// The finished dependencies instance `i` reads: all of them but the failed ones.
fn upstream(
    plan: &Plan,
    i: usize,
    cache: &Cache,
    failed_upstream: &[(String, String)],
) -> Vec<Upstream> {
    plan.graph.instances[i]
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
        .collect()
}

/// Runs the stage; a panic is a bug, but it must not take the other stages (or the cache)
/// down with it, so it becomes this instance's error.
/// A stage that returns while Ctrl-C is pending may have cut a loop short: its result is not
/// kept (long loops stop at the next iteration rather than finishing the work).
fn run_guarded(st: &StageSpec, ctx: &RunCtx) -> anyhow::Result<()> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| st.imp.run(ctx)))
        .unwrap_or_else(|p| {
            Err(anyhow::anyhow!(
                "internal error (please report): {}",
                panic_text(&p)
            ))
        })
        .and_then(|()| crate::core::interrupt::check())
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
            crate::core::fsutil::write_atomic(&target, &bytes)?;
            written.push(format!("{dest}/{name}"));
        }
    }
    Ok(written)
}

fn same_contents(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) if x.len() == y.len() => {
            crate::core::fsutil::hash_file(a).ok() == crate::core::fsutil::hash_file(b).ok()
        }
        _ => false,
    }
}
