//! The left-out effects the diagnosis can name, one file each (docs/formats.md, "Left-out
//! effects"). An effect is a [`Hypothesis`]: its parameters with physical bounds and units, the
//! force it adds to the model (a [`Term`]), what a run must have for it to be testable, the
//! regime where it shows and the quantity its evidence is plotted against.
//!
//! Adding an effect is one new file with a `pub static EFFECT: Hypothesis` and one line in
//! [`REGISTRY`]. These are the diagnosis's models; the twin conceals effects with code of its
//! own (`crate::twin::world`), so that finding them on twin data is not reading back one's own
//! implementation.

mod coupled_drag;
mod net_buoyancy;
mod reverse_thrust_loss;
mod sensor_delay;
mod tether_drag;
mod thruster_deadband;
mod thruster_lag;
mod wall_effect;
mod water_current;

pub use thruster_lag::{alike_in_words, law_in_words};

use super::Run;
use crate::core::dof::Dof;
pub use crate::core::model::motion::State;
use crate::core::model::{Plant, Vec6};
use crate::diagnose::SLOTS;
use std::sync::Arc;

/// A list of effects to test.
pub type Registry = &'static [&'static Hypothesis];

/// Every effect the diagnosis tests, in the order it tries them.
pub static REGISTRY: Registry = &[
    &net_buoyancy::EFFECT,
    &thruster_lag::EFFECT,
    &reverse_thrust_loss::EFFECT,
    &thruster_deadband::EFFECT,
    &tether_drag::EFFECT,
    &water_current::EFFECT,
    &wall_effect::EFFECT,
    &coupled_drag::EFFECT,
    &sensor_delay::EFFECT,
];

/// The effect of the registry called `name`.
pub fn hypothesis(name: &str) -> Option<&'static Hypothesis> {
    REGISTRY.iter().copied().find(|h| h.name == name)
}

/// One parameter of an effect and the range the search may take it over.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    pub name: &'static str,
    pub lo: f64,
    pub hi: f64,
    pub unit: &'static str,
    pub limits: Limits,
}

impl Param {
    /// The share of the range the search reads on a vehicle of `size` ([`super::Data::size`]):
    /// `size` (at most 1) for a force-like parameter (in newtons) whose range starts at 0 (a
    /// threshold, a drag coefficient), a size whose range was set for the reference vehicle;
    /// the whole range for any other. The search's grid and its bound at 0 both use it.
    pub fn share(&self, size: f64) -> f64 {
        if self.lo == 0.0 && self.is_force() {
            size.clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    /// The bounds the search takes the parameter over on a vehicle of `size`: the range as
    /// written for the reference vehicle, and on a heavier one a force-like parameter's range
    /// times `size` (a dead zone of 45 N on a 119 kg vehicle is as plausible as one of 13 N on
    /// the 35.2 kg reference). A smaller vehicle keeps the whole range (its grid reads the
    /// lower [`Param::share`] of it).
    pub fn bounds(&self, size: f64) -> (f64, f64) {
        if self.is_force() {
            let s = size.max(1.0);
            (self.lo * s, self.hi * s)
        } else {
            (self.lo, self.hi)
        }
    }

    /// A force or moment, or a coefficient of one (its unit starts with newtons).
    fn is_force(&self) -> bool {
        self.unit.starts_with('N')
    }
}

/// Which of a parameter's bounds are physics rather than the search's reach. A fit that ends on
/// a search bound wants more than the effect can give and is not a finding; one that ends on a
/// physical bound (no slack, a dead zone that offsets by all of itself) is a value like others.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limits {
    /// Both bounds are the search's.
    Search,
    /// The lower bound is physical (zero slack, no moment dead zone), the upper the search's.
    PhysicalFloor,
    /// Both bounds are physical (a fraction between none and all).
    Physical,
}

/// What every run must have for an effect to be testable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    Nothing,
    /// `tether_anchor_m` in run.yaml.
    Anchor,
    /// `pool` dimensions in run.yaml.
    Pool,
}

