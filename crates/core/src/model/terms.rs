//! The terms of the coupled 6-DOF model of seed 003 (eq. 1-9) and the parameter sets of its
//! Table I: which added-mass, drag and buoyancy coefficients a fit identifies.
//!
//! Every coefficient is in SNAME sign, as the generalised force it contributes on the body:
//! `Added(i, j)` is the symmetric pair X_vdot = Y_udot .. (M_A = -[added]), `Linear(i, j)` is
//! the force in DOF i per unit velocity j (Y_r, N_v ..), `Quadratic { row, vel, by }` the force
//! in `row` per `nu_vel |nu_by|` (seed 003 eq. 8: row `row` of D_Q,by, column `vel`), and the
//! composite buoyancy of eq. 9: the net weight W - B (N, positive sinks) and the moment
//! eta = W r_g - B r_b (N m), acting as `[ (W-B) g ; eta x g ]` with `g` the unit gravity
//! vector in the body frame. (Seed 003 writes b on the side of the mass; here it acts with the
//! thrust, as the constant forces do, so the signs above are the physical ones.)

use crate::dof::Dof;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Term {
    /// Symmetric added mass (i <= j).
    Added(usize, usize),
    Linear(usize, usize),
    Quadratic {
        row: usize,
        vel: usize,
        by: usize,
    },
    /// A constant generalised force X_0 .. N_0.
    Constant(usize),
    /// Net weight W - B of seed 003 eq. 9 (beta).
    NetWeight,
    /// One component of the buoyancy-induced moment vector eta of eq. 9.
    Moment(usize),
    /// One component of the centre of gravity's position r_g (x_g, y_g, z_g, m) from the point
    /// the logged moments are taken about (the origin of the thrusters' layout, or of a logged
    /// wrench): the logged force's moment about the centre of gravity is the logged moment
    /// less r_g x F ([`super::params::Hydro::thrust_about_cg`]).
    Lever(usize),
}

/// The kind of a term, as estimators treat them (signs, bounds, two-step fits).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    AddedMass,
    LinearDrag,
    QuadraticDrag,
    /// A constant generalised force (only for the DOFs the vehicle lists in `constant_force`).
    Constant,
    /// Net weight and the moment of weight and buoyancy (seed 003 eq. 9).
    Buoyancy,
    /// Where the centre of gravity is from the point the logged moments are taken about.
    Lever,
}

impl Term {
    pub fn group(self) -> Group {
        match self {
            Term::Added(..) => Group::AddedMass,
            Term::Linear(..) => Group::LinearDrag,
            Term::Quadratic { .. } => Group::QuadraticDrag,
            Term::Constant(_) => Group::Constant,
            Term::NetWeight | Term::Moment(_) => Group::Buoyancy,
            Term::Lever(_) => Group::Lever,
        }
    }

    /// The equation (DOF) the term belongs to: its row, the lower index of a mass pair, heave
    /// for the net weight, the moment's axis for eta, and for r_g the first of the two
    /// moments it moves ([`Term::equations`]).
    pub fn dof(self) -> Dof {
        let i = match self {
            Term::Added(i, _) | Term::Linear(i, _) | Term::Constant(i) => i,
            Term::Quadratic { row, .. } => row,
            Term::NetWeight => 2,
            Term::Moment(a) => a + 3,
            Term::Lever(a) => lever_moments(a)[0],
        };
        Dof::ALL[i]
    }

    /// The equations the term enters: its own, except for the weight and buoyancy. W - B pushes
    /// along the vertical, which tilts into surge and sway; a component of eta is a moment
    /// about its axis crossed with the vertical, so it turns the other two axes (eta_z rights
    /// roll and pitch, eta_x acts in pitch and yaw, eta_y in roll and yaw).
    pub fn equations(self) -> Vec<Dof> {
        match self {
            Term::NetWeight => vec![Dof::Surge, Dof::Sway, Dof::Heave],
            Term::Moment(a) => (0..3)
                .filter(|&b| b != a)
                .map(|b| Dof::ALL[b + 3])
                .collect(),
            Term::Lever(a) => lever_moments(a).iter().map(|&i| Dof::ALL[i]).collect(),
            t => vec![t.dof()],
        }
    }

