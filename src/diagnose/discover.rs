//! Discovery beyond the vocabulary: when a structured residual remains after the named effects,
//! propose its closed form (sparse regression over a library of physically readable terms, in
//! the spirit of SINDy and its discrepancy-modelling variants) and keep it only if it holds up.
//!
//! 1. **The residual generalised force** on the training runs: the model's equation error on
//!    the fused state, `M (a_measured - a_model)`, per DOF, with the named effects already kept
//!    inside the model, in integrated form (seed 000's idea): over windows of `WINDOW_S`, the
//!    measured velocity change against the model's acceleration integrated at the measured
//!    state, and every library term averaged over the same window. No noisy velocity is
//!    differentiated, and no smoothing shifts one side against the other. Each row is
//!    weighted by its uncertainty from the fusion (the fused velocities' variances at the
//!    window's ends, through the difference quotient and the mass).
//! 2. **A library** for the DOF: velocities, `|x| x` and cross products, the commands, each
//!    command's first-order lag deficit (`lowpass(X) - X`), the own command's sign, products of
//!    commands across DOFs, pool-frame position, depth and depth-shaped drag, distance to the
//!    nearest wall, tether length, heading (sin, cos: a current) and a constant, and a sine
//!    pair (amplitude and phase) at each frequency where the residual's pooled periodogram has
//!    a significant peak (over `PEAK_RATIO` times its median).
//! 3. **Sparse selection that holds up**: forward stepwise least squares (a term enters only if
//!    it lowers the residual's sum of squares by `MIN_DROP` of what is left; at most
//!    `MAX_TERMS`), repeated on `RESAMPLES` block-bootstrap resamples of the training runs and
//!    on each training run alone. A term is kept only if selected on `KEEP_SHARE` of the
//!    resamples and on most of the runs where it varies. Coefficients carry the resamples' 95 %
//!    interval.
//! 4. **Proof on held-out runs**: the term is added to the simulator as a force and must lower
//!    the held-out error cost by the margin a named effect must (`Criteria`), or nothing is
//!    reported.
//! 5. **Names where they fit**: a constant heave force is `net_buoyancy`, a command's lag
//!    deficit `thruster_lag`, a `|u| v` cross term `coupled_drag`, heading terms
//!    `water_current`, the command's sign `thruster_deadband`, the wall distance `wall_effect`,
//!    the tether length `tether_drag`; anything else stays `unexplained`, with its expression.

use super::effects::State;
use super::result::Figure;
use super::{Augmentation, Criteria, DOFS, Data, NU, Run};
use crate::dof::Dof;
use crate::model::{Plant, Vec6};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::sync::Arc;

/// The most terms a discovered closed form has (a sine with its phase counts as one).
pub const MAX_TERMS: usize = 2;
/// A term enters the stepwise fit only if it removes this share of the residual left.
const MIN_DROP: f64 = 0.05;
/// Block-bootstrap resamples of the training runs, and the block length, s.
const RESAMPLES: usize = 40;
const BLOCK_S: f64 = 10.0;
/// Share of the resamples that must select a term for it to be kept.
pub const KEEP_SHARE: f64 = 0.7;
/// Sampling of the regression, s (the residual is smooth at this scale).
const EVERY_S: f64 = 0.1;
/// A periodogram peak is significant at this multiple of the periodogram's median.
const PEAK_RATIO: f64 = 25.0;
/// Frequencies searched for peaks, Hz.
const F_MIN: f64 = 0.05;
const F_MAX: f64 = 2.0;
/// First-order lags tried on the commands, s.
const LAGS_S: [f64; 2] = [0.3, 1.0];
/// Depth scales of the near-surface drag terms, m.
const DEPTH_SCALES_M: [f64; 2] = [0.5, 1.0];

/// One library term, a function of the recording (time, command, pose) and the velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feature {
    Constant,
    Velocity(usize),
    /// |x| x.
    Quadratic(usize),
    /// x_a x_b.
    Product(usize, usize),
    /// |x_a| x_b.
    AbsProduct(usize, usize),
    Command(usize),
    /// lowpass_tau(X) - X: what a first-order lag with this time constant takes off.
    LagDeficit(usize, f64),
    CommandSign(usize),
    CommandProduct(usize, usize),
    PoolX,
    PoolY,
    Depth,
    /// |x| x exp(-depth / scale).
    NearSurfaceDrag(usize, f64),
    WallDistance,
    TetherLength,
    CosHeading,
    SinHeading,
    /// sin and cos of 2 pi f t (two columns: amplitude and phase).
    Sine(f64),
}

