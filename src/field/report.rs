//! The field-trial identifiers' sections, each in its paper's own form: ARX (seed 002: the
//! structures tf1-tf4 compared, simulated against the second run, the transfer function with
//! its poles and zeros), integrated-regressor LS and RLS (seed 000: parameters against truth,
//! the RLS trace, the prediction error's autocorrelation).

use crate::core::plot::lines::{Chart, Correlogram, Series, figure};
use crate::field::arx::stage::{Detrend, Settings as ArxSettings};
use crate::field::arx::{Detail as ArxDetail, Model, Simulation};
use crate::field::truth::Truth;
use crate::field::{Detail, Field, FieldResult};
use maud::{Markup, html};

/// Every field-trial section, in the order of the stages.
pub fn sections(results: &[Field], truth: &Truth) -> anyhow::Result<Markup> {
    Ok(html! {
        @for Field { result: r, detail } in results {
            @match detail {
                Detail::Arx(d, s) => (arx_section(r, d, s, truth)?),
                Detail::Integrated(d, _) => (crate::field::integrated::report::section(r, d, truth)?),
                Detail::Adaptive(d, _) => (crate::field::adaptive::report::section(r, d, truth)?),
            }
        }
    })
}

fn criterion_name(c: crate::field::arx::Criterion) -> &'static str {
    use crate::field::arx::Criterion::*;
    match c {
        Mdl => "minimum description length (MDL) on the estimation runs",
        Aic => "Akaike's information criterion (AIC) on the estimation runs",
        Fpe => "Akaike's final prediction error (FPE) on the estimation runs",
        Prediction => "one-step prediction loss on the held-out runs",
        Simulation => "simulation loss on the held-out runs",
    }
}

fn num(x: Option<f64>, digits: usize) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "diverged".into(),
    }
}

fn arx_section(
    r: &FieldResult,
    d: &ArxDetail,
    s: &ArxSettings,
    truth: &Truth,
) -> anyhow::Result<Markup> {
    let detrend = if s.detrend == Detrend::None {
        "not detrended"
    } else {
        "each run's mean removed"
    };
    let selected = d.models.iter().find(|m| m.selected);
    Ok(html! {
        h2 id=(format!("field-{}", r.stage)) {
            "ARX: " (d.output) " from " (d.input) " (stage " code { (r.stage) } ", seed 002)"
        }
        p {
            "A(q) y(t) = B(q) u(t−k) + v(t), least squares on the one-step prediction error (seed 002 eq. 2.2–2.6), sampled every "
            (d.sample_s) " s, " (detrend) ". Estimated on " (r.estimation_runs.join(", "))
            "; simulated from the input alone on "
            @if r.validation_runs.is_empty() {
                "no held-out run (the estimation run is shown)"
            } @else {
                (r.validation_runs.join(", "))
            }
            ". " (d.grid_size)
            " structures of the grid were estimated on the same equations and ranked by "
            b { (criterion_name(d.criterion)) }
            "; the named structures are compared beside the one it selected."
        }
        (structure_table(d, r))
        @if let Some(m) = selected {
            (transfer_function(m, d, truth))
        }
        @for s in &d.simulations {
            (simulation_figure(r, d, s)?)
        }
        (residual_test(r, d)?)
        (ranking_table(d))
    })
}

/// One held-out run: measured, and each structure simulated from the input alone.
fn simulation_figure(r: &FieldResult, d: &ArxDetail, s: &Simulation) -> anyhow::Result<Markup> {
    let mut series = vec![Series {
        label: "measured",
        x: &s.t,
        y: &s.measured,
        reference: false,
    }];
    for (name, y) in s.models.iter().filter(|(_, y)| !y.is_empty()) {
        series.push(Series {
            label: name,
            x: &s.t,
            y,
            reference: false,
        });
    }
    let title = format!(
        "{} on {}: measured and simulated from {}",
        d.output, s.run, d.input
    );
    let y_desc = format!("{} ({}, detrended)", d.output, d.output_unit);
    let fig_id = format!("field-{}-sim-{}", r.stage, s.run);
    let caption = html! {
        (d.output) " on held-out run " code { (s.run) }
        " (detrended, blue) and each structure simulated from " (d.input)
        " alone from the measured initial samples (MATLAB " code { "compare" }
        "); a structure whose simulation diverged is left out."
    };
    let fig = figure(
        &fig_id,
        caption,
        &Chart::lines(&title, "time (s)", &y_desc, series),
    )?;
    Ok(fig)
}

/// The selected model's one-step prediction error: its autocorrelation against the band of
/// a white sequence (MATLAB `resid`).
fn residual_test(r: &FieldResult, d: &ArxDetail) -> anyhow::Result<Markup> {
    let lags: Vec<f64> = (0..d.residual_acf.len()).map(|l| l as f64).collect();
    let title = format!(
        "autocorrelation of the prediction error ({})",
        d.residual_run
    );
    let acf = Correlogram {
        title: &title,
        x_desc: "lag (samples)",
        label: "selected",
        lags: &lags,
        acf: &d.residual_acf,
        band: d.residual_band,
    };
    let fig_id = format!("field-{}-resid", r.stage);
    let caption = html! {
        "Autocorrelation of the selected model's one-step prediction error on "
        code { (d.residual_run) }
        " by lag, with the 99 % band of a white sequence (dotted)."
    };
    let fig = acf.figure(&fig_id, caption)?;
    Ok(html! {
        p {
            "Residual test (MATLAB " code { "resid" }
            "): the selected model's one-step prediction error on " (d.residual_run) " has "
            (acf.outside()) " of " (d.residual_acf.len().saturating_sub(1))
            " lags outside the 99 % band ±" (format!("{:.3}", d.residual_band))
            " of a white sequence."
        }
        (fig)
    })
}