    /// A diagonal term (X_udot, X_u, X_uu): one that physics signs.
    pub fn is_diagonal(self) -> bool {
        match self {
            Term::Added(i, j) | Term::Linear(i, j) => i == j,
            Term::Quadratic { row, vel, by } => row == vel && vel == by,
            _ => false,
        }
    }

    /// The sign physics allows: diagonal added mass and drag are negative in SNAME form (a
    /// positive one is negative inertia, or drag that feeds energy in); cross terms, constant
    /// forces and buoyancy may point either way.
    pub fn physical_sign(self) -> Option<f64> {
        self.is_diagonal().then_some(-1.0)
    }

    /// SNAME name: X_udot, X_vdot (= Y_udot), Y_r, X_uu, Y_v|r| (Y per v|r|), X_0, W-B, eta_x.
    pub fn name(self) -> String {
        let f = |i: usize| Dof::ALL[i].force();
        let v = |i: usize| Dof::ALL[i].velocity();
        match self {
            Term::Added(i, j) => format!("{}_{}dot", f(i), v(j)),
            Term::Linear(i, j) => format!("{}_{}", f(i), v(j)),
            Term::Quadratic { row, vel, by } if vel == by => {
                format!("{}_{}{}", f(row), v(vel), v(by))
            }
            Term::Quadratic { row, vel, by } => format!("{}_{}|{}|", f(row), v(vel), v(by)),
            Term::Constant(i) => format!("{}_0", f(i)),
            Term::NetWeight => "W-B".into(),
            Term::Moment(a) => format!("eta_{}", ['x', 'y', 'z'][a]),
            Term::Lever(a) => format!("{}_g", ['x', 'y', 'z'][a]),
        }
    }

    pub fn unit(self) -> &'static str {
        let ang = |i: usize| i >= 3;
        match self {
            Term::Added(i, j) => match (ang(i), ang(j)) {
                (false, false) => "kg",
                (true, true) => "kg m^2",
                _ => "kg m",
            },
            Term::Linear(i, j) => match (ang(i), ang(j)) {
                (false, false) => "N s/m",
                (true, true) => "N m s/rad",
                (false, true) => "N s/rad",
                (true, false) => "N s",
            },
            Term::Quadratic { row, vel, by } => {
                match (ang(row), u8::from(ang(vel)) + u8::from(ang(by))) {
                    (false, 0) => "N s^2/m^2",
                    (false, 1) => "N s^2/(m rad)",
                    (false, _) => "N s^2/rad^2",
                    (true, 0) => "N s^2/m",
                    (true, 1) => "N s^2/rad",
                    (true, _) => "N m s^2/rad^2",
                }
            }
            Term::Constant(i) if ang(i) => "N m",
            Term::Constant(_) | Term::NetWeight => "N",
            Term::Moment(_) => "N m",
            Term::Lever(_) => "m",
        }
    }

    /// Every term a structure can name over `dofs` (mass pairs, drag, constants, buoyancy).
    pub fn parse(name: &str) -> Option<Term> {
        all_terms(&Dof::ALL, &Dof::ALL)
            .into_iter()
            .find(|t| t.name() == name)
    }
}

/// The parameter sets of seed 003 Table I, and hydrofit's diagonal model of seed 001.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Structure {
    /// Diagonal added mass, linear and quadratic drag (seed 001 eq. 4-5), constant forces
    /// where the vehicle lists them.
    #[default]
    Diagonal,
    /// Full quadratic drag, full mass matrix, buoyancy (241 terms in 6 DOF).
    FullQd,
    /// Diagonal quadratic drag, full mass matrix, buoyancy (31).
    DiagQd,
    /// Full quadratic drag, diagonal mass matrix, buoyancy (226).
    DiagMass,
    /// Diagonal quadratic drag, diagonal mass matrix, buoyancy (16).
    DiagAll,
    /// Full linear drag, full mass matrix, buoyancy (61).
    FullLd,
    /// A base set with terms added and removed (`custom_terms`); by default seed 003's CUSTOM:
    /// FULL QD with the roll's linear drag K_p in place of its quadratic K_pp (241).
    Custom,
}

