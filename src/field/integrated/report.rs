//! Seed 000's section: the integrated-regressor estimates against truth (its Table 1 in form),
//! the prediction errors and their autocorrelation with the 95 % band (Fig. 2-3), measured and
//! predicted outputs (Fig. 4) and the RLS convergence traces (Fig. 5), with the time each
//! parameter that changed during a run took to be followed.

use crate::core::html::esc;
use crate::core::plot::lines::{Chart, Correlogram, Series, figure};
use crate::field::FieldResult;
use crate::field::integrated::{Detail, Prediction, RunTrace};
use crate::field::truth::Truth;
use std::fmt::Write;

pub fn section(r: &FieldResult, truth: &Truth) -> anyhow::Result<String> {
    let d: Detail = serde_json::from_value(r.detail.clone())?;
    let mut h = intro(r, &d);
    h += &table(&d, truth);
    h += &rls_part(&d, truth)?;
    for p in &d.predictions {
        h += &prediction(r, p)?;
    }
    Ok(h)
}

/// The heading and the equations as fitted.
fn intro(r: &FieldResult, d: &Detail) -> String {
    let mut h = String::new();
    let eqs: Vec<String> = d
        .equations
        .iter()
        .map(|e| {
            format!(
                "d{}/dt = {}",
                e.state,
                e.terms
                    .iter()
                    .map(|t| format!("θ·{t}"))
                    .collect::<Vec<_>>()
                    .join(" + ")
            )
        })
        .collect();
    let _ = writeln!(
        h,
        "<h2 id=\"field-{st}\">Integrated-regressor least squares{rls} (stage <code>{st}</code>, seed 000)</h2>\n<p>{eqs}, integrated over windows of {w:.2} s so that no acceleration is needed: y(t<sub>k</sub>) − y(t<sub>k−m</sub>) = F<sub>k</sub> θ (seed 000 eq. 12–18), least squares on {est} (eq. 16); one-step prediction errors on {val}.</p>",
        st = esc(&r.stage),
        rls = if d.rls.is_some() {
            " and recursive least squares"
        } else {
            ""
        },
        eqs = esc(&eqs.join("; ")),
        w = d.window_s,
        est = esc(&r.estimation_runs.join(", ")),
        val = if r.validation_runs.is_empty() {
            "the estimation runs (no run is held out)".into()
        } else {
            esc(&r.validation_runs.join(", "))
        },
    );
    h
}

/// The RLS settings, and per trace its tracking table and charts.
fn rls_part(d: &Detail, truth: &Truth) -> anyhow::Result<String> {
    let mut h = String::new();
    if let Some(rls) = &d.rls {
        let memory = d.window_s / (1.0 - rls.forgetting).max(1e-12);
        let _ = writeln!(
            h,
            "<p>RLS (eq. 19): forgetting factor λ = {}, a memory of about {memory:.0} s; P<sub>0</sub> = {} diag(1/mean F<sub>j</sub><sup>2</sup>), θ<sub>0</sub> = 0.</p>",
            rls.forgetting, rls.p0
        );
        for tr in &d.traces {
            h += &tracking_table(d, tr, truth);
            h += &trace_charts(d, tr, truth)?;
        }
    }
    Ok(h)
}

/// One state's one-step prediction on one run and its error's autocorrelation.
fn prediction(r: &FieldResult, p: &Prediction) -> anyhow::Result<String> {
    let mut h = String::new();
    let title = format!(
        "d{}/dt on {}: measured and one-step predicted",
        p.state, p.run
    );
    let fig_id = format!(
        "field-{}-pred-{}-{}",
        esc(&r.stage),
        esc(&p.state),
        esc(&p.run)
    );
    let caption = format!(
        "{} on <code>{}</code>: the measured state (blue) and its one-step prediction from the previous window's value and the integrated regressor (seed 000 Fig. 4).",
        esc(&p.state),
        esc(&p.run)
    );
    h += &figure(
        &fig_id,
        &caption,
        &Chart {
            title: &title,
            x_desc: "time (s)",
            y_desc: &format!("{} (accumulated increments)", p.state),
            series: vec![
                Series {
                    label: "measured",
                    x: &p.t,
                    y: &p.measured,
                    reference: false,
                },
                Series {
                    label: "predicted",
                    x: &p.t,
                    y: &p.predicted,
                    reference: false,
                },
            ],
            hlines: vec![],
            stems: false,
        },
    )?;
    let title = format!(
        "autocorrelation of the prediction error, {} ({})",
        p.state, p.run
    );
    let acf = Correlogram {
        title: &title,
        x_desc: "lag (s)",
        label: &p.state,
        lags: &p.lag_s,
        acf: &p.acf,
        band: p.band,
    };
    let _ = writeln!(
        h,
        "<p>Prediction error of d{}/dt on {}: {} of {} lags outside the 95 % band ±{:.3} of a white sequence.</p>",
        esc(&p.state),
        esc(&p.run),
        acf.outside(),
        p.acf.len().saturating_sub(1),
        p.band
    );
    let fig_id = format!(
        "field-{}-acf-{}-{}",
        esc(&r.stage),
        esc(&p.state),
        esc(&p.run)
    );
    let caption = format!(
        "Autocorrelation of the prediction error of d{}/dt on <code>{}</code> with the 95 % band of a white sequence (dotted; seed 000 Fig. 3).",
        esc(&p.state),
        esc(&p.run)
    );
    h += &acf.figure(&fig_id, &caption)?;
    Ok(h)
}

