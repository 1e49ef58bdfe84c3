//! The project's OpenFOAM cases: a 2D circular cylinder pushed along x, and a 3D sphere pushed
//! along any direction, by a constant force in still water (laminar pimpleFoam,
//! sixDoFRigidBodyMotion on a morphing mesh). Written from the templates in
//! `src/openfoam/template/` and `template_sphere/`, mesh generation (blockMesh) included.

use std::path::Path;

/// Water density, kg/m^3, as the case's `rhoInf`.
pub const RHO: f64 = 1000.0;

#[derive(Debug, Clone, PartialEq)]
pub struct CylinderCase {
    /// Applied force along +x, N per metre of span.
    pub force_n: f64,
    /// Body mass, kg per metre of span.
    pub mass_kg: f64,
    pub radius_m: f64,
    /// Simulated time, s (None: long enough for about 2.5 m of travel).
    pub end_time_s: Option<f64>,
}

impl CylinderCase {
    /// Potential-flow added mass of a circular cylinder per metre of span: rho pi r^2.
    pub fn displaced_mass(&self) -> f64 {
        RHO * std::f64::consts::PI * self.radius_m * self.radius_m
    }

    /// Rough terminal speed with Cd ~ 0.9, to size the run.
    fn speed_estimate(&self) -> f64 {
        (self.force_n / (0.5 * RHO * 2.0 * self.radius_m * 0.9)).sqrt()
    }

    /// About 2.5 m (12.5 diameters) of travel: the wake has built up, and the morphing mesh
    /// (fixed beyond 8 m from the body) is still sound.
    pub fn end_time(&self) -> f64 {
        self.end_time_s.unwrap_or_else(|| {
            let u = self.speed_estimate();
            let rise = (self.mass_kg + self.displaced_mass()) * u / self.force_n;
            (rise + 2.5 / u).min(60.0).round()
        })
    }

    fn substitutions(&self) -> Vec<(&'static str, String)> {
        let r = self.radius_m;
        let rc = r / std::f64::consts::SQRT_2;
        let ma = self.displaced_mass();
        // Added mass twice the body's or more makes the explicit coupling unstable unless the
        // body's acceleration is relaxed (about m / (m + m_a)).
        let relax = (self.mass_kg / (self.mass_kg + ma) + 0.15).clamp(0.3, 1.0);
        let u = self.speed_estimate();
        // Courant number 1 on the smallest cell (about r/25) at the expected speed.
        let dt = (r / 25.0 / u).clamp(0.002, 0.05);
        let f = |x: f64| format!("{x}");
        vec![
            ("RADIUS", f(r)),
            ("MR", f(-r)),
            ("RC", format!("{rc:.9}")),
            ("MRC", format!("{:.9}", -rc)),
            ("X0", f(-12.0)),
            ("X1", f(15.0)),
            ("Y0", f(-11.0)),
            ("Y1", f(11.0)),
            ("NR", "80".into()),
            ("NC", "40".into()),
            ("GRADE", "265".into()),
            ("FORCE", f(self.force_n)),
            ("MASS", f(self.mass_kg)),
            ("DISPLACED", format!("{ma:.3}")),
            ("INNER", "0.3".into()),
            ("OUTER", "8".into()),
            ("RELAX", format!("{relax:.2}")),
            ("END", f(self.end_time())),
            ("DT", format!("{dt:.3}")),
            ("MAXCO", "1".into()),
            ("OUTERCORR", "2".into()),
        ]
    }

    /// Writes the case folder (refuses to overwrite an existing one).
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.force_n.is_finite() && self.force_n != 0.0,
            "the applied force must be non-zero"
        );
        anyhow::ensure!(
            self.mass_kg > 0.0 && self.radius_m > 0.0,
            "mass and radius must be positive"
        );
        fill(TEMPLATES, &self.substitutions(), dir)
    }
}

