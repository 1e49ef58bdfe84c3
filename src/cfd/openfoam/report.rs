//! The report's section on a fit of a CFD test body run in OpenFOAM (the 2D cylinder, the 3D
//! sphere): how each case ran, the identified parameters against their reference values (potential-flow
//! added mass), and the drag the runs show against what a constant-coefficient model can say.

use crate::cfd::openfoam::RunInfo;
use crate::cfd::openfoam::Track;
use crate::core::dof::Dof;
use crate::core::plot::{self as plots, Trace};
use crate::identify::Estimate;
use crate::identify::result::FitResult;
use maud::{Markup, PreEscaped, html};

/// One OpenFOAM case of the fit, with the model simulated under its applied force.
pub struct Case<'a> {
    pub name: &'a str,
    /// The DOF the case pushes the body in; velocity, acceleration and the model's velocity
    /// are in it.
    pub dof: Dof,
    pub info: &'a RunInfo,
    pub t: &'a [f64],
    pub velocity: &'a [f64],
    pub accel: &'a [f64],
    pub simulated: Vec<f64>,
    pub nmae: f64,
    pub track: Option<&'a Track>,
    /// Forces and masses per metre of span (a 2D case): drag per ½ ρ u² L, not ½ ρ u² A.
    pub two_dimensional: bool,
}

impl Case<'_> {
    /// The fit's parameter of this case's DOF: `dot` (X_udot), `lin` (X_u) or `quad` (X_uu).
    fn param(&self, f: &FitResult, which: &str) -> f64 {
        let (x, u) = (self.dof.force(), self.dof.velocity());
        let name = match which {
            "dot" => format!("{x}_{u}dot"),
            "lin" => format!("{x}_{u}"),
            _ => format!("{x}_{u}{u}"),
        };
        value(f, &name).map_or(0.0, |v| v.0)
    }

    /// The reference area of the drag coefficient: the length per metre of span (2D), the
    /// disc of diameter `length` (3D).
    fn reference_area(&self, length: f64) -> f64 {
        if self.two_dimensional {
            length
        } else {
            std::f64::consts::PI * length * length / 4.0
        }
    }
}

/// Drag coefficient along a run, from the fluid force on the body less the added-mass
/// reaction (or, without a force table, from the applied force less the body's inertia):
/// (distance / L, Cd measured, Cd of the constant-coefficient model at the same speed).
pub struct DragCurve {
    pub travel: Vec<f64>,
    pub measured: Vec<f64>,
    pub model: Vec<f64>,
}

fn value(f: &FitResult, name: &str) -> Option<(f64, f64)> {
    f.fit
        .parameters
        .iter()
        .find(|p| p.name == name)
        .map(|p| (p.value, p.stderr))
}

pub fn drag_curve(c: &Case, f: &FitResult, length: f64) -> DragCurve {
    let ma = -c.param(f, "dot");
    let (xu, xuu) = (c.param(f, "lin"), c.param(f, "quad"));
    let axis = c.dof.index();
    let umax = c.velocity.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let area = c.reference_area(length);
    let q = |u: f64| 0.5 * c.info.rho * area * u * u;
    let mut out = DragCurve {
        travel: Vec::new(),
        measured: Vec::new(),
        model: Vec::new(),
    };
    let track = c.track.filter(|tr| tr.t.len() + 1 == c.t.len());
    for k in 1..c.t.len() {
        let u = c.velocity[k];
        // Below a fifth of the top speed the coefficient is dominated by the inertia terms.
        if u.abs() < 0.2 * umax {
            continue;
        }
        let (x, drag) = match track {
            Some(tr) => {
                let fx = tr.fluid_force.as_ref().map(|f| f[k - 1][axis]);
                let drag = fx.map_or(
                    c.info.applied_force_n[axis] - (c.info.mass_kg + ma) * c.accel[k],
                    |fx| -fx - ma * c.accel[k],
                );
                (tr.position[k - 1][axis], drag)
            }
            None => (
                f64::NAN,
                c.info.applied_force_n[axis] - (c.info.mass_kg + ma) * c.accel[k],
            ),
        };
        out.travel.push(x / length);
        out.measured.push(drag / q(u));
        out.model.push((-xu * u - xuu * u * u.abs()) / q(u));
    }
    out
}