/// Parameters against truth (Table 1 in form).
fn table(d: &Detail, truth: &Truth) -> String {
    let mut h = String::from(
        "<table><tr><th>parameter</th><th>estimate</th><th>std. error</th><th>truth</th><th>error</th><th>error / std. error</th></tr>\n",
    );
    for e in &d.equations {
        for (j, n) in e.names.iter().enumerate() {
            let (v, s) = (e.estimate.theta[j], e.estimate.stderr[j]);
            let (tv, err, z) = match truth.get(n) {
                Some(t) => (
                    format!("{t:.5}"),
                    format!("{:+.1} %", 100.0 * (v - t) / t),
                    format!("{:+.1}", (v - t) / s),
                ),
                None => ("–".into(), "–".into(), "–".into()),
            };
            let _ = writeln!(
                h,
                "<tr><td><code>{}</code></td><td>{v:.5}</td><td>{s:.5}</td><td>{tv}</td><td>{err}</td><td>{z}</td></tr>",
                esc(n)
            );
        }
    }
    h.push_str("</table>\n");
    h
}

/// The truth of parameter `name` at time `t`: its value, or `name@T`'s from time T on.
fn truth_at(truth: &Truth, name: &str, t: f64) -> Option<f64> {
    let mut v = *truth.get(name)?;
    let prefix = format!("{name}@");
    let mut steps: Vec<(f64, f64)> = truth
        .iter()
        .filter_map(|(k, x)| Some((k.strip_prefix(&prefix)?.parse::<f64>().ok()?, *x)))
        .collect();
    steps.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (at, x) in steps {
        if t >= at {
            v = x;
        }
    }
    Some(v)
}

/// For each parameter whose truth steps during the run: before and after, and how long RLS
/// took to stay within 15 % of the step of the new value.
fn tracking_table(d: &Detail, tr: &RunTrace, truth: &Truth) -> String {
    let mut rows = String::new();
    for (e, t) in d.equations.iter().zip(&tr.traces) {
        for (j, n) in e.names.iter().enumerate() {
            let prefix = format!("{n}@");
            let Some((at, after)) = truth
                .iter()
                .find_map(|(k, x)| Some((k.strip_prefix(&prefix)?.parse::<f64>().ok()?, *x)))
            else {
                continue;
            };
            let Some(before) = truth.get(n) else { continue };
            // A change of a few per cent (a coupling's echo of the one that changed) is not
            // a step a trace can be judged on.
            if (after - before).abs() < 0.05 * before.abs() {
                continue;
            }
            let x: Vec<f64> = t.theta.iter().map(|th| th[j]).collect();
            let tol = 0.15 * (after - before).abs();
            let settle = crate::field::integrated::settling_time(&t.t, &x, at, after, tol);
            let just_before = t.t.iter().rposition(|s| *s < at).map(|k| x[k]);
            let _ = writeln!(
                rows,
                "<tr><td><code>{}</code></td><td>{at:.0}</td><td>{before:.4}</td><td>{}</td><td>{after:.4}</td><td>{:.4}</td><td>{}</td></tr>",
                esc(n),
                just_before.map_or("–".into(), |v| format!("{v:.4}")),
                x.last().copied().unwrap_or(f64::NAN),
                settle.map_or("not within the run".into(), |s| format!("{s:.0} s"))
            );
        }
    }
    if rows.is_empty() {
        return String::new();
    }
    format!(
        "<p>Parameters that changed during {} (the twin's truth):</p><table><tr><th>parameter</th><th>changed at (s)</th><th>true before</th><th>RLS just before</th><th>true after</th><th>RLS at the end</th><th>followed within 15 % of the step after</th></tr>\n{rows}</table>\n",
        esc(&tr.run)
    )
}

/// One chart per equation: each parameter's RLS trace, and its truth dashed where known.
fn trace_charts(d: &Detail, tr: &RunTrace, truth: &Truth) -> anyhow::Result<String> {
    let mut h = String::new();
    for (e, t) in d.equations.iter().zip(&tr.traces) {
        let cols: Vec<Vec<f64>> = (0..e.names.len())
            .map(|j| t.theta.iter().map(|th| th[j]).collect())
            .collect();
        let truths: Vec<Option<Vec<f64>>> = e
            .names
            .iter()
            .map(|n| t.t.iter().map(|s| truth_at(truth, n, *s)).collect())
            .collect();
        let mut series = Vec::new();
        for (j, n) in e.names.iter().enumerate() {
            series.push(Series {
                label: n,
                x: &t.t,
                y: &cols[j],
                reference: false,
            });
        }
        for (i, tv) in truths.iter().flatten().enumerate() {
            let label = if i == 0 { "truth" } else { "" };
            series.push(Series {
                label,
                x: &t.t,
                y: tv,
                reference: true,
            });
        }
        let title = format!("RLS convergence, d{}/dt ({})", e.state, tr.run);
        let fig_id = format!("field-rls-{}-{}", esc(&e.state), esc(&tr.run));
        let caption = format!(
            "RLS estimates of the d{}/dt parameters through <code>{}</code> (colour) and the twin's truth where known (dashed; seed 000 Fig. 5).",
            esc(&e.state),
            esc(&tr.run)
        );
        h += &figure(
            &fig_id,
            &caption,
            &Chart {
                title: &title,
                x_desc: "time (s)",
                y_desc: "parameter",
                series,
                hlines: vec![],
                stems: false,
            },
        )?;
    }
    Ok(h)
}