impl Needs {
    pub fn met_by(self, r: &Run) -> bool {
        match self {
            Needs::Nothing => true,
            Needs::Anchor => r.anchor.is_some() && has_position(r),
            Needs::Pool => r.pool.is_some() && has_position(r),
        }
    }

    /// What run `r` lacks when it does not meet the need.
    pub fn missing_in(self, r: &Run) -> &'static str {
        match self {
            Needs::Nothing => "nothing",
            Needs::Anchor if r.anchor.is_some() => NO_POSITION,
            Needs::Pool if r.pool.is_some() => NO_POSITION,
            Needs::Anchor => "tether_anchor_m in run.yaml (where the tether enters the water)",
            Needs::Pool => "pool: {length_m, width_m, depth_m} in run.yaml",
        }
    }
}

/// What a run without a position lacks, and how to give it one.
const NO_POSITION: &str = "a horizontal position at every sample: UWB or an imaging sonar, or start_m [x, y] in run.yaml (where the run started) to dead-reckon one from the navigation log's velocity and heading";

/// Whether the run's fused horizontal position is known (finite) at every sample: an effect
/// that reads the position is never scored on a made-up one.
pub(crate) fn has_position(r: &Run) -> bool {
    !r.pos[0].is_empty()
        && r.pos[0].len() == r.t.len()
        && r.pos[..2].iter().all(|p| p.iter().all(|x| x.is_finite()))
}

/// The quantity an effect's evidence is plotted against, per run, sample and DOF (index into
/// the run's slots), with its axis label for that DOF.
pub struct Axis {
    pub label: fn(Dof) -> String,
    pub value: fn(&Run, usize, usize) -> f64,
}

/// The axis of effects that act after command steps (a lag, a delay).
pub const SINCE_STEP: Axis = Axis {
    label: |_| "time since the last command step (s)".into(),
    value: |r, k, _| since_step(r, k),
};

/// The axis of effects that depend on the command's size or sign in the DOF.
pub const COMMAND: Axis = Axis {
    label: |d| format!("command in {d} ({})", d.force_unit()),
    value: |r, k, j| r.cmd[k][j],
};

/// An effect as a hypothesis of the diagnosis.
pub struct Hypothesis {
    pub name: &'static str,
    pub params: &'static [Param],
    pub needs: Needs,
    /// The effect at parameter values `p` (one per [`Param`]).
    pub build: fn(&[f64]) -> Arc<dyn Term>,
    /// The DOF it acts on first (for its evidence plot).
    pub main_dof: Dof,
    /// The DOFs its force acts in; empty: every DOF the command drives. An effect that acts in
    /// none of the DOFs the model is compared in is listed untested.
    pub acts_in: &'static [Dof],
    /// The regime its evidence quotes (a name in `REGIMES`).
    pub regime: &'static str,
    pub axis: Axis,
}

impl Hypothesis {
    /// How many of the parameters `p` count against the effect: one at its physical floor (no
    /// filter, no slack, no dead zone) leaves the simpler effect, and is not counted.
    pub fn free_params(&self, p: &[f64]) -> f64 {
        let at_floor = |q: &Param, v: f64| {
            q.limits == Limits::PhysicalFloor && v - q.lo <= 0.01 * (q.hi - q.lo)
        };
        (self.params.iter().zip(p))
            .filter(|(q, v)| !at_floor(q, **v))
            .count() as f64
    }
}

/// What an effect's force may read besides the velocity: the base plant, and the heading and
/// the run's geometry at the pose held over one integration step.
pub struct Env<'a> {
    pub plant: &'a Plant,
    /// cos and sin of the heading.
    pub cos_psi: f64,
    pub sin_psi: f64,
    /// Straight-line distance from the tether's anchor, m (`None`: the run has no anchor).
    pub tether_length: Option<f64>,
    /// Distance to the nearest side wall, m, negative outside the pool (`None`: no pool size).
    pub wall_distance: Option<f64>,
}

