//! Seed 004's section: the identified plant and actuator parameters, scaled by the known one,
//! against truth (its Table 7 in form), the convergence of the scaled estimates, the
//! excitation of every run with the parameter combinations the data cannot identify, the
//! self- and cross-validation errors (Table 6) and measured against simulated velocities with
//! the initial and the identified parameters (Fig. 4).

use crate::core::plot::lines::{Chart, Series, figure};
use crate::field::FieldResult;
use crate::field::adaptive::result::{Detail, RunExcitation, Simulation};
use crate::field::truth::Truth;
use maud::{Markup, html};

const DOFS: [(&str, &str); 6] = [
    ("u", "m/s"),
    ("v", "m/s"),
    ("w", "m/s"),
    ("p", "rad/s"),
    ("q", "rad/s"),
    ("r", "rad/s"),
];

pub fn section(r: &FieldResult, d: &Detail, truth: &Truth) -> anyhow::Result<Markup> {
    let rms = DOFS
        .iter()
        .zip(d.velocity_error_rms)
        .map(|((n, u), v)| format!("{n} {v:.4} {u}"))
        .collect::<Vec<_>>()
        .join(", ");
    Ok(html! {
        h2 id=(format!("field-{}", r.stage)) {
            "Adaptive identification of plant and actuators (stage " code { (r.stage) } ", seed 004)"
        }
        p {
            "The identifier plant runs alongside " (r.estimation_runs.join(", "))
            " (body velocities, attitude, fin and propeller commands; no acceleration signal): M(θ̂) dν̂/dt = −k M(θ̂)(ν̂ − ν) − R(ν, 0) θ̂, dθ̂/dt = Γ R(ν, dν̂/dt)"
            sup { "T" }
            "(ν̂ − ν). Every positive multiple of the true parameters fits the data (the regressor's nullspace), so the estimate is scaled to "
            code { (d.scale_by) } " = " (d.known_value)
            ". RMS velocity error over the last quarter: " (rms) "."
        }
        (table(d, truth))
        (convergence(d, truth)?)
        (excitation(d))
        (validation(d))
        (fig4(d)?)
    })
}

fn table(d: &Detail, truth: &Truth) -> Markup {
    html! {
        table {
            tr {
                th { "parameter" } th { "initial" } th { "identified (scaled)" } th { "truth" }
                th { "error" }
            }
            @for (j, n) in d.names.iter().enumerate() {
                (table_row(d, truth, j, n))
            }
        }
    }
}

/// Parameter `j` (named `n`) of [`table`].
fn table_row(d: &Detail, truth: &Truth, j: usize, n: &str) -> Markup {
    let v = d.scaled[j];
    let (t, e) = match truth.get(n) {
        Some(t) if *t != 0.0 => (
            format!("{t:.4}"),
            format!("{:+.1} %", 100.0 * (v - t) / t.abs()),
        ),
        Some(t) => (format!("{t:.4}"), format!("{:+.4} (absolute)", v - t)),
        None => ("–".into(), "–".into()),
    };
    html! {
        tr {
            td {
                code { (n) }
                @if n == d.scale_by {
                    " (known)"
                }
            }
            td { (format!("{:.4}", d.initial[j])) }
            td { (format!("{v:.4}")) }
            td { (t) }
            td { (e) }
        }
    }
}

/// The scaled estimates over the identification, each divided by its truth (or by its final
/// value without one), in three charts: masses, drag and buoyancy, actuators.
fn convergence(d: &Detail, truth: &Truth) -> anyhow::Result<Markup> {
    let groups = [
        ("mass", 0..6),
        ("drag and buoyancy", 6..15),
        ("actuators", 15..20),
    ];
    Ok(html! {
        @for (title, range) in groups {
            (convergence_group(d, truth, title, range)?)
        }
    })
}

/// One chart of [`convergence`]: the parameters in `range`.
fn convergence_group(
    d: &Detail,
    truth: &Truth,
    title: &str,
    range: std::ops::Range<usize>,
) -> anyhow::Result<Markup> {
    let cols: Vec<(String, Vec<f64>)> = range
        .filter(|&j| d.names[j] != d.scale_by)
        .filter_map(|j| {
            let refv = truth
                .get(&d.names[j])
                .copied()
                .filter(|t| *t != 0.0)
                .unwrap_or(d.scaled[j]);
            (refv != 0.0).then(|| {
                (
                    d.names[j].clone(),
                    d.trace.iter().map(|t| t[j] / refv).collect(),
                )
            })
        })
        .collect();
    let series = cols
        .iter()
        .map(|(n, y)| Series {
            label: n,
            x: &d.trace_t,
            y,
            reference: false,
        })
        .collect();
    let fig_id = format!(
        "field-aid-convergence-{}",
        title.split(' ').next().unwrap_or("x")
    );
    let caption = html! {
        "Convergence of the " (title) " parameters: each estimate scaled by the known "
        code { (d.scale_by) }
        " and divided by its truth (or, without one, by its final value), over the identification; 1 is the truth (dotted)."
    };
    let title = format!("convergence: {title} (scaled estimate / truth)");
    let fig = figure(
        &fig_id,
        caption,
        &Chart {
            title: &title,
            x_desc: "identification time (s)",
            y_desc: "estimate / truth",
            series,
            hlines: vec![1.0],
            stems: false,
        },
    )?;
    Ok(fig)
}

