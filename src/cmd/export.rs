//! `hydrofit export --to FORMAT`: the identified model written for a simulator or a toolbox
//! (see `export/`), from the cache of the last build; `hydrofit import-model FILE`: a
//! simulator's model file read as hydrofit reads it, printed as hydrofit's YAML.

use crate::export::{Format, Model};
use crate::pipeline::Plan;
use std::path::Path;
use std::process::ExitCode;

/// Writes the model of fit stage `model` (or the pipeline's only fit of its vehicle) in
/// `formats` into `out` (relative to the project), and says what each format left out.
pub fn run(
    root: &Path,
    formats: &[Format],
    model: Option<&str>,
    out: &Path,
) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let cache = plan.cache();
    let pick = pick_fit(&plan, model)?;
    let f = crate::cmd::provenance::load_fit(&plan, &cache, pick)?;
    let m = Model::of(&f, &plan.graph.spec.vehicle);
    let dir = if out.is_absolute() {
        out.to_path_buf()
    } else {
        root.join(out)
    };
    std::fs::create_dir_all(&dir)?;
    for &format in formats {
        let e = crate::export::export(&m, format);
        crate::core::fsutil::write_atomic(&dir.join(&e.file_name), e.text.as_bytes())?;
        eprintln!("wrote {}", dir.join(&e.file_name).display());
        for l in &e.left_out {
            eprintln!("  {format:?} cannot hold {l}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The fit stage named `model`, or the pipeline's only fit of its own vehicle.
pub fn pick_fit(plan: &Plan, model: Option<&str>) -> anyhow::Result<usize> {
    let cache = plan.cache();
    let g = &plan.graph;
    let fits: Vec<usize> = (0..g.instances.len())
        .filter(|&i| g.stage_of(i).kind.name == "fit")
        .collect();
    let names: Vec<&str> = fits.iter().map(|&i| g.instances[i].id.as_str()).collect();
    let pick = match model {
        Some(m) => fits
            .iter()
            .copied()
            .find(|&i| g.instances[i].id == m)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "--model {m}: no fit stage of that name; fit stages: {}",
                    names.join(", ")
                )
            })?,
        None if fits.len() == 1 => fits[0],
        None => {
            let own: Vec<usize> = fits
                .iter()
                .copied()
                .filter(|&i| {
                    crate::cmd::provenance::load_fit(plan, &cache, i)
                        .is_ok_and(|f| f.vehicle.is_none())
                })
                .collect();
            match own[..] {
                [i] => i,
                _ => anyhow::bail!(
                    "which model? the pipeline has fit stages {}: name one with --model",
                    names.join(", ")
                ),
            }
        }
    };
    Ok(pick)
}

/// Reads `file` (format by its name unless given) and prints it as hydrofit's model file.
pub fn import(file: &Path, format: Option<Format>) -> anyhow::Result<ExitCode> {
    let name = file.to_string_lossy();
    let format = format.or_else(|| Format::of_path(&name)).ok_or_else(|| {
        anyhow::anyhow!("{name}: which format? give --format gazebo|uuv|stonefish|mss|yaml")
    })?;
    let text = std::fs::read_to_string(file).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let m = crate::export::import(format, &text).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    crate::outln!("{}", crate::export::export(&m, Format::Yaml).text);
    Ok(ExitCode::SUCCESS)
}
