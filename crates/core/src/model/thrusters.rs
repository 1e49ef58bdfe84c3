//! The vehicle's thrusters (`vehicle.thrusters` in `pipeline.yaml`): where each one sits and
//! which way it pushes, how its command (PWM, normalised, rpm) becomes thrust through a
//! measured curve, and the allocation matrix that turns the thrusts into the body wrench
//! `tau = B f`, column i = [d_i; r_i x d_i] (Fossen 2011, eq. 11.8). Per-thruster commands are
//! turned into the wrench here, before any model sees them.

use crate::dof::Dof;
use serde::{Deserialize, Serialize};

/// `vehicle.thrusters`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Thrusters {
    /// A documented layout (positions and directions): `bluerov2`, `bluerov2_heavy`,
    /// `bluerov1_thesis`. Leave it out and list `units` for any other vehicle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
    /// The thrusters in the order of the logged commands.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub units: Vec<Thruster>,
    /// What a logged command is: `pwm` (microseconds; the default), `normalised` (-1..1),
    /// `rpm` or `newtons` (the thrust itself, as a simulator's thruster topics give it).
    #[serde(default)]
    pub command: Command,
    /// A PWM command's neutral and half range: thrust follows (pwm - neutral_us) /
    /// half_range_us (ArduSub and Blue Robotics ESCs: 1500 and 400).
    #[serde(default = "neutral_us")]
    pub neutral_us: f64,
    #[serde(default = "half_range_us")]
    pub half_range_us: f64,
    /// Thrust against the normalised command (PWM and normalised commands) or the shaft
    /// speed (rpm): a named curve (`t200_16v`, `t200_12v`) or a table
    /// `{input: [...], thrust_n: [...]}`. Commands in newtons need none (a table there
    /// states the thrusters' limits: thrust against thrust, held at its ends).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curve: Option<Curve>,
    /// A factor on every thrust (a thrust curve measured on another supply voltage, a
    /// nozzle); 1 by default.
    #[serde(default = "one")]
    pub gain: f64,
}

fn one() -> f64 {
    1.0
}

fn neutral_us() -> f64 {
    1500.0
}

fn half_range_us() -> f64 {
    400.0
}

/// One thruster, in the body frame (x forward, y starboard, z down, from the centre of
/// gravity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Thruster {
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    pub position_m: [f64; 3],
    /// The direction of the force on the vehicle for a positive command (normalised when
    /// read).
    pub direction: [f64; 3],
}

/// The kind of a logged thruster command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Command {
    /// ESC pulse width in microseconds.
    #[default]
    Pwm,
    /// A command already in -1..1.
    Normalised,
    /// Shaft speed in rev/min; the curve is thrust against rpm.
    Rpm,
    /// The thrust itself, N (a simulator's per-thruster thrust, a thrust the autopilot
    /// logs); through the curve when one is given, else as it is.
    Newtons,
}

/// The thrust a command in newtons is held to when no curve states the thrusters' limits: none
/// a vehicle reaches.
const NEWTONS_UNLIMITED: f64 = 1e4;

/// A thrust curve: named, or a table of thrust (N) against the normalised command (or rpm),
/// interpolated linearly and held at its ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Curve {
    Named(NamedCurve),
    Table { input: Vec<f64>, thrust_n: Vec<f64> },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NamedCurve {
    /// Blue Robotics T200, 16 V (T200 Public Performance Data, September 2019).
    T200_16v,
    /// Blue Robotics T200, 12 V (same source).
    T200_12v,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// BlueROV2 (ArduSub FRAME_CONFIG 1, "vectored"): four vectored horizontal and two
    /// vertical T200, in ArduSub's motor order.
    Bluerov2,
    /// BlueROV2 Heavy (FRAME_CONFIG 2, "vectored 6DOF"): four vectored horizontal and four
    /// vertical T200.
    Bluerov2Heavy,
    /// The first-version BlueROV of the 2016 thesis (github MrEkelund/ExjobbROV): thrusters
    /// 1, 2 vertical front, 3, 4 horizontal, 5 vertical aft, 6 lateral, positive up, forward
    /// and to port.
    Bluerov1Thesis,
}

