//! The residual generalised force the regression explains, row by row, its spectrum, and the
//! library's columns over the same rows.

use super::super::effects::State;
use super::super::{Augmentation, Data, Slots, spectrum};
use super::library::{Feature, Prepared};
use crate::core::model::{Plant, Vec6};
use crate::diagnose::SLOTS;

/// Sampling of the regression, s (the residual is smooth at this scale).
pub(super) const EVERY_S: f64 = 0.1;
/// A periodogram peak is significant at this multiple of the periodogram's median.
pub(super) const PEAK_RATIO: f64 = spectrum::LINE_RATIO;
/// Frequencies searched for peaks, Hz.
const F_MIN: f64 = 0.05;
const F_MAX: f64 = 2.0;

/// The residual force of the training runs at the regression's rows. Each row is a window of
/// `WINDOW_S`: the measured velocity change over it against the model's acceleration
/// integrated over it (so no derivative of a noisy velocity is taken, and smoothing cannot
/// shift the measured acceleration against the model's: both sides see the same window, as
/// the library's terms do, averaged over it).
pub(super) struct Rows {
    /// The DOFs of the per-DOF arrays.
    pub slots: Slots,
    /// (run index, first sample, last sample) of each row's window.
    pub at: Vec<(usize, usize, usize)>,
    /// Residual force per DOF, averaged over the window.
    pub y: [Vec<f64>; SLOTS],
    /// Its standard deviation from the fusion: the fused velocities' at the window's ends,
    /// through the difference quotient and the mass.
    pub sigma: [Vec<f64>; SLOTS],
}

/// Length of a row's window, s.
const WINDOW_S: f64 = 0.6;

/// Trapezoidal mean of `f(k)` over samples `a..=b` of `t`.
pub(super) fn window_mean(t: &[f64], a: usize, b: usize, mut f: impl FnMut(usize) -> f64) -> f64 {
    if b <= a {
        return f(a);
    }
    let mut sum = 0.0;
    let mut prev = f(a);
    for k in a + 1..=b {
        let x = f(k);
        sum += 0.5 * (prev + x) * (t[k] - t[k - 1]);
        prev = x;
    }
    sum / (t[b] - t[a])
}

/// The model's equation error on the training runs, as a generalised force per DOF.
pub(super) fn residual_rows(plant: &Plant, aug: &Augmentation, data: &Data) -> Rows {
    let (mass, _) = plant.mass_matrix();
    let mut rows = Rows {
        slots: data.slots,
        at: Vec::new(),
        y: Default::default(),
        sigma: Default::default(),
    };
    for (ri, run) in data.train.iter().enumerate() {
        let n = run.t.len();
        if n < 10 {
            continue;
        }
        let dt = (run.t[n - 1] - run.t[0]) / (n - 1) as f64;
        let span = ((WINDOW_S / dt).round() as usize).max(1);
        let every = ((EVERY_S / dt).round() as usize).max(1);
        // The model's acceleration at every sample, at the measured state, the thrusters'
        // state (under a lag) following the command.
        let mut w = super::super::world_for(plant, aug, run);
        let mut s = State {
            thrust: super::super::start_of(plant, aug, run),
            ..State::default()
        };
        let mut model: Vec<Vec6> = Vec::with_capacity(n);
        for k in 0..n {
            let c = run.cmd6(k);
            run.set_velocity(k, &mut s);
            s.pos = [run.pos[0][k], run.pos[1][k], run.pos[2][k]];
            s.psi = run.psi[k];
            w.gravity = run.gravity(k);
            model.push(w.accel(&s, &c));
            if k + 1 < n {
                s.thrust = w.step(&s, &c, run.t[k + 1] - run.t[k]).thrust;
            }
        }
        let mut a = every;
        while a + span < n.saturating_sub(every) {
            let b = a + span;
            // Slot j is the DOF of index j in nu: the rows are body vectors.
            let dv: Vec6 = std::array::from_fn(|j| {
                let model_mean = window_mean(&run.t, a, b, |k| model[k][j]);
                (run.vel[j][b] - run.vel[j][a]) / (run.t[b] - run.t[a]) - model_mean
            });
            for (j, m) in mass.iter().enumerate() {
                rows.y[j].push((0..6).map(|q| m[q] * dv[q]).sum());
                let sd = run.std[j][a].hypot(run.std[j][b]) / (run.t[b] - run.t[a]);
                rows.sigma[j].push(m[j].abs() * sd);
            }
            rows.at.push((ri, a, b));
            a += every;
        }
    }
    rows
}

