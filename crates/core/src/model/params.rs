//! Hydrodynamic parameters: the coefficients of the model (seed 003 eq. 1-9, of which the
//! diagonal model of seed 001 is one configuration) and the named vector an estimator works on.

use super::terms::{CustomTerms, Structure, Term};
use crate::dof::Dof;

pub use super::terms::Group;

pub type Mat6 = [[f64; 6]; 6];

/// Hydrodynamic coefficients in SNAME form, indexed by `Dof::index()`: `added[i][j]` is
/// X_udot, X_vdot .. (symmetric; M_A = -added), `lin[i][j]` the force in DOF i per unit
/// velocity j (X_u, Y_r ..), `quad[k][i][j]` the force in DOF i per `nu_j |nu_k|` (seed 003
/// eq. 8, D_Qk), `constant[i]` X_0 .. a constant generalised force on the body (a steady
/// tether pull, a thruster offset; Z_0 < 0 pushes the vehicle up), `net_weight` W - B and
/// `moment` W r_g - B r_b of eq. 9, and `lever` the centre of gravity from the point the
/// logged moments are taken about (see [`Hydro::thrust_about_cg`]). Diagonal drag and added
/// mass are negative for a real vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hydro {
    pub added: Mat6,
    pub lin: Mat6,
    pub quad: [Mat6; 6],
    pub constant: [f64; 6],
    pub net_weight: f64,
    pub moment: [f64; 3],
    pub lever: [f64; 3],
}

/// The moment `r x f` of a force `f` at `r` (body axes): what a force's moment about the
/// logged origin exceeds its moment about a centre of gravity at `r` from it by.
#[inline]
pub fn lever_moment(r: [f64; 3], f: [f64; 3]) -> [f64; 3] {
    [
        r[1] * f[2] - r[2] * f[1],
        r[2] * f[0] - r[0] * f[2],
        r[0] * f[1] - r[1] * f[0],
    ]
}

impl Hydro {
    /// The diagonal model: added mass, linear and quadratic drag per DOF.
    pub fn diagonal(added: [f64; 6], lin: [f64; 6], quad: [f64; 6]) -> Hydro {
        let mut h = Hydro::default();
        for i in 0..6 {
            h.added[i][i] = added[i];
            h.lin[i][i] = lin[i];
            h.quad[i][i][i] = quad[i];
        }
        h
    }

    /// Seed 001, Table 1 (docs/formats.md reference vehicle).
    pub fn reference() -> Hydro {
        Hydro::diagonal(
            [-16.04, -37.74, -83.60, 0.0, 0.0, -1.06],
            [-2.41, -1.50, -21.75, 0.0, 0.0, -1.18],
            [-44.17, -114.30, -121.30, 0.0, 0.0, -2.64],
        )
    }

    /// The logged force and moment `tau` as they act about the centre of gravity: the moment
    /// less `lever x F`. A thruster layout (or a logged wrench) gives its moments about its
    /// own origin; where the vehicle's centre of gravity is elsewhere, each force's lever arm
    /// about it differs by r_g (Fossen 2011, sect. 7.5: moments about the CG from a CO).
    #[inline]
    pub fn thrust_about_cg(&self, tau: &[f64; 6]) -> [f64; 6] {
        if self.lever == [0.0; 3] {
            return *tau;
        }
        let arm = lever_moment(self.lever, [tau[0], tau[1], tau[2]]);
        std::array::from_fn(|i| if i < 3 { tau[i] } else { tau[i] - arm[i - 3] })
    }

    /// The diagonal added mass X_udot .. N_rdot.
    pub fn added_diag(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.added[i][i])
    }

    /// The diagonal linear drag X_u .. N_r.
    pub fn lin_diag(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.lin[i][i])
    }

    /// The diagonal quadratic drag X_uu .. N_rr.
    pub fn quad_diag(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.quad[i][i][i])
    }

    /// Whether every coefficient off the diagonal, and the buoyancy, is zero: the seed-001
    /// model, which the simulators evaluate without a mass-matrix solve.
    pub fn is_diagonal(&self) -> bool {
        let off = |i: usize, j: usize| i != j;
        (0..6).all(|i| {
            (0..6).all(|j| {
                (!off(i, j) || (self.added[i][j] == 0.0 && self.lin[i][j] == 0.0))
                    && (0..6).all(|k| (i == j && j == k) || self.quad[k][i][j] == 0.0)
            })
        }) && self.net_weight == 0.0
            && self.moment == [0.0; 3]
    }

    /// The value of one term.
    pub fn get(&self, t: Term) -> f64 {
        match t {
            Term::Added(i, j) => self.added[i][j],
            Term::Linear(i, j) => self.lin[i][j],
            Term::Quadratic { row, vel, by } => self.quad[by][row][vel],
            Term::Constant(i) => self.constant[i],
            Term::NetWeight => self.net_weight,
            Term::Moment(a) => self.moment[a],
            Term::Lever(a) => self.lever[a],
        }
    }

    /// Sets one term (both halves of a symmetric mass pair).
    pub fn set(&mut self, t: Term, value: f64) {
        match t {
            Term::Added(i, j) => {
                self.added[i][j] = value;
                self.added[j][i] = value;
            }
            Term::Linear(i, j) => self.lin[i][j] = value,
            Term::Quadratic { row, vel, by } => self.quad[by][row][vel] = value,
            Term::Constant(i) => self.constant[i] = value,
            Term::NetWeight => self.net_weight = value,
            Term::Moment(a) => self.moment[a] = value,
            Term::Lever(a) => self.lever[a] = value,
        }
    }
}