const V: [&str; 4] = ["u", "v", "w", "r"];
const C: [&str; 4] = ["X", "Y", "Z", "N"];

impl Feature {
    fn columns(self) -> usize {
        if matches!(self, Feature::Sine(_)) {
            2
        } else {
            1
        }
    }

    /// The term as it is written in an expression.
    pub fn label(self) -> String {
        match self {
            Feature::Constant => "1".into(),
            Feature::Velocity(j) => V[j].into(),
            Feature::Quadratic(j) => format!("|{0}| {0}", V[j]),
            Feature::Product(a, b) => format!("{} {}", V[a], V[b]),
            Feature::AbsProduct(a, b) => format!("|{}| {}", V[a], V[b]),
            Feature::Command(q) => C[q].into(),
            Feature::LagDeficit(q, tau) => format!("(lag_{tau}s({0}) - {0})", C[q]),
            Feature::CommandSign(q) => format!("sign({})", C[q]),
            Feature::CommandProduct(a, b) => format!("{} {}", C[a], C[b]),
            Feature::PoolX => "x".into(),
            Feature::PoolY => "y".into(),
            Feature::Depth => "z".into(),
            Feature::NearSurfaceDrag(j, l) => format!("|{0}| {0} exp(-z/{l} m)", V[j]),
            Feature::WallDistance => "d_wall".into(),
            Feature::TetherLength => "L_tether".into(),
            Feature::CosHeading => "cos(psi)".into(),
            Feature::SinHeading => "sin(psi)".into(),
            Feature::Sine(f) => format!("sin(2 pi {f:.3} t + phase)"),
        }
    }

    /// The named effect this term is, for the DOF `j` it acts in, if it is one in disguise.
    fn named(self, j: usize) -> Option<&'static str> {
        match self {
            Feature::Constant if j == 2 => Some("net_buoyancy"),
            Feature::LagDeficit(q, _) if q == j => Some("thruster_lag"),
            Feature::CommandSign(q) if q == j => Some("thruster_deadband"),
            Feature::AbsProduct(a, b) | Feature::Product(a, b) if a < 2 && b < 2 && a != b => {
                Some("coupled_drag")
            }
            Feature::CosHeading | Feature::SinHeading => Some("water_current"),
            Feature::WallDistance => Some("wall_effect"),
            Feature::TetherLength => Some("tether_drag"),
            _ => None,
        }
    }

    /// Column values at sample `k` of `run` with velocity `vel` [u, v, w, r].
    fn eval(self, run: &Run, pre: &Prepared, k: usize, vel: &[f64; 4], out: &mut Vec<f64>) {
        let cmd = run.cmd[k];
        let x = match self {
            Feature::Constant => 1.0,
            Feature::Velocity(j) => vel[j],
            Feature::Quadratic(j) => vel[j].abs() * vel[j],
            Feature::Product(a, b) => vel[a] * vel[b],
            Feature::AbsProduct(a, b) => vel[a].abs() * vel[b],
            Feature::Command(q) => cmd[q],
            Feature::LagDeficit(q, tau) => {
                let i = LAGS_S.iter().position(|l| *l == tau).unwrap_or(0);
                pre.lagged[i][k][q] - cmd[q]
            }
            Feature::CommandSign(q) => {
                if cmd[q].abs() < 1e-9 {
                    0.0
                } else {
                    cmd[q].signum()
                }
            }
            Feature::CommandProduct(a, b) => cmd[a] * cmd[b],
            Feature::PoolX => run.pos[0][k],
            Feature::PoolY => run.pos[1][k],
            Feature::Depth => run.pos[2][k],
            Feature::NearSurfaceDrag(j, l) => {
                vel[j].abs() * vel[j] * (-run.pos[2][k].max(0.0) / l).exp()
            }
            Feature::WallDistance => run.wall_distance(k).unwrap_or(0.0),
            Feature::TetherLength => run.tether_length(k).unwrap_or(0.0),
            Feature::CosHeading => run.psi[k].cos(),
            Feature::SinHeading => run.psi[k].sin(),
            Feature::Sine(f) => {
                // On the logs' own clock (a run trimmed to its logs' overlap keeps it).
                let (s, c) = (TAU * f * run.t[k]).sin_cos();
                out.push(s);
                out.push(c);
                return;
            }
        };
        out.push(x);
    }
}