fn run_t(data: &Data, ri: usize, k: usize) -> f64 {
    data.train[ri].t[k]
}

/// One DOF's residual rows per training run, each row at its window's centre time: the
/// segments of its pooled periodogram.
fn segments(data: &Data, rows: &Rows, j: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < rows.at.len() {
        let ri = rows.at[start].0;
        let end = start + rows.at[start..].iter().take_while(|a| a.0 == ri).count();
        let times = (start..end)
            .map(|q| {
                let (_, a, b) = rows.at[q];
                0.5 * (run_t(data, ri, a) + run_t(data, ri, b))
            })
            .collect();
        out.push((times, rows.y[j][start..end].to_vec()));
        start = end;
    }
    out
}

/// The significant peaks of the residual's pooled periodogram (at most two, refined), and
/// the periodogram itself for the figure.
pub(super) fn peaks(data: &Data, rows: &Rows, j: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let span = data
        .train
        .iter()
        .map(|r| r.t.last().unwrap_or(&0.0) - r.t.first().unwrap_or(&0.0))
        .fold(0.0, f64::max)
        .max(1.0);
    let df = 0.25 / span;
    let grid: Vec<f64> = (0..)
        .map(|i| F_MIN + i as f64 * df)
        .take_while(|f| *f <= F_MAX)
        .collect();
    let segs = segments(data, rows, j);
    let p = spectrum::pooled(&segs, &grid);
    let mut sorted = p.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2].max(1e-300);
    let mut maxima: Vec<usize> = (1..p.len() - 1)
        .filter(|&i| p[i] >= p[i - 1] && p[i] >= p[i + 1] && p[i] > PEAK_RATIO * median)
        .collect();
    maxima.sort_by(|a, b| p[*b].total_cmp(&p[*a]));
    let mut out: Vec<f64> = Vec::new();
    for i in maxima {
        if out.len() == 2 {
            break;
        }
        if out.iter().all(|f| (f - grid[i]).abs() > 0.05) {
            // Golden-section refinement within a grid step either side.
            let (mut a, mut b) = (grid[i] - df, grid[i] + df);
            let g = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..20 {
                let (c, d) = (b - g * (b - a), a + g * (b - a));
                let pc = spectrum::pooled(&segs, &[c])[0];
                let pd = spectrum::pooled(&segs, &[d])[0];
                if pc > pd {
                    b = d;
                } else {
                    a = c;
                }
            }
            out.push(0.5 * (a + b));
        }
    }
    (out, grid, p)
}

/// Column matrix (row-major) of `features` over `rows`, with their column offsets.
pub(super) fn design(
    data: &Data,
    pre: &[Prepared],
    rows: &Rows,
    features: &[Feature],
) -> (Vec<f64>, usize) {
    let width: usize = features.iter().map(|f| f.columns()).sum();
    let mut x = Vec::with_capacity(rows.at.len() * width);
    let mut buf = Vec::with_capacity(width);
    let mut prev = Vec::with_capacity(width);
    let mut mean = vec![0.0; width];
    for &(ri, a, b) in &rows.at {
        let run = &data.train[ri];
        mean.iter_mut().for_each(|m| *m = 0.0);
        // Trapezoids, as `window_mean` for each column at once.
        for k in a..=b {
            buf.clear();
            let vel: [f64; SLOTS] = std::array::from_fn(|j| run.vel[j][k]);
            for f in features {
                f.eval(run, &pre[ri], k, &vel, &mut buf);
            }
            if k > a {
                let h = run.t[k] - run.t[k - 1];
                for (m, (p, x)) in mean.iter_mut().zip(prev.iter().zip(&buf)) {
                    *m += 0.5 * (p + x) * h;
                }
            }
            std::mem::swap(&mut prev, &mut buf);
        }
        let len = (run.t[b] - run.t[a]).max(1e-12);
        x.extend(mean.iter().map(|m| m / len));
    }
    (x, width)
}
