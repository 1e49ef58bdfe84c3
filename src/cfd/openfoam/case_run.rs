//! One case folder as a build obtains it: which case a stage's input files are, its results
//! (left in the folder by a run of exactly these inputs, or from a fresh run), the body's
//! motion read back, and the results kept in the cache and, after a fresh run, in the case.

use super::{CaseSetup, Results, RunInfo, STAMP, Track};
use crate::core::provenance::InputFile;
use std::path::{Path, PathBuf};

/// A case with its results obtained and read.
pub struct CaseRun {
    /// The case folder, relative to the project.
    pub rel: String,
    pub dir: PathBuf,
    /// The case's input files (project-relative), with their hashes.
    pub inputs: Vec<InputFile>,
    pub setup: CaseSetup,
    pub results: Results,
    pub track: Track,
    pub log: super::results::Log,
}

impl CaseRun {
    /// The case whose input files (relative to `root`) are `inputs`, with its results:
    /// those left in the case or a fresh run's, as [`super::obtain_results`] decides.
    /// `message` hears what a run is doing.
    pub fn obtain(
        root: &Path,
        inputs: &[InputFile],
        message: &dyn Fn(String),
        slurm: Option<&crate::cfd::slurm::SlurmOptions>,
    ) -> anyhow::Result<CaseRun> {
        let Located {
            rel,
            dir,
            files,
            identity,
            setup,
        } = Located::new(root, inputs)?;
        let state_dir = root.join(crate::pipeline::STATE_DIR);
        let exec = super::Executor {
            slurm,
            state_dir: &state_dir,
        };
        let results = super::obtain_results(&dir, &rel, &files, &setup, &identity, message, exec)?;
        let (track, log, _) = super::read_track(&results.dir, &setup.application)
            .map_err(|e| e.context(format!("case {rel}")))?;
        Ok(CaseRun {
            rel,
            dir,
            inputs: inputs.to_vec(),
            setup,
            results,
            track,
            log,
        })
    }

    /// Whether the case is 2D (an `empty` patch in its mesh, one cell thick): its forces and
    /// masses are then per metre of span.
    pub fn two_dimensional(&self) -> bool {
        ["system/blockMeshDict", "constant/polyMesh/boundary"]
            .iter()
            .filter_map(|rel| std::fs::read_to_string(self.dir.join(rel)).ok())
            .any(|t| super::dict::has_empty_patch(&t))
    }

    /// The case's name: its folder's.
    pub fn name(&self) -> String {
        Path::new(&self.rel)
            .file_name()
            .map_or(self.rel.clone(), |n| n.to_string_lossy().into_owned())
    }

    /// Copies the result files into `out` (flattened: `postProcessing_forces_0_force.dat`);
    /// after a fresh run with `keep_in_case`, also into the case folder, as running it by
    /// hand would, the stamp last.
    pub fn keep_results(&self, out: &Path, keep_in_case: bool) -> anyhow::Result<()> {
        let back = self.results.ran && keep_in_case;
        for rel in super::result_files(&self.setup.application) {
            if let Ok(bytes) = std::fs::read(self.results.dir.join(&rel)) {
                let flat = rel.replace('/', "_");
                crate::core::fsutil::write_atomic(&out.join(flat), &bytes)?;
                if back {
                    let to = self.dir.join(&rel);
                    std::fs::create_dir_all(to.parent().expect("has a parent"))?;
                    crate::core::fsutil::write_atomic(&to, &bytes)?;
                }
            }
        }
        if back {
            // Last: the stamp vouches for the files written before it.
            crate::core::fsutil::write_atomic(
                &self.dir.join(STAMP),
                serde_json::to_string_pretty(&self.results.stamp)?.as_bytes(),
            )?;
        }
        Ok(())
    }

    /// How the results came about, for the report.
    pub fn info(&self) -> RunInfo {
        let (setup, stamp, log) = (&self.setup, &self.results.stamp, &self.log);
        RunInfo {
            solver: setup.application.clone(),
            openfoam: stamp.openfoam.clone(),
            ran_in_this_build: self.results.ran,
            steps: log.steps.len(),
            end_time_s: setup.end_time_s,
            cpu_time_s: log.execution_time_s.or(stamp.execution_time_s),
            wall_time_s: log.clock_time_s.or(stamp.clock_time_s),
            applied_force_n: setup.applied_force(),
            mass_kg: setup.mass_kg,
            rho: setup.rho,
            slurm_job: stamp.slurm_job.clone(),
            node: stamp.node.clone(),
        }
    }
}

/// A case folder with what identifies its inputs and what it says about the run.
struct Located {
    rel: String,
    dir: PathBuf,
    /// Input files relative to the case.
    files: Vec<String>,
    identity: String,
    setup: CaseSetup,
}

impl Located {
    fn new(root: &Path, inputs: &[InputFile]) -> anyhow::Result<Located> {
        let rel = case_folder(inputs)?;
        let dir = root.join(&rel);
        let local: Vec<(String, String)> = inputs
            .iter()
            .map(|i| (i.path[rel.len() + 1..].to_string(), i.blake3.clone()))
            .collect();
        let identity = super::inputs_hash(&local);
        let setup = super::read_setup(&dir, &rel)?;
        let files = local.into_iter().map(|(p, _)| p).collect();
        Ok(Located {
            rel,
            dir,
            files,
            identity,
            setup,
        })
    }
}

/// Submits the cases (each given by its input files) that have to run, with no results of
/// these inputs left in their folders, as one Slurm array job named after `stage`; see
/// [`super::submit_array`]. A case that cannot be read or run here is left to its own
/// instance, which says why.
pub fn submit_series(
    root: &Path,
    cases: &[Vec<InputFile>],
    opts: &crate::cfd::slurm::SlurmOptions,
    stage: &str,
) -> anyhow::Result<Option<super::ArrayJob>> {
    let located: Vec<Located> = cases
        .iter()
        .filter_map(|inputs| Located::new(root, inputs).ok())
        .filter(|c| {
            !super::solve::results_left(&c.dir, &c.setup, &c.identity)
                && super::solver_available(&c.setup.application)
        })
        .collect();
    let list: Vec<super::ArrayCase> = located
        .iter()
        .map(|c| super::ArrayCase {
            dir: &c.dir,
            files: &c.files,
            setup: &c.setup,
            identity: &c.identity,
        })
        .collect();
    let state_dir = root.join(crate::pipeline::STATE_DIR);
    super::submit_array(&state_dir, &list, opts, stage)
}

/// The case folder of a stage's input files: the one holding `system/controlDict`.
fn case_folder(inputs: &[InputFile]) -> anyhow::Result<String> {
    let control = inputs
        .iter()
        .find_map(|i| i.path.strip_suffix("/system/controlDict"))
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: not an OpenFOAM case (no system/controlDict)",
                inputs.first().map_or("?", |i| i.path.as_str())
            )
        })?;
    Ok(control.to_string())
}