impl Env<'_> {
    /// A pool-frame horizontal force in the body frame.
    pub fn to_body(&self, fx: f64, fy: f64) -> (f64, f64) {
        let (c, sn) = (self.cos_psi, self.sin_psi);
        (c * fx + sn * fy, -sn * fx + c * fy)
    }
}

/// Adds a quadratic drag `-k |v| v` on the horizontal velocity over ground v (surge and sway).
/// The pool-frame force turned into the body frame is the same drag on the body-frame velocity,
/// so no heading is needed.
pub fn add_horizontal_drag(k: f64, s: &State, f: &mut Vec6) {
    let speed = (s.nu[0] * s.nu[0] + s.nu[1] * s.nu[1]).sqrt();
    f[0] -= k * speed * s.nu[0];
    f[1] -= k * speed * s.nu[1];
}

/// A first-order lag of what drives the thrust: the lag's state is `sign(F) |F|^(1/exponent)`
/// for a force F, and delivers `sign(x) |x|^exponent` (exponent 1: the force itself lags; 2: a
/// propeller's speed lags, its thrust going with the speed's square).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lag {
    pub time_constant_s: f64,
    pub exponent: f64,
}

impl Lag {
    /// The lag's state that delivers the force `f`.
    pub fn state_of(&self, f: f64) -> f64 {
        let n = self.exponent;
        if n == 1.0 || f == 0.0 {
            f
        } else if n == 2.0 {
            f.signum() * f.abs().sqrt()
        } else {
            f.signum() * f.abs().powf(1.0 / n)
        }
    }

    /// The force the lag's state `x` delivers.
    pub fn force_of(&self, x: f64) -> f64 {
        let n = self.exponent;
        if n == 1.0 || x == 0.0 {
            x
        } else if n == 2.0 {
            x * x.abs()
        } else {
            x.signum() * x.abs().powf(n)
        }
    }
}

/// An effect at its parameter values, as the simulator applies it. Every hook defaults to
/// "does nothing", so an effect implements only the ones it acts through.
pub trait Term: std::fmt::Debug + Send + Sync {
    /// Changes the command into what the thrusters deliver in steady state.
    fn shape_command(&self, _cmd: &mut Vec6) {}
    /// A first-order lag between the command and the delivered force.
    fn lag(&self) -> Option<Lag> {
        None
    }
    /// Adds the effect's generalised force (body frame) at state `s`.
    fn add_force(&self, _env: &Env, _s: &State, _f: &mut Vec6) {}
    /// Whether [`Term::add_force`] reads the position or heading.
    fn needs_pose(&self) -> bool {
        false
    }
    /// Time by which the recording lags the command log, s (a sensor effect, not a force).
    fn delay_s(&self) -> f64 {
        0.0
    }
    /// Time constant of a first-order low-pass through which the recording sees the vehicle,
    /// s (a sensor effect, not a force).
    fn sensor_filter_s(&self) -> f64 {
        0.0
    }
    /// False for an effect that changes only how the recording is read (a sensor delay).
    fn acts_on_plant(&self) -> bool {
        true
    }
}

/// Time since the last step of any command (a change over 15 % of its largest), s.
pub fn since_step(r: &Run, k: usize) -> f64 {
    let scale: [f64; SLOTS] =
        std::array::from_fn(|q| r.cmd.iter().fold(1e-9f64, |a, c| a.max(c[q].abs())));
    let mut i = k;
    while i > 0 {
        if (0..SLOTS).any(|q| (r.cmd[i][q] - r.cmd[i - 1][q]).abs() > 0.15 * scale[q]) {
            return r.t[k] - r.t[i];
        }
        i -= 1;
    }
    r.t[k] - r.t[0]
}

/// Linear plus quadratic drag of the base plant in DOF `i` at velocity `x`.
pub fn drag(p: &Plant, i: usize, x: f64) -> f64 {
    p.diagonal_drag(i, x)
}
