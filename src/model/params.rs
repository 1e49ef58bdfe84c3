//! Hydrodynamic parameters: the named vector an estimator works on, and its physical layout.

use crate::dof::Dof;

/// Diagonal hydrodynamic coefficients in SNAME form, indexed by `Dof::index()`:
/// `added[i]` is X_udot.., `lin[i]` is X_u.., `quad[i]` is X_uu.. (all negative for a real vehicle),
/// `constant[i]` is X_0..: a constant generalised force on the body (net buoyancy, a steady
/// tether pull), N or N m, in SNAME sign (Z_0 < 0 pushes the vehicle up).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hydro {
    pub added: [f64; 6],
    pub lin: [f64; 6],
    pub quad: [f64; 6],
    pub constant: [f64; 6],
}

impl Hydro {
    /// Seed 001, Table 1 (docs/formats.md reference vehicle).
    pub fn reference() -> Hydro {
        Hydro {
            added: [-16.04, -37.74, -83.60, 0.0, 0.0, -1.06],
            lin: [-2.41, -1.50, -21.75, 0.0, 0.0, -1.18],
            quad: [-44.17, -114.30, -121.30, 0.0, 0.0, -2.64],
            constant: [0.0; 6],
        }
    }
}

/// The groups of the diagonal structure, in parameter-vector order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    AddedMass,
    LinearDrag,
    QuadraticDrag,
    /// A constant generalised force (only for the DOFs the vehicle lists in `constant_force`).
    Constant,
}

impl Group {
    /// The sign physics allows: added mass and drag coefficients are negative in SNAME form
    /// (a positive one would be negative inertia or drag that feeds energy in); a constant
    /// force may point either way.
    pub fn physical_sign(self) -> Option<f64> {
        match self {
            Group::AddedMass | Group::LinearDrag | Group::QuadraticDrag => Some(-1.0),
            Group::Constant => None,
        }
    }
}

/// Maps the flat parameter vector `theta` to named coefficients: group-major, then the
/// vehicle's DOF order (X_udot, Y_vdot, .., X_u, .., X_uu, ..), as seed 001 Table 1 lists them,
/// then the constant forces (X_0, ..) of the DOFs that have one.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamLayout {
    pub dofs: Vec<Dof>,
    pub constant: Vec<Dof>,
}

impl ParamLayout {
    pub fn new(dofs: &[Dof]) -> ParamLayout {
        ParamLayout {
            dofs: dofs.to_vec(),
            constant: Vec::new(),
        }
    }

    /// The layout of a vehicle: its DOFs and the DOFs with a constant force term.
    pub fn of(vehicle: &crate::model::Vehicle) -> ParamLayout {
        ParamLayout::with_constant(&vehicle.dofs, &vehicle.constant_force)
    }

    pub fn with_constant(dofs: &[Dof], constant: &[Dof]) -> ParamLayout {
        let constant = dofs
            .iter()
            .copied()
            .filter(|d| constant.contains(d))
            .collect();
        ParamLayout {
            dofs: dofs.to_vec(),
            constant,
        }
    }

    pub fn len(&self) -> usize {
        3 * self.dofs.len() + self.constant.len()
    }

    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// Group and DOF of parameter `j`.
    pub fn slot(&self, j: usize) -> (Group, Dof) {
        let n = self.dofs.len();
        if j >= 3 * n {
            return (Group::Constant, self.constant[j - 3 * n]);
        }
        let group = [Group::AddedMass, Group::LinearDrag, Group::QuadraticDrag][j / n];
        (group, self.dofs[j % n])
    }

    pub fn name(&self, j: usize) -> String {
        let (g, d) = self.slot(j);
        let (f, v) = (d.force(), d.velocity());
        match g {
            Group::AddedMass => format!("{f}_{v}dot"),
            Group::LinearDrag => format!("{f}_{v}"),
            Group::QuadraticDrag => format!("{f}_{v}{v}"),
            Group::Constant => format!("{f}_0"),
        }
    }

    pub fn names(&self) -> Vec<String> {
        (0..self.len()).map(|j| self.name(j)).collect()
    }

    /// The unit of coefficient `j`.
    pub fn unit(&self, j: usize) -> &'static str {
        let (g, d) = self.slot(j);
        match (g, d.is_angular()) {
            (Group::AddedMass, false) => "kg",
            (Group::AddedMass, true) => "kg m^2",
            (Group::LinearDrag, false) => "N s/m",
            (Group::LinearDrag, true) => "N m s/rad",
            (Group::QuadraticDrag, false) => "N s^2/m^2",
            (Group::QuadraticDrag, true) => "N m s^2/rad^2",
            (Group::Constant, false) => "N",
            (Group::Constant, true) => "N m",
        }
    }

    pub fn to_hydro(&self, theta: &[f64]) -> Hydro {
        let mut h = Hydro::default();
        for (j, &value) in theta.iter().enumerate().take(self.len()) {
            let (g, d) = self.slot(j);
            let i = d.index();
            match g {
                Group::AddedMass => h.added[i] = value,
                Group::LinearDrag => h.lin[i] = value,
                Group::QuadraticDrag => h.quad[i] = value,
                Group::Constant => h.constant[i] = value,
            }
        }
        h
    }

    pub fn from_hydro(&self, h: &Hydro) -> Vec<f64> {
        (0..self.len())
            .map(|j| {
                let (g, d) = self.slot(j);
                let i = d.index();
                match g {
                    Group::AddedMass => h.added[i],
                    Group::LinearDrag => h.lin[i],
                    Group::QuadraticDrag => h.quad[i],
                    Group::Constant => h.constant[i],
                }
            })
            .collect()
    }
}

/// A coefficient's unit per metre of span (a 2D body): kg -> kg/m, N s/m -> N s/m^2,
/// N s^2/m^2 -> N s^2/m^3, N -> N/m.
pub fn per_metre_of_span(unit: &str) -> String {
    if let Some((head, pow)) = unit.rsplit_once("/m^")
        && let Ok(k) = pow.parse::<u32>()
    {
        return format!("{head}/m^{}", k + 1);
    }
    if let Some(head) = unit.strip_suffix("/m") {
        return format!("{head}/m^2");
    }
    format!("{unit}/m")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_per_metre_of_span_divide_by_one_more_metre() {
        let l = ParamLayout::with_constant(&[Dof::Surge], &[Dof::Surge]);
        let per_span: Vec<String> = (0..l.len()).map(|j| per_metre_of_span(l.unit(j))).collect();
        assert_eq!(per_span, ["kg/m", "N s/m^2", "N s^2/m^3", "N/m"]);
    }

    #[test]
    fn names_follow_table_1() {
        let l = ParamLayout::new(&[Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw]);
        assert_eq!(
            l.names(),
            [
                "X_udot", "Y_vdot", "Z_wdot", "N_rdot", "X_u", "Y_v", "Z_w", "N_r", "X_uu", "Y_vv",
                "Z_ww", "N_rr"
            ]
        );
        let h = Hydro::reference();
        assert_eq!(l.to_hydro(&l.from_hydro(&h)), h);
        let c = ParamLayout::with_constant(&l.dofs, &[Dof::Yaw, Dof::Heave]);
        assert_eq!(c.len(), 14);
        assert_eq!(&c.names()[12..], ["Z_0", "N_0"]);
        assert_eq!(c.unit(13), "N m");
        let mut h = Hydro::reference();
        h.constant[2] = -8.0;
        assert_eq!(c.to_hydro(&c.from_hydro(&h)), h);
    }
}