/// The comparison of structures (the paper's tf1-tf4 and the selected one).
fn structure_table(d: &ArxDetail, r: &FieldResult) -> Markup {
    html! {
        table {
            tr {
                th { "structure" } th { "na" } th { "nb" } th { "k" }
                th { "loss V (estimation)" } th { "MDL" } th { "AIC" } th { "FPE" }
                @for v in &r.validation_runs {
                    th { "fit on " (v) " (%)" }
                }
                th { "stable" } th { "steady gain" }
            }
            @for m in &d.models {
                (structure_row(m))
            }
        }
    }
}

/// One structure's row of [`structure_table`].
fn structure_row(m: &Model) -> Markup {
    let o = m.arx.orders;
    html! {
        tr class=[m.selected.then_some("best")] {
            td {
                (m.name)
                @if m.selected && m.name != "selected" {
                    " (selected)"
                }
            }
            td { (o.na) } td { (o.nb) } td { (o.k) }
            td { (format!("{:.4e}", m.arx.loss)) }
            td { (format!("{:.1}", m.arx.mdl)) }
            td { (format!("{:.1}", m.arx.aic)) }
            td { (format!("{:.4e}", m.arx.fpe)) }
            @for v in &m.validation {
                td { (num(v.fit_pct, 1)) }
            }
            td { @if m.stable { "yes" } @else { "no" } }
            td { (format!("{:.4}", m.gain)) }
        }
    }
}

/// The selected model's transfer function with standard errors, its poles and zeros, and the
/// truth's poles mapped to the same sample time where a twin left them.
fn transfer_function(m: &Model, d: &ArxDetail, truth: &Truth) -> Markup {
    let coef = |v: &[f64], s: &[f64], p: &str| -> String {
        v.iter()
            .zip(s)
            .enumerate()
            .map(|(i, (v, s))| format!("{p}{} = {v:.5} ± {s:.5}", i + 1))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let o = m.arx.orders;
    let mut truth_poles = Vec::new();
    for i in 1.. {
        let (Some(re), Some(im)) = (
            truth.get(&format!("pole{i}_re")),
            truth.get(&format!("pole{i}_im")),
        ) else {
            break;
        };
        let e = (re * d.sample_s).exp();
        truth_poles.push([e * (im * d.sample_s).cos(), e * (im * d.sample_s).sin()]);
    }
    let gain = truth.get(&format!("{}_gain", d.output));
    html! {
        p {
            "Selected transfer function G(z) = z" sup { "−" (o.k) } " B(z" sup { "−1" } ")/A(z"
            sup { "−1" } ") with " (coef(&m.arx.a, &m.arx.a_std, "a")) "; "
            (coef(&m.arx.b, &m.arx.b_std, "b")) "."
        }
        table {
            tr {
                th {} th { "z" } th { "|z|" } th { "s = ln z / h (1/s)" }
                th { "ω" sub { "n" } " (rad/s)" } th { "ζ" }
            }
            @for p in &m.poles {
                (root_row(html! { "pole" }, *p, d.sample_s))
            }
            @for z in &m.zeros {
                (root_row(html! { "zero" }, *z, d.sample_s))
            }
            @for z in &truth_poles {
                (root_row(html! { "truth pole (e" sup { "sh" } ")" }, *z, d.sample_s))
            }
        }
        @if let Some(g) = gain {
            p {
                (format!(
                    "Steady gain: {:.4} identified, {g:.4} true ({:+.1} %).",
                    m.gain,
                    100.0 * (m.gain - g) / g
                ))
            }
        }
    }
}

/// A pole or zero `z` of [`transfer_function`]'s table, with its continuous-time equivalent
/// at the sample time `h`.
fn root_row(what: Markup, z: [f64; 2], h: f64) -> Markup {
    let r = z[0].hypot(z[1]);
    let s = [r.ln() / h, z[1].atan2(z[0]) / h];
    let wn = s[0].hypot(s[1]);
    let sign = |x: f64| if x < 0.0 { "−" } else { "+" };
    html! {
        tr {
            td { (what) }
            td { (format!("{:.4} {} {:.4}i", z[0], sign(z[1]), z[1].abs())) }
            td { (format!("{r:.4}")) }
            td { (format!("{:.3} {} {:.3}i", s[0], sign(s[1]), s[1].abs())) }
            td { (format!("{wn:.3}")) }
            td { (format!("{:.3}", -s[0] / wn.max(f64::MIN_POSITIVE))) }
        }
    }
}

/// The best structures of the grid by the criterion (MATLAB `selstruc`'s table).
fn ranking_table(d: &ArxDetail) -> Markup {
    html! {
        details {
            summary {
                "The " (d.ranking.len()) " best of " (d.grid_size) " structures by "
                (criterion_name(d.criterion))
            }
            table {
                tr {
                    th { "na" } th { "nb" } th { "k" } th { "loss V" } th { "MDL" } th { "AIC" }
                    th { "FPE" } th { "held-out prediction loss" } th { "held-out simulation loss" }
                }
                @for s in &d.ranking {
                    tr {
                        td { (s.orders.na) } td { (s.orders.nb) } td { (s.orders.k) }
                        td { (format!("{:.4e}", s.loss)) }
                        td { (format!("{:.1}", s.mdl)) }
                        td { (format!("{:.1}", s.aic)) }
                        td { (format!("{:.4e}", s.fpe)) }
                        td { (s.prediction_loss.map_or("–".into(), |v| format!("{v:.4e}"))) }
                        td { (s.simulation_loss.map_or("diverged".into(), |v| format!("{v:.4e}"))) }
                    }
                }
            }
        }
    }
}
