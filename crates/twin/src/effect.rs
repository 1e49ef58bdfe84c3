//! The left-out effects the twin can conceal, with their magnitudes, as the twin's command line
//! names them (docs/formats.md, "Left-out effects"); [`crate::world`] simulates them.

use serde::{Deserialize, Serialize};

/// One left-out effect with its magnitude. Signs follow the frames of docs/formats.md (z down).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "name", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// Weight minus buoyancy, N, along pool z (positive: the vehicle sinks).
    NetBuoyancy { force_n: f64 },
    /// Time constant of the thrusters' motor speed, s: the speed n follows the command's
    /// sqrt(|T|) sign(T) through a first-order lag and the delivered force is n |n| (Fossen
    /// 2011, sec. 6.7: thrust quadratic in propeller speed). A step from rest takes about
    /// 1.6 time constants to deliver 63 %.
    ThrusterLag { time_constant_s: f64 },
    /// Time constant of a first-order lag on the delivered force itself, s (a controller or
    /// an ESC that ramps the thrust): the same name as [`Effect::ThrusterLag`], another law.
    ForceLag { time_constant_s: f64 },
    /// Fraction of a reverse (negative) surge, sway or heave command that is lost, faded in
    /// over a few newtons around zero as the propeller's flow reverses:
    /// efficiency 1 - loss / (1 + exp(T / 2 N)).
    ReverseThrustLoss { loss: f64 },
    /// A dead zone (N for forces, N m for the yaw moment): nothing below it, and above it the
    /// command less the dead zone (static friction of the seals), with a knee rounded over a
    /// tenth of the zone (a softplus).
    ThrusterDeadband { force_n: f64, moment_nm: f64 },
    /// Drag of the umbilical: -c L |v| v on the horizontal velocity in the pool frame, with L
    /// the cable paid out (horizontal run from the anchor, plus depth below it, plus slack), c
    /// in N s^2/m^3.
    TetherDrag { coefficient: f64, slack_m: f64 },
    /// A current in the pool frame, m/s, at the pool's middle; it varies by +-30 % along the
    /// pool's length (one sine over the length). Drag and added mass act on the velocity
    /// relative to it (Fossen 2011 sect. 10.3), the water's velocity changing along the pool
    /// as the vehicle crosses it.
    WaterCurrent { velocity_m_s: [f64; 2] },
    /// Extra drag near the side walls: -c |v| v / (1 + (d / decay)^2), d the distance to the
    /// nearest wall (an image flow's algebraic fall-off).
    WallEffect { coefficient: f64, decay_m: f64 },
    /// Quadratic drag on the resultant horizontal speed beyond what the per-axis drag holds:
    /// X += -c (|V| - |u|) u, Y += -c (|V| - |v|) v, |V| = sqrt(u^2 + v^2), c in N s^2/m^2.
    CoupledDrag { coefficient: f64 },
    /// Position, attitude and depth sensors report late by `delay_s` and through a first-order
    /// low-pass of time constant `filter_s` (their total latency is about the sum).
    SensorDelay { delay_s: f64, filter_s: f64 },
    // Outside the diagnosis's vocabulary: physics no named effect describes, for proving that
    // discovery finds a closed form (each written here, apart from the discovery's library).
    /// A vertical force oscillating at a wave maker's or a pump's frequency, in phase with
    /// the run's clock (the logger and the wave maker start together): F sin(2 pi f t + phase).
    Wave {
        force_n: f64,
        frequency_hz: f64,
        phase_rad: f64,
    },
    /// A surge thruster mounted askew: its thrust line passes `arm_m` beside the centre of
    /// gravity, so the surge thrust it delivers also turns the vehicle (N += arm X).
    SkewedThruster { arm_m: f64 },
    /// Extra drag near the free surface (waves made, ventilation): surge and sway drag grow by
    /// c |v| v exp(-(z / depth_m)^2), z the depth below the surface.
    SurfaceDrag { coefficient: f64, depth_m: f64 },
    /// A tether that twists as the vehicle turns: a yaw moment against the heading turned
    /// through since the cable was laid untwisted (at heading 0), -k psi with psi continuous
    /// (turns counted), N m per rad.
    TetherTorsion { stiffness_nm_per_rad: f64 },
    /// A battery that drains during the run: the thrusters' speed at a given command falls
    /// with the voltage, so every thruster delivers the share 1 - loss t / 60 s of its force
    /// (t on the run's clock, `loss_per_minute` the share lost per minute).
    BatterySag { loss_per_minute: f64 },
    /// Thrusters that cannot deliver more than `force_n` (N, surge, sway and heave) or
    /// `moment_nm` (N m, roll, pitch and yaw): a larger command is clipped, as a motor at full
    /// speed or an ESC at its current limit clips it.
    ThrustSaturation { force_n: f64, moment_nm: f64 },
    /// A hull that is bluffer astern: backing up (u < 0) meets the extra drag -c |u| u on top of
    /// the model's, c in N s^2/m^2; going ahead meets none.
    AsymmetricDrag { coefficient: f64 },
    /// Propellers that lose thrust to the inflow: moving at speed along a thruster's push
    /// (surge, sway or heave), it delivers F (1 - s / `speed_m_s`), s the speed along the push
    /// (none lost moving against it, all at `speed_m_s`).
    InflowLoss { speed_m_s: f64 },
    /// A hull whose sway added mass exceeds the model's: an extra Munk moment N += c u v,
    /// c in kg (Fossen 2011, sec. 6.3: (X_udot - Y_vdot) u v turns a hull across the flow).
    MunkMoment { coefficient: f64 },
    /// Buoyancy foam that compresses with depth: the vehicle gets heavier by `n_per_m` newtons
    /// for each metre below the surface (Z += k z, z down).
    DepthBuoyancy { n_per_m: f64 },
    /// A hull trimmed nose-down: going ahead or astern makes a vertical lift that goes with the
    /// square of the surge speed, Z += c u^2 (down whichever way the vehicle goes), c in
    /// N s^2/m^2.
    ForwardLift { coefficient: f64 },
    /// A constant yaw moment, N m: one thruster of a pair delivering more than its twin at
    /// zero command (an ESC's offset), or a sail-like appendage in a steady flow.
    YawBias { moment_nm: f64 },
    /// A tether whose weight pulls the vehicle back toward the anchor: a horizontal restoring
    /// force -k d in the pool frame, d the horizontal offset from the anchor, k in N/m (a
    /// catenary's stiffness, linearised).
    TetherSpring { stiffness_n_per_m: f64 },
    /// Tunnel thrusters in a cross flow: going ahead or astern, the lateral thrusters (sway
    /// force and yaw moment) deliver F (1 - |u| / `speed_m_s`), none at that surge speed (the
    /// jet bent aft and reattaching to the hull).
    CrossflowLoss { speed_m_s: f64 },
}

