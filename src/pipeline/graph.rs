//! Expands stages into instances: a stage with input globs fans out to one instance per
//! matched file (or folder), so a new case adds one instance and touches nothing else.

use super::spec::{Spec, StageSpec};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone)]
pub struct Instance {
    /// `stage` or `stage[case]`.
    pub id: String,
    /// Index into `spec.stages`.
    pub stage: usize,
    /// Input files, relative to the project root, `/`-separated, sorted.
    pub inputs: Vec<String>,
    /// Indices of the instances it reads from (earlier in `instances`).
    pub deps: Vec<usize>,
    /// Parameters of an instance its stage's settings define (a case of a series); part of
    /// its key.
    pub params: Vec<(String, String)>,
}

pub struct Graph {
    pub spec: Spec,
    /// In dependency order.
    pub instances: Vec<Instance>,
}

#[derive(Debug, thiserror::Error)]
pub enum GraphError {
    #[error(
        "stage `{stage}` matched no files with {globs}\n  help: put its input files there, or fix the glob under stages.{stage}.inputs in pipeline.yaml"
    )]
    NoInputs { stage: String, globs: String },
    #[error("cannot list {pattern}: {source}")]
    Glob {
        pattern: String,
        source: glob::GlobError,
    },
    #[error(
        "{path}: is a folder, where stage `{stage}` takes files\n  help: rename or remove the folder, or narrow the glob under stages.{stage}.inputs in pipeline.yaml"
    )]
    FolderForFile { stage: String, path: String },
    #[error(
        "stage `{stage}`: {why}\n  help: see the README's section on case series (stages.{stage}.settings in pipeline.yaml)"
    )]
    Variants { stage: String, why: String },
    #[error(
        "stage `{stage}` defines a case series, so its inputs must match one template case folder; they match {count}: {list}\n  help: narrow stages.{stage}.inputs in pipeline.yaml to the template"
    )]
    Template {
        stage: String,
        count: usize,
        list: String,
    },
    #[error("cannot read input {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
}