/// Maps the flat parameter vector `theta` to named coefficients. For the diagonal structure
/// the order is group-major, then the vehicle's DOF order (X_udot, Y_vdot, .., X_u, ..,
/// X_uu, ..) as seed 001 Table 1 lists them, then the constant forces (X_0, ..); for the
/// coupled structures: mass, linear drag, quadratic drag, constants, buoyancy.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamLayout {
    pub dofs: Vec<Dof>,
    pub constant: Vec<Dof>,
    pub structure: Structure,
    pub terms: Vec<Term>,
}

/// The most linear cross drag terms per DOF the lane simulator ([`super::lanes`]) takes
/// (N_v and N_u in yaw, M_u and M_w in pitch).
pub const MAX_CROSS: usize = 2;

impl ParamLayout {
    /// The diagonal structure over `dofs`.
    pub fn new(dofs: &[Dof]) -> ParamLayout {
        ParamLayout::with_constant(dofs, &[])
    }

    /// The diagonal structure over `dofs` with constant forces on `constant`.
    pub fn with_constant(dofs: &[Dof], constant: &[Dof]) -> ParamLayout {
        ParamLayout::build(Structure::Diagonal, dofs, constant, &CustomTerms::default())
            .expect("the diagonal structure always builds")
    }

    pub fn build(
        structure: Structure,
        dofs: &[Dof],
        constant: &[Dof],
        custom: &CustomTerms,
    ) -> Result<ParamLayout, String> {
        let constant: Vec<Dof> = dofs
            .iter()
            .copied()
            .filter(|d| constant.contains(d))
            .collect();
        let mut terms = structure.terms(dofs, &constant, custom)?;
        // A structure may take a constant's place with a physical term (the net weight).
        let constant: Vec<Dof> = (constant.into_iter())
            .filter(|d| terms.contains(&Term::Constant(d.index())))
            .collect();
        if structure == Structure::Diagonal {
            // Seed 001 Table 1 order: the vehicle's DOF order within each group.
            let pos = |t: &Term| dofs.iter().position(|d| *d == t.dof());
            terms.sort_by_key(|t| (t.group() as usize, pos(t)));
        }
        Ok(ParamLayout {
            dofs: dofs.to_vec(),
            constant,
            structure,
            terms,
        })
    }

    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// Whether every model of this layout has a diagonal mass, with drag diagonal but for at
    /// most [`MAX_CROSS`] linear cross terms per DOF (N_v, Y_r, K_v, M_u, M_w),
    /// weight and buoyancy allowed: what the lane simulator ([`super::lanes`]) evaluates
    /// without a mass-matrix solve.
    pub fn is_diagonal_model(&self) -> bool {
        let cross_in = |i: usize| {
            (self.terms.iter())
                .filter(|t| matches!(t, Term::Linear(r, c) if *r == i && r != c))
                .count()
        };
        (0..6).all(|i| cross_in(i) <= MAX_CROSS)
            && self.terms.iter().all(|t| match *t {
                Term::Added(i, j) => i == j,
                Term::Quadratic { .. } => t.is_diagonal(),
                Term::Linear(..)
                | Term::Constant(_)
                | Term::NetWeight
                | Term::Moment(_)
                | Term::Lever(_) => true,
            })
    }

    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Group and DOF (equation) of parameter `j`.
    pub fn slot(&self, j: usize) -> (Group, Dof) {
        (self.terms[j].group(), self.terms[j].dof())
    }

    /// The index of a term, when the layout has it.
    pub fn index_of(&self, t: Term) -> Option<usize> {
        self.terms.iter().position(|x| *x == t)
    }

    pub fn name(&self, j: usize) -> String {
        self.terms[j].name()
    }

    pub fn names(&self) -> Vec<String> {
        self.terms.iter().map(|t| t.name()).collect()
    }

    /// The unit of coefficient `j`.
    pub fn unit(&self, j: usize) -> &'static str {
        self.terms[j].unit()
    }

    pub fn to_hydro(&self, theta: &[f64]) -> Hydro {
        let mut h = Hydro::default();
        for (t, &value) in self.terms.iter().zip(theta) {
            h.set(*t, value);
        }
        h
    }

    pub fn from_hydro(&self, h: &Hydro) -> Vec<f64> {
        self.terms.iter().map(|t| h.get(*t)).collect()
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

    /// Beside roll or pitch the diagonal model's net buoyancy is the net weight, which tilts
    /// with the vehicle, in place of a heave constant; the other constants stay.
    #[test]
    fn a_tilting_diagonal_model_has_the_net_weight_for_its_heave_constant() {
        let l = ParamLayout::with_constant(&Dof::ALL, &Dof::ALL);
        let names = l.names();
        assert!(names.contains(&"W-B".to_string()), "{names:?}");
        assert!(!names.contains(&"Z_0".to_string()), "{names:?}");
        assert!(names.contains(&"X_0".to_string()), "{names:?}");
        assert_eq!(
            l.constant,
            [Dof::Surge, Dof::Sway, Dof::Roll, Dof::Pitch, Dof::Yaw]
        );
        // Level, or without a translational DOF, there is no net weight to tell apart.
        let level = ParamLayout::with_constant(&[Dof::Heave, Dof::Yaw], &[Dof::Heave]);
        assert_eq!(level.names().last().map(String::as_str), Some("Z_0"));
        let turning = ParamLayout::with_constant(&[Dof::Roll, Dof::Pitch], &[Dof::Roll]);
        assert!(!turning.names().contains(&"W-B".to_string()));
    }
}
