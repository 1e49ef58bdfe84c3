//! Sparse selection that holds up: forward stepwise least squares, repeated on block-bootstrap
//! resamples and on each training run alone, and every subset of the kept terms refitted for
//! the held-out runs to choose among.

use super::super::Data;
use super::library::{Feature, Prepared, library};
use super::rows::{EVERY_S, Rows, design, peaks};
use super::term::Discovered;
use crate::diagnose::result::DiscoveredTerm;

/// The most terms a discovered closed form has (a sine with its phase counts as one).
pub const MAX_TERMS: usize = 2;
/// A term enters the stepwise fit only if it removes this share of the residual left.
const MIN_DROP: f64 = 0.05;
/// Block-bootstrap resamples of the training runs, and the block length, s.
const RESAMPLES: usize = 40;
const BLOCK_S: f64 = 10.0;
/// Share of the resamples that must select a term for it to be kept.
pub const KEEP_SHARE: f64 = 0.7;
/// The |cosine| over one run's rows above which a term selected there stands in for another
/// (a depth within a third of its mean is the constant).
const STAND_IN: f64 = 0.95;

/// Least squares of `y` on the columns `cols` of `x` over the rows `idx`; coefficients and RSS.
fn lstsq(x: &[f64], width: usize, y: &[f64], idx: &[usize], cols: &[usize]) -> (Vec<f64>, f64) {
    let p = cols.len();
    if p == 0 {
        return (Vec::new(), idx.iter().map(|&i| y[i] * y[i]).sum());
    }
    let a = nalgebra::DMatrix::from_fn(idx.len(), p, |r, c| x[idx[r] * width + cols[c]]);
    let b = nalgebra::DVector::from_fn(idx.len(), |r, _| y[idx[r]]);
    let Some(svd) = crate::core::numerics::svd(a.clone(), true, true) else {
        return (vec![0.0; p], f64::INFINITY);
    };
    let smax = svd.singular_values.max();
    let Ok(sol) = svd.solve(&b, 1e-10 * smax.max(1e-300)) else {
        return (vec![0.0; p], f64::INFINITY);
    };
    let rss = (&b - &a * &sol).norm_squared();
    (sol.iter().copied().collect(), rss)
}

