//! The library of candidate terms: what each reads of the recording (time, commands, pose)
//! and of the velocity, how it is written, and which named effect it is in disguise.

use super::super::{Data, Run, Slots};
use crate::core::dof::Dof;
use crate::diagnose::SLOTS;
use std::f64::consts::TAU;

/// First-order lags tried on the commands, s.
const LAGS_S: [f64; 2] = [0.3, 1.0];
/// Depth scales of the near-surface drag terms, m.
const DEPTH_SCALES_M: [f64; 2] = [0.5, 1.0];
/// Levels a DOF's command is tried clipped at, as shares of its largest over the training runs.
const CLIP_SHARES: [f64; 5] = [0.4, 0.5, 0.6, 0.7, 0.8];

/// One library term, a function of the recording (time, command, pose) and the velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feature {
    Constant,
    Velocity(usize),
    /// |x| x.
    Quadratic(usize),
    /// |x| x on one side only: ahead (x > 0) when `true`, astern (x < 0) when `false` (a hull
    /// bluffer at one end).
    OneSided(usize, bool),
    /// x_a x_b (x_a^2 when a = b: a force that goes with a speed squared whichever way the
    /// vehicle moves, a trimmed hull's lift; with a != b the Munk moment's form).
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
    /// The heading, continuous over the run (turns counted), rad: a moment that grows with
    /// the turns made (a tether twisting).
    Heading,
    /// A command times the run's clock: a thrust that fades or grows over the run (a battery
    /// draining, `X += c t X`).
    CommandTime(usize),
    /// sin and cos of 2 pi f t (two columns: amplitude and phase).
    Sine(f64),
    /// clip(X, +-level) - X: what thrusters that deliver at most `level` (N or N m) take off
    /// the command.
    Clip(usize, f64),
    /// |x_a| X_q: a command whose delivery changes with a speed (tunnel thrusters losing
    /// thrust in a cross flow, `Y += -c |u| Y`).
    CommandSpeed(usize, usize),
    /// The horizontal offset from the tether's anchor (from the pool frame's origin when the
    /// runs give no anchor) along the body's x axis (0) or y axis (1): a restoring pull toward
    /// the anchor, `X += -k (p - p_a)_x`.
    AnchorOffset(usize),
    /// sqrt(|X|) u: a propeller's thrust lost to the inflow along its axis, T_nu |n| u_a in
    /// Blanke's thrust model (Fossen 2011, sec. 6.7), with |n| as sqrt(|X|).
    Inflow(usize),
}

impl Feature {
    pub(super) fn columns(self) -> usize {
        if matches!(self, Feature::Sine(_)) {
            2
        } else {
            1
        }
    }

    /// The term as it is written in an expression, its indices slots of `slots`.
    pub fn label(self, slots: &Slots) -> String {
        let v = |j: usize| slots.dof(j).velocity();
        let c = |q: usize| slots.dof(q).force();
        match self {
            Feature::Constant => "1".into(),
            Feature::Velocity(j) => v(j).into(),
            Feature::Quadratic(j) => format!("|{0}| {0}", v(j)),
            Feature::OneSided(j, ahead) => {
                format!("|{0}| {0} [{0} {1} 0]", v(j), if ahead { ">" } else { "<" })
            }
            Feature::Product(a, b) if a == b => format!("{}^2", v(a)),
            Feature::Product(a, b) => format!("{} {}", v(a), v(b)),
            Feature::AbsProduct(a, b) => format!("|{}| {}", v(a), v(b)),
            Feature::Command(q) => c(q).into(),
            Feature::LagDeficit(q, tau) => format!("(lag_{tau}s({0}) - {0})", c(q)),
            Feature::CommandSign(q) => format!("sign({})", c(q)),
            Feature::CommandProduct(a, b) => format!("{} {}", c(a), c(b)),
            Feature::PoolX => "x".into(),
            Feature::PoolY => "y".into(),
            Feature::Depth => "z".into(),
            Feature::NearSurfaceDrag(j, l) => format!("|{0}| {0} exp(-z/{l} m)", v(j)),
            Feature::WallDistance => "d_wall".into(),
            Feature::TetherLength => "L_tether".into(),
            Feature::CosHeading => "cos(psi)".into(),
            Feature::SinHeading => "sin(psi)".into(),
            Feature::Heading => "psi".into(),
            Feature::CommandTime(q) => format!("t {}", c(q)),
            Feature::Sine(f) => format!("sin(2 pi {f:.3} t + phase)"),
            Feature::Clip(q, level) => format!("(clip({0}, +-{level:.3}) - {0})", c(q)),
            Feature::Inflow(q) => format!("sqrt(|{}|) {}", c(q), v(q)),
            Feature::CommandSpeed(q, a) => format!("|{}| {}", v(a), c(q)),
            Feature::AnchorOffset(axis) => format!("(p - p_a)_{}", ["x", "y"][axis.min(1)]),
        }
    }