/// The OpenFOAM section of fit `f`: how each case ran, the identified parameters against their
/// reference values, the velocities against the model, and the drag along each run.
pub fn section(f: &FitResult, cases: &[Case]) -> anyhow::Result<Markup> {
    let body = f
        .vehicle
        .as_ref()
        .map_or("CFD test body".to_string(), |v| v.name.clone());
    let per_span = if cases.iter().all(|c| c.two_dimensional) {
        " Masses and forces are per metre of span (2D cases)."
    } else {
        ""
    };
    let window = f
        .settings
        .get("added_mass_window_s")
        .and_then(|v| v.as_f64());
    let velocity = velocity_figure(cases)?;
    let drag = f
        .settings
        .get("reference_length_m")
        .and_then(|v| v.as_f64())
        .map(|length| drag_figure(f, cases, length))
        .transpose()?;
    Ok(html! {
        h2 id=(format!("openfoam-{}", f.stage)) {
            "OpenFOAM: " (body) " — model " code { (f.stage) }
        }
        p {
            "Each case was run by OpenFOAM (pimpleFoam, laminar, sixDoFRigidBodyMotion on a morphing mesh): a constant force pushes the body from rest in still water, along the direction of its DOF."
            (per_span)
        }
        (runs_table(cases))
        @if let Some(w) = window {
            p {
                "Two-step fit: the added mass from the first " (w) " s of each case (after the start-up transient), while the body accelerates from rest and its drag is still small; then the linear and quadratic drag from every sample with that added mass held."
            }
        }
        (reference_table(f))
        (velocity)
        @if let Some(drag) = drag {
            (drag)
        }
    })
}

/// How each case ran (force, mass, steps, solver time, where its results came from, peak speed,
/// the model's error), and the OpenFOAM build that ran them.
fn runs_table(cases: &[Case]) -> Markup {
    let build = cases
        .iter()
        .map(|c| &c.info.openfoam)
        .find(|s| !s.is_empty());
    html! {
        table {
            tr {
                th { "case" } th { "DOF" } th { "force (N)" } th { "mass (kg)" }
                th { "end time (s)" } th { "steps" } th { "solver CPU (s)" } th { "wall (s)" }
                th { "results" } th { "peak speed (m/s)" } th { "model NMAE" }
            }
            @for c in cases {
                @let i = c.info;
                tr {
                    td { (c.name) }
                    td { (c.dof.name()) }
                    td { (i.applied_force_n[c.dof.index()]) }
                    td { (i.mass_kg) }
                    td { (i.end_time_s) }
                    td { (i.steps) }
                    td { (i.cpu_time_s.map_or("–".into(), |x| format!("{x:.0}"))) }
                    td { (i.wall_time_s.map_or("–".into(), |x| format!("{x:.0}"))) }
                    td { (results_cell(i)) }
                    td { (format!("{:.4}", c.velocity.iter().fold(0.0f64, |a, v| a.max(v.abs())))) }
                    td { (format!("{:.3}", c.nmae)) }
                }
            }
        }
        @if let Some(v) = build {
            p class="small" { "OpenFOAM build: " code { (v) } "." }
        }
    }
}

/// Where a case's results came from, with the Slurm job that made them when one did (plain
/// text; the template escapes it).
fn results_cell(i: &RunInfo) -> String {
    let how = if i.ran_in_this_build {
        "run by this build"
    } else {
        "read from the case folder"
    };
    match (&i.slurm_job, &i.node) {
        (Some(job), Some(node)) => format!("{how} (Slurm job {job} on {node})"),
        (Some(job), None) => format!("{how} (Slurm job {job})"),
        _ => how.to_string(),
    }
}

/// How much larger (+) or smaller (-) `value` is than `reference` in magnitude, %: an added
/// mass of -31.99 kg/m against -31.42 is 1.8 % more added mass, +1.8 %, whatever the sign
/// convention writes.
fn magnitude_difference(value: f64, reference: f64) -> f64 {
    100.0 * (value.abs() - reference.abs()) / reference.abs()
}

/// The identified parameters against their reference values, with the one-step fit's values
/// in a column of their own when there is one.
fn reference_table(f: &FitResult) -> Markup {
    let one_step = f.one_step.as_deref();
    html! {
        h3 { "Identified against reference values" }
        table {
            tr {
                th { "parameter" } th { "identified" } th { "± std. error" } th { "reference" }
                th { "size against the reference" } th { "reference from" }
                @if one_step.is_some() {
                    th { "one-step fit over whole runs" }
                }
            }
            @for p in &f.fit.parameters {
                tr {
                    td { code { (p.name) } }
                    td { (format!("{:.4}", p.value)) }
                    td { (format!("{:.2e}", p.stderr)) }
                    @match f.expected.get(&p.name) {
                        Some(e) => {
                            td { (format!("{:.4}", e.value)) }
                            td { (format!("{:+.2} %", magnitude_difference(p.value, e.value))) }
                            td { (e.source) }
                        }
                        None => { td { "–" } td { "–" } td {} }
                    }
                    @if let Some(one) = one_step_cell(f, p) {
                        td { (one) }
                    }
                }
            }
        }
    }
}

