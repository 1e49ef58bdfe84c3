//! The project's OpenFOAM case: a 2D circular cylinder pushed along x by a constant force in
//! still water (laminar pimpleFoam, sixDoFRigidBodyMotion on a morphing O-grid). Written from
//! the templates in `src/openfoam/template/`, mesh generation (blockMesh) included.

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
        anyhow::ensure!(
            !dir.exists(),
            "{} exists; choose a new case folder",
            dir.display()
        );
        let subs = self.substitutions();
        for (rel, template) in TEMPLATES {
            let mut text = template.to_string();
            for (k, v) in &subs {
                text = text.replace(&format!("@{k}@"), v);
            }
            debug_assert!(!text.contains("@RADIUS@") && !text.contains("@END@"));
            let path = dir.join(rel);
            std::fs::create_dir_all(path.parent().expect("has a parent"))?;
            std::fs::write(&path, text)?;
        }
        Ok(())
    }
}

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
}
