//! Total least squares on a DOF the runs hardly excite. TLS corrects the regressor as well as
//! the force, dividing by the gap between the smallest singular values; where a DOF's
//! acceleration is mostly noise that correction can carry its mass through zero (the ExjobbROV
//! heave, held at depth by its controller: M_RB - M_A = -0.0033 kg). Without added mass between
//! DOFs such a DOF's equation stands alone (with those it shares a restoring term with), so it
//! takes the ordinary least-squares coefficients and the fit says so; with coupled added mass
//! no DOF can be replaced alone and the fit is refused with the reason.

use crate::core::dof::Dof;
use crate::core::model::params::Group;
use crate::core::model::terms::Term;
use crate::core::model::{ParamLayout, Plant, Vehicle};
use crate::core::response::Response;
use crate::identify::Fit;

/// The DOFs whose diagonal of M_RB - M_A is not positive under `fit`, with that diagonal, when
/// `layout` has no added mass between DOFs; `None` when it has (no DOF stands alone).
pub fn unphysical_dofs(
    vehicle: &Vehicle,
    layout: &ParamLayout,
    fit: &Fit,
) -> Option<Vec<(Dof, f64)>> {
    let coupled = |t: &Term| matches!(t, Term::Added(i, j) if i != j);
    if layout.terms.iter().any(coupled) || fit.parameters.len() < layout.len() {
        return None;
    }
    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
    let plant = Plant::new(vehicle, layout.to_hydro(&theta[..layout.len()]));
    Some(
        vehicle
            .dofs
            .iter()
            .map(|d| (*d, plant.mass()[d.index()]))
            .filter(|(_, m)| *m <= 0.0)
            .collect(),
    )
}

/// The DOFs where `fit`'s diagonal drag, linear and quadratic together, pushes instead of
/// damping at a speed the runs reach (a coefficient past its physical sign, which total least
/// squares does not hold at zero as ordinary least squares does): a simulation of the model
/// runs away there. With the speed (a tenth, a quarter, half or all of the fastest of
/// `responses` in the DOF) and the damping per unit of velocity there, negative.
pub fn runaway_dofs(
    layout: &ParamLayout,
    fit: &Fit,
    responses: &[&Response],
) -> Vec<(Dof, f64, f64)> {
    let drag = |dof: Dof, group: Group| {
        (layout.terms.iter().zip(&fit.parameters))
            .find(|(t, _)| t.is_diagonal() && t.dof() == dof && t.group() == group)
            .map_or(0.0, |(_, p)| p.value)
    };
    let mut out = Vec::new();
    for &dof in &layout.dofs {
        let (lin, quad) = (
            drag(dof, Group::LinearDrag),
            drag(dof, Group::QuadraticDrag),
        );
        let top = (responses.iter())
            .filter_map(|r| r.dofs.get(&dof))
            .flat_map(|s| s.velocity.iter())
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let pushes = [0.1, 0.25, 0.5, 1.0]
            .iter()
            .map(|f| (f * top, -(lin + quad * f * top)))
            .find(|(_, damping)| *damping < 0.0);
        if let Some((speed, damping)) = pushes.filter(|_| top > 0.0) {
            out.push((dof, speed, damping));
        }
    }
    out
}

/// What the fit's notes say of the DOFs `runaway` (from [`runaway_dofs`]) taking ordinary
/// least squares' coefficients, `replaced` with the DOFs they share terms with.
pub fn runaway_note(runaway: &[(Dof, f64, f64)], replaced: &[Dof]) -> String {
    let list: Vec<String> = runaway
        .iter()
        .map(|(d, speed, damping)| {
            format!(
                "{d} (damping {damping:.3} {} per {} at {speed:.3} {})",
                d.force_unit(),
                d.velocity_unit(),
                d.velocity_unit()
            )
        })
        .collect();
    let all: Vec<String> = replaced.iter().map(|d| d.to_string()).collect();
    format!(
        "total least squares gave a drag past its physical sign that pushes instead of damping at a speed the runs reach in {}: its simulation would run away there. TLS does not hold a coefficient at its sign as ordinary least squares does, so the coefficients of {} are ordinary least squares'; the wrong sign stands in for something the model lacks there (a lag, a command that delivers less than it asks) or noise in a DOF the runs hardly excite",
        list.join(", "),
        all.join(", ")
    )
}

