//! The field-trial identifiers' sections, each in its paper's own form: ARX (seed 002: the
//! structures tf1-tf4 compared, simulated against the second run, the transfer function with
//! its poles and zeros), integrated-regressor LS and RLS (seed 000: parameters against truth,
//! the RLS trace, the prediction error's autocorrelation).

use crate::core::html::esc;
use crate::core::plot::lines::{Chart, Correlogram, Series, figure};
use crate::field::FieldResult;
use crate::field::arx::{Detail as ArxDetail, Model, Simulation};
use crate::field::truth::Truth;
use std::fmt::Write;

/// Every field-trial section, in the order of the stages.
pub fn sections(results: &[FieldResult], truth: &Truth) -> anyhow::Result<String> {
    let mut h = String::new();
    for r in results {
        h += &match r.kind.as_str() {
            "arx" => arx_section(r, truth)?,
            "integrated" => crate::field::integrated::report::section(r, truth)?,
            "adaptive" => crate::field::adaptive::report::section(r, truth)?,
            _ => format!(
                "<h2>{}</h2><p>Unknown identifier kind `{}`.</p>",
                esc(&r.stage),
                esc(&r.kind)
            ),
        };
    }
    Ok(h)
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

fn arx_section(r: &FieldResult, truth: &Truth) -> anyhow::Result<String> {
    let d: ArxDetail = serde_json::from_value(r.detail.clone())?;
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<h2 id=\"field-{st}\">ARX: {out} from {inp} (stage <code>{st}</code>, seed 002)</h2>\n<p>A(q) y(t) = B(q) u(t−k) + v(t), least squares on the one-step prediction error (seed 002 eq. 2.2–2.6), sampled every {h} s, {detrend}. Estimated on {est}; simulated from the input alone on {val}. {n} structures of the grid were estimated on the same equations and ranked by <b>{crit}</b>; the named structures are compared beside the one it selected.</p>",
        st = esc(&r.stage),
        out = esc(&d.output),
        inp = esc(&d.input),
        h = d.sample_s,
        detrend = if r.settings["detrend"] == "none" {
            "not detrended"
        } else {
            "each run's mean removed"
        },
        est = esc(&r.estimation_runs.join(", ")),
        val = if r.validation_runs.is_empty() {
            "no held-out run (the estimation run is shown)".into()
        } else {
            esc(&r.validation_runs.join(", "))
        },
        n = d.grid_size,
        crit = criterion_name(d.criterion),
    );
    h += &structure_table(&d, r);
    if let Some(m) = d.models.iter().find(|m| m.selected) {
        h += &transfer_function(m, &d, truth);
    }
    for s in &d.simulations {
        h += &simulation_figure(r, &d, s)?;
    }
    h += &residual_test(r, &d)?;
    h += &ranking_table(&d);
    Ok(h)
}

/// One held-out run: measured, and each structure simulated from the input alone.
fn simulation_figure(r: &FieldResult, d: &ArxDetail, s: &Simulation) -> anyhow::Result<String> {
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
    let fig_id = format!("field-{}-sim-{}", esc(&r.stage), esc(&s.run));
    let caption = format!(
        "{} on held-out run <code>{}</code> (detrended, blue) and each structure simulated from {} alone from the measured initial samples (MATLAB <code>compare</code>); a structure whose simulation diverged is left out.",
        esc(&d.output),
        esc(&s.run),
        esc(&d.input)
    );
    figure(
        &fig_id,
        &caption,
        &Chart {
            title: &title,
            x_desc: "time (s)",
            y_desc: &y_desc,
            series,
            hlines: vec![],
            stems: false,
        },
    )
}

/// The selected model's one-step prediction error: its autocorrelation against the band of
/// a white sequence (MATLAB `resid`).
fn residual_test(r: &FieldResult, d: &ArxDetail) -> anyhow::Result<String> {
    let mut h = String::new();
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
    let _ = writeln!(
        h,
        "<p>Residual test (MATLAB <code>resid</code>): the selected model's one-step prediction error on {} has {} of {} lags outside the 99 % band ±{:.3} of a white sequence.</p>",
        esc(&d.residual_run),
        acf.outside(),
        d.residual_acf.len().saturating_sub(1),
        d.residual_band
    );
    let fig_id = format!("field-{}-resid", esc(&r.stage));
    let caption = format!(
        "Autocorrelation of the selected model's one-step prediction error on <code>{}</code> by lag, with the 99 % band of a white sequence (dotted).",
        esc(&d.residual_run)
    );
    h += &acf.figure(&fig_id, &caption)?;
    Ok(h)
}

