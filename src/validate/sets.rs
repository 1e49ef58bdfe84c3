//! The parameter sets compared (seed 003 Tables IV and V): per model and DOF, the mean
//! absolute error of its simulation on the trials it was identified from, and the normalised
//! error on the trials held out; and, where the twin's parameters are among the inputs, each
//! set's coefficients against them.

use crate::core::dof::Dof;
use crate::identify::result::FitResult;
use crate::validate::pool::Scores;
use maud::{Markup, html};
use std::collections::BTreeMap;

/// The file of true coefficients (`name,value` lines) a twin writes beside its runs' truth.
pub const TRUTH_PARAMETERS: &str = "parameters.csv";

/// One metric of a DOF's score.
type Metric = fn(&crate::validate::Metrics) -> f64;

/// The worst relative error so far and the term it is on.
type Worst = Option<(f64, String)>;

/// Mean of a metric over the runs of `role`, per DOF.
fn mean_by_dof(scores: &Scores, model: &str, role: &str, metric: Metric) -> BTreeMap<Dof, f64> {
    let mut sums: BTreeMap<Dof, (f64, usize)> = BTreeMap::new();
    let runs = scores
        .models
        .iter()
        .filter(|m| m.model == model)
        .flat_map(|m| &m.runs);
    for r in runs.filter(|r| r.role == role && !r.diverged) {
        for (d, s) in &r.dofs {
            let e = sums.entry(*d).or_default();
            e.0 += metric(&s.metrics);
            e.1 += 1;
        }
    }
    sums.into_iter()
        .map(|(d, (s, n))| (d, s / n as f64))
        .collect()
}

/// cm/s for a translation, deg/s for a rotation (seed 003's units).
fn paper_unit(d: Dof, v: f64) -> f64 {
    if d.is_angular() {
        v.to_degrees()
    } else {
        100.0 * v
    }
}

/// The section, when two or more fits of different structures were validated on pool runs.
pub fn section(
    fits: &[FitResult],
    scores: &Scores,
    truth: Option<&BTreeMap<String, f64>>,
) -> Markup {
    let structures: std::collections::BTreeSet<&str> =
        fits.iter().map(|f| f.structure.label()).collect();
    if structures.len() < 2 {
        return Markup::default();
    }
    let mut fits: Vec<&FitResult> = fits
        .iter()
        .filter(|f| scores.models.iter().any(|m| m.model == f.stage))
        .collect();
    fits.sort_by_key(|f| (f.structure.label(), f.method.clone()));
    let dofs: Vec<Dof> = Dof::ALL
        .into_iter()
        .filter(|d| fits.iter().any(|f| f.dofs.contains(d)))
        .collect();
    let tables: [(&str, &str, Metric, bool); 2] = [
        ("train", "MAE on the identification trials", |m| m.mae, true),
        (
            "validate",
            "normalised MAE on the held-out trials",
            |m| m.nmae,
            false,
        ),
    ];
    let mut best_held_out: BTreeMap<Dof, (f64, String)> = BTreeMap::new();
    let mut rendered = Vec::new();
    for (role, caption, metric, paper) in tables {
        let rows: Vec<(&FitResult, BTreeMap<Dof, f64>)> = fits
            .iter()
            .map(|f| (*f, mean_by_dof(scores, &f.stage, role, metric)))
            .collect();
        if rows.iter().all(|(_, m)| m.is_empty()) {
            continue;
        }
        rendered.push(set_table(&rows, &dofs, caption, paper, &mut best_held_out));
    }
    let list: Vec<String> = best_held_out
        .iter()
        .map(|(d, (_, s))| format!("{} {s}", d.velocity()))
        .collect();
    html! {
        (intro())
        @for t in &rendered { (t) }
        @if !best_held_out.is_empty() {
            p { "Lowest held-out error per DOF: " (list.join(", ")) "." }
        }
        @if let Some(truth) = truth { (against_truth(&fits, truth)) }
    }
}

/// The heading and what the tables hold.
fn intro() -> Markup {
    html! {
        h2 id="sets" { "Parameter sets compared (seed 003, Tables IV and V)" }
        p {
            "Every fit simulated under each trial's logged command, as the validation does. Mean absolute error on the trials it was identified from ("
            code { "train" }
            "; cm/s for translations, deg/s for rotations, as seed 003 Table IV), and normalised mean absolute error, mean |v"
            sub { "model" } " − v" sub { "meas" } "| / mean |v" sub { "meas" }
            "|, on the trials held out ("
            code { "validate" }
            "; Table V). The lowest of each column is in bold."
        }
    }
}

