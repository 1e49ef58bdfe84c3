//! The diagnosis's figures: where the model misses on a held-out run, and each named effect's
//! evidence (the residual over time before and after it, and the RMS residual binned against
//! the effect's own variable), with captions whose direction words the numbers choose.

use super::result::{Figure, pct};
use super::{self as dx, Augmentation, Data, Mismatch};
use crate::core::dof::Dof;
use crate::core::model::Plant;
use crate::diagnose::SLOTS;

/// The CFD model's residual on the held-out run that carries most of it, every DOF.
pub(super) fn residual_overview(
    data: &Data,
    res: &[[Vec<f64>; SLOTS]],
    mismatch: &[Mismatch],
) -> anyhow::Result<Option<Figure>> {
    let Some(m) = mismatch.first() else {
        return Ok(None);
    };
    let Some(i) = data.validate.iter().position(|r| r.name == m.run) else {
        return Ok(None);
    };
    let run = &data.validate[i];
    let zero = vec![0.0; run.t.len()];
    let traces: Vec<crate::core::plot::Trace> = (data.slots.on())
        .map(|j| crate::core::plot::Trace {
            label: data.slots.dof(j).name(),
            t: &run.t,
            measured: &res[i][j],
            simulated: &zero,
        })
        .collect();
    let svg = crate::core::plot::curves(
        &format!("{}: residual of the model (simulated - fused)", run.name),
        "time (s)",
        "residual (m/s, rad/s)",
        &traces,
        "zero",
    )?;
    Ok(Some(Figure {
        caption: format!(
            "Where the model misses on held-out run {}: the residual per DOF; the mismatch table lists its windows.",
            run.name
        ),
        svg,
    }))
}

/// The held-out run and DOF where the model misses most: the recording, the model's simulation
/// and the simulation with every named effect, on the same axes, with the RMS error of each
/// simulation in the caption. None when nothing was named.
pub(super) fn overlay_figure(
    plant: &Plant,
    data: &Data,
    mismatch: &[Mismatch],
    selected: &dx::Selection,
    model: &str,
) -> anyhow::Result<Option<Figure>> {
    let Some(m) = mismatch.first().filter(|_| !selected.is_empty()) else {
        return Ok(None);
    };
    let (Some(run), Some(j)) = (
        data.validate.iter().find(|r| r.name == m.run),
        data.slots.slot(m.dof),
    ) else {
        return Ok(None);
    };
    let one = std::slice::from_ref(run);
    // A residual plus the recording is the simulation as the cost compares it (read a sensor
    // delay earlier, where one was named).
    let simulated = |aug: &Augmentation| -> Vec<f64> {
        let r = dx::residuals(plant, aug, one).swap_remove(0);
        r[j].iter().zip(&run.vel[j]).map(|(e, v)| e + v).collect()
    };
    let (base, with) = (
        simulated(&Augmentation::default()),
        simulated(&dx::augmentation(selected)),
    );
    let rms = |sim: &[f64]| {
        let (s, n) = sim
            .iter()
            .zip(&run.vel[j])
            .map(|(a, b)| a - b)
            .filter(|e| e.is_finite())
            .fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
        (s / n.max(1) as f64).sqrt()
    };
    let names: Vec<&str> = selected.iter().map(|(h, _)| h.name).collect();
    let d = data.slots.dof(j);
    let model_label = format!("model {model} (dashed)");
    let svg = crate::core::plot::overlay(&crate::core::plot::Overlay {
        title: &format!("{}: {} velocity, recorded and simulated", run.name, d),
        y_desc: &format!("{} ({})", d.velocity(), d.velocity_unit()),
        t: &run.t,
        recorded: &run.vel[j],
        std: &run.std[j],
        model: (&model_label, &base),
        augmented: ("with the named effects", &with),
    })?;
    let (eb, ea) = (rms(&base), rms(&with));
    let word = if ea < eb { "lower" } else { "not lower" };
    Ok(Some(Figure {
        caption: format!(
            "Held-out run {}, {d}, where the model misses most: the recording (blue, with its ±2σ band), model {model} simulated under the logged command (dashed black; RMS error {eb:.3} {u}) and the same model with {} (red; RMS error {ea:.3} {u}, {word}).",
            run.name,
            names.join(" and "),
            u = d.velocity_unit()
        ),
        svg,
    }))
}