/// Positions (m) and directions of the documented layouts, in motor order (body frame
/// x forward, y starboard, z down).
///
/// BlueROV2: ArduSub's mixing factors (ArduPilot `AP_Motors6DOF.cpp`, `setup_motors`) give
/// the directions: motors 1-4 at 45 degrees (1 front-starboard pushing back and to
/// starboard, 2 front-port back and to port, 3 rear-starboard forward and to starboard, 4
/// rear-port forward and to port), 5 and 6 vertical pushing down; positions from the
/// Robotic-Decision-Making-Lab `blue` URDF (MIT). Heavy: the same horizontals, four
/// verticals at the corners, lever arms of von Benzon et al. 2022 (J. Mar. Sci. Eng.
/// 10:1898, Table A1). Thesis BlueROV: its eq. actuatorGeometry and table of arms.
fn layout_units(l: Layout) -> Vec<Thruster> {
    const S: f64 = std::f64::consts::FRAC_1_SQRT_2;
    let t = |name: &str, p: [f64; 3], d: [f64; 3]| Thruster {
        name: name.into(),
        position_m: p,
        direction: d,
    };
    let horizontals = |x_front: f64, x_rear: f64, y: f64, z: f64| {
        vec![
            t("1", [x_front, y, z], [-S, S, 0.0]),
            t("2", [x_front, -y, z], [-S, -S, 0.0]),
            t("3", [x_rear, y, z], [S, S, 0.0]),
            t("4", [x_rear, -y, z], [S, -S, 0.0]),
        ]
    };
    match l {
        Layout::Bluerov2 => {
            let mut u = horizontals(0.14, -0.15, 0.092, 0.0);
            u.push(t("5", [0.0, 0.109, -0.077], [0.0, 0.0, 1.0]));
            u.push(t("6", [0.0, -0.109, -0.077], [0.0, 0.0, 1.0]));
            u
        }
        Layout::Bluerov2Heavy => {
            let mut u = horizontals(0.156, -0.156, 0.111, 0.085);
            for (n, x, y) in [("5", 0.12, 0.218), ("6", 0.12, -0.218), ("7", -0.12, 0.218)] {
                u.push(t(n, [x, y, 0.0], [0.0, 0.0, 1.0]));
            }
            u.push(t("8", [-0.12, -0.218, 0.0], [0.0, 0.0, 1.0]));
            u
        }
        Layout::Bluerov1Thesis => vec![
            t("1", [0.19, -0.11, 0.0], [0.0, 0.0, -1.0]),
            t("2", [0.19, 0.11, 0.0], [0.0, 0.0, -1.0]),
            t("3", [0.0, -0.11, 0.0], [1.0, 0.0, 0.0]),
            t("4", [0.0, 0.11, 0.0], [1.0, 0.0, 0.0]),
            t("5", [-0.17, 0.0, 0.0], [0.0, 0.0, -1.0]),
            t("6", [0.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        ],
    }
}

/// Blue Robotics T200 bollard thrust (N) against PWM (us), from their "T200 Public
/// Performance Data 10-20 V, September 2019" (forward 1500-1900 us, reverse 1100-1500 us;
/// kgf times 9.80665), every 20 us with the edges of the dead band.
const T200_PWM: [f64; 45] = [
    1100., 1120., 1140., 1160., 1180., 1200., 1220., 1240., 1260., 1280., 1300., 1320., 1340.,
    1360., 1380., 1400., 1420., 1440., 1460., 1464., 1468., 1472., 1480., 1500., 1520., 1528.,
    1532., 1536., 1540., 1560., 1580., 1600., 1620., 1640., 1660., 1680., 1700., 1720., 1740.,
    1760., 1780., 1800., 1820., 1840., 1860.,
];
const T200_16V_N: [f64; 45] = [
    -39.913, -37.952, -35.892, -32.460, -29.322, -26.576, -24.026, -21.575, -19.025, -16.377,
    -14.122, -11.768, -10.003, -8.041, -6.374, -4.707, -3.138, -1.765, -0.686, -0.490, -0.392, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.392, 0.490, 0.785, 2.157, 3.923, 5.884, 8.041, 10.101, 12.553, 15.102,
    17.848, 20.790, 23.830, 27.066, 30.499, 33.539, 37.461, 41.678, 45.601,
];
const T200_12V_N: [f64; 45] = [
    -28.439, -27.066, -25.105, -22.948, -20.986, -19.123, -16.966, -15.004, -13.435, -11.670,
    -10.003, -8.532, -7.061, -5.590, -4.315, -3.138, -1.961, -1.079, -0.392, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.392, 1.275, 2.452, 3.825, 5.394, 6.963, 8.728, 10.591, 12.553,
    14.514, 16.769, 18.829, 21.378, 24.124, 26.576, 29.518, 31.970,
];
/// The last two points of each curve (1880 and 1900 us), kept apart to keep the tables above
/// in rows of equal length.
const T200_TOP_PWM: [f64; 2] = [1880.0, 1900.0];
const T200_TOP_16V: [f64; 2] = [49.131, 51.485];
const T200_TOP_12V: [f64; 2] = [34.323, 36.383];

impl NamedCurve {
    /// The curve as (normalised command, thrust N), for 1500 +- 400 us.
    fn table(self) -> (Vec<f64>, Vec<f64>) {
        let (body, top) = match self {
            NamedCurve::T200_16v => (&T200_16V_N, &T200_TOP_16V),
            NamedCurve::T200_12v => (&T200_12V_N, &T200_TOP_12V),
        };
        let u = T200_PWM
            .iter()
            .chain(&T200_TOP_PWM)
            .map(|p| (p - 1500.0) / 400.0)
            .collect();
        (u, body.iter().chain(top).copied().collect())
    }
}

impl Curve {
    fn table(&self) -> (Vec<f64>, Vec<f64>) {
        match self {
            Curve::Named(n) => n.table(),
            Curve::Table { input, thrust_n } => (input.clone(), thrust_n.clone()),
        }
    }
}

/// The thrusters as a build uses them: the units, the curve as a table and the allocation.
#[derive(Debug, Clone)]
pub struct Allocation {
    pub units: Vec<Thruster>,
    /// Column i is thruster i's [force; moment] per newton of thrust.
    pub columns: Vec<[f64; 6]>,
    curve: (Vec<f64>, Vec<f64>),
    command: Command,
    neutral_us: f64,
    half_range_us: f64,
    gain: f64,
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl Thrusters {
    /// The units: the layout's, or those listed.
    pub fn units(&self) -> Vec<Thruster> {
        match self.layout {
            Some(l) if self.units.is_empty() => layout_units(l),
            _ => self.units.clone(),
        }
    }

    /// What is wrong with the description, one sentence each (empty when it can be used).
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.layout.is_some() && !self.units.is_empty() {
            out.push("thrusters: give either `layout` or `units`, not both".into());
        }
        if self.layout.is_none() && self.units.is_empty() {
            out.push(
                "thrusters: give a `layout` (bluerov2, bluerov2_heavy, bluerov1_thesis) or list `units` with position_m and direction"
                    .into(),
            );
        }
        for (i, u) in self.units.iter().enumerate() {
            let n = u.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(n.is_finite() && n > 1e-9) || u.position_m.iter().any(|x| !x.is_finite()) {
                out.push(format!(
                    "thrusters: unit {} needs a finite position_m and a non-zero direction",
                    i + 1
                ));
            }
        }
        if self.command == Command::Pwm
            && !(self.half_range_us.is_finite()
                && self.half_range_us > 0.0
                && self.neutral_us.is_finite())
        {
            out.push("thrusters: half_range_us must be a positive number of microseconds and neutral_us finite".into());
        }
        if !(self.gain.is_finite() && self.gain > 0.0) {
            out.push(format!(
                "thrusters: gain must be a positive number, not {}",
                self.gain
            ));
        }
        match (&self.curve, self.command) {
            (None, Command::Newtons) => {}
            (None, _) => out.push(
                "thrusters: give a `curve` (t200_16v, t200_12v or {input: [...], thrust_n: [...]}): a pwm, normalised or rpm command becomes thrust through it".into(),
            ),
            (Some(_), _) => out.extend(curve_problems(&self.curve_table())),
        }
        out
    }

    /// The curve as a table: the one given, or for commands in newtons without one thrust
    /// against itself (empty for other commands without one: a problem).
    fn curve_table(&self) -> (Vec<f64>, Vec<f64>) {
        match (&self.curve, self.command) {
            (Some(c), _) => c.table(),
            (None, Command::Newtons) => {
                let ends = vec![-NEWTONS_UNLIMITED, NEWTONS_UNLIMITED];
                (ends.clone(), ends)
            }
            (None, _) => (Vec::new(), Vec::new()),
        }
    }

    /// The allocation of a described set (call [`Thrusters::problems`] first).
    pub fn allocation(&self) -> Allocation {
        let units = self.units();
        let columns = units
            .iter()
            .map(|u| {
                let n = u.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
                let d = u.direction.map(|x| x / n);
                let m = cross(u.position_m, d);
                [d[0], d[1], d[2], m[0], m[1], m[2]]
            })
            .collect();
        Allocation {
            units,
            columns,
            curve: self.curve_table(),
            command: self.command,
            neutral_us: self.neutral_us,
            half_range_us: self.half_range_us,
            gain: self.gain,
        }
    }
}

fn curve_problems((x, y): &(Vec<f64>, Vec<f64>)) -> Vec<String> {
    if x.len() != y.len() || x.len() < 2 {
        return vec![format!(
            "thrusters: the curve's `input` and `thrust_n` need the same number of points, at least 2 (they have {} and {})",
            x.len(),
            y.len()
        )];
    }
    if x.iter().chain(y).any(|v| !v.is_finite()) || x.windows(2).any(|w| w[1] <= w[0]) {
        return vec![
            "thrusters: the curve's `input` must be finite and increasing, its `thrust_n` finite"
                .into(),
        ];
    }
    Vec::new()
}

impl Allocation {
    /// Thrust (N) of one thruster under the logged command `c`.
    pub fn thrust(&self, c: f64) -> f64 {
        let x = match self.command {
            Command::Pwm => (c - self.neutral_us) / self.half_range_us,
            Command::Normalised | Command::Rpm | Command::Newtons => c,
        };
        self.gain * interp(&self.curve.0, &self.curve.1, x)
    }

    /// The command (as logged) that gives thrust `f` (N), and whether the thruster cannot
    /// give that much (the command is then the curve's end in that direction). Where the
    /// curve gives `f` at several commands (a deadband's flat zero), the one nearest neutral.
    pub fn command_for(&self, f: f64) -> (f64, bool) {
        let (x, y) = (&self.curve.0, &self.curve.1);
        let want = f / self.gain;
        let mut best: Option<f64> = None;
        for k in 1..x.len() {
            let (x0, x1, y0, y1) = (x[k - 1], x[k], y[k - 1], y[k]);
            if want < y0.min(y1) || want > y0.max(y1) {
                continue;
            }
            let at = if (y1 - y0).abs() < 1e-12 {
                0.0_f64.clamp(x0, x1)
            } else {
                x0 + (x1 - x0) * (want - y0) / (y1 - y0)
            };
            if best.is_none_or(|b| at.abs() < b.abs()) {
                best = Some(at);
            }
        }
        let (at, clipped) = match best {
            Some(at) => (at, false),
            None => {
                // Beyond the curve: its strongest point in the wanted direction.
                let ends = x.iter().zip(y.iter());
                let end = if want > 0.0 {
                    ends.max_by(|a, b| a.1.total_cmp(b.1))
                } else {
                    ends.min_by(|a, b| a.1.total_cmp(b.1))
                };
                (*end.expect("a curve has points").0, true)
            }
        };
        let logged = match self.command {
            Command::Pwm => self.neutral_us + at * self.half_range_us,
            Command::Normalised | Command::Rpm | Command::Newtons => at,
        };
        (logged, clipped)
    }

    /// What a logged command is (`pwm`, `normalised`, `rpm`).
    pub fn command_kind(&self) -> Command {
        self.command
    }

    /// `n` points of the thrust curve over its commands: (command as logged, thrust in N).
    pub fn curve_points(&self, n: usize) -> (Vec<f64>, Vec<f64>) {
        let (x0, x1) = (self.curve.0[0], self.curve.0[self.curve.0.len() - 1]);
        let to_command = |x: f64| match self.command {
            Command::Pwm => self.neutral_us + x * self.half_range_us,
            Command::Normalised | Command::Rpm | Command::Newtons => x,
        };
        let xs: Vec<f64> = (0..n)
            .map(|k| to_command(x0 + (x1 - x0) * k as f64 / (n - 1).max(1) as f64))
            .collect();
        let ys = xs.iter().map(|&c| self.thrust(c)).collect();
        (xs, ys)
    }

    /// The body wrench [X, Y, Z, K, M, N] of the commands `cmds` (one per unit, in order).
    pub fn wrench(&self, cmds: &[f64]) -> [f64; 6] {
        let mut tau = [0.0; 6];
        for (col, &c) in self.columns.iter().zip(cmds) {
            let f = self.thrust(c);
            for (t, b) in tau.iter_mut().zip(col) {
                *t += b * f;
            }
        }
        tau
    }

    /// The rank of the allocation matrix and the DOFs its columns reach (a DOF is actuated
    /// when its unit wrench lies in the column space, to 1e-6).
    pub fn actuated(&self) -> (usize, Vec<Dof>) {
        let n = self.columns.len();
        let b = nalgebra::DMatrix::from_fn(6, n, |i, j| self.columns[j][i]);
        let svd = b.clone().svd(true, false);
        let tol = 1e-9 * svd.singular_values.max().max(1e-300);
        let rank = svd.singular_values.iter().filter(|s| **s > tol).count();
        let u = svd.u.expect("computed");
        let dofs = Dof::ALL
            .into_iter()
            .filter(|d| {
                let i = d.index();
                // The projection of e_i onto the column space: sum over the basis vectors.
                let p: f64 = (0..rank).map(|k| u[(i, k)].powi(2)).sum();
                p > 1.0 - 1e-6
            })
            .collect();
        (rank, dofs)
    }
}

/// Linear interpolation in a table with increasing `x`, held at its ends.
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    if at <= x[0] {
        return y[0];
    }
    if at >= x[x.len() - 1] {
        return y[y.len() - 1];
    }
    let k = x.partition_point(|v| *v <= at).max(1);
    let (x0, x1, y0, y1) = (x[k - 1], x[k], y[k - 1], y[k]);
    y0 + (y1 - y0) * (at - x0) / (x1 - x0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thrusters(layout: Layout) -> Thrusters {
        Thrusters {
            layout: Some(layout),
            units: vec![],
            command: Command::default(),
            neutral_us: 1500.0,
            half_range_us: 400.0,
            curve: Some(Curve::Named(NamedCurve::T200_16v)),
            gain: 1.0,
        }
    }

    #[test]
    fn a_thrust_gives_back_its_command() {
        let a = thrusters(Layout::Bluerov2).allocation();
        for pwm in [1150.0, 1300.0, 1420.0, 1580.0, 1700.0, 1890.0] {
            let (c, clipped) = a.command_for(a.thrust(pwm));
            assert!(!clipped && (c - pwm).abs() < 0.5, "{pwm} -> {c}");
        }
        // Zero thrust is neutral (the deadband's nearest point), too much is clipped.
        let (c, clipped) = a.command_for(0.0);
        assert!(!clipped && (c - 1500.0).abs() < 30.0, "{c}");
        let (c, clipped) = a.command_for(1e4);
        assert!(clipped && (c - 1900.0).abs() < 1e-9, "{c}");
        let (c, clipped) = a.command_for(-1e4);
        assert!(clipped && (c - 1100.0).abs() < 1e-9, "{c}");
    }

    #[test]
    fn the_layouts_push_as_ardusub_mixes() {
        // ArduSub's factors for the vectored frame: motor 1 forward -1, lateral +1, yaw +1;
        // motor 5 throttle -1 (a positive command pushes down), roll +1.
        let a = thrusters(Layout::Bluerov2).allocation();
        let c1 = a.columns[0];
        assert!(c1[0] < 0.0 && c1[1] > 0.0 && c1[5] > 0.0, "{c1:?}");
        let c5 = a.columns[4];
        assert!(c5[2] > 0.0 && c5[3] > 0.0, "{c5:?}");
        let (rank, dofs) = a.actuated();
        assert_eq!(rank, 5, "the vectored frame has no pitch authority");
        assert_eq!(
            dofs,
            [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Roll, Dof::Yaw]
        );
        let (rank, dofs) = thrusters(Layout::Bluerov2Heavy).allocation().actuated();
        assert_eq!((rank, dofs.len()), (6, 6));
    }

    #[test]
    fn the_thesis_layout_is_its_geometry_matrix() {
        // K = 0.11 (f1 - f2), M = 0.19 (f1 + f2) - 0.17 f5, N = 0.11 (f3 - f4), Z = -(f1 + f2 + f5).
        let a = thrusters(Layout::Bluerov1Thesis).allocation();
        let want = [
            [0.0, 0.0, -1.0, 0.11, 0.19, 0.0],
            [0.0, 0.0, -1.0, -0.11, 0.19, 0.0],
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.11],
            [1.0, 0.0, 0.0, 0.0, 0.0, -0.11],
            [0.0, 0.0, -1.0, 0.0, -0.17, 0.0],
            [0.0, -1.0, 0.0, 0.0, 0.0, 0.0],
        ];
        for (c, w) in a.columns.iter().zip(want) {
            for (x, y) in c.iter().zip(w) {
                assert!((x - y).abs() < 1e-12, "{c:?} against {w:?}");
            }
        }
    }

    #[test]
    fn pwm_goes_through_the_curve() {
        let a = thrusters(Layout::Bluerov2).allocation();
        assert_eq!(a.thrust(1500.0), 0.0);
        assert!((a.thrust(1900.0) - 51.485).abs() < 1e-9);
        assert!((a.thrust(1100.0) + 39.913).abs() < 1e-9);
        assert!((a.thrust(1590.0) - 0.5 * (3.923 + 5.884)).abs() < 1e-9);
        assert_eq!(a.thrust(2500.0), 51.485, "held at the end");
        // All six at 1700 us: the horizontals cancel, the verticals push down.
        let w = a.wrench(&[1700.0; 6]);
        assert!(w[0].abs() < 1e-9 && w[1].abs() < 1e-9 && (w[2] - 2.0 * 17.848).abs() < 1e-9);
    }

    #[test]
    fn a_bad_description_is_said() {
        let mut t = thrusters(Layout::Bluerov2);
        t.curve = Some(Curve::Table {
            input: vec![0.0, 0.0],
            thrust_n: vec![1.0, 2.0],
        });
        t.gain = -1.0;
        let p = t.problems().join("; ");
        assert!(p.contains("increasing") && p.contains("gain"), "{p}");
        t.curve = None;
        assert!(t.problems().iter().any(|p| p.contains("give a `curve`")));
    }

    /// A simulator logs each thruster's thrust: it goes into the allocation as it is, or
    /// held at a curve's ends where one states the limits.
    #[test]
    fn commands_in_newtons_need_no_curve() {
        let mut t = thrusters(Layout::Bluerov2);
        (t.command, t.curve) = (Command::Newtons, None);
        assert!(t.problems().is_empty(), "{:?}", t.problems());
        let a = t.allocation();
        assert_eq!((a.thrust(12.5), a.thrust(-30.0)), (12.5, -30.0));
        assert_eq!(a.command_for(7.0), (7.0, false));
        let w = a.wrench(&[10.0, 10.0, 0.0, 0.0, 0.0, 0.0]);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((w[0] + 20.0 * s).abs() < 1e-9 && w[1].abs() < 1e-9, "{w:?}");
        t.curve = Some(Curve::Table {
            input: vec![-40.0, 40.0],
            thrust_n: vec![-40.0, 40.0],
        });
        assert_eq!(t.allocation().thrust(55.0), 40.0);
    }
}