/// The terms of a `custom` structure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CustomTerms {
    pub base: Structure,
    #[serde(default)]
    pub add: Vec<String>,
    #[serde(default)]
    pub remove: Vec<String>,
}

impl CustomTerms {
    /// The custom set that is exactly the terms `names` (over `dofs`, with constant forces on
    /// `constant`): a model read from a file has the terms it has.
    pub fn only(names: &[String], dofs: &[Dof], constant: &[Dof]) -> CustomTerms {
        let base = Structure::FullQd
            .terms(dofs, constant, &CustomTerms::default())
            .unwrap_or_default();
        let base_names: Vec<String> = base.iter().map(|t| t.name()).collect();
        CustomTerms {
            base: Structure::FullQd,
            add: names
                .iter()
                .filter(|n| !base_names.contains(n))
                .cloned()
                .collect(),
            remove: base_names
                .iter()
                .filter(|n| !names.contains(n))
                .cloned()
                .collect(),
        }
    }
}

impl Default for CustomTerms {
    fn default() -> Self {
        CustomTerms {
            base: Structure::FullQd,
            add: vec!["K_p".into()],
            remove: vec!["K_pp".into()],
        }
    }
}

impl Structure {
    pub const ALL: [Structure; 7] = [
        Structure::Diagonal,
        Structure::FullQd,
        Structure::DiagQd,
        Structure::DiagMass,
        Structure::DiagAll,
        Structure::FullLd,
        Structure::Custom,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Structure::Diagonal => "diagonal",
            Structure::FullQd => "full_qd",
            Structure::DiagQd => "diag_qd",
            Structure::DiagMass => "diag_mass",
            Structure::DiagAll => "diag_all",
            Structure::FullLd => "full_ld",
            Structure::Custom => "custom",
        }
    }

    /// The terms over `dofs`, with constant forces on `constant` (diagonal structure) and
    /// `custom` for the custom structure. Order: mass, linear, quadratic, constants, buoyancy.
    pub fn terms(
        self,
        dofs: &[Dof],
        constant: &[Dof],
        custom: &CustomTerms,
    ) -> Result<Vec<Term>, String> {
        let ix: Vec<usize> = Dof::ALL
            .iter()
            .filter(|d| dofs.contains(d))
            .map(|d| d.index())
            .collect();
        let (full_mass, drag) = match self {
            Structure::Diagonal => (false, Drag::DiagBoth),
            Structure::FullQd => (true, Drag::FullQuadratic),
            Structure::DiagQd => (true, Drag::DiagQuadratic),
            Structure::DiagMass => (false, Drag::FullQuadratic),
            Structure::DiagAll => (false, Drag::DiagQuadratic),
            Structure::FullLd => (true, Drag::FullLinear),
            Structure::Custom => return custom_terms(dofs, constant, custom),
        };
        let mut out = mass_terms(&ix, full_mass);
        out.extend(drag.terms(&ix));
        out.extend(
            ix.iter()
                .filter(|&&i| constant.contains(&Dof::ALL[i]))
                .map(|&i| Term::Constant(i)),
        );
        if self != Structure::Diagonal {
            out.extend(buoyancy_terms(&ix));
        } else if ix.iter().any(|&i| i == 3 || i == 4) {
            // A vehicle that rolls or pitches is held level by the moment of its weight and
            // buoyancy: without it a diagonal model of roll and pitch has no restoring term.
            // The vertical offset of the centre of gravity below the centre of buoyancy
            // (eta_z) is that restoring moment. A horizontal offset gives, near level trim, a
            // constant pitch (eta_x) or roll (eta_y) moment: where the model already has that
            // constant (`constant_force`), the two cannot be told apart, and the offset's
            // small cross terms (a yaw moment when rolled) would be fitted to noise, as they
            // would where the model has no pitch (eta_x) or roll (eta_y): there they are those
            // cross terms alone, and a model of roll by itself has no column for them at all.
            let free = |i: usize| ix.contains(&i) && !constant.contains(&Dof::ALL[i]);
            // The net weight W - B is vertical: as the vehicle pitches or rolls it tilts into
            // surge and sway, where a body-fixed constant force cannot follow it (pitched
            // 30 deg, 2 N of buoyancy pushes 1 N along the hull).
            // At level trim it is a constant heave force, which it replaces.
            if ix.iter().any(|&i| i < 3) {
                out.retain(|t| *t != Term::Constant(2));
                out.push(Term::NetWeight);
            }
            out.push(Term::Moment(2));
            if free(4) {
                out.push(Term::Moment(0));
            }
            if free(3) {
                out.push(Term::Moment(1));
            }
        }
        Ok(out)
    }
}