fn combo(d: &Detail, c: &[(usize, f64)]) -> String {
    c.iter()
        .map(|(j, w)| format!("{w:+.2} {}", d.names[*j]))
        .collect::<Vec<_>>()
        .join(" ")
}

fn excitation(d: &Detail) -> Markup {
    html! {
        p {
            "Persistence of excitation: the smallest eigenvalue of the regressor's Gram matrix (columns equilibrated, measured accelerations used for this check only) over the largest, off the nullspace; below "
            (format!("{:.0e}", d.threshold))
            " a combination is not identified by the run."
        }
        table {
            tr {
                th { "run" } th { "smallest / largest" } th { "per window" }
                th { "least excited combinations (ratio: weights)" }
            }
            @for e in &d.excitation {
                (excitation_row(d, e))
            }
        }
    }
}

/// One run's row of [`excitation`].
fn excitation_row(d: &Detail, e: &RunExcitation) -> Markup {
    let wins = e
        .windows
        .iter()
        .map(|w| format!("{:.1e}", w.min_ratio))
        .collect::<Vec<_>>()
        .join(" ");
    let low = e.whole.min_ratio < d.threshold;
    html! {
        tr {
            td { (e.run) }
            td class=[low.then_some("warn")] { (format!("{:.1e}", e.whole.min_ratio)) }
            td { (wins) }
            td {
                @for (i, (ratio, c)) in e.whole.weakest.iter().enumerate() {
                    @if i > 0 {
                        br;
                    }
                    (format!("{ratio:.1e}"))
                    @if *ratio < d.threshold {
                        " " b { "not identified" }
                    }
                    ": " (combo(d, c))
                }
            }
        }
    }
}

fn validation(d: &Detail) -> Markup {
    html! {
        p {
            "Self-validation (the training run) and cross-validation (the others): mean absolute error of the velocities simulated from the logged commands alone (seed 004 Table 6 in form)."
        }
        table {
            tr {
                th { "trained on" } th { "simulated on" } th { "parameters" }
                @for (n, u) in DOFS {
                    th { (n) " (" (u) ")" }
                }
            }
            @for v in &d.validation {
                @for (label, m) in [("initial", &v.initial), ("identified", &v.identified)] {
                    tr {
                        td { (v.trained_on) }
                        td { (v.run) " (" (v.role) ")" }
                        td { (label) }
                        @match m {
                            Some(m) => {
                                @for x in m {
                                    td { (format!("{x:.4}")) }
                                }
                            }
                            None => td colspan="6" { "diverged" },
                        }
                    }
                }
            }
        }
    }
}

fn fig4(d: &Detail) -> anyhow::Result<Markup> {
    Ok(html! {
        @for s in &d.simulations {
            @for (i, (n, u)) in DOFS.iter().enumerate() {
                (fig4_dof(s, i, n, u)?)
            }
        }
    })
}

/// Degree of freedom `i` (named `n`, in unit `u`) on one held-out run of [`fig4`].
fn fig4_dof(s: &Simulation, i: usize, n: &str, u: &str) -> anyhow::Result<Markup> {
    let col = |v: &[[f64; 6]]| v.iter().map(|x| x[i]).collect::<Vec<f64>>();
    let (m, a, b) = (col(&s.measured), col(&s.initial), col(&s.identified));
    let mut series = vec![Series {
        label: "measured",
        x: &s.t,
        y: &m,
        reference: false,
    }];
    if !a.is_empty() {
        series.push(Series {
            label: "initial parameters",
            x: &s.t,
            y: &a,
            reference: false,
        });
    }
    if !b.is_empty() {
        series.push(Series {
            label: "identified",
            x: &s.t,
            y: &b,
            reference: false,
        });
    }
    let title = format!("{n} on {} (cross-validation)", s.run);
    let fig_id = format!("field-aid-{n}-{}", s.run);
    let caption = html! {
        (n) " on held-out " code { (s.run) }
        ": measured (blue), and the model simulated from the logged commands alone with the initial parameters and with the identified ones (seed 004 Fig. 4)."
    };
    let fig = figure(
        &fig_id,
        caption,
        &Chart::lines(&title, "time (s)", &format!("{n} ({u})"), series),
    )?;
    Ok(fig)
}