/// Writes the templates into the new case folder `dir`, placeholders filled.
fn fill(
    templates: &[(&str, &str)],
    subs: &[(&'static str, String)],
    dir: &Path,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        !dir.exists(),
        "{} exists; choose a new case folder",
        dir.display()
    );
    for (rel, template) in templates {
        let mut text = template.to_string();
        for (k, v) in subs {
            text = text.replace(&format!("@{k}@"), v);
        }
        debug_assert!(!text.contains("@RADIUS@") && !text.contains("@END@"));
        let path = dir.join(rel);
        std::fs::create_dir_all(path.parent().expect("has a parent"))?;
        std::fs::write(&path, text)?;
    }
    Ok(())
}

/// A 3D sphere pushed from rest by a constant force along a unit direction, translating
/// only along it. Its potential-flow added mass is half the displaced water, 1/2 rho V, the
/// same in every direction.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereCase {
    /// Applied force, N, along `direction`.
    pub force_n: f64,
    pub mass_kg: f64,
    pub radius_m: f64,
    /// Unit vector of the force and of the motion (normalised when written).
    pub direction: [f64; 3],
    /// Simulated time, s (None: until about 6 radii of travel, 4 s at most).
    pub end_time_s: Option<f64>,
}

impl SphereCase {
    /// Displaced water, rho 4/3 pi r^3.
    pub fn displaced_mass(&self) -> f64 {
        RHO * 4.0 / 3.0 * std::f64::consts::PI * self.radius_m.powi(3)
    }

    /// Potential-flow added mass: 1/2 rho V.
    pub fn added_mass(&self) -> f64 {
        0.5 * self.displaced_mass()
    }

    /// Rough terminal speed with Cd ~ 0.5.
    fn speed_estimate(&self) -> f64 {
        let r = self.radius_m;
        (self.force_n.abs() / (0.5 * RHO * std::f64::consts::PI * r * r * 0.5)).sqrt()
    }

    /// Until about 6 radii of travel (or the speed's time constant, or 4 s), at least 0.3 s:
    /// the added mass is read while the body accelerates, and the morphing mesh stays sound.
    pub fn end_time(&self) -> f64 {
        self.end_time_s.unwrap_or_else(|| {
            let m = self.mass_kg + self.added_mass();
            let tau = m * self.speed_estimate() / self.force_n.abs();
            let a0 = self.force_n.abs() / m;
            let t = tau.min((12.0 * self.radius_m / a0).sqrt()).min(4.0);
            ((t * 10.0).round() / 10.0).max(0.3)
        })
    }