fn rel(root: &Path, p: &Path) -> String {
    let r = p.strip_prefix(root).unwrap_or(p);
    r.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// Matched entries of a stage: (name for the instance id, files).
fn fan_out(root: &Path, st: &StageSpec) -> Result<Vec<(String, Vec<String>)>, GraphError> {
    let matched = matched_entries(root, st)?;
    if matched.is_empty() {
        return Err(GraphError::NoInputs {
            stage: st.name.clone(),
            globs: st.inputs.join(", "),
        });
    }
    Ok(named_by_stem(matched))
}

/// Every path the stage's globs match, skipping hidden names, with its files (the path
/// itself, or a folder's files its kind keeps).
fn matched_entries(
    root: &Path,
    st: &StageSpec,
) -> Result<BTreeMap<String, Vec<String>>, GraphError> {
    let mut matched: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for g in &st.inputs {
        // The project's own path is literal: `[`, `]`, `*` or `?` in it are not a pattern.
        let pattern = format!("{}/{g}", glob::Pattern::escape(&root.to_string_lossy()));
        let paths = glob::glob(&pattern).expect("globs are checked when the spec is parsed");
        for p in paths {
            let p = p.map_err(|source| GraphError::Glob {
                pattern: g.clone(),
                source,
            })?;
            let r = rel(root, &p);
            if p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'))
            {
                continue;
            }
            let files = entry_files(st, &p, &r)?;
            matched.insert(r, files);
        }
    }
    Ok(matched)
}

/// The input files of one matched path `p` (`r` relative to the root): a file is its own
/// input; a folder gives the files under it that the stage's kind keeps.
fn entry_files(st: &StageSpec, p: &Path, r: &str) -> Result<Vec<String>, GraphError> {
    let mut files = Vec::new();
    if p.is_dir() && st.kind.file_inputs {
        return Err(GraphError::FolderForFile {
            stage: st.name.clone(),
            path: r.to_string(),
        });
    }
    if p.is_dir() {
        // The case folder's files, skipping hidden names.
        let under =
            crate::core::fsutil::files_under(p, true).map_err(|source| GraphError::Read {
                path: r.to_string(),
                source,
            })?;
        files.extend(under.into_iter().map(|f| format!("{r}/{f}")));
        if let Some(keep) = st.kind.input_filter {
            let prefix = format!("{r}/");
            files.retain(|f| f.strip_prefix(&prefix).is_some_and(keep));
        }
    } else {
        files.push(r.to_string());
    }
    Ok(files)
}

/// The files of the one template case a stage's settings fan out over.
fn template_files(root: &Path, st: &StageSpec) -> Result<Vec<String>, GraphError> {
    let matched = fan_out(root, st)?;
    if matched.len() != 1 {
        return Err(GraphError::Template {
            stage: st.name.clone(),
            count: matched.len(),
            list: matched
                .iter()
                .map(|(n, _)| n.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    Ok(matched.into_iter().flat_map(|(_, f)| f).collect())
}

/// Names each entry by its file stem; falls back to the path where stems collide.
fn named_by_stem(matched: BTreeMap<String, Vec<String>>) -> Vec<(String, Vec<String>)> {
    let stem = |r: &str| {
        Path::new(r)
            .file_stem()
            .map_or(r.to_string(), |s| s.to_string_lossy().into_owned())
    };
    let mut count: BTreeMap<String, usize> = BTreeMap::new();
    for r in matched.keys() {
        *count.entry(stem(r)).or_default() += 1;
    }
    matched
        .into_iter()
        .map(|(r, files)| {
            (
                if count[&stem(&r)] > 1 {
                    r.clone()
                } else {
                    stem(&r)
                },
                files,
            )
        })
        .collect()
}

impl Graph {
    pub fn expand(root: &Path, spec: Spec) -> Result<Graph, GraphError> {
        let mut instances: Vec<Instance> = Vec::new();
        let mut of_stage: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
        for (si, st) in spec.stages.iter().enumerate() {
            let deps: Vec<usize> = st
                .from
                .iter()
                .flat_map(|f| of_stage[f.as_str()].iter().copied())
                .collect();
            let variants = st.imp.variants().map_err(|why| GraphError::Variants {
                stage: st.name.clone(),
                why,
            })?;
            let entries = if let Some(variants) = variants {
                let files = template_files(root, st)?;
                variants
                    .into_iter()
                    .map(|v| (v.name, files.clone(), v.params))
                    .collect()
            } else if st.kind.fan_out {
                let plain = |(n, f)| (n, f, vec![]);
                fan_out(root, st)?.into_iter().map(plain).collect()
            } else if st.inputs.is_empty() {
                vec![(String::new(), vec![], vec![])]
            } else {
                let files = match fan_out(root, st) {
                    Ok(m) => m.into_iter().flat_map(|(_, f)| f).collect(),
                    Err(GraphError::NoInputs { .. }) => vec![],
                    Err(e) => return Err(e),
                };
                vec![(String::new(), files, vec![])]
            };
            let mut mine = Vec::new();
            for (name, inputs, params) in entries {
                let id = if name.is_empty() {
                    st.name.clone()
                } else {
                    format!("{}[{name}]", st.name)
                };
                mine.push(instances.len());
                instances.push(Instance {
                    id,
                    stage: si,
                    inputs,
                    deps: deps.clone(),
                    params,
                });
            }
            of_stage.insert(&st.name, mine);
        }
        Ok(Graph { spec, instances })
    }

    pub fn stage_of(&self, i: usize) -> &StageSpec {
        &self.spec.stages[self.instances[i].stage]
    }

    /// blake3 of every input file's contents.
    pub fn hash_inputs(&self, root: &Path) -> Result<BTreeMap<String, String>, GraphError> {
        let mut out = BTreeMap::new();
        for inst in &self.instances {
            for f in &inst.inputs {
                if !out.contains_key(f) {
                    let h = crate::core::fsutil::hash_file(&root.join(f)).map_err(|source| {
                        GraphError::Read {
                            path: f.clone(),
                            source,
                        }
                    })?;
                    out.insert(f.clone(), h);
                }
            }
        }
        Ok(out)
    }

    /// Instances needed to build `targets` (stage names or instance ids; all when empty).
    pub fn closure(&self, targets: &[String]) -> Result<Vec<bool>, String> {
        let mut need = vec![targets.is_empty(); self.instances.len()];
        for t in targets {
            let hits: Vec<usize> = (0..self.instances.len())
                .filter(|&i| self.instances[i].id == *t || self.stage_of(i).name == *t)
                .collect();
            if hits.is_empty() {
                let names = self.spec.stages.iter().map(|s| s.name.as_str());
                let hint = crate::core::diag::nearest(t, names)
                    .map_or(String::new(), |s| format!(" (did you mean `{s}`?)"));
                return Err(format!(
                    "no stage or stage instance named `{t}` in pipeline.yaml{hint}"
                ));
            }
            for i in hits {
                need[i] = true;
            }
        }
        for i in (0..self.instances.len()).rev() {
            if need[i] {
                for &d in &self.instances[i].deps {
                    need[d] = true;
                }
            }
        }
        Ok(need)
    }
}