/// The residual in DOF `j` over time, before and after effect `h`, on the held-out run where
/// it was largest before.
fn worst_run_figure(
    data: &Data,
    h: &dx::Hypothesis,
    j: usize,
    rb: &[[Vec<f64>; SLOTS]],
    ra: &[[Vec<f64>; SLOTS]],
) -> anyhow::Result<Option<Figure>> {
    use crate::core::plot::{Trace, curves};
    let worst = (0..data.validate.len()).max_by(|&a, &b| {
        let e = |r: &[Vec<f64>; SLOTS]| {
            r[j].iter()
                .filter(|x| x.is_finite())
                .map(|x| x * x)
                .sum::<f64>()
        };
        e(&rb[a]).total_cmp(&e(&rb[b]))
    });
    let Some(i) = worst else {
        return Ok(None);
    };
    let run = &data.validate[i];
    let d = data.slots.dof(j);
    let tr = [Trace {
        label: "before",
        t: &run.t,
        measured: &rb[i][j],
        simulated: &ra[i][j],
    }];
    let svg = curves(
        &format!("{}: {} residual before and after {}", run.name, d, h.name),
        "time (s)",
        &format!("residual {} ({})", d.velocity(), d.velocity_unit()),
        &tr,
        &format!("with {} (dashed)", h.name),
    )?;
    Ok(Some(Figure {
        caption: format!(
            "{}: the {} residual on held-out run {} without the effect (colour) and with it (dashed).",
            h.name, d, run.name
        ),
        svg,
    }))
}

/// For an effect: the residual before and after it in its DOF on the worst held-out run, and
/// the residual binned along the quantity the effect depends on.
pub(super) fn evidence_figures(
    plant: &Plant,
    data: &Data,
    h: &dx::Hypothesis,
    before: &Augmentation,
    after: &Augmentation,
    dofs: &[Dof],
) -> anyhow::Result<Vec<Figure>> {
    use crate::core::plot::{Trace, curves};
    let Some(j) = dofs
        .first()
        .and_then(|d| data.slots.slot(*d))
        .or_else(|| data.slots.slot(h.main_dof))
        .or_else(|| data.slots.on().next())
    else {
        return Ok(Vec::new());
    };
    let rb = dx::residuals(plant, before, &data.validate);
    let ra = dx::residuals(plant, after, &data.validate);
    let mut out = Vec::new();
    if let Some(fig) = worst_run_figure(data, h, j, &rb, &ra)? {
        out.push(fig);
    }
    let (label, x) = evidence_axis(h, data, j);
    let bin = |res: &[[Vec<f64>; SLOTS]]| binned(&x, res, j);
    let (cx, yb) = bin(&rb);
    let (_, ya) = bin(&ra);
    if cx.len() >= 3 {
        let tr = [Trace {
            label: "before",
            t: &cx,
            measured: &yb,
            simulated: &ya,
        }];
        let svg = curves(
            &format!(
                "{}: RMS {} residual against {}",
                h.name,
                data.slots.dof(j),
                label
            ),
            &label,
            "RMS residual",
            &tr,
            &format!("with {} (dashed)", h.name),
        )?;
        out.push(Figure {
            caption: binned_caption(h.name, &label, &yb, &ya),
            svg,
        });
    }
    Ok(out)
}

/// The quantity an effect's evidence is plotted against, per held-out run and sample.
fn evidence_axis(h: &dx::Hypothesis, data: &Data, j: usize) -> (String, Vec<Vec<f64>>) {
    let values = data
        .validate
        .iter()
        .map(|r| (0..r.t.len()).map(|k| (h.axis.value)(r, k, j)).collect())
        .collect();
    ((h.axis.label)(data.slots.dof(j)), values)
}