fn custom_terms(dofs: &[Dof], constant: &[Dof], c: &CustomTerms) -> Result<Vec<Term>, String> {
    if c.base == Structure::Custom {
        return Err("custom_terms.base must be one of the other structures, not custom".into());
    }
    let mut out = c.base.terms(dofs, constant, &CustomTerms::default())?;
    let lookup = |name: &String| {
        let t = Term::parse(name).ok_or_else(|| {
            format!("custom_terms: {name:?} is not a term (names look like K_p, X_vdot, Y_v|r|, N_rr, W-B, eta_x)")
        })?;
        match all_terms(dofs, &Dof::ALL).contains(&t) {
            true => Ok(t),
            false => Err(format!(
                "custom_terms: {name} involves a DOF the vehicle does not move in"
            )),
        }
    };
    for name in &c.remove {
        let t = lookup(name)?;
        let before = out.len();
        out.retain(|x| *x != t);
        if out.len() == before {
            return Err(format!(
                "custom_terms.remove: {name} is not in {}",
                c.base.label()
            ));
        }
    }
    for name in &c.add {
        let t = lookup(name)?;
        if out.contains(&t) {
            return Err(format!(
                "custom_terms.add: {name} is already in {}",
                c.base.label()
            ));
        }
        out.push(t);
    }
    out.sort();
    Ok(out)
}

enum Drag {
    DiagBoth,
    DiagQuadratic,
    FullQuadratic,
    FullLinear,
}

impl Drag {
    fn terms(self, ix: &[usize]) -> Vec<Term> {
        let quad = |row, vel, by| Term::Quadratic { row, vel, by };
        match self {
            Drag::DiagBoth => ix
                .iter()
                .map(|&i| Term::Linear(i, i))
                .chain(ix.iter().map(|&i| quad(i, i, i)))
                .collect(),
            Drag::DiagQuadratic => ix.iter().map(|&i| quad(i, i, i)).collect(),
            Drag::FullLinear => pairs(ix).map(|(i, j)| Term::Linear(i, j)).collect(),
            Drag::FullQuadratic => pairs(ix)
                .flat_map(|(i, j)| ix.iter().map(move |&k| quad(i, j, k)))
                .collect(),
        }
    }
}

fn pairs(ix: &[usize]) -> impl Iterator<Item = (usize, usize)> + '_ {
    ix.iter()
        .flat_map(move |&i| ix.iter().map(move |&j| (i, j)))
}

fn mass_terms(ix: &[usize], full: bool) -> Vec<Term> {
    match full {
        true => pairs(ix)
            .filter(|(i, j)| i <= j)
            .map(|(i, j)| Term::Added(i, j))
            .collect(),
        false => ix.iter().map(|&i| Term::Added(i, i)).collect(),
    }
}

/// The furthest a fit puts the centre of gravity from the point the logged moments are
/// about, per axis (m): a vehicle's thrusters are laid out about a point within its frame,
/// and half a metre is more than any ROV's or small AUV's offset between the two.
pub const LEVER_BOUND_M: f64 = 0.5;

/// The moments (DOF indices) a component of r_g moves, through the logged force across it:
/// x_g pitch (with the heave force) and yaw (sway), y_g roll (heave) and yaw (surge), z_g
/// roll (sway) and pitch (surge).
pub fn lever_moments(a: usize) -> [usize; 2] {
    match a {
        0 => [4, 5],
        1 => [3, 5],
        _ => [3, 4],
    }
}

/// The net weight acts on the translational DOFs, eta on roll and pitch (its yaw moment
/// vanishes at level trim, and every component needs a rotational DOF to be seen at all).
fn buoyancy_terms(ix: &[usize]) -> Vec<Term> {
    let mut out = Vec::new();
    if ix.iter().any(|&i| i < 3) {
        out.push(Term::NetWeight);
    }
    if ix.iter().any(|&i| i == 3 || i == 4) {
        out.extend((0..3).map(Term::Moment));
    }
    out
}

