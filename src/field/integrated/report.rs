//! Seed 000's section: the integrated-regressor estimates against truth (its Table 1 in form),
//! the prediction errors and their autocorrelation with the 95 % band (Fig. 2-3), measured and
//! predicted outputs (Fig. 4) and the RLS convergence traces (Fig. 5), with the time each
//! parameter that changed during a run took to be followed.

use crate::core::plot::lines::{Chart, Correlogram, Series, figure};
use crate::field::FieldResult;
use crate::field::integrated::{Detail, EquationFit, Prediction, RunTrace, Trace};
use crate::field::truth::Truth;
use maud::{Markup, html};

pub fn section(r: &FieldResult, d: &Detail, truth: &Truth) -> anyhow::Result<Markup> {
    Ok(html! {
        (intro(r, d))
        (table(d, truth))
        (rls_part(d, truth)?)
        @for p in &d.predictions {
            (prediction(r, p)?)
        }
    })
}

/// The heading and the equations as fitted.
fn intro(r: &FieldResult, d: &Detail) -> Markup {
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
    html! {
        h2 id=(format!("field-{}", r.stage)) {
            "Integrated-regressor least squares"
            @if d.rls.is_some() {
                " and recursive least squares"
            }
            " (stage " code { (r.stage) } ", seed 000)"
        }
        p {
            (eqs.join("; ")) ", integrated over windows of " (format!("{:.2}", d.window_s))
            " s so that no acceleration is needed: y(t" sub { "k" } ") − y(t" sub { "k−m" }
            ") = F" sub { "k" } " θ (seed 000 eq. 12–18), least squares on "
            (r.estimation_runs.join(", ")) " (eq. 16); one-step prediction errors on "
            @if r.validation_runs.is_empty() {
                "the estimation runs (no run is held out)"
            } @else {
                (r.validation_runs.join(", "))
            }
            "."
        }
    }
}

/// The RLS settings, and per trace its tracking table and charts.
fn rls_part(d: &Detail, truth: &Truth) -> anyhow::Result<Markup> {
    let Some(rls) = &d.rls else {
        return Ok(html! {});
    };
    let memory = d.window_s / (1.0 - rls.forgetting).max(1e-12);
    Ok(html! {
        p {
            "RLS (eq. 19): forgetting factor λ = " (rls.forgetting) ", a memory of about "
            (format!("{memory:.0}")) " s; P" sub { "0" } " = " (rls.p0) " diag(1/mean F"
            sub { "j" } sup { "2" } "), θ" sub { "0" } " = 0."
        }
        @for tr in &d.traces {
            (tracking_table(d, tr, truth))
            (trace_charts(d, tr, truth)?)
        }
    })
}