/// What a run's features need besides the sample: its commands through each lag.
#[derive(Debug, Clone)]
pub struct Prepared {
    lagged: Vec<Vec<[f64; 4]>>,
}

fn prepare(run: &Run) -> Prepared {
    let lagged = LAGS_S
        .iter()
        .map(|&tau| {
            let mut y = run.cmd.first().copied().unwrap_or([0.0; 4]);
            let mut out = Vec::with_capacity(run.t.len());
            for k in 0..run.t.len() {
                if k > 0 {
                    let a = 1.0 - (-(run.t[k] - run.t[k - 1]) / tau).exp();
                    for (yq, cq) in y.iter_mut().zip(run.cmd[k - 1]) {
                        *yq += a * (cq - *yq);
                    }
                }
                out.push(y);
            }
            out
        })
        .collect();
    Prepared { lagged }
}

/// The library for DOF `j`, with the sines at `peaks` (Hz).
fn library(j: usize, peaks: &[f64], data: &Data) -> Vec<Feature> {
    let mut f = vec![Feature::Constant];
    for a in 0..4 {
        f.push(Feature::Velocity(a));
        f.push(Feature::Quadratic(a));
    }
    for a in 0..4 {
        for b in 0..4 {
            if a < b {
                f.push(Feature::Product(a, b));
            }
            if a != b {
                f.push(Feature::AbsProduct(a, b));
            }
        }
    }
    for q in 0..4 {
        f.push(Feature::Command(q));
        for tau in LAGS_S {
            f.push(Feature::LagDeficit(q, tau));
        }
        for b in q + 1..4 {
            f.push(Feature::CommandProduct(q, b));
        }
    }
    f.push(Feature::CommandSign(j));
    f.extend([Feature::PoolX, Feature::PoolY, Feature::Depth]);
    for l in DEPTH_SCALES_M {
        f.push(Feature::NearSurfaceDrag(j, l));
    }
    if data.train.iter().all(|r| r.pool.is_some()) {
        f.push(Feature::WallDistance);
    }
    if data.train.iter().all(|r| r.anchor.is_some()) {
        f.push(Feature::TetherLength);
    }
    f.extend([Feature::CosHeading, Feature::SinHeading]);
    f.extend(peaks.iter().map(|&p| Feature::Sine(p)));
    f
}

/// A discovered term: its DOF, the features kept and their coefficients (per column).
#[derive(Debug, Clone)]
pub struct Discovered {
    pub dof: usize,
    pub features: Vec<Feature>,
    pub coef: Vec<f64>,
}

impl Discovered {
    pub fn prepare(&self, run: &Run) -> Prepared {
        prepare(run)
    }

    /// The term's generalised force at sample `k` of `run`, with the model's state `s`.
    pub fn force(&self, run: &Run, pre: &Prepared, k: usize, s: &State) -> Vec6 {
        let vel = [s.nu[0], s.nu[1], s.nu[2], s.nu[5]];
        let mut cols = Vec::with_capacity(self.coef.len());
        for f in &self.features {
            f.eval(run, pre, k, &vel, &mut cols);
        }
        let mut out = [0.0; 6];
        out[NU[self.dof]] = cols.iter().zip(&self.coef).map(|(x, c)| x * c).sum();
        out
    }
}

/// One kept term of a discovered closed form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscoveredTerm {
    pub term: String,
    /// Coefficient (for a sine: its amplitude), in the DOF's force unit per unit of the term.
    pub coefficient: f64,
    /// 95 % interval over the bootstrap resamples.
    pub interval: [f64; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequency_hz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_rad: Option<f64>,
    /// Share of the resamples that selected it.
    pub selected_share: f64,
    /// Training runs that selected it alone, of those where it varies.
    pub runs_selected: [usize; 2],
}

/// The closed form proposed for what the named effects leave, proven on held-out runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub dof: Dof,
    /// e.g. `Z += 11.8 sin(2 pi 0.420 t + 0.30) N`.
    pub expression: String,
    pub terms: Vec<DiscoveredTerm>,
    /// The named effect it is in disguise, if it is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub named_as: Option<String>,
    /// Terms in the library it was chosen from.
    pub library_terms: usize,
    /// Significant peaks of the residual's spectrum, Hz.
    pub spectrum_peaks_hz: Vec<f64>,
    pub validation_nmae_before: BTreeMap<Dof, f64>,
    pub validation_nmae_after: BTreeMap<Dof, f64>,
    pub validation_cost_before: f64,
    pub validation_cost_after: f64,
}