/// The effects outside the diagnosis's vocabulary, as `from_arg` takes them.
pub const OUTSIDE: [&str; 14] = [
    "wave",
    "skewed_thruster",
    "surface_drag",
    "tether_torsion",
    "battery_sag",
    "thrust_saturation",
    "asymmetric_drag",
    "inflow_loss",
    "munk_moment",
    "depth_buoyancy",
    "forward_lift",
    "yaw_bias",
    "tether_spring",
    "crossflow_loss",
];

pub const NAMES: [&str; 9] = [
    "net_buoyancy",
    "thruster_lag",
    "reverse_thrust_loss",
    "thruster_deadband",
    "tether_drag",
    "water_current",
    "wall_effect",
    "coupled_drag",
    "sensor_delay",
];

impl Effect {
    pub fn name(&self) -> &'static str {
        match self {
            Effect::NetBuoyancy { .. } => NAMES[0],
            Effect::ThrusterLag { .. } | Effect::ForceLag { .. } => NAMES[1],
            Effect::ReverseThrustLoss { .. } => NAMES[2],
            Effect::ThrusterDeadband { .. } => NAMES[3],
            Effect::TetherDrag { .. } => NAMES[4],
            Effect::WaterCurrent { .. } => NAMES[5],
            Effect::WallEffect { .. } => NAMES[6],
            Effect::CoupledDrag { .. } => NAMES[7],
            Effect::SensorDelay { .. } => NAMES[8],
            Effect::Wave { .. } => OUTSIDE[0],
            Effect::SkewedThruster { .. } => OUTSIDE[1],
            Effect::SurfaceDrag { .. } => OUTSIDE[2],
            Effect::TetherTorsion { .. } => OUTSIDE[3],
            Effect::BatterySag { .. } => OUTSIDE[4],
            Effect::ThrustSaturation { .. } => OUTSIDE[5],
            Effect::AsymmetricDrag { .. } => OUTSIDE[6],
            Effect::InflowLoss { .. } => OUTSIDE[7],
            Effect::MunkMoment { .. } => OUTSIDE[8],
            Effect::DepthBuoyancy { .. } => OUTSIDE[9],
            Effect::ForwardLift { .. } => OUTSIDE[10],
            Effect::YawBias { .. } => OUTSIDE[11],
            Effect::TetherSpring { .. } => OUTSIDE[12],
            Effect::CrossflowLoss { .. } => OUTSIDE[13],
        }
    }

    /// Parses `name=value` as the twin's command line takes it, with a typical second parameter.
    pub fn from_arg(arg: &str) -> Result<Effect, String> {
        let (name, value) = arg.split_once('=').ok_or_else(|| {
            format!("`{arg}`: write an effect as name=magnitude, e.g. thruster_lag=0.3")
        })?;
        let x: f64 = value
            .parse()
            .map_err(|_| format!("`{arg}`: magnitude `{value}` is not a number"))?;
        Ok(match name {
            "net_buoyancy" => Effect::NetBuoyancy { force_n: x },
            "thruster_lag" => Effect::ThrusterLag { time_constant_s: x },
            "reverse_thrust_loss" => Effect::ReverseThrustLoss { loss: x },
            "thruster_deadband" => Effect::ThrusterDeadband {
                force_n: x,
                moment_nm: x * 0.1,
            },
            "tether_drag" => Effect::TetherDrag {
                coefficient: x,
                slack_m: 2.0,
            },
            "water_current" => Effect::WaterCurrent {
                velocity_m_s: [x, 0.3 * x],
            },
            "wall_effect" => Effect::WallEffect {
                coefficient: x,
                decay_m: 0.8,
            },
            "coupled_drag" => Effect::CoupledDrag { coefficient: x },
            "sensor_delay" => Effect::SensorDelay {
                delay_s: x,
                filter_s: 0.5 * x,
            },
            "wave" => Effect::Wave {
                force_n: x,
                frequency_hz: 0.42,
                phase_rad: 0.3,
            },
            "skewed_thruster" => Effect::SkewedThruster { arm_m: x },
            "surface_drag" => Effect::SurfaceDrag {
                coefficient: x,
                depth_m: 1.0,
            },
            "tether_torsion" => Effect::TetherTorsion {
                stiffness_nm_per_rad: x,
            },
            "battery_sag" => Effect::BatterySag { loss_per_minute: x },
            "thrust_saturation" => Effect::ThrustSaturation {
                force_n: x,
                moment_nm: x * 0.1,
            },
            "asymmetric_drag" => Effect::AsymmetricDrag { coefficient: x },
            "inflow_loss" => Effect::InflowLoss { speed_m_s: x },
            "crossflow_loss" => Effect::CrossflowLoss { speed_m_s: x },
            "munk_moment" => Effect::MunkMoment { coefficient: x },
            "depth_buoyancy" => Effect::DepthBuoyancy { n_per_m: x },
            "forward_lift" => Effect::ForwardLift { coefficient: x },
            "yaw_bias" => Effect::YawBias { moment_nm: x },
            "tether_spring" => Effect::TetherSpring {
                stiffness_n_per_m: x,
            },
            _ => {
                let hint = hydrofit_core::diag::nearest(name, NAMES.into_iter().chain(OUTSIDE))
                    .map_or(String::new(), |s| format!(" (did you mean `{s}`?)"));
                return Err(format!(
                    "unknown effect `{name}`{hint}; known: {}, and outside the diagnosis's vocabulary {}",
                    NAMES.join(", "),
                    OUTSIDE.join(", ")
                ));
            }
        })
    }
}