/// The comparison of structures (the paper's tf1-tf4 and the selected one).
fn structure_table(d: &ArxDetail, r: &FieldResult) -> String {
    let mut h = String::from(
        "<table><tr><th>structure</th><th>na</th><th>nb</th><th>k</th><th>loss V (estimation)</th><th>MDL</th><th>AIC</th><th>FPE</th>",
    );
    for v in &r.validation_runs {
        let _ = write!(h, "<th>fit on {} (%)</th>", esc(v));
    }
    h.push_str("<th>stable</th><th>steady gain</th></tr>\n");
    for m in &d.models {
        let o = m.arx.orders;
        let _ = write!(
            h,
            "<tr{}><td>{}{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.4e}</td><td>{:.1}</td><td>{:.1}</td><td>{:.4e}</td>",
            if m.selected { " class=\"best\"" } else { "" },
            esc(&m.name),
            if m.selected && m.name != "selected" {
                " (selected)"
            } else {
                ""
            },
            o.na,
            o.nb,
            o.k,
            m.arx.loss,
            m.arx.mdl,
            m.arx.aic,
            m.arx.fpe
        );
        for v in &m.validation {
            let _ = write!(h, "<td>{}</td>", num(v.fit_pct, 1));
        }
        let _ = writeln!(
            h,
            "<td>{}</td><td>{:.4}</td></tr>",
            if m.stable { "yes" } else { "no" },
            m.gain
        );
    }
    h.push_str("</table>\n");
    h
}

/// The selected model's transfer function with standard errors, its poles and zeros, and the
/// truth's poles mapped to the same sample time where a twin left them.
fn transfer_function(m: &Model, d: &ArxDetail, truth: &Truth) -> String {
    let coef = |v: &[f64], s: &[f64], p: &str| -> String {
        v.iter()
            .zip(s)
            .enumerate()
            .map(|(i, (v, s))| format!("{p}{} = {v:.5} ± {s:.5}", i + 1))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let o = m.arx.orders;
    let mut h = format!(
        "<p>Selected transfer function G(z) = z<sup>−{}</sup> B(z<sup>−1</sup>)/A(z<sup>−1</sup>) with {}; {}.</p>\n",
        o.k,
        coef(&m.arx.a, &m.arx.a_std, "a"),
        coef(&m.arx.b, &m.arx.b_std, "b")
    );
    h.push_str("<table><tr><th></th><th>z</th><th>|z|</th><th>s = ln z / h (1/s)</th><th>ω<sub>n</sub> (rad/s)</th><th>ζ</th></tr>\n");
    let row = |h: &mut String, what: &str, z: [f64; 2]| {
        let r = z[0].hypot(z[1]);
        let s = [r.ln() / d.sample_s, z[1].atan2(z[0]) / d.sample_s];
        let wn = s[0].hypot(s[1]);
        let _ = writeln!(
            h,
            "<tr><td>{what}</td><td>{:.4} {} {:.4}i</td><td>{r:.4}</td><td>{:.3} {} {:.3}i</td><td>{wn:.3}</td><td>{:.3}</td></tr>",
            z[0],
            if z[1] < 0.0 { "−" } else { "+" },
            z[1].abs(),
            s[0],
            if s[1] < 0.0 { "−" } else { "+" },
            s[1].abs(),
            -s[0] / wn.max(f64::MIN_POSITIVE)
        );
    };
    for p in &m.poles {
        row(&mut h, "pole", *p);
    }
    for z in &m.zeros {
        row(&mut h, "zero", *z);
    }
    for i in 1.. {
        let (Some(re), Some(im)) = (
            truth.get(&format!("pole{i}_re")),
            truth.get(&format!("pole{i}_im")),
        ) else {
            break;
        };
        let e = (re * d.sample_s).exp();
        let z = [e * (im * d.sample_s).cos(), e * (im * d.sample_s).sin()];
        row(&mut h, "truth pole (e<sup>sh</sup>)", z);
    }
    h.push_str("</table>\n");
    if let Some(g) = truth.get(&format!("{}_gain", d.output)) {
        let _ = writeln!(
            h,
            "<p>Steady gain: {:.4} identified, {g:.4} true ({:+.1} %).</p>",
            m.gain,
            100.0 * (m.gain - g) / g
        );
    }
    h
}

/// The best structures of the grid by the criterion (MATLAB `selstruc`'s table).
fn ranking_table(d: &ArxDetail) -> String {
    let mut h = format!(
        "<details><summary>The {} best of {} structures by {}</summary><table><tr><th>na</th><th>nb</th><th>k</th><th>loss V</th><th>MDL</th><th>AIC</th><th>FPE</th><th>held-out prediction loss</th><th>held-out simulation loss</th></tr>\n",
        d.ranking.len(),
        d.grid_size,
        criterion_name(d.criterion)
    );
    for s in &d.ranking {
        let o = s.orders;
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.4e}</td><td>{:.1}</td><td>{:.1}</td><td>{:.4e}</td><td>{}</td><td>{}</td></tr>",
            o.na,
            o.nb,
            o.k,
            s.loss,
            s.mdl,
            s.aic,
            s.fpe,
            s.prediction_loss.map_or("–".into(), |v| format!("{v:.4e}")),
            s.simulation_loss
                .map_or("diverged".into(), |v| format!("{v:.4e}"))
        );
    }
    h.push_str("</table></details>\n");
    h
}
