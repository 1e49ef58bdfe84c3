//! The parameter sets compared (seed 003 Tables IV and V): per model and DOF, the mean
//! absolute error of its simulation on the trials it was identified from, and the normalised
//! error on the trials held out; and, where the twin's parameters are among the inputs, each
//! set's coefficients against them.

use crate::core::dof::Dof;
use crate::core::html::esc;
use crate::identify::result::FitResult;
use crate::validate::pool::Scores;
use std::collections::BTreeMap;
use std::fmt::Write as _;

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
) -> String {
    let structures: std::collections::BTreeSet<&str> =
        fits.iter().map(|f| f.structure.label()).collect();
    if structures.len() < 2 {
        return String::new();
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
    let mut h =
        String::from("<h2 id=\"sets\">Parameter sets compared (seed 003, Tables IV and V)</h2>\n");
    let _ = writeln!(
        h,
        "<p>Every fit simulated under each trial's logged command, as the validation does. Mean absolute error on the trials it was identified from (<code>train</code>; cm/s for translations, deg/s for rotations, as seed 003 Table IV), and normalised mean absolute error, mean |v<sub>model</sub> − v<sub>meas</sub>| / mean |v<sub>meas</sub>|, on the trials held out (<code>validate</code>; Table V). The lowest of each column is in bold.</p>"
    );
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
    for (role, caption, metric, paper) in tables {
        let rows: Vec<(&FitResult, BTreeMap<Dof, f64>)> = fits
            .iter()
            .map(|f| (*f, mean_by_dof(scores, &f.stage, role, metric)))
            .collect();
        if rows.iter().all(|(_, m)| m.is_empty()) {
            continue;
        }
        set_table(&mut h, &rows, &dofs, caption, paper, &mut best_held_out);
    }
    if !best_held_out.is_empty() {
        let list: Vec<String> = best_held_out
            .iter()
            .map(|(d, (_, s))| format!("{} {s}", d.velocity()))
            .collect();
        let _ = writeln!(
            h,
            "<p>Lowest held-out error per DOF: {}.</p>",
            list.join(", ")
        );
    }
    if let Some(truth) = truth {
        against_truth(&mut h, &fits, truth);
    }
    h
}

/// One of seed 003's tables: each fit's metric per DOF (in the paper's units when `paper`),
/// the lowest of each column in bold; the held-out table also records the best set per DOF.
fn set_table(
    h: &mut String,
    rows: &[(&FitResult, BTreeMap<Dof, f64>)],
    dofs: &[Dof],
    caption: &str,
    paper: bool,
    best_held_out: &mut BTreeMap<Dof, (f64, String)>,
) {
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
    let _ = write!(
        h,
        "<table><caption>{caption}</caption><tr><th>fit</th><th>set</th><th>method</th><th>terms</th>"
    );
    for d in dofs {
        let _ = write!(h, "<th>{}</th>", d.velocity());
    }
    h.push_str("</tr>\n");
    for (f, m) in rows {
        let _ = write!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td>",
            esc(&f.stage),
            f.structure.label(),
            f.method,
            f.fit.parameters.len()
        );
        for d in dofs {
            let cell = m.get(d).map_or("–".into(), |v| {
                let s = if paper {
                    format!("{:.2}", paper_unit(*d, *v))
                } else {
                    format!("{v:.4}")
                };
                if *v == best[d] {
                    format!("<b>{s}</b>")
                } else {
                    s
                }
            });
            let _ = write!(h, "<td>{cell}</td>");
            if !paper
                && let Some(v) = m.get(d)
                && best_held_out.get(d).is_none_or(|b| *v < b.0)
            {
                best_held_out.insert(*d, (*v, f.structure.label().to_string()));
            }
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}

/// Each set's coefficients against the twin's: the diagonal terms one by one (relative
/// error), the cross terms as one RMS error relative to the RMS of the true ones.
fn against_truth(h: &mut String, fits: &[&FitResult], truth: &BTreeMap<String, f64>) {
    let _ = writeln!(
        h,
        "<p>Against the twin's coefficients (<code>truth/{TRUTH_PARAMETERS}</code>): the worst relative error of the diagonal terms and of the buoyancy terms, and the RMS error of each set's cross terms (mass and drag couplings) over the RMS of the true ones. A set without a term the truth has cannot recover it; its other terms absorb it.</p>"
    );
    h.push_str("<table><tr><th>fit</th><th>diagonal terms: worst</th><th>buoyancy: worst</th><th>cross terms: RMS error / RMS truth</th></tr>\n");
    for f in fits {
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
        let show = |x: &Option<(f64, String)>| {
            x.as_ref().map_or("–".into(), |(r, n)| {
                format!("{:.1} % ({})", 100.0 * r, esc(n))
            })
        };
        let cross = if cross_true > 0.0 {
            format!("{:.2}", (cross_err / cross_true).sqrt())
        } else {
            "–".into()
        };
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{cross}</td></tr>",
            esc(&f.stage),
            show(&diag),
            show(&buoy)
        );
    }
    h.push_str("</table>\n");
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
