//! Discovery's figures: the residual force against the discovered term, and the spectrum.

use super::super::Data;
use super::super::effects::State;
use super::super::result::Figure;
use super::library::Prepared;
use super::rows::{PEAK_RATIO, Rows, window_mean};
use super::select::{Proposal, Variant};
use crate::diagnose::result::Candidate;

/// The residual force against the discovered term's contribution on the training run where
/// it matters most, and the residual's spectrum with its peaks.
pub(super) fn figures(
    data: &Data,
    rows: &Rows,
    pre: &[Prepared],
    c: &Candidate,
    p: &Proposal,
    var: &Variant,
) -> anyhow::Result<Vec<Figure>> {
    let mut out = vec![residual_figure(data, rows, pre, c, p.dof, var)?];
    if let Some(f) = spectrum_figure(c, p)? {
        out.push(f);
    }
    Ok(out)
}

/// The term's contribution to each residual row (its window's mean), at the fused state.
fn contributions(data: &Data, rows: &Rows, pre: &[Prepared], j: usize, var: &Variant) -> Vec<f64> {
    rows.at
        .iter()
        .map(|&(ri, a, b)| {
            let run = &data.train[ri];
            window_mean(&run.t, a, b, |k| {
                let mut s = State::default();
                run.set_velocity(k, &mut s);
                var.term.force(run, &pre[ri], k, &s)[j]
            })
        })
        .collect()
}

/// The residual force and the discovered term on the training run where the term carries the
/// largest share.
fn residual_figure(
    data: &Data,
    rows: &Rows,
    pre: &[Prepared],
    c: &Candidate,
    j: usize,
    var: &Variant,
) -> anyhow::Result<Figure> {
    use crate::core::plot::lines::{Chart, Series, chart};
    let d = data.slots.dof(j);
    let contrib = contributions(data, rows, pre, j, var);
    let mut by_run = vec![0.0; data.train.len()];
    for (q, &(ri, _, _)) in rows.at.iter().enumerate() {
        by_run[ri] += contrib[q].powi(2);
    }
    let ri = (0..by_run.len())
        .max_by(|a, b| by_run[*a].total_cmp(&by_run[*b]))
        .unwrap_or(0);
    let idx: Vec<usize> = (0..rows.at.len()).filter(|&q| rows.at[q].0 == ri).collect();
    let run = &data.train[ri];
    let t: Vec<f64> = idx
        .iter()
        .map(|&q| 0.5 * (run.t[rows.at[q].1] + run.t[rows.at[q].2]))
        .collect();
    let res: Vec<f64> = idx.iter().map(|&q| rows.y[j][q]).collect();
    let con: Vec<f64> = idx.iter().map(|&q| contrib[q]).collect();
    let unit = d.force_unit();
    let y_desc = format!("{d} force ({unit})");
    let svg = chart(&Chart {
        title: &format!(
            "{}: what the model leaves in {d}, and the discovered term",
            run.name
        ),
        x_desc: "time (s)",
        y_desc: &y_desc,
        series: vec![
            Series {
                label: "residual force",
                x: &t,
                y: &res,
                reference: false,
            },
            Series {
                label: "discovered term",
                x: &t,
                y: &con,
                reference: true,
            },
        ],
        hlines: Vec::new(),
        stems: false,
    })?;
    Ok(Figure {
        caption: format!(
            "Discovery, training run {}: the {d} residual force of the model with the named effects (M times measured minus modelled acceleration; blue) and the discovered term {} (dashed).",
            run.name, c.expression
        ),
        svg,
    })
}

/// The residual's periodogram relative to its median, with the significance level.
fn spectrum_figure(c: &Candidate, p: &Proposal) -> anyhow::Result<Option<Figure>> {
    use crate::core::plot::lines::{Chart, Series, chart};
    let d = c.dof;
    let (grid, power) = &p.spectrum;
    if grid.is_empty() {
        return Ok(None);
    }
    let mut sorted = power.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let svg = chart(&Chart {
        title: &format!("Spectrum of the {d} residual force (training runs pooled)"),
        x_desc: "frequency (Hz)",
        y_desc: "power (relative to the median)",
        series: vec![Series {
            label: "periodogram",
            x: grid,
            y: &power
                .iter()
                .map(|x| x / median.max(1e-300))
                .collect::<Vec<_>>(),
            reference: false,
        }],
        hlines: vec![PEAK_RATIO],
        stems: false,
    })?;
    let peaks = if c.spectrum_peaks_hz.is_empty() {
        "no peak rises above it".to_string()
    } else {
        format!(
            "significant peaks at {} Hz",
            c.spectrum_peaks_hz
                .iter()
                .map(|f| format!("{f:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    Ok(Some(Figure {
        caption: format!(
            "Discovery: the periodogram of the {d} residual force, relative to its median; the dotted line is the significance level ({PEAK_RATIO} times the median): {peaks}."
        ),
        svg,
    }))
}