    fn substitutions(&self) -> Vec<(&'static str, String)> {
        let r = self.radius_m;
        let a = r / 3f64.sqrt();
        let half = 20.0 * r;
        // Radial cells: the first 0.02 r thick at the sphere (a thicker wall cell under-reads
        // the wall pressure: -3.7 % added mass at 0.08 r), growing geometrically to the box.
        let (nr, first) = (30, 0.02 * r);
        let ratio = {
            let (mut lo, mut hi) = (1.000_000_1f64, 2.0f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if first * (mid.powi(nr) - 1.0) / (mid - 1.0) > half - r {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let relax = (self.mass_kg / (self.mass_kg + self.added_mass()) + 0.15).clamp(0.3, 1.0);
        let dt = (r / 12.0 / self.speed_estimate()).clamp(0.004, 0.02);
        let norm = self.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
        // `+ 0.0` writes -0 as 0.
        let d = self.direction.map(|x| x / norm + 0.0);
        let f = |x: f64| format!("{x}");
        vec![
            ("RADIUS", f(r)),
            ("A", format!("{a:.9}")),
            ("MA", format!("{:.9}", -a)),
            ("HALF", f(half)),
            ("MHALF", f(-half)),
            ("NS", "12".into()),
            ("NR", nr.to_string()),
            ("GRADE", format!("{:.2}", ratio.powi(nr - 1))),
            ("FORCE", f(self.force_n)),
            ("MASS", f(self.mass_kg)),
            ("DISPLACED", format!("{:.3}", self.displaced_mass())),
            ("DIRX", f(d[0])),
            ("DIRY", f(d[1])),
            ("DIRZ", f(d[2])),
            ("INNER", f(2.0 * r)),
            ("OUTER", f(0.8 * half)),
            ("RELAX", format!("{relax:.2}")),
            ("END", f(self.end_time())),
            ("DT", format!("{dt:.4}")),
            ("MAXCO", "1".into()),
            ("OUTERCORR", "2".into()),
        ]
    }

    /// Writes the case folder (refuses to overwrite an existing one).
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.force_n.is_finite() && self.force_n != 0.0,
            "the applied force must be non-zero"
        );
        anyhow::ensure!(
            self.mass_kg > 0.0 && self.radius_m > 0.0,
            "mass and radius must be positive"
        );
        anyhow::ensure!(
            self.direction.iter().all(|x| x.is_finite())
                && self.direction.iter().any(|x| *x != 0.0),
            "the direction must be a non-zero vector"
        );
        fill(SPHERE_TEMPLATES, &self.substitutions(), dir)
    }
}

macro_rules! templates {
    ($dir:literal: $($rel:literal),* $(,)?) => {
        &[$(($rel, include_str!(concat!($dir, "/", $rel)))),*]
    };
}

const SPHERE_TEMPLATES: &[(&str, &str)] = templates!("template_sphere":
    "system/blockMeshDict",
    "system/controlDict",
    "system/fvSchemes",
    "system/fvSolution",
    "constant/dynamicMeshDict",
    "constant/transportProperties",
    "constant/turbulenceProperties",
    "0/U",
    "0/p",
    "0/pointDisplacement",
);

const TEMPLATES: &[(&str, &str)] = &[
    (
        "system/blockMeshDict",
        include_str!("template/system/blockMeshDict"),
    ),
    (
        "system/controlDict",
        include_str!("template/system/controlDict"),
    ),
    (
        "system/fvSchemes",
        include_str!("template/system/fvSchemes"),
    ),
    (
        "system/fvSolution",
        include_str!("template/system/fvSolution"),
    ),
    (
        "constant/dynamicMeshDict",
        include_str!("template/constant/dynamicMeshDict"),
    ),
    (
        "constant/transportProperties",
        include_str!("template/constant/transportProperties"),
    ),
    (
        "constant/turbulenceProperties",
        include_str!("template/constant/turbulenceProperties"),
    ),
    ("0/U", include_str!("template/0/U")),
    ("0/p", include_str!("template/0/p")),
    (
        "0/pointDisplacement",
        include_str!("template/0/pointDisplacement"),
    ),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_placeholder_is_filled() {
        let c = CylinderCase {
            force_n: 2.0,
            mass_kg: 62.832,
            radius_m: 0.1,
            end_time_s: None,
        };
        let dir = tempfile::tempdir().unwrap();
        let case = dir.path().join("c");
        c.write(&case).unwrap();
        for (rel, _) in TEMPLATES {
            let text = std::fs::read_to_string(case.join(rel)).unwrap();
            assert!(!text.contains('@'), "{rel} keeps a placeholder");
        }
        assert!((c.displaced_mass() - 31.4159).abs() < 1e-3);
        assert!(c.write(&case).is_err(), "never overwrites");
    }

    #[test]
    fn the_sphere_case_says_its_force_mass_and_direction() {
        let c = SphereCase {
            force_n: 1.0,
            mass_kg: 8.0,
            radius_m: 0.1,
            direction: [0.0, 0.0, 2.0],
            end_time_s: None,
        };
        let dir = tempfile::tempdir().unwrap();
        let case = dir.path().join("s");
        c.write(&case).unwrap();
        for (rel, _) in SPHERE_TEMPLATES {
            let text = std::fs::read_to_string(case.join(rel)).unwrap();
            assert!(!text.contains('@'), "{rel} keeps a placeholder");
        }
        let s = crate::cfd::openfoam::read_setup(&case, "s").unwrap();
        assert_eq!(s.mass_kg, 8.0);
        assert_eq!(s.applied_force(), [0.0, 0.0, 1.0]);
        assert!((c.added_mass() - 2.0944).abs() < 1e-4);
        assert_eq!(c.end_time(), 3.5, "the run the template was checked with");
        let mesh = std::fs::read_to_string(case.join("system/blockMeshDict")).unwrap();
        assert!(!crate::cfd::openfoam::dict::has_empty_patch(&mesh), "3D");
        assert!(c.write(&case).is_err(), "never overwrites");
    }
}