/// Parameter `p`'s value in the one-step fit, with how much it differs from the reference
/// when there is one; `None` without a one-step fit.
fn one_step_cell(f: &FitResult, p: &Estimate) -> Option<String> {
    let q = f.one_step.as_deref()?.iter().find(|q| q.name == p.name)?;
    let rel = f.expected.get(&p.name).map_or(String::new(), |e| {
        format!(" ({:+.1} %)", magnitude_difference(q.value, e.value))
    });
    Some(format!("{:.4}{rel}", q.value))
}

/// The figure of each case's velocity in its DOF against the identified model's (one figure
/// per DOF the cases are pushed in).
fn velocity_figure(cases: &[Case]) -> anyhow::Result<Markup> {
    let mut dofs: Vec<Dof> = cases.iter().map(|c| c.dof).collect();
    dofs.sort_by_key(|d| d.index());
    dofs.dedup();
    let figures = dofs
        .into_iter()
        .map(|dof| velocity_figure_of(cases, dof))
        .collect::<anyhow::Result<Vec<Markup>>>()?;
    Ok(html! {
        @for fig in figures {
            (fig)
        }
    })
}

fn velocity_figure_of(cases: &[Case], dof: Dof) -> anyhow::Result<Markup> {
    let mut traces: Vec<Trace> = cases
        .iter()
        .filter(|c| c.dof == dof)
        .map(|c| Trace {
            label: c.name,
            t: c.t,
            measured: c.velocity,
            simulated: &c.simulated,
        })
        .collect();
    plots::sort_by_final_value(&mut traces);
    let svg = plots::curves(
        &format!("{} velocity: OpenFOAM and the identified model", dof.name()),
        "time (s)",
        &format!("{} (m/s)", dof.velocity()),
        &traces,
        "identified model (dashed)",
    )?;
    let id = if dof == Dof::Surge {
        "openfoam-velocity".to_string()
    } else {
        format!("openfoam-velocity-{}", dof.name())
    };
    Ok(html! {
        figure id=(id) {
            (PreEscaped(svg))
            figcaption {
                (capitalised(dof.name()))
                " velocity of each OpenFOAM case (colour; the legend in the order the curves end, top to bottom) and of the identified constant-coefficient model under the same force (dashed)."
            }
        }
    })
}

/// The figure of the drag coefficient along each run against the model's, and what it says;
/// nothing when no run is fast enough to show one.
fn drag_figure(f: &FitResult, cases: &[Case], length: f64) -> anyhow::Result<Markup> {
    let curves: Vec<(&Case, DragCurve)> = cases
        .iter()
        .map(|c| (c, drag_curve(c, f, length)))
        .filter(|(_, d)| !d.travel.is_empty())
        .collect();
    let traces: Vec<Trace> = curves
        .iter()
        .map(|(c, d)| Trace {
            label: c.name,
            t: &d.travel,
            measured: &d.measured,
            simulated: &d.model,
        })
        .collect();
    if traces.is_empty() {
        return Ok(html! {});
    }
    let svg = plots::curves(
        "drag coefficient against distance travelled",
        "distance travelled / reference length",
        "Cd",
        &traces,
        "constant-coefficient model",
    )?;
    let reference = if cases.iter().all(|c| c.two_dimensional) {
        format!("Cd = drag / (½ ρ u² L), L = {length} m per metre of span")
    } else {
        format!("Cd = drag / (½ ρ u² A), A = π L² / 4, L = {length} m")
    };
    Ok(html! {
        figure id="openfoam-drag" {
            (PreEscaped(svg))
            figcaption {
                "Drag coefficient " (reference)
                ", from the fluid force on the body less the added-mass reaction, at speeds above a fifth of each run's peak (colour); the identified model's Cd at the same speed (dashed)."
            }
        }
        (finding(&curves, f))
    })
}

fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next().map_or(String::new(), |f| {
        f.to_uppercase().collect::<String>() + c.as_str()
    })
}

/// Where a drag curve's measured Cd peaks: (sample index, Cd).
fn peak(d: &DragCurve) -> (usize, f64) {
    d.measured.iter().enumerate().fold(
        (0, f64::MIN),
        |a, (k, v)| if *v > a.1 { (k, *v) } else { a },
    )
}

