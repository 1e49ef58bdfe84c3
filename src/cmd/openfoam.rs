//! `hydrofit openfoam new`: a new OpenFOAM case of a test body pushed by a constant force.

use crate::cfd::openfoam::case::{CylinderCase, SphereCase};
use std::path::Path;
use std::process::ExitCode;

/// The body of a new OpenFOAM case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Shape {
    Cylinder,
    Sphere,
}

/// What `openfoam new` was asked for.
pub struct New<'a> {
    pub shape: Shape,
    pub force: f64,
    pub mass: Option<f64>,
    pub radius: f64,
    pub direction: &'a str,
    pub end_time: Option<f64>,
}

/// Writes the case into `dir` and says what it wrote.
pub fn new(dir: &Path, n: New) -> anyhow::Result<ExitCode> {
    let what = match n.shape {
        Shape::Sphere => sphere(dir, &n)?,
        Shape::Cylinder => cylinder(dir, &n)?,
    };
    println!("wrote {} ({what})", dir.display());
    Ok(ExitCode::SUCCESS)
}

fn sphere(dir: &Path, n: &New) -> anyhow::Result<String> {
    let direction = parse_direction(n.direction)?;
    let mut c = SphereCase {
        force_n: n.force,
        mass_kg: 0.0,
        radius_m: n.radius,
        direction,
        end_time_s: n.end_time,
    };
    c.mass_kg = n.mass.unwrap_or(2.0 * c.displaced_mass());
    c.write(dir)?;
    Ok(format!(
        "sphere, force {} N along {direction:?}, mass {:.3} kg, end time {} s; potential-flow added mass {:.3} kg",
        n.force,
        c.mass_kg,
        c.end_time(),
        c.added_mass()
    ))
}

fn cylinder(dir: &Path, n: &New) -> anyhow::Result<String> {
    anyhow::ensure!(
        n.direction == "x",
        "the cylinder case moves along x only; --direction is for --shape sphere"
    );
    let mut c = CylinderCase {
        force_n: n.force,
        mass_kg: 0.0,
        radius_m: n.radius,
        end_time_s: n.end_time,
    };
    c.mass_kg = n.mass.unwrap_or(2.0 * c.displaced_mass());
    c.write(dir)?;
    Ok(format!(
        "force {} N/m, mass {:.3} kg/m, end time {} s",
        n.force,
        c.mass_kg,
        c.end_time()
    ))
}

/// `x`, `y`, `z` (or with a sign, `-z`), or three numbers `1,0,1`.
fn parse_direction(s: &str) -> anyhow::Result<[f64; 3]> {
    let axis = |a: &str| match a {
        "x" => Some([1.0, 0.0, 0.0]),
        "y" => Some([0.0, 1.0, 0.0]),
        "z" => Some([0.0, 0.0, 1.0]),
        _ => None,
    };
    if let Some(v) = axis(s) {
        return Ok(v);
    }
    if let Some(v) = s.strip_prefix('-').and_then(axis) {
        return Ok(v.map(|x| -x + 0.0));
    }
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            anyhow::anyhow!("--direction {s}: give x, y, z, -z or three numbers like 1,0,1")
        })?;
    let [x, y, z] = parts[..] else {
        anyhow::bail!("--direction {s}: give three numbers like 1,0,1");
    };
    Ok([x, y, z])
}