/// One of seed 003's tables: each fit's metric per DOF (in the paper's units when `paper`),
/// the lowest of each column in bold; the held-out table also records the best set per DOF.
fn set_table(
    rows: &[(&FitResult, BTreeMap<Dof, f64>)],
    dofs: &[Dof],
    caption: &str,
    paper: bool,
    best_held_out: &mut BTreeMap<Dof, (f64, String)>,
) -> Markup {
    let best: BTreeMap<Dof, f64> = dofs
        .iter()
        .map(|d| {
            (
                *d,
                rows.iter()
                    .filter_map(|(_, m)| m.get(d))
                    .copied()
                    .fold(f64::INFINITY, f64::min),
            )
        })
        .collect();
    // Each row's cells: the value as printed, and whether it is the lowest of its column.
    let mut cells: Vec<Vec<(String, bool)>> = Vec::new();
    for (f, m) in rows {
        let row = dofs.iter().map(|d| {
            m.get(d).map_or(("–".into(), false), |v| {
                let s = if paper {
                    format!("{:.2}", paper_unit(*d, *v))
                } else {
                    format!("{v:.4}")
                };
                (s, *v == best[d])
            })
        });
        cells.push(row.collect());
        for d in dofs {
            if !paper
                && let Some(v) = m.get(d)
                && best_held_out.get(d).is_none_or(|b| *v < b.0)
            {
                best_held_out.insert(*d, (*v, f.structure.label().to_string()));
            }
        }
    }
    html! {
        table {
            caption { (caption) }
            tr {
                th { "fit" } th { "set" } th { "method" } th { "terms" }
                @for d in dofs { th { (d.velocity()) } }
            }
            @for ((f, _), row) in rows.iter().zip(&cells) {
                tr {
                    td { code { (f.stage) } }
                    td { (f.structure.label()) }
                    td { (f.method) }
                    td { (f.fit.parameters.len()) }
                    @for (s, bold) in row {
                        td { @if *bold { b { (s) } } @else { (s) } }
                    }
                }
            }
        }
    }
}

/// Each set's coefficients against the twin's: the diagonal terms one by one (relative
/// error), the cross terms as one RMS error relative to the RMS of the true ones.
fn against_truth(fits: &[&FitResult], truth: &BTreeMap<String, f64>) -> Markup {
    html! {
        p {
            "Against the twin's coefficients (" code { "truth/" (TRUTH_PARAMETERS) }
            "): the worst relative error of the diagonal terms and of the buoyancy terms, and the RMS error of each set's cross terms (mass and drag couplings) over the RMS of the true ones. A set without a term the truth has cannot recover it; its other terms absorb it."
        }
        table {
            tr {
                th { "fit" } th { "diagonal terms: worst" } th { "buoyancy: worst" }
                th { "cross terms: RMS error / RMS truth" }
            }
            @for f in fits {
                @let (diag, buoy, cross) = truth_errors(f, truth);
                tr {
                    td { code { (f.stage) } }
                    td { (diag) }
                    td { (buoy) }
                    td { (cross) }
                }
            }
        }
    }
}

/// One set's errors against the twin's coefficients, as printed: the worst diagonal term, the
/// worst buoyancy term, and the cross terms' RMS error over the RMS of the true ones.
fn truth_errors(f: &FitResult, truth: &BTreeMap<String, f64>) -> (String, String, String) {
    let layout = f.layout();
    let (mut diag, mut buoy): (Worst, Worst) = (None, None);
    let (mut cross_err, mut cross_true) = (0.0, 0.0);
    for (j, p) in f.fit.parameters.iter().enumerate() {
        let t = truth.get(&p.name).copied().unwrap_or(0.0);
        let term = layout.terms[j];
        if term.is_diagonal() || term.group() == crate::core::model::params::Group::Buoyancy {
            let rel = if t != 0.0 {
                ((p.value - t) / t).abs()
            } else {
                f64::NAN
            };
            let slot = if term.is_diagonal() {
                &mut diag
            } else {
                &mut buoy
            };
            if rel.is_finite() && slot.as_ref().is_none_or(|s| rel > s.0) {
                *slot = Some((rel, p.name.clone()));
            }
        } else {
            cross_err += (p.value - t).powi(2);
            cross_true += t * t;
        }
    }
    let show = |x: &Worst| {
        x.as_ref()
            .map_or("–".into(), |(r, n)| format!("{:.1} % ({n})", 100.0 * r))
    };
    let cross = if cross_true > 0.0 {
        format!("{:.2}", (cross_err / cross_true).sqrt())
    } else {
        "–".into()
    };
    (show(&diag), show(&buoy), cross)
}

/// Reads a `name,value` file of true coefficients.
pub fn read_truth(path: &std::path::Path) -> anyhow::Result<BTreeMap<String, f64>> {
    let text = std::fs::read_to_string(path)?;
    let mut out = BTreeMap::new();
    for (n, line) in text
        .lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let (name, value) = line
            .split_once(',')
            .ok_or_else(|| anyhow::anyhow!("{}:{}: expected name,value", path.display(), n + 1))?;
        let v: f64 = value.trim().parse().map_err(|_| {
            anyhow::anyhow!("{}:{}: {value:?} is not a number", path.display(), n + 1)
        })?;
        out.insert(name.trim().to_string(), v);
    }
    Ok(out)
}