/// The residual force of the training runs at the regression's rows. Each row is a window of
/// `WINDOW_S`: the measured velocity change over it against the model's acceleration
/// integrated over it (so no derivative of a noisy velocity is taken, and smoothing cannot
/// shift the measured acceleration against the model's: both sides see the same window, as
/// the library's terms do, averaged over it).
struct Rows {
    /// (run index, first sample, last sample) of each row's window.
    at: Vec<(usize, usize, usize)>,
    /// Residual force per DOF, averaged over the window.
    y: [Vec<f64>; 4],
    /// Its standard deviation from the fusion: the fused velocities' at the window's ends,
    /// through the difference quotient and the mass.
    sigma: [Vec<f64>; 4],
}

/// Length of a row's window, s.
const WINDOW_S: f64 = 0.6;

/// Trapezoidal mean of `f(k)` over samples `a..=b` of `t`.
fn window_mean(t: &[f64], a: usize, b: usize, mut f: impl FnMut(usize) -> f64) -> f64 {
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
fn residual_rows(plant: &Plant, aug: &Augmentation, data: &Data) -> Rows {
    let (mass, _) = plant.mass_matrix();
    let mut rows = Rows {
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
        let w = super::world_for(plant, aug, run);
        let mut s = State {
            thrust: w.shape_command(&cmd6(run, 0)),
            ..State::default()
        };
        let mut model: Vec<Vec6> = Vec::with_capacity(n);
        for k in 0..n {
            let c = cmd6(run, k);
            for (j, &i) in NU.iter().enumerate() {
                s.nu[i] = run.vel[j][k];
            }
            s.pos = [run.pos[0][k], run.pos[1][k], run.pos[2][k]];
            s.psi = run.psi[k];
            model.push(w.accel(&s, &c));
            if k + 1 < n {
                s.thrust = w.step(&s, &c, run.t[k + 1] - run.t[k]).thrust;
            }
        }
        let mut a = every;
        while a + span < n.saturating_sub(every) {
            let b = a + span;
            let dv: Vec6 = std::array::from_fn(|i| {
                let model_mean = window_mean(&run.t, a, b, |k| model[k][i]);
                match NU.iter().position(|&q| q == i) {
                    Some(j) => (run.vel[j][b] - run.vel[j][a]) / (run.t[b] - run.t[a]) - model_mean,
                    None => 0.0,
                }
            });
            for (j, &i) in NU.iter().enumerate() {
                rows.y[j].push((0..6).map(|q| mass[i][q] * dv[q]).sum());
                let sd = run.std[j][a].hypot(run.std[j][b]) / (run.t[b] - run.t[a]);
                rows.sigma[j].push(mass[i][i].abs() * sd);
            }
            rows.at.push((ri, a, b));
            a += every;
        }
    }
    rows
}

fn cmd6(run: &Run, k: usize) -> Vec6 {
    let c = run.cmd[k];
    [c[0], c[1], c[2], 0.0, 0.0, c[3]]
}

fn run_t(data: &Data, ri: usize, k: usize) -> f64 {
    data.train[ri].t[k]
}

/// Pooled periodogram of one DOF's residual over the training runs at frequencies `f`.
fn periodogram(data: &Data, rows: &Rows, j: usize, f: &[f64]) -> Vec<f64> {
    let mut p = vec![0.0; f.len()];
    let mut start = 0;
    while start < rows.at.len() {
        let ri = rows.at[start].0;
        let end = start + rows.at[start..].iter().take_while(|a| a.0 == ri).count();
        let centre = |q: usize| {
            let (_, a, b) = rows.at[q];
            0.5 * (run_t(data, ri, a) + run_t(data, ri, b))
        };
        let y = &rows.y[j][start..end];
        let mean = y.iter().sum::<f64>() / y.len().max(1) as f64;
        let times: Vec<f64> = (start..end).map(centre).collect();
        for (pi, &fi) in f.iter().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (yq, tq) in y.iter().zip(&times) {
                let (s, c) = (TAU * fi * tq).sin_cos();
                re += (yq - mean) * c;
                im += (yq - mean) * s;
            }
            p[pi] += (re * re + im * im) / (end - start) as f64;
        }
        start = end;
    }
    p
}

