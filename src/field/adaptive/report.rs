//! Seed 004's section: the identified plant and actuator parameters, scaled by the known one,
//! against truth (its Table 7 in form), the convergence of the scaled estimates, the
//! excitation of every run with the parameter combinations the data cannot identify, the
//! self- and cross-validation errors (Table 6) and measured against simulated velocities with
//! the initial and the identified parameters (Fig. 4).

use crate::core::html::esc;
use crate::core::plot::lines::{Chart, Series, figure};
use crate::field::FieldResult;
use crate::field::adaptive::result::Detail;
use crate::field::truth::Truth;
use std::fmt::Write;

const DOFS: [(&str, &str); 6] = [
    ("u", "m/s"),
    ("v", "m/s"),
    ("w", "m/s"),
    ("p", "rad/s"),
    ("q", "rad/s"),
    ("r", "rad/s"),
];

pub fn section(r: &FieldResult, truth: &Truth) -> anyhow::Result<String> {
    let d: Detail = serde_json::from_value(r.detail.clone())?;
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<h2 id=\"field-{st}\">Adaptive identification of plant and actuators (stage <code>{st}</code>, seed 004)</h2>\n<p>The identifier plant runs alongside {est} (body velocities, attitude, fin and propeller commands; no acceleration signal): M(θ̂) dν̂/dt = −k M(θ̂)(ν̂ − ν) − R(ν, 0) θ̂, dθ̂/dt = Γ R(ν, dν̂/dt)<sup>T</sup>(ν̂ − ν). Every positive multiple of the true parameters fits the data (the regressor's nullspace), so the estimate is scaled to <code>{k}</code> = {kv}. RMS velocity error over the last quarter: {rms}.</p>",
        st = esc(&r.stage),
        est = esc(&r.estimation_runs.join(", ")),
        k = esc(&d.scale_by),
        kv = d.known_value,
        rms = DOFS
            .iter()
            .zip(d.velocity_error_rms)
            .map(|((n, u), v)| format!("{n} {v:.4} {u}"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    h += &table(&d, truth);
    h += &convergence(&d, truth)?;
    h += &excitation(&d);
    h += &validation(&d);
    h += &fig4(&d)?;
    Ok(h)
}

fn table(d: &Detail, truth: &Truth) -> String {
    let mut h = String::from(
        "<table><tr><th>parameter</th><th>initial</th><th>identified (scaled)</th><th>truth</th><th>error</th></tr>\n",
    );
    for (j, n) in d.names.iter().enumerate() {
        let v = d.scaled[j];
        let (t, e) = match truth.get(n) {
            Some(t) if *t != 0.0 => (
                format!("{t:.4}"),
                format!("{:+.1} %", 100.0 * (v - t) / t.abs()),
            ),
            Some(t) => (format!("{t:.4}"), format!("{:+.4} (absolute)", v - t)),
            None => ("–".into(), "–".into()),
        };
        let known = if *n == d.scale_by { " (known)" } else { "" };
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code>{known}</td><td>{:.4}</td><td>{v:.4}</td><td>{t}</td><td>{e}</td></tr>",
            esc(n),
            d.initial[j]
        );
    }
    h.push_str("</table>\n");
    h
}

/// The scaled estimates over the identification, each divided by its truth (or by its final
/// value without one), in three charts: masses, drag and buoyancy, actuators.
fn convergence(d: &Detail, truth: &Truth) -> anyhow::Result<String> {
    let mut h = String::new();
    let groups = [
        ("mass", 0..6),
        ("drag and buoyancy", 6..15),
        ("actuators", 15..20),
    ];
    for (title, range) in groups {
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
        let caption = format!(
            "Convergence of the {title} parameters: each estimate scaled by the known <code>{}</code> and divided by its truth (or, without one, by its final value), over the identification; 1 is the truth (dotted).",
            esc(&d.scale_by)
        );
        let title = format!("convergence: {title} (scaled estimate / truth)");
        h += &figure(
            &fig_id,
            &caption,
            &Chart {
                title: &title,
                x_desc: "identification time (s)",
                y_desc: "estimate / truth",
                series,
                hlines: vec![1.0],
                stems: false,
            },
        )?;
    }
    Ok(h)
}

fn combo(d: &Detail, c: &[(usize, f64)]) -> String {
    c.iter()
        .map(|(j, w)| format!("{w:+.2} {}", d.names[*j]))
        .collect::<Vec<_>>()
        .join(" ")
}

fn excitation(d: &Detail) -> String {
    let mut h = format!(
        "<p>Persistence of excitation: the smallest eigenvalue of the regressor's Gram matrix (columns equilibrated, measured accelerations used for this check only) over the largest, off the nullspace; below {:.0e} a combination is not identified by the run.</p><table><tr><th>run</th><th>smallest / largest</th><th>per window</th><th>least excited combinations (ratio: weights)</th></tr>\n",
        d.threshold
    );
    for e in &d.excitation {
        let wins = e
            .windows
            .iter()
            .map(|w| format!("{:.1e}", w.min_ratio))
            .collect::<Vec<_>>()
            .join(" ");
        let weak = e
            .whole
            .weakest
            .iter()
            .map(|(ratio, c)| {
                let flag = if *ratio < d.threshold {
                    " <b>not identified</b>"
                } else {
                    ""
                };
                format!("{ratio:.1e}{flag}: {}", esc(&combo(d, c)))
            })
            .collect::<Vec<_>>()
            .join("<br>");
        let low = e.whole.min_ratio < d.threshold;
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td{}>{:.1e}</td><td>{wins}</td><td>{weak}</td></tr>",
            esc(&e.run),
            if low { " class=\"warn\"" } else { "" },
            e.whole.min_ratio
        );
    }
    h.push_str("</table>\n");
    h
}

fn validation(d: &Detail) -> String {
    let mut h = String::from(
        "<p>Self-validation (the training run) and cross-validation (the others): mean absolute error of the velocities simulated from the logged commands alone (seed 004 Table 6 in form).</p><table><tr><th>trained on</th><th>simulated on</th><th>parameters</th>",
    );
    for (n, u) in DOFS {
        let _ = write!(h, "<th>{n} ({u})</th>");
    }
    h.push_str("</tr>\n");
    for v in &d.validation {
        for (label, m) in [("initial", &v.initial), ("identified", &v.identified)] {
            let cells = match m {
                Some(m) => m
                    .iter()
                    .map(|x| format!("<td>{x:.4}</td>"))
                    .collect::<String>(),
                None => "<td colspan=\"6\">diverged</td>".into(),
            };
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{} ({})</td><td>{label}</td>{cells}</tr>",
                esc(&v.trained_on),
                esc(&v.run),
                esc(&v.role)
            );
        }
    }
    h.push_str("</table>\n");
    h
}

fn fig4(d: &Detail) -> anyhow::Result<String> {
    let mut h = String::new();
    for s in &d.simulations {
        for (i, (n, u)) in DOFS.iter().enumerate() {
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
            let fig_id = format!("field-aid-{n}-{}", esc(&s.run));
            let caption = format!(
                "{n} on held-out <code>{}</code>: measured (blue), and the model simulated from the logged commands alone with the initial parameters and with the identified ones (seed 004 Fig. 4).",
                esc(&s.run)
            );
            h += &figure(
                &fig_id,
                &caption,
                &Chart {
                    title: &title,
                    x_desc: "time (s)",
                    y_desc: &format!("{n} ({u})"),
                    series,
                    hlines: vec![],
                    stems: false,
                },
            )?;
        }
    }
    Ok(h)
}