/// How a binned RMS residual runs along its axis, in words the numbers choose: the
/// least-squares line through the bins changes by over a third of their mean between the first
/// bin and the last ("grows", "falls"), or it does not ("stays about flat").
fn trend(y: &[f64]) -> &'static str {
    let n = y.len() as f64;
    let mean = y.iter().sum::<f64>() / n;
    let xm = (n - 1.0) / 2.0;
    let (sxy, sxx) = y.iter().enumerate().fold((0.0, 0.0), |(a, b), (i, v)| {
        let dx = i as f64 - xm;
        (a + dx * (v - mean), b + dx * dx)
    });
    let change = if sxx > 0.0 {
        sxy / sxx * (n - 1.0)
    } else {
        0.0
    };
    if mean <= 0.0 || change.abs() <= mean / 3.0 {
        "stays about flat"
    } else if change > 0.0 {
        "grows"
    } else {
        "falls"
    }
}

/// The caption of an effect's evidence figure, its direction words computed from the binned
/// RMS residual before (`yb`) and after (`ya`) the effect.
fn binned_caption(name: &str, label: &str, yb: &[f64], ya: &[f64]) -> String {
    let mean = |y: &[f64]| y.iter().sum::<f64>() / y.len().max(1) as f64;
    let (mb, ma) = (mean(yb), mean(ya));
    let change = if ma <= mb {
        format!("{} lower", pct(1.0 - ma / mb))
    } else {
        format!("{} higher", pct(ma / mb - 1.0))
    };
    let ends = |y: &[f64]| (y[0], y[y.len() - 1]);
    let ((b0, b1), (a0, a1)) = (ends(yb), ends(ya));
    format!(
        "{name}: the held-out RMS residual against {label}. Without the effect it {} ({b0:.3} in the first bin, {b1:.3} in the last); with it (dashed) it {} ({a0:.3} to {a1:.3}) and is {change} on average.",
        trend(yb),
        trend(ya)
    )
}

/// RMS residual of DOF j in 12 bins of x between its 2nd and 98th percentiles.
fn binned(x: &[Vec<f64>], res: &[[Vec<f64>; SLOTS]], j: usize) -> (Vec<f64>, Vec<f64>) {
    let mut all: Vec<f64> = x
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    if all.len() < 50 {
        return (vec![], vec![]);
    }
    all.sort_by(f64::total_cmp);
    let (lo, hi) = (all[all.len() / 50], all[all.len() * 49 / 50]);
    if hi <= lo {
        return (vec![], vec![]);
    }
    const N: usize = 12;
    let mut sum = [0.0; N];
    let mut cnt = [0.0; N];
    for (xr, e) in x.iter().zip(res) {
        for (xv, ev) in xr.iter().zip(&e[j]) {
            if xv.is_finite() && ev.is_finite() && *xv >= lo && *xv <= hi {
                let b = (((xv - lo) / (hi - lo)) * N as f64).min(N as f64 - 1.0) as usize;
                sum[b] += ev * ev;
                cnt[b] += 1.0;
            }
        }
    }
    (0..N)
        .filter(|&b| cnt[b] >= 10.0)
        .map(|b| {
            (
                lo + (b as f64 + 0.5) * (hi - lo) / N as f64,
                (sum[b] / cnt[b]).sqrt(),
            )
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_words_follow_the_numbers() {
        assert_eq!(trend(&[0.05, 0.08, 0.12, 0.15, 0.2]), "grows");
        assert_eq!(trend(&[0.18, 0.12, 0.07, 0.05, 0.04]), "falls");
        assert_eq!(
            trend(&[0.05, 0.052, 0.049, 0.051, 0.05]),
            "stays about flat"
        );
        // A peak in the middle is not a trend either way.
        assert_eq!(trend(&[0.02, 0.06, 0.1, 0.06, 0.02]), "stays about flat");
        // The figure of the issue: largest right after a step, falling; with the effect, lower
        // but still not flat.
        let c = binned_caption(
            "thruster_lag",
            "time since a command step (s)",
            &[0.18, 0.12, 0.08, 0.05, 0.04],
            &[0.02, 0.04, 0.07, 0.1, 0.09],
        );
        assert!(c.contains("Without the effect it falls (0.180"), "{c}");
        assert!(
            c.contains("with it (dashed) it grows (0.020 to 0.090)"),
            "{c}"
        );
        assert!(c.contains("32 % lower on average"), "{c}");
        // An effect that makes things worse is said to.
        let c = binned_caption("x", "y", &[0.05, 0.05, 0.05], &[0.06, 0.06, 0.06]);
        assert!(
            c.contains("stays about flat") && c.contains("20 % higher"),
            "{c}"
        );
    }
}
