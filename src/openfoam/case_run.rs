//! One case folder as a build obtains it: which case a stage's input files are, its results
//! (left in the folder by a run of exactly these inputs, or from a fresh run), the body's
//! motion read back, and the results kept in the cache and, after a fresh run, in the case.

use super::{CaseSetup, Results, RunInfo, STAMP, Track};
use crate::provenance::InputFile;
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
        slurm: Option<&super::slurm::SlurmOptions>,
    ) -> anyhow::Result<CaseRun> {
        let rel = case_folder(inputs)?;
        let dir = root.join(&rel);
        let local: Vec<(String, String)> = inputs
            .iter()
            .map(|i| (i.path[rel.len() + 1..].to_string(), i.blake3.clone()))
            .collect();
        let identity = super::inputs_hash(&local);
        let setup = super::read_setup(&dir, &rel)?;
        let files: Vec<String> = local.iter().map(|(p, _)| p.clone()).collect();
        let state_dir = root.join(crate::pipeline::STATE_DIR);
        let exec = super::Executor {
            slurm,
            state_dir: &state_dir,
        };
        let results = super::obtain_results(&dir, &rel, &files, &setup, &identity, message, exec)?;
        let (track, log, _) = super::read_track(&results.dir, &setup.application)
            .map_err(|e| anyhow::anyhow!("case {rel}: {e}"))?;
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
                crate::fsutil::write_atomic(&out.join(flat), &bytes)?;
                if back {
                    let to = self.dir.join(&rel);
                    std::fs::create_dir_all(to.parent().expect("has a parent"))?;
                    crate::fsutil::write_atomic(&to, &bytes)?;
                }
            }
        }
        if back {
            // Last: the stamp vouches for the files written before it.
            crate::fsutil::write_atomic(
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
            slurm_job: self.results.ran.then(|| stamp.slurm_job.clone()).flatten(),
            node: self.results.ran.then(|| stamp.node.clone()).flatten(),
        }
    }
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