    /// The named effect this term is, for the slot `j` of `slots` it acts in, if it is one in
    /// disguise (docs/formats.md's names: `coupled_drag` is any off-diagonal drag term).
    pub(super) fn named(self, slots: &Slots, j: usize) -> Option<&'static str> {
        let horizontal = |q: usize| matches!(slots.dof(q), Dof::Surge | Dof::Sway);
        match self {
            Feature::Constant if slots.dof(j) == Dof::Heave => Some("net_buoyancy"),
            Feature::LagDeficit(q, _) if q == j => Some("thruster_lag"),
            Feature::CommandSign(q) if q == j => Some("thruster_deadband"),
            // The signed product u v is the Munk moment's form (added mass, not drag).
            Feature::AbsProduct(a, b) if horizontal(a) && horizontal(b) && a != b => {
                Some("coupled_drag")
            }
            // Off-diagonal drag (docs/formats.md): a quadratic drag of another DOF's motion
            // (`N += c |v| v`, `M += c |r| r`), or this DOF's drag scaled by another's speed.
            Feature::Quadratic(a) if a != j => Some("coupled_drag"),
            Feature::AbsProduct(a, b) if b == j && a != b => Some("coupled_drag"),
            Feature::CosHeading | Feature::SinHeading => Some("water_current"),
            Feature::WallDistance => Some("wall_effect"),
            Feature::TetherLength => Some("tether_drag"),
            _ => None,
        }
    }

    /// Column values at sample `k` of `run` with velocity `vel` (per slot).
    pub(super) fn eval(
        self,
        run: &Run,
        pre: &Prepared,
        k: usize,
        vel: &[f64; SLOTS],
        out: &mut Vec<f64>,
    ) {
        let cmd = run.cmd[k];
        let x = match self {
            Feature::Constant => 1.0,
            Feature::Velocity(j) => vel[j],
            Feature::Quadratic(j) => vel[j].abs() * vel[j],
            Feature::OneSided(j, ahead) if (vel[j] > 0.0) == ahead => vel[j].abs() * vel[j],
            Feature::OneSided(..) => 0.0,
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
            Feature::Heading => pre.heading[k],
            Feature::CommandTime(q) => run.t[k] * cmd[q],
            Feature::Clip(q, level) => cmd[q].clamp(-level, level) - cmd[q],
            Feature::Inflow(q) => cmd[q].abs().sqrt() * vel[q],
            Feature::CommandSpeed(q, a) => vel[a].abs() * cmd[q],
            Feature::AnchorOffset(axis) => {
                let a = run.anchor.unwrap_or([0.0; 3]);
                let (dx, dy) = (run.pos[0][k] - a[0], run.pos[1][k] - a[1]);
                let (s, c) = run.psi[k].sin_cos();
                if axis == 0 {
                    c * dx + s * dy
                } else {
                    -s * dx + c * dy
                }
            }
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

/// What a run's features need besides the sample: its commands through each lag, and its
/// heading made continuous.
#[derive(Debug, Clone)]
pub struct Prepared {
    lagged: Vec<Vec<[f64; SLOTS]>>,
    heading: Vec<f64>,
}

pub(super) fn prepare(run: &Run) -> Prepared {
    let lagged = LAGS_S
        .iter()
        .map(|&tau| {
            let mut y = run.cmd.first().copied().unwrap_or([0.0; SLOTS]);
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
    Prepared {
        lagged,
        heading: crate::pool::fusion::unwrap_angles(&run.psi),
    }
}

/// The library for DOF `j`, with the sines at `peaks` (Hz).
pub(super) fn library(j: usize, peaks: &[f64], data: &Data) -> Vec<Feature> {
    let mut f = vec![Feature::Constant];
    // Velocities of the DOFs the model moves in (a slot it leaves out is at rest).
    let on: Vec<usize> = data.slots.on().collect();
    for &a in &on {
        f.push(Feature::Velocity(a));
        f.push(Feature::Quadratic(a));
    }
    for &a in &on {
        for &b in &on {
            if a <= b {
                f.push(Feature::Product(a, b));
            }
            if a != b {
                f.push(Feature::AbsProduct(a, b));
            }
        }
    }
    // The commands of the slots the model moves in (the others are zero in the runs).
    for &q in &on {
        f.push(Feature::Command(q));
        for tau in LAGS_S {
            f.push(Feature::LagDeficit(q, tau));
        }
        for &b in on.iter().filter(|&&b| b > q) {
            f.push(Feature::CommandProduct(q, b));
        }
    }
    f.push(Feature::CommandSign(j));
    f.push(Feature::CommandTime(j));
    if on.contains(&j) {
        f.extend([Feature::OneSided(j, true), Feature::OneSided(j, false)]);
        f.push(Feature::Inflow(j));
        f.extend(on.iter().map(|&a| Feature::CommandSpeed(j, a)));
        f.extend(clips(j, data));
    }
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
    if matches!(data.slots.dof(j), Dof::Surge | Dof::Sway) {
        f.extend([Feature::AnchorOffset(0), Feature::AnchorOffset(1)]);
    }
    if data.slots.dof(j) == Dof::Yaw {
        f.push(Feature::Heading);
    }
    f.extend(peaks.iter().map(|&p| Feature::Sine(p)));
    f
}

/// Clipped commands of slot `j` at [`CLIP_SHARES`] of its largest over the training runs
/// (none for a DOF never commanded).
fn clips(j: usize, data: &Data) -> Vec<Feature> {
    let top = (data.train.iter())
        .flat_map(|r| r.cmd.iter().map(|c| c[j].abs()))
        .fold(0.0, f64::max);
    if top <= 0.0 {
        return Vec::new();
    }
    CLIP_SHARES
        .iter()
        .map(|s| Feature::Clip(j, three_figures(s * top)))
        .collect()
}

/// `x` (positive) rounded to three significant figures: a clip level reads as it is written.
pub(super) fn three_figures(x: f64) -> f64 {
    let scale = 10f64.powi(2 - x.log10().floor() as i32);
    (x * scale).round() / scale
}