/// `dofs` and every modelled DOF that shares a term with one of them (the moment of weight
/// and buoyancy enters two equations): their coefficients are fitted together, so they are
/// replaced together.
pub fn together(layout: &ParamLayout, dofs: &[Dof]) -> Vec<Dof> {
    let mut set = dofs.to_vec();
    loop {
        let before = set.len();
        for t in &layout.terms {
            let eqs = t.equations();
            if eqs.iter().any(|d| set.contains(d)) {
                for d in eqs {
                    if layout.dofs.contains(&d) && !set.contains(&d) {
                        set.push(d);
                    }
                }
            }
        }
        if set.len() == before {
            return set;
        }
    }
}

/// `fit` with the coefficients of every term entering an equation of `dofs`, and those
/// equations' residual levels, taken from `ols` (the same problem's ordinary least-squares
/// fit); `dofs` as [`together`] gives them.
pub fn with_dofs_from(layout: &ParamLayout, mut fit: Fit, ols: &Fit, dofs: &[Dof]) -> Fit {
    for (j, t) in layout.terms.iter().enumerate() {
        if t.equations().iter().any(|d| dofs.contains(d))
            && let Some(p) = ols.parameters.get(j)
        {
            fit.parameters[j] = p.clone();
        }
    }
    for d in dofs {
        if let Some(s) = ols.residual_sigma.get(d.name()) {
            fit.residual_sigma.insert(d.name().to_string(), *s);
        }
    }
    fit
}