/// The significant peaks of the residual's pooled periodogram (at most two, refined), and
/// the periodogram itself for the figure.
fn peaks(data: &Data, rows: &Rows, j: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
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
    let p = periodogram(data, rows, j, &grid);
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
                let pc = periodogram(data, rows, j, &[c])[0];
                let pd = periodogram(data, rows, j, &[d])[0];
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
fn design(data: &Data, pre: &[Prepared], rows: &Rows, features: &[Feature]) -> (Vec<f64>, usize) {
    let width: usize = features.iter().map(|f| f.columns()).sum();
    let mut x = Vec::with_capacity(rows.at.len() * width);
    let mut buf = Vec::with_capacity(width);
    let mut mean = vec![0.0; width];
    for &(ri, a, b) in &rows.at {
        let run = &data.train[ri];
        mean.iter_mut().for_each(|m| *m = 0.0);
        let mut prev: Option<Vec<f64>> = None;
        for k in a..=b {
            buf.clear();
            let vel = [run.vel[0][k], run.vel[1][k], run.vel[2][k], run.vel[3][k]];
            for f in features {
                f.eval(run, &pre[ri], k, &vel, &mut buf);
            }
            if let Some(p) = &prev {
                let h = run.t[k] - run.t[k - 1];
                for c in 0..width {
                    mean[c] += 0.5 * (p[c] + buf[c]) * h;
                }
            }
            prev = Some(buf.clone());
        }
        let len = (run.t[b] - run.t[a]).max(1e-12);
        x.extend(mean.iter().map(|m| m / len));
    }
    (x, width)
}

/// Least squares of `y` on the columns `cols` of `x` over the rows `idx`; coefficients and RSS.
fn lstsq(x: &[f64], width: usize, y: &[f64], idx: &[usize], cols: &[usize]) -> (Vec<f64>, f64) {
    let p = cols.len();
    if p == 0 {
        return (Vec::new(), idx.iter().map(|&i| y[i] * y[i]).sum());
    }
    let a = nalgebra::DMatrix::from_fn(idx.len(), p, |r, c| x[idx[r] * width + cols[c]]);
    let b = nalgebra::DVector::from_fn(idx.len(), |r, _| y[idx[r]]);
    let Some(svd) = crate::numerics::svd(a.clone(), true, true) else {
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
fn resample(rows: &Rows, rng: &mut crate::rng::Rng) -> Vec<usize> {
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
struct Proposal {
    dof: usize,
    /// The kept terms and each non-empty subset of them, refitted.
    variants: Vec<Variant>,
    library_terms: usize,
    peaks: Vec<f64>,
    spectrum: (Vec<f64>, Vec<f64>),
}

/// One closed form: its terms, their coefficients (per column) and what the report says.
#[derive(Clone)]
struct Variant {
    features: Vec<Feature>,
    coef: Vec<f64>,
    terms: Vec<DiscoveredTerm>,
}

/// Sparse, stability-selected regression of DOF `j`'s residual on its library.
fn propose(data: &Data, pre: &[Prepared], rows: &Rows, j: usize) -> Option<Proposal> {
    let (peaks_hz, grid, spectrum) = peaks(data, rows, j);
    let features = library(j, &peaks_hz, data);
    let (x, width) = design(data, pre, rows, &features);
    let n = rows.at.len();
    // Weighted by the fusion's uncertainty (1 / sigma^2, normalised to a mean of 1; a sigma
    // below a tenth of the median is taken as that, so no row decides alone).
    let mut sorted: Vec<f64> = rows.sigma[j]
        .iter()
        .copied()
        .filter(|s| s.is_finite())
        .collect();
    sorted.sort_by(f64::total_cmp);
    let floor = 0.1
        * sorted
            .get(sorted.len() / 2)
            .copied()
            .unwrap_or(1.0)
            .max(1e-300);
    let w: Vec<f64> = rows.sigma[j]
        .iter()
        .map(|s| {
            if s.is_finite() {
                s.max(floor).powi(-2)
            } else {
                floor.powi(-2)
            }
        })
        .collect();
    let mean_w = w.iter().sum::<f64>() / n.max(1) as f64;
    let sw: Vec<f64> = w.iter().map(|x| (x / mean_w).sqrt()).collect();
    let x: Vec<f64> = (0..n * width).map(|i| x[i] * sw[i / width]).collect();
    let yw: Vec<f64> = rows.y[j].iter().zip(&sw).map(|(a, b)| a * b).collect();
    let y = &yw;
    // Columns scaled to unit RMS (the threshold is then the same for every term).
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
    for f in &features {
        groups.push((c0..c0 + f.columns()).collect());
        c0 += f.columns();
    }
    let all: Vec<usize> = (0..n).collect();
    let chosen = stepwise(&xs, width, y, &all, &groups);
    if chosen.is_empty() {
        return None;
    }
    let mut rng = crate::rng::Rng::derive(17, &format!("discover/{j}"));
    let mut count = vec![0usize; groups.len()];
    let cols_of = |gs: &[usize]| -> Vec<usize> {
        gs.iter().flat_map(|&g| groups[g].iter().copied()).collect()
    };
    for _ in 0..RESAMPLES {
        if crate::interrupt::requested() {
            return None;
        }
        let idx = resample(rows, &mut rng);
        for g in stepwise(&xs, width, y, &idx, &groups) {
            count[g] += 1;
        }
    }
    // Each training run alone, for the runs where the group varies.
    let runs: Vec<Vec<usize>> = (0..data.train.len())
        .map(|ri| (0..n).filter(|&r| rows.at[r].0 == ri).collect())
        .collect();
    let varies = |g: usize, idx: &[usize]| {
        groups[g].iter().any(|&c| {
            let m = idx.iter().map(|&r| xs[r * width + c]).sum::<f64>() / idx.len().max(1) as f64;
            let v = idx
                .iter()
                .map(|&r| (xs[r * width + c] - m).powi(2))
                .sum::<f64>()
                / idx.len().max(1) as f64;
            v.sqrt() > 0.2 || matches!(features[g], Feature::Constant)
        })
    };
    let per_run: Vec<Vec<usize>> = runs
        .iter()
        .map(|idx| {
            if idx.len() < 50 {
                Vec::new()
            } else {
                stepwise(&xs, width, y, idx, &groups)
            }
        })
        .collect();
    let mut keep = Vec::new();
    let mut terms_runs = Vec::new();
    for &g in &chosen {
        let share = count[g] as f64 / RESAMPLES as f64;
        let informative: Vec<usize> = (0..runs.len())
            .filter(|&ri| runs[ri].len() >= 50 && varies(g, &runs[ri]))
            .collect();
        let selected = informative
            .iter()
            .filter(|&&ri| per_run[ri].contains(&g))
            .count();
        if share >= KEEP_SHARE && !informative.is_empty() && 2 * selected > informative.len() {
            keep.push(g);
            terms_runs.push((share, [selected, informative.len()]));
        }
    }
    if keep.is_empty() {
        return None;
    }
    // Every non-empty subset of the kept terms, refitted: the held-out runs choose among them
    // as they choose among named effects (a term stable on the training runs can still be an
    // artefact the held-out runs do not share).
    let variants = (1..1usize << keep.len())
        .map(|mask| {
            let sub: Vec<usize> = (0..keep.len()).filter(|q| mask >> q & 1 == 1).collect();
            let groups_sub: Vec<usize> = sub.iter().map(|&q| keep[q]).collect();
            let cols = cols_of(&groups_sub);
            let (coef_s, _) = lstsq(&xs, width, y, &all, &cols);
            // Back to the features' own units; intervals from the resamples refitted.
            let coef: Vec<f64> = cols
                .iter()
                .zip(&coef_s)
                .map(|(&c, b)| if scale[c] > 0.0 { b / scale[c] } else { 0.0 })
                .collect();
            let boot: Vec<Vec<f64>> = (0..RESAMPLES)
                .map(|_| lstsq(&xs, width, y, &resample(rows, &mut rng), &cols).0)
                .collect();
            let mut terms = Vec::new();
            let mut at = 0;
            for &q in &sub {
                let f = features[keep[q]];
                let (share, runs_selected) = terms_runs[q];
                let k = f.columns();
                let unscale = |v: &[f64]| -> Vec<f64> {
                    (0..k)
                        .map(|i| v[at + i] / scale[cols[at + i]].max(1e-300))
                        .collect()
                };
                let value = |v: &[f64]| -> f64 {
                    let u = unscale(v);
                    if k == 2 { u[0].hypot(u[1]) } else { u[0] }
                };
                let mut samples: Vec<f64> = boot.iter().map(|b| value(b)).collect();
                samples.sort_by(f64::total_cmp);
                let pick = |p: f64| samples[(p * (samples.len() - 1) as f64).round() as usize];
                let full = unscale(&coef_s);
                let (coefficient, frequency_hz, phase_rad) = match f {
                    // a sin + b cos = A sin(x + phase), A = hypot(a, b), phase = atan2(b, a).
                    Feature::Sine(hz) => (
                        full[0].hypot(full[1]),
                        Some(hz),
                        Some(full[1].atan2(full[0])),
                    ),
                    _ => (full[0], None, None),
                };
                terms.push(DiscoveredTerm {
                    term: f.label(),
                    coefficient,
                    interval: [pick(0.025), pick(0.975)],
                    frequency_hz,
                    phase_rad,
                    selected_share: share,
                    runs_selected,
                });
                at += k;
            }
            Variant {
                features: groups_sub.iter().map(|&g| features[g]).collect(),
                coef,
                terms,
            }
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

/// `Z += 11.8 sin(2 pi 0.420 t + 0.30) N`.
fn expression(dof: Dof, terms: &[DiscoveredTerm]) -> String {
    let sym = C[DOFS.iter().position(|d| *d == dof).unwrap_or(0)];
    let parts: Vec<String> = terms
        .iter()
        .map(|t| match (t.frequency_hz, t.phase_rad) {
            (Some(f), Some(ph)) => format!(
                "{:.3} sin(2 pi {f:.3} t {} {:.2})",
                t.coefficient,
                if ph < 0.0 { "-" } else { "+" },
                ph.abs()
            ),
            _ if t.term == "1" => format!("{:.4}", t.coefficient),
            _ => format!("{:.4} {}", t.coefficient, t.term),
        })
        .collect();
    format!(
        "{sym} += {} {}",
        parts.join(" + ").replace("+ -", "- "),
        dof.force_unit()
    )
}

/// The discovery for the DOFs `dofs` where a structured residual is left after `aug`: the
/// proven candidate, if any, and its figures.
pub fn discover(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    dofs: &[Dof],
    crit: &Criteria,
) -> anyhow::Result<Option<(Candidate, Vec<Figure>)>> {
    let rows = residual_rows(plant, aug, data);
    if rows.at.len() < 100 {
        return Ok(None);
    }
    let pre: Vec<Prepared> = data.train.iter().map(prepare).collect();
    let before = data.eval(plant, aug, true);
    let cb = before.cost(&data.scale);
    let mut best: Option<(Candidate, (Proposal, Variant), f64)> = None;
    for j in (0..4).filter(|&j| dofs.contains(&DOFS[j])) {
        let Some(p) = propose(data, &pre, &rows, j) else {
            continue;
        };
        // The variant with the lowest held-out cost after the per-parameter penalty.
        let scored: Vec<(usize, f64, super::Sums)> = p
            .variants
            .iter()
            .enumerate()
            .map(|(v, var)| {
                let mut with = aug.clone();
                with.discovered = Some(Arc::new(Discovered {
                    dof: j,
                    features: var.features.clone(),
                    coef: var.coef.clone(),
                }));
                let after = data.eval(plant, &with, true);
                let params: usize = var.features.iter().map(|f| f.columns()).sum();
                let penalised =
                    after.cost(&data.scale) + crit.gain_per_parameter * cb * params as f64;
                (v, penalised, after)
            })
            .collect();
        let Some((v, _, after)) = scored.into_iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
            continue;
        };
        let var = p.variants[v].clone();
        let ca = after.cost(&data.scale);
        let params: usize = var.features.iter().map(|f| f.columns()).sum();
        let gain = (cb - ca) / cb.max(1e-300);
        let proven = gain >= crit.min_gain + crit.gain_per_parameter * params as f64
            && cb - ca >= crit.min_noise_multiple * data.noise_cost;
        if !proven || best.as_ref().is_some_and(|b| b.2 <= ca) {
            continue;
        }
        let named: Vec<Option<&str>> = var.features.iter().map(|f| f.named(j)).collect();
        let named_as = match named.first() {
            Some(Some(n)) if named.iter().all(|x| *x == Some(n)) => Some(n.to_string()),
            _ => None,
        };
        let candidate = Candidate {
            dof: DOFS[j],
            expression: expression(DOFS[j], &var.terms),
            terms: var.terms.clone(),
            named_as,
            library_terms: p.library_terms,
            spectrum_peaks_hz: p.peaks.clone(),
            validation_nmae_before: super::nmae_map(&before),
            validation_nmae_after: super::nmae_map(&after),
            validation_cost_before: cb,
            validation_cost_after: ca,
        };
        best = Some((candidate, (p, var), ca));
    }
    let Some((candidate, (p, var), _)) = best else {
        return Ok(None);
    };
    let figures = figures(data, &rows, &pre, &candidate, &p, &var)?;
    Ok(Some((candidate, figures)))
}

/// The residual force against the discovered term's contribution on the training run where
/// it matters most, and the residual's spectrum with its peaks.
fn figures(
    data: &Data,
    rows: &Rows,
    pre: &[Prepared],
    c: &Candidate,
    p: &Proposal,
    var: &Variant,
) -> anyhow::Result<Vec<Figure>> {
    use crate::plot::lines::{Chart, Series, chart};
    let j = p.dof;
    let d = DOFS[j];
    let term = Discovered {
        dof: j,
        features: var.features.clone(),
        coef: var.coef.clone(),
    };
    // The run whose rows carry the largest share of the term's contribution.
    let contrib: Vec<f64> = rows
        .at
        .iter()
        .map(|&(ri, a, b)| {
            let run = &data.train[ri];
            window_mean(&run.t, a, b, |k| {
                let s = State {
                    nu: [
                        run.vel[0][k],
                        run.vel[1][k],
                        run.vel[2][k],
                        0.0,
                        0.0,
                        run.vel[3][k],
                    ],
                    ..State::default()
                };
                term.force(run, &pre[ri], k, &s)[NU[j]]
            })
        })
        .collect();
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
    let mut out = vec![Figure {
        caption: format!(
            "Discovery, training run {}: the {d} residual force of the model with the named effects (M times measured minus modelled acceleration; blue) and the discovered term {} (dashed).",
            run.name, c.expression
        ),
        svg,
    }];
    let (grid, power) = &p.spectrum;
    if !grid.is_empty() {
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
        out.push(Figure {
            caption: format!(
                "Discovery: the periodogram of the {d} residual force, relative to its median; the dotted line is the significance level ({PEAK_RATIO} times the median): {peaks}."
            ),
            svg,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_effects_in_disguise_are_named_and_the_rest_are_not() {
        assert_eq!(Feature::Constant.named(2), Some("net_buoyancy"));
        assert_eq!(
            Feature::Constant.named(0),
            None,
            "a body-frame constant surge force"
        );
        assert_eq!(Feature::LagDeficit(1, 0.3).named(1), Some("thruster_lag"));
        assert_eq!(
            Feature::LagDeficit(0, 0.3).named(3),
            None,
            "another DOF's lag"
        );
        assert_eq!(Feature::AbsProduct(0, 1).named(1), Some("coupled_drag"));
        assert_eq!(Feature::SinHeading.named(0), Some("water_current"));
        assert_eq!(Feature::CommandSign(3).named(3), Some("thruster_deadband"));
        for f in [
            Feature::Sine(0.42),
            Feature::Command(0),
            Feature::NearSurfaceDrag(0, 0.5),
            Feature::CommandProduct(0, 3),
        ] {
            assert_eq!(f.named(3), None, "{}", f.label());
        }
    }

    #[test]
    fn a_sine_reads_as_amplitude_and_phase() {
        let t = DiscoveredTerm {
            term: Feature::Sine(0.42).label(),
            coefficient: 11.8,
            interval: [11.0, 12.5],
            frequency_hz: Some(0.42),
            phase_rad: Some(0.3),
            selected_share: 1.0,
            runs_selected: [4, 4],
        };
        assert_eq!(
            expression(Dof::Heave, &[t]),
            "Z += 11.800 sin(2 pi 0.420 t + 0.30) N"
        );
        let x = DiscoveredTerm {
            term: "X".into(),
            coefficient: -0.06,
            interval: [-0.07, -0.05],
            frequency_hz: None,
            phase_rad: None,
            selected_share: 0.9,
            runs_selected: [3, 3],
        };
        assert_eq!(expression(Dof::Yaw, &[x]), "N += -0.0600 X N m");
    }

    #[test]
    fn a_window_mean_is_the_trapezoid_over_the_window() {
        let t: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        // The mean of t over [0, 1] is 0.5; of t^2 it is about 1/3.
        assert!((window_mean(&t, 0, 10, |k| t[k]) - 0.5).abs() < 1e-12);
        assert!((window_mean(&t, 0, 10, |k| t[k] * t[k]) - 1.0 / 3.0).abs() < 2e-3);
    }
}