/// One state's one-step prediction on one run and its error's autocorrelation.
fn prediction(r: &FieldResult, p: &Prediction) -> anyhow::Result<Markup> {
    let title = format!(
        "d{}/dt on {}: measured and one-step predicted",
        p.state, p.run
    );
    let fig_id = format!("field-{}-pred-{}-{}", r.stage, p.state, p.run);
    let caption = html! {
        (p.state) " on " code { (p.run) }
        ": the measured state (blue) and its one-step prediction from the previous window's value and the integrated regressor (seed 000 Fig. 4)."
    };
    let chart = figure(
        &fig_id,
        caption,
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
    let fig_id = format!("field-{}-acf-{}-{}", r.stage, p.state, p.run);
    let caption = html! {
        "Autocorrelation of the prediction error of d" (p.state) "/dt on " code { (p.run) }
        " with the 95 % band of a white sequence (dotted; seed 000 Fig. 3)."
    };
    let correlogram = acf.figure(&fig_id, caption)?;
    Ok(html! {
        (chart)
        p {
            "Prediction error of d" (p.state) "/dt on " (p.run) ": " (acf.outside()) " of "
            (p.acf.len().saturating_sub(1)) " lags outside the 95 % band ±"
            (format!("{:.3}", p.band)) " of a white sequence."
        }
        (correlogram)
    })
}

/// Parameters against truth (Table 1 in form).
fn table(d: &Detail, truth: &Truth) -> Markup {
    html! {
        table {
            tr {
                th { "parameter" } th { "estimate" } th { "std. error" } th { "truth" }
                th { "error" } th { "error / std. error" }
            }
            @for e in &d.equations {
                @for (j, n) in e.names.iter().enumerate() {
                    (table_row(e, j, n, truth))
                }
            }
        }
    }
}

/// Parameter `j` (named `n`) of equation `e` in [`table`].
fn table_row(e: &EquationFit, j: usize, n: &str, truth: &Truth) -> Markup {
    let (v, s) = (e.estimate.theta[j], e.estimate.stderr[j]);
    let (tv, err, z) = match truth.get(n) {
        Some(t) => (
            format!("{t:.5}"),
            format!("{:+.1} %", 100.0 * (v - t) / t),
            format!("{:+.1}", (v - t) / s),
        ),
        None => ("–".into(), "–".into(), "–".into()),
    };
    html! {
        tr {
            td { code { (n) } }
            td { (format!("{v:.5}")) }
            td { (format!("{s:.5}")) }
            td { (tv) }
            td { (err) }
            td { (z) }
        }
    }
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
fn tracking_table(d: &Detail, tr: &RunTrace, truth: &Truth) -> Markup {
    let rows: Vec<Markup> = d
        .equations
        .iter()
        .zip(&tr.traces)
        .flat_map(|(e, t)| {
            e.names
                .iter()
                .enumerate()
                .filter_map(move |(j, n)| tracking_row(t, j, n, truth))
        })
        .collect();
    html! {
        @if !rows.is_empty() {
            p { "Parameters that changed during " (tr.run) " (the twin's truth):" }
            table {
                tr {
                    th { "parameter" } th { "changed at (s)" } th { "true before" }
                    th { "RLS just before" } th { "true after" } th { "RLS at the end" }
                    th { "followed within 15 % of the step after" }
                }
                @for row in &rows {
                    (row)
                }
            }
        }
    }
}

/// Parameter `j` (named `n`) of one equation's trace `t` in [`tracking_table`], if its truth
/// steps during the run.
fn tracking_row(t: &Trace, j: usize, n: &str, truth: &Truth) -> Option<Markup> {
    let prefix = format!("{n}@");
    let (at, after) = truth
        .iter()
        .find_map(|(k, x)| Some((k.strip_prefix(&prefix)?.parse::<f64>().ok()?, *x)))?;
    let before = *truth.get(n)?;
    // A change of a few per cent (a coupling's echo of the one that changed) is not
    // a step a trace can be judged on.
    if (after - before).abs() < 0.05 * before.abs() {
        return None;
    }
    let x: Vec<f64> = t.theta.iter().map(|th| th[j]).collect();
    let tol = 0.15 * (after - before).abs();
    let settle = crate::field::integrated::settling_time(&t.t, &x, at, after, tol);
    let just_before = t.t.iter().rposition(|s| *s < at).map(|k| x[k]);
    Some(html! {
        tr {
            td { code { (n) } }
            td { (format!("{at:.0}")) }
            td { (format!("{before:.4}")) }
            td { (just_before.map_or("–".into(), |v| format!("{v:.4}"))) }
            td { (format!("{after:.4}")) }
            td { (format!("{:.4}", x.last().copied().unwrap_or(f64::NAN))) }
            td { (settle.map_or("not within the run".into(), |s| format!("{s:.0} s"))) }
        }
    })
}

/// One chart per equation: each parameter's RLS trace, and its truth dashed where known.
fn trace_charts(d: &Detail, tr: &RunTrace, truth: &Truth) -> anyhow::Result<Markup> {
    Ok(html! {
        @for (e, t) in d.equations.iter().zip(&tr.traces) {
            (trace_chart(e, t, &tr.run, truth)?)
        }
    })
}

/// Equation `e`'s chart of [`trace_charts`] through run `run`.
fn trace_chart(e: &EquationFit, t: &Trace, run: &str, truth: &Truth) -> anyhow::Result<Markup> {
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
    let title = format!("RLS convergence, d{}/dt ({})", e.state, run);
    let fig_id = format!("field-rls-{}-{run}", e.state);
    let caption = html! {
        "RLS estimates of the d" (e.state) "/dt parameters through " code { (run) }
        " (colour) and the twin's truth where known (dashed; seed 000 Fig. 5)."
    };
    let fig = figure(
        &fig_id,
        caption,
        &Chart::lines(&title, "time (s)", "parameter", series),
    )?;
    Ok(fig)
}