/// Every term over `dofs`: full mass, full linear and quadratic drag, constants and buoyancy.
/// Every term a model over all six DOFs can have, constants included.
pub fn every_term() -> Vec<Term> {
    all_terms(&Dof::ALL, &Dof::ALL)
}

/// Every term a model over `dofs` can have, with constant forces on `constant`.
pub fn terms_over(dofs: &[Dof], constant: &[Dof]) -> Vec<Term> {
    all_terms(dofs, constant)
}

fn all_terms(dofs: &[Dof], constant: &[Dof]) -> Vec<Term> {
    let ix: Vec<usize> = dofs.iter().map(|d| d.index()).collect();
    let mut out = mass_terms(&ix, true);
    out.extend(Drag::FullLinear.terms(&ix));
    out.extend(Drag::FullQuadratic.terms(&ix));
    out.extend(
        ix.iter()
            .filter(|&&i| constant.contains(&Dof::ALL[i]))
            .map(|&i| Term::Constant(i)),
    );
    out.extend(buoyancy_terms(&ix));
    out.extend(
        (0..3)
            .map(Term::Lever)
            .filter(|t| (t.equations().iter()).any(|d| ix.contains(&d.index()))),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(s: Structure) -> usize {
        s.terms(&Dof::ALL, &[], &CustomTerms::default())
            .unwrap()
            .len()
    }

    #[test]
    fn table_i_parameter_counts() {
        // Seed 003 Table I. Its DIAG QD row prints 16, but its own description (6 quadratic,
        // 21 mass, 4 buoyancy) adds up to 31, which is what is built.
        assert_eq!(count(Structure::FullQd), 241);
        assert_eq!(count(Structure::DiagQd), 31);
        assert_eq!(count(Structure::DiagMass), 226);
        assert_eq!(count(Structure::DiagAll), 16);
        assert_eq!(count(Structure::FullLd), 61);
        assert_eq!(count(Structure::Custom), 241);
        let four = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
        let diag = Structure::Diagonal.terms(&four, &[Dof::Heave], &CustomTerms::default());
        assert_eq!(diag.unwrap().len(), 13);
    }

    /// Every weight and buoyancy term of a diagonal model acts in one of the model's DOFs:
    /// for every set of rotational DOFs, with and without their constant moments (a term
    /// that acts in none is a zero column, and the regression singular: roll alone was).
    #[test]
    fn a_diagonal_models_restoring_terms_act_in_its_dofs() {
        let rotational = [Dof::Roll, Dof::Pitch, Dof::Yaw];
        for mask in 1..8u32 {
            let dofs: Vec<Dof> = (0..3)
                .filter(|b| mask & (1 << b) != 0)
                .map(|b| rotational[b])
                .collect();
            for constant in [&[][..], &dofs[..]] {
                let terms = Structure::Diagonal
                    .terms(&dofs, constant, &CustomTerms::default())
                    .unwrap();
                for t in terms {
                    assert!(
                        t.equations().iter().any(|d| dofs.contains(d)),
                        "{} in a model of {dofs:?} (constants {constant:?})",
                        t.name()
                    );
                }
            }
        }
    }

    #[test]
    fn custom_swaps_the_roll_drag_and_names_parse_back() {
        let t = Structure::Custom
            .terms(&Dof::ALL, &[], &CustomTerms::default())
            .unwrap();
        assert!(t.contains(&Term::Linear(3, 3)));
        assert!(!t.contains(&Term::Quadratic {
            row: 3,
            vel: 3,
            by: 3
        }));
        for term in all_terms(&Dof::ALL, &Dof::ALL) {
            assert_eq!(Term::parse(&term.name()), Some(term), "{}", term.name());
        }
        let bad = CustomTerms {
            add: vec!["K_q|z|".into()],
            ..CustomTerms::default()
        };
        let err = Structure::Custom.terms(&Dof::ALL, &[], &bad).unwrap_err();
        assert!(err.contains("not a term"), "{err}");
    }
}