/// What the drag curves say about a constant-coefficient model, in numbers.
fn finding(curves: &[(&Case, DragCurve)], f: &FitResult) -> Markup {
    let peaks: Vec<(usize, f64)> = curves.iter().map(|(_, d)| peak(d)).collect();
    let worst = curves.iter().map(|(c, _)| c.nmae).fold(0.0f64, f64::max);
    let fall = curves
        .iter()
        .zip(&peaks)
        .map(|((_, d), (_, cmax))| cmax / d.measured.last().expect("non-empty"))
        .fold(0.0f64, f64::max);
    let rel = |name: &str| {
        f.fit
            .parameters
            .iter()
            .find(|p| p.name == name)
            .map_or(f64::NAN, |p| (p.stderr / p.value).abs())
    };
    html! {
        h3 { "What the runs say about the drag" }
        ul {
            @for ((c, d), (kmax, cmax)) in curves.iter().zip(&peaks) {
                @let end = d.measured.last().expect("non-empty");
                @let model_end = d.model.last().expect("non-empty");
                li {
                    code { (c.name) }
                    (format!(
                        ": Cd peaks at {cmax:.2} after {:.1} lengths of travel and is {end:.2} at the end ({:.1} lengths); the model says {model_end:.2} there; model velocity NMAE {:.3}.",
                        d.travel[*kmax],
                        d.travel.last().expect("non-empty"),
                        c.nmae
                    ))
                }
            }
        }
        p { (drag_summary(&f.stage, fall, worst, rel("X_udot"), rel("X_uu"))) }
    }
}

/// The paragraph under the drag figure, each claim chosen by its number: whether Cd falls
/// along a run (`fall`: the largest peak-to-end ratio), the model's worst velocity NMAE, and
/// which of the added mass and the quadratic drag has the smaller relative standard error.
fn drag_summary(stage: &str, fall: f64, worst: f64, rel_added: f64, rel_quad: f64) -> Markup {
    let better = if !(rel_added.is_finite() && rel_quad.is_finite()) {
        String::new()
    } else if rel_added < rel_quad {
        format!(
            " The added mass is the better-determined parameter (relative standard error {:.2} % against {:.2} % for the quadratic drag).",
            100.0 * rel_added,
            100.0 * rel_quad
        )
    } else {
        format!(
            " The quadratic drag is the better-determined parameter (relative standard error {:.2} % against {:.2} % for the added mass).",
            100.0 * rel_quad,
            100.0 * rel_added
        )
    };
    html! {
        @if fall >= 1.2 {
            "The drag is not a function of speed alone: it depends on how far the body has travelled (the wake builds up behind it), with Cd falling by up to a factor "
            (format!("{fall:.1}"))
            " from its peak within one run. A model with constant linear and quadratic drag ("
            code { (stage) }
            ") can only average this over the runs, so its velocity error reaches NMAE "
            (format!("{worst:.3}"))
            ". Use the drag from these runs for motions of similar length only."
        } @else {
            "Cd stays within a factor "
            (format!("{fall:.2}"))
            " of its peak along every run: the drag is close to a function of speed alone, and the constant-coefficient model ("
            code { (stage) }
            ") follows it to a velocity NMAE of "
            (format!("{worst:.3}"))
            " at worst."
        }
        (better)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_larger_added_mass_is_a_positive_difference_whatever_its_sign() {
        let d = super::magnitude_difference(-31.9856, -31.416);
        assert!((d - 1.81).abs() < 0.01, "{d}");
        let d = super::magnitude_difference(-24.5, -31.416);
        assert!((d + 22.0).abs() < 0.1, "{d}");
        assert!(super::magnitude_difference(2.0, 1.0) > 0.0);
    }

    #[test]
    fn the_drag_paragraph_says_what_its_numbers_say() {
        let s = super::drag_summary("cyl", 2.1, 0.08, 0.001, 0.013).into_string();
        assert!(s.contains("Cd falling by up to a factor 2.1"), "{s}");
        assert!(s.contains("The added mass is the better-determined"), "{s}");
        let s = super::drag_summary("cyl", 1.05, 0.01, 0.05, 0.013).into_string();
        assert!(s.contains("close to a function of speed alone"), "{s}");
        assert!(!s.contains("falling"), "{s}");
        assert!(
            s.contains("The quadratic drag is the better-determined"),
            "{s}"
        );
    }
}