/// Forward stepwise selection of feature groups on rows `idx`: the groups chosen.
fn stepwise(
    x: &[f64],
    width: usize,
    y: &[f64],
    idx: &[usize],
    groups: &[Vec<usize>],
) -> Vec<usize> {
    let mut chosen: Vec<usize> = Vec::new();
    let mut rss = idx.iter().map(|&i| y[i] * y[i]).sum::<f64>();
    while chosen.len() < MAX_TERMS {
        let best = (0..groups.len())
            .filter(|g| !chosen.contains(g))
            .map(|g| {
                let cols: Vec<usize> = chosen
                    .iter()
                    .chain(std::iter::once(&g))
                    .flat_map(|&c| groups[c].iter().copied())
                    .collect();
                (g, lstsq(x, width, y, idx, &cols).1)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((g, r)) if r < (1.0 - MIN_DROP) * rss => {
                chosen.push(g);
                rss = r;
            }
            _ => break,
        }
    }
    chosen
}

/// A block-bootstrap resample of the row indices: blocks of `BLOCK_S` within runs.
fn resample(rows: &Rows, rng: &mut crate::core::rng::Rng) -> Vec<usize> {
    let block = (BLOCK_S / EVERY_S).round().max(1.0) as usize;
    let starts: Vec<usize> = (0..rows.at.len()).step_by(block).collect();
    let mut out = Vec::with_capacity(rows.at.len());
    while out.len() < rows.at.len() {
        let s = starts[rng.below(starts.len())];
        let run = rows.at[s].0;
        out.extend((s..(s + block).min(rows.at.len())).take_while(|&i| rows.at[i].0 == run));
    }
    out
}

/// What discovery found for one DOF before the held-out proof.
pub(super) struct Proposal {
    pub dof: usize,
    /// The kept terms and each non-empty subset of them, refitted.
    pub variants: Vec<Variant>,
    pub library_terms: usize,
    pub peaks: Vec<f64>,
    pub spectrum: (Vec<f64>, Vec<f64>),
}

/// One closed form: the term the simulator adds and what the report says of it.
#[derive(Clone)]
pub(super) struct Variant {
    pub term: Discovered,
    pub terms: Vec<DiscoveredTerm>,
}

/// The regression of one DOF's residual: its columns weighted and scaled to unit RMS, and
/// which columns belong to which feature.
struct Design {
    xs: Vec<f64>,
    width: usize,
    y: Vec<f64>,
    /// Each column's RMS before scaling (to take coefficients back to the features' units).
    scale: Vec<f64>,
    /// The columns of each feature (a sine has two).
    groups: Vec<Vec<usize>>,
}

impl Design {
    /// Whether group `h`, selected on rows `idx`, stands in for group `g` there: single
    /// columns collinear on those rows (|cosine| at least `STAND_IN`). Within one run at a
    /// steady depth, the depth is the constant: a yaw moment of 0.5 N m was chosen as `Depth`
    /// on two of four runs, `Constant` on the others, and the constant failed the runs'
    /// majority.
    fn stands_in(&self, h: usize, g: usize, idx: &[usize]) -> bool {
        let (&[ch], &[cg]) = (&self.groups[h][..], &self.groups[g][..]) else {
            return false;
        };
        let col = |r: usize, c: usize| self.xs[r * self.width + c];
        let (mut hg, mut hh, mut gg) = (0.0, 0.0, 0.0);
        for &r in idx {
            let (a, b) = (col(r, ch), col(r, cg));
            (hg, hh, gg) = (hg + a * b, hh + a * a, gg + b * b);
        }
        hg.abs() >= STAND_IN * (hh * gg).sqrt() && hh > 0.0 && gg > 0.0
    }

    fn cols_of(&self, gs: &[usize]) -> Vec<usize> {
        gs.iter()
            .flat_map(|&g| self.groups[g].iter().copied())
            .collect()
    }

    fn select(&self, idx: &[usize]) -> Vec<usize> {
        stepwise(&self.xs, self.width, &self.y, idx, &self.groups)
    }

    fn lstsq(&self, idx: &[usize], cols: &[usize]) -> (Vec<f64>, f64) {
        lstsq(&self.xs, self.width, &self.y, idx, cols)
    }
}

/// Row weights from the fusion's uncertainty (1 / sigma^2, normalised to a mean of 1; a sigma
/// below a tenth of the median is taken as that, so no row decides alone), as square roots.
fn row_weights(sigma: &[f64]) -> Vec<f64> {
    let mut sorted: Vec<f64> = sigma.iter().copied().filter(|s| s.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let floor = 0.1
        * sorted
            .get(sorted.len() / 2)
            .copied()
            .unwrap_or(1.0)
            .max(1e-300);
    let w: Vec<f64> = sigma
        .iter()
        .map(|s| {
            if s.is_finite() {
                s.max(floor).powi(-2)
            } else {
                floor.powi(-2)
            }
        })
        .collect();
    let mean_w = w.iter().sum::<f64>() / sigma.len().max(1) as f64;
    w.iter().map(|x| (x / mean_w).sqrt()).collect()
}

/// DOF `j`'s design: the library's columns and the residual, weighted, with the columns scaled
/// to unit RMS (the selection's threshold is then the same for every term).
fn weighted_design(
    data: &Data,
    pre: &[Prepared],
    rows: &Rows,
    j: usize,
    features: &[Feature],
) -> Design {
    let (x, width) = design(data, pre, rows, features);
    let n = rows.at.len();
    let sw = row_weights(&rows.sigma[j]);
    let x: Vec<f64> = (0..n * width).map(|i| x[i] * sw[i / width]).collect();
    let y: Vec<f64> = rows.y[j].iter().zip(&sw).map(|(a, b)| a * b).collect();
    let mut scale = vec![0.0; width];
    for r in 0..n {
        for c in 0..width {
            scale[c] += x[r * width + c].powi(2);
        }
    }
    let scale: Vec<f64> = scale.iter().map(|s| (s / n as f64).sqrt()).collect();
    let xs: Vec<f64> = (0..n * width)
        .map(|i| {
            let s = scale[i % width];
            if s > 0.0 { x[i] / s } else { 0.0 }
        })
        .collect();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut c0 = 0;
    for f in features {
        groups.push((c0..c0 + f.columns()).collect());
        c0 += f.columns();
    }
    Design {
        xs,
        width,
        y,
        scale,
        groups,
    }
}

/// Sparse, stability-selected regression of DOF `j`'s residual on its library.
pub(super) fn propose(data: &Data, pre: &[Prepared], rows: &Rows, j: usize) -> Option<Proposal> {
    let (peaks_hz, grid, spectrum) = peaks(data, rows, j);
    let mut features = library(j, &peaks_hz, data);
    let mut d = weighted_design(data, pre, rows, j, &features);
    let all: Vec<usize> = (0..rows.at.len()).collect();
    let chosen = d.select(&all);
    if chosen.is_empty() {
        return None;
    }
    let mut rng = crate::core::rng::Rng::derive(17, &format!("discover/{j}"));
    let (keep, terms_runs) = stable_terms(data, rows, &d, &features, &chosen, j, &mut rng)?;
    if refine_clips(data, pre, rows, j, &mut features, &keep) {
        d = weighted_design(data, pre, rows, j, &features);
    }
    // Every non-empty subset of the kept terms, refitted: the held-out runs choose among them
    // as they choose among named effects (a term stable on the training runs can still be an
    // artefact the held-out runs do not share).
    let variants = (1..1usize << keep.len())
        .map(|mask| {
            let sub: Vec<usize> = (0..keep.len()).filter(|q| mask >> q & 1 == 1).collect();
            variant(rows, &d, &features, j, &sub, &keep, &terms_runs, &mut rng)
        })
        .collect();
    Some(Proposal {
        dof: j,
        variants,
        library_terms: features.len(),
        peaks: peaks_hz,
        spectrum: (grid, spectrum),
    })
}

/// Levels of the kept clipped commands (`keep`, indices into `features`), each refined within a
/// quarter of its grid value by golden section on the residual the kept terms leave on all
/// rows: the library's grid clips at shares of the largest command, the thrusters at their
/// own limit. Whether any level moved.
fn refine_clips(
    data: &Data,
    pre: &[Prepared],
    rows: &Rows,
    j: usize,
    features: &mut [Feature],
    keep: &[usize],
) -> bool {
    let mut moved = false;
    let all: Vec<usize> = (0..rows.at.len()).collect();
    for (at, &g) in keep.iter().enumerate() {
        let Feature::Clip(q, level) = features[g] else {
            continue;
        };
        let rss = |l: f64| {
            let mut kept: Vec<Feature> = keep.iter().map(|&k| features[k]).collect();
            kept[at] = Feature::Clip(q, l);
            let d = weighted_design(data, pre, rows, j, &kept);
            d.lstsq(&all, &(0..d.width).collect::<Vec<_>>()).1
        };
        let best = crate::core::numerics::golden_min(rss, 0.75 * level, 1.25 * level, 1e-3 * level);
        let best = super::library::three_figures(best);
        if best != level && rss(best) < rss(level) {
            features[g] = Feature::Clip(q, best);
            moved = true;
        }
    }
    moved
}

/// A kept term's share of the resamples that selected it, and (training runs that selected
/// it alone, runs where it varies).
type Support = (f64, [usize; 2]);

/// The spread (standard deviation) of a modulating factor in [0, 1] over a run below which the
/// run does not tell the modulated term from the plain one ([`modulated`]).
const MODULATION_SD: f64 = 0.05;

/// Of the terms `chosen` on all rows of slot `j`, those the block-bootstrap resamples select
/// at least [`KEEP_SHARE`] of the time and most informative training runs select alone, each
/// with its share and (runs selecting it, runs where it varies). A tie among the runs keeps a
/// term no named effect has the form of: it is no evidence against the term, and the held-out
/// proof still decides. A named effect's form needs a majority, since a look-alike found on
/// top of another effect would otherwise keep that effect named (docs/diagnosis.md, step 5,
/// "Selection that holds up").
/// `None` when none is kept or the build is interrupted.
fn stable_terms(
    data: &Data,
    rows: &Rows,
    d: &Design,
    features: &[Feature],
    chosen: &[usize],
    j: usize,
    rng: &mut crate::core::rng::Rng,
) -> Option<(Vec<usize>, Vec<Support>)> {
    let n = rows.at.len();
    let mut count = vec![0usize; d.groups.len()];
    for _ in 0..RESAMPLES {
        if crate::core::interrupt::requested() {
            return None;
        }
        let idx = resample(rows, rng);
        for g in d.select(&idx) {
            count[g] += 1;
        }
    }
    // Each training run alone, for the runs where the group varies.
    let runs: Vec<Vec<usize>> = (0..data.train.len())
        .map(|ri| (0..n).filter(|&r| rows.at[r].0 == ri).collect())
        .collect();
    let varies = |g: usize, idx: &[usize]| {
        d.groups[g].iter().any(|&c| {
            let col = |r: usize| d.xs[r * d.width + c];
            let m = idx.iter().map(|&r| col(r)).sum::<f64>() / idx.len().max(1) as f64;
            let v =
                idx.iter().map(|&r| (col(r) - m).powi(2)).sum::<f64>() / idx.len().max(1) as f64;
            v.sqrt() > 0.2 || matches!(features[g], Feature::Constant)
        }) && modulated(data, rows, &features[g], idx)
    };
    let per_run: Vec<Vec<usize>> = runs
        .iter()
        .map(|idx| {
            if idx.len() < 50 {
                Vec::new()
            } else {
                d.select(idx)
            }
        })
        .collect();
    let mut keep = Vec::new();
    let mut terms_runs = Vec::new();
    for &g in chosen {
        let share = count[g] as f64 / RESAMPLES as f64;
        // The constant counts in every run, where a term that varies little stands in for it
        // (`Design::stands_in`): such a run cannot tell them apart and counts neither way.
        // Other terms count only where they vary, and apart from the terms they resemble.
        let constant = matches!(features[g], Feature::Constant);
        let informative: Vec<usize> = (0..runs.len())
            .filter(|&ri| runs[ri].len() >= 50 && varies(g, &runs[ri]))
            .filter(|&ri| {
                let chose = &per_run[ri];
                !constant
                    || chose.contains(&g)
                    || !chose.iter().any(|&h| d.stands_in(h, g, &runs[ri]))
            })
            .collect();
        let selected = informative
            .iter()
            .filter(|&&ri| per_run[ri].contains(&g))
            .count();
        let majority = if features[g].named(&rows.slots, j).is_none() {
            2 * selected >= informative.len()
        } else {
            2 * selected > informative.len()
        };
        if share >= KEEP_SHARE && !informative.is_empty() && majority {
            keep.push(g);
            terms_runs.push((share, [selected, informative.len()]));
        }
    }
    (!keep.is_empty()).then_some((keep, terms_runs))
}

/// The closed form of the kept terms `sub` (indices into `keep`), refitted on all rows, with
/// intervals from the resamples refitted.
#[allow(clippy::too_many_arguments)]
fn variant(
    rows: &Rows,
    d: &Design,
    features: &[Feature],
    j: usize,
    sub: &[usize],
    keep: &[usize],
    terms_runs: &[Support],
    rng: &mut crate::core::rng::Rng,
) -> Variant {
    let all: Vec<usize> = (0..rows.at.len()).collect();
    let groups_sub: Vec<usize> = sub.iter().map(|&q| keep[q]).collect();
    let cols = d.cols_of(&groups_sub);
    let (coef_s, _) = d.lstsq(&all, &cols);
    // Back to the features' own units.
    let coef: Vec<f64> = cols
        .iter()
        .zip(&coef_s)
        .map(|(&c, b)| {
            if d.scale[c] > 0.0 {
                b / d.scale[c]
            } else {
                0.0
            }
        })
        .collect();
    let boot: Vec<Vec<f64>> = (0..RESAMPLES)
        .map(|_| d.lstsq(&resample(rows, rng), &cols).0)
        .collect();
    let mut terms = Vec::new();
    let mut at = 0;
    for &q in sub {
        let f = features[keep[q]];
        let k = f.columns();
        terms.push(term(
            f,
            &rows.slots,
            d,
            &cols[at..at + k],
            &coef_s[at..at + k],
            &boot,
            at,
            terms_runs[q],
        ));
        at += k;
    }
    Variant {
        term: Discovered {
            dof: j,
            features: groups_sub.iter().map(|&g| features[g]).collect(),
            coef,
        },
        terms,
    }
}

/// One kept term as the report states it: its coefficient in its own units (a sine's
/// amplitude and phase), its 95 % interval over the resamples `boot` (whose columns for it
/// start at `at`), and how often it was selected.
#[allow(clippy::too_many_arguments)]
fn term(
    f: Feature,
    slots: &crate::diagnose::Slots,
    d: &Design,
    cols: &[usize],
    coef_s: &[f64],
    boot: &[Vec<f64>],
    at: usize,
    (share, runs_selected): Support,
) -> DiscoveredTerm {
    let k = cols.len();
    let unscale = |v: &[f64]| -> Vec<f64> {
        (0..k)
            .map(|i| v[i] / d.scale[cols[i]].max(1e-300))
            .collect()
    };
    let value = |v: &[f64]| -> f64 {
        let u = unscale(v);
        if k == 2 { u[0].hypot(u[1]) } else { u[0] }
    };
    let mut samples: Vec<f64> = boot.iter().map(|b| value(&b[at..at + k])).collect();
    samples.sort_by(f64::total_cmp);
    let pick = |p: f64| samples[(p * (samples.len() - 1) as f64).round() as usize];
    let full = unscale(coef_s);
    let (coefficient, frequency_hz, phase_rad) = match f {
        // a sin + b cos = A sin(x + phase), A = hypot(a, b), phase = atan2(b, a).
        Feature::Sine(hz) => (
            full[0].hypot(full[1]),
            Some(hz),
            Some(full[1].atan2(full[0])),
        ),
        _ => (full[0], None, None),
    };
    DiscoveredTerm {
        term: f.label(slots),
        coefficient,
        interval: [pick(0.025), pick(0.975)],
        frequency_hz,
        phase_rad,
        selected_share: share,
        runs_selected,
    }
}

/// Whether the factor that modulates a feature varies over the rows `idx`, for the features
/// that are a simpler term times such a factor: a near-surface drag `|u| u exp(-z/l)` in a run
/// that stays at one depth is the plain `|u| u` scaled, and that run can pick either of the
/// two; only the runs that change depth by enough to change the factor tell them apart (on
/// a twin whose surge and sway drag grew near the surface, 1 of 3 runs chose the near-surface
/// form, the two that never came up chose the plain one).
fn modulated(data: &Data, rows: &Rows, f: &Feature, idx: &[usize]) -> bool {
    let Feature::NearSurfaceDrag(_, l) = *f else {
        return true;
    };
    let factor: Vec<f64> = (idx.iter())
        .map(|&r| {
            let (ri, a, _) = rows.at[r];
            (-data.train[ri].pos[2][a].max(0.0) / l).exp()
        })
        .filter(|x| x.is_finite())
        .collect();
    let n = factor.len().max(1) as f64;
    let m = factor.iter().sum::<f64>() / n;
    let sd = (factor.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt();
    sd > MODULATION_SD
}