/// What the fit's notes say of a fall-back of the DOFs `bad` (with their masses), `replaced`
/// with the DOFs they share terms with.
pub fn note(bad: &[(Dof, f64)], replaced: &[Dof]) -> String {
    let list: Vec<String> = bad
        .iter()
        .map(|(d, m)| {
            let unit = if d.is_angular() { "kg m^2" } else { "kg" };
            format!("{d} ({m:.4} {unit})")
        })
        .collect();
    let names: Vec<String> = bad.iter().map(|(d, _)| d.to_string()).collect();
    let all: Vec<String> = replaced.iter().map(|d| d.to_string()).collect();
    format!(
        "total least squares gave a mass M_RB - M_A that is not positive in {}: the runs hardly excite {}, and TLS's correction of the regressor there is mostly noise. No added mass couples {} to another DOF, so the coefficients of {} are ordinary least squares'; runs that accelerate the vehicle in {} would let TLS fit them",
        list.join(", "),
        names.join(" and "),
        names.join(" and "),
        all.join(", "),
        names.join(" and ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Estimate;

    fn estimate(name: &str, value: f64) -> Estimate {
        Estimate {
            name: name.into(),
            value,
            unit: String::new(),
            stderr: 0.1,
            interval: None,
            identifiable: true,
            note: None,
        }
    }

    fn fit(values: &[f64], sigma: f64, layout: &ParamLayout) -> Fit {
        Fit {
            parameters: layout
                .terms
                .iter()
                .zip(values)
                .map(|(t, v)| estimate(&t.name(), *v))
                .collect(),
            residual_sigma: layout
                .dofs
                .iter()
                .map(|d| (d.name().to_string(), sigma))
                .collect(),
            samples: 100,
            condition_number: 1.0,
            ..Fit::default()
        }
    }

    /// Heave's added mass beyond the rigid body's (a negative total) is found, and only heave's
    /// three coefficients are replaced; yaw keeps TLS's.
    #[test]
    fn a_dof_with_a_negative_mass_takes_the_least_squares_coefficients_alone() {
        let mut vehicle = Vehicle::reference();
        vehicle.dofs = vec![Dof::Heave, Dof::Yaw];
        let layout = ParamLayout::of(&vehicle);
        let names: Vec<String> = layout.terms.iter().map(|t| t.name()).collect();
        let heave_mass = vehicle.rigid_mass()[Dof::Heave.index()];
        // TLS: Z_wdot beyond the rigid mass (total -0.5 kg), every other coefficient -1.
        let tls_values: Vec<f64> = layout
            .terms
            .iter()
            .map(|t| match t {
                Term::Added(2, 2) => heave_mass + 0.5,
                _ => -1.0,
            })
            .collect();
        let tls = fit(&tls_values, 1.0, &layout);
        let bad = unphysical_dofs(&vehicle, &layout, &tls).unwrap();
        assert_eq!(bad.len(), 1, "{bad:?} of {names:?}");
        assert_eq!(bad[0].0, Dof::Heave);
        assert!((bad[0].1 + 0.5).abs() < 1e-9, "{bad:?}");
        let ols = fit(&vec![-2.0; layout.len()], 2.0, &layout);
        let merged = with_dofs_from(&layout, tls, &ols, &[Dof::Heave]);
        for (t, p) in layout.terms.iter().zip(&merged.parameters) {
            let want = if t.dof() == Dof::Heave { -2.0 } else { -1.0 };
            assert_eq!(p.value, want, "{}", p.name);
        }
        assert_eq!(merged.residual_sigma["heave"], 2.0);
        assert_eq!(merged.residual_sigma["yaw"], 1.0);
        assert!(
            unphysical_dofs(&vehicle, &layout, &merged)
                .unwrap()
                .is_empty()
        );
        let text = note(&bad, &[Dof::Heave]);
        assert!(text.contains("heave (-0.5000 kg)"), "{text}");
    }

    /// Roll and pitch share the moment of weight and buoyancy (eta_z): a roll that falls back
    /// takes pitch with it, and yaw, which shares nothing with them here, stays.
    #[test]
    fn dofs_that_share_a_term_fall_back_together() {
        let mut vehicle = Vehicle::reference();
        vehicle.dofs = vec![Dof::Roll, Dof::Pitch, Dof::Yaw];
        vehicle.constant_force = vehicle.dofs.clone();
        let layout = ParamLayout::of(&vehicle);
        assert!(layout.terms.contains(&Term::Moment(2)));
        assert_eq!(together(&layout, &[Dof::Roll]), vec![Dof::Roll, Dof::Pitch]);
        assert_eq!(together(&layout, &[Dof::Yaw]), vec![Dof::Yaw]);
    }

    /// A yaw whose quadratic drag is past its sign pushes beyond 0.91 rad/s, which the runs
    /// reach: it runs away; a small linear drag past its sign beside a large quadratic one
    /// pushes only below a thousandth of the top speed, and does not.
    #[test]
    fn a_drag_that_pushes_at_the_runs_speed_is_found() {
        use crate::core::response::{Series, Source};
        let mut vehicle = Vehicle::reference();
        vehicle.dofs = vec![Dof::Yaw];
        let layout = ParamLayout::of(&vehicle);
        let run = Response {
            t: vec![0.0, 1.0],
            dofs: [(
                Dof::Yaw,
                Series {
                    force: vec![0.0; 2],
                    velocity: vec![0.2, -1.5],
                    accel: vec![0.0; 2],
                    force_source: Source::Column,
                    accel_source: Source::Differentiated,
                },
            )]
            .into_iter()
            .collect(),
            attitude: Vec::new(),
        };
        let with = |lin: f64, quad: f64| {
            let values: Vec<f64> = (layout.terms.iter())
                .map(|t| match t.group() {
                    Group::LinearDrag => lin,
                    Group::QuadraticDrag => quad,
                    _ => -0.2,
                })
                .collect();
            runaway_dofs(&layout, &fit(&values, 1.0, &layout), &[&run])
        };
        let away = with(-34.4, 37.8);
        assert_eq!(away.len(), 1, "{away:?}");
        assert_eq!(away[0].0, Dof::Yaw);
        assert!(away[0].1 > 0.91 && away[0].2 < 0.0, "{away:?}");
        assert!(with(-34.4, -1.0).is_empty());
        assert!(with(0.01, -50.0).is_empty());
        let text = runaway_note(&away, &[Dof::Yaw]);
        assert!(text.contains("yaw (damping"), "{text}");
    }
}
