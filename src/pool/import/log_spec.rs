//! `run.yaml`'s `log:` section: a log the vehicle wrote (a ROS 1 bag, an MCAP file, an
//! ArduPilot `.BIN` or `.tlog`), the span of it that is this run, and which topic and fields
//! carry each signal the pool stage reads (a fin-steered vehicle's actuators too). Common stacks have defaults (`stack: mavros`,
//! `ardusub`, `ardusub_tlog`, `px4`); anything set here overrides them.

use serde::{Deserialize, Serialize};

/// The log of a run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogSpec {
    /// The log's path, relative to the run folder or absolute.
    pub file: String,
    /// The part of the log that is this run: seconds from the log's first message. Several
    /// run folders may cut one log into runs this way.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub span_s: Option<[f64; 2]>,
    /// The software that wrote the log, for the default topics: `mavros` (a BlueROV2 with
    /// mavros, ROS 1 or 2), `ardusub` (an ArduSub DataFlash log), `ardusub_tlog` (its MAVLink
    /// telemetry log), `px4` (a PX4 ULog, or PX4's ROS 2 topics `/fmu/out/...`) or `none`. By
    /// default: `ardusub` for a DataFlash log, `ardusub_tlog` for a tlog, `px4` for a ULog or
    /// a ROS log with `/fmu/` topics, `mavros` for a ROS log with mavros topics, `none` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stack: Option<Stack>,
    /// Which time a message is taken at: `auto` (its header stamp where it has one, else the
    /// time the log recorded it), `header` or `receive`.
    #[serde(default)]
    pub time: TimeSource,
    /// The unit of a CSV table's time column whose name gives none (`s`, `ms`, `us`, `ns`);
    /// read from its values when left out (docs/logs.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_unit: Option<TimeUnit>,
    /// Folders holding the `.msg` files of the message types a ROS 2 `.db3` bag does not
    /// define (Humble and older carry none): each a folder of packages (`<pkg>/msg/*.msg`, a
    /// workspace's `src/`), a package or its `msg/` folder; relative to the run folder.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub message_folders: Vec<String>,
    /// Per-thruster commands, one field per unit of `vehicle.thrusters`, in its order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<Source>,
    /// The commanded body wrench instead: X, Y, Z, K, M, N (or X, Y, Z, N).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrench: Option<Source>,
    /// Body velocity u, v, w (a DVL, a navigation filter); in a world frame (`frame: ned` or
    /// `enu`) it is turned into the body frame with the attitude.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Source>,
    /// Roll, pitch, yaw as three fields, or a quaternion: four fields x, y, z, w, or its path
    /// (`quaternion: orientation`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attitude: Option<Source>,
    /// Body rates p, q, r.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rates: Option<Source>,
    /// Specific force along the body axes (an accelerometer).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceleration: Option<Source>,
    /// Depth, or a pressure (`unit: pa`, gauge) or an altitude (`unit: up_m`) it is read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<Source>,
    /// A position fix in the pool frame, x, y (and z): a UWB or acoustic positioning system.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<Source>,
    /// A position tracked in a fixed imaging sonar's images, pool frame, x, y.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sonar: Option<Source>,
    /// The actuator commands of a vehicle steered by fins and propeller speed, as
    /// `actuators.csv` holds them: one field per actuator, each named by `columns` as that
    /// file's header names it (`fin_top_deg`, `prop_rpm`: the name and the unit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuators: Option<Source>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stack {
    Mavros,
    Ardusub,
    ArdusubTlog,
    Px4,
    None,
}

impl Stack {
    /// As `run.yaml` names it.
    pub fn name(self) -> &'static str {
        match self {
            Stack::Mavros => "mavros",
            Stack::Ardusub => "ardusub",
            Stack::ArdusubTlog => "ardusub_tlog",
            Stack::Px4 => "px4",
            Stack::None => "none",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeSource {
    #[default]
    Auto,
    Header,
    Receive,
}

/// The unit of a CSV table's time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    Ns,
}

impl TimeUnit {
    /// Seconds per unit.
    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }
}

/// Where one signal is in the log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Source {
    /// The topic; `{a..b}` in it stands for topics a .. b-1, one part of the signal each (a
    /// simulator's per-thruster topics: `/rov/thrusters/{0..6}/input`), in that order, each
    /// giving the `fields` named.
    pub topic: String,
    /// Field paths (`twist.twist.linear.x`, `data[3]`, `C1`); `name[a..b]` stands for
    /// `name[a]` .. `name[b-1]`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fields: Vec<String>,
    /// For an attitude: the path of a quaternion (x, y, z, w), instead of three angles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<String>,
    /// The unit of the fields, when not SI.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<Unit>,
    /// The frame of the fields: `frd` (body x forward, y starboard, z down; the default for
    /// body vectors), `flu` (ROS's body frame, REP-103), `ned` or `enu` (world frames, for a
    /// velocity, a quaternion's reference or a position; a position's default is `ned`, the
    /// pool frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<Frame>,
    /// For a pressure read as depth: the water's density (default 1000 kg/m^3, a pool).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_kg_m3: Option<f64>,
    /// For a velocity: a field of the same messages that is false (0) where the sample is not
    /// a measurement (a DVL without bottom lock). Water Linked's `velocity_valid`
    /// (`dvl_msgs/DVL`) is found without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub valid: Option<String>,
    /// For a body velocity measured away from the centre of gravity (a DVL): the sensor's
    /// position there, metres, x forward, y starboard, z down. The velocity there is
    /// `v + omega x at`; the rates (`log.rates`) take `omega x at` off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<[f64; 3]>,
    /// For the actuators: each field's column as `actuators.csv` would head it, its name and
    /// unit (`fin_top_deg`, `prop_rpm`, `thruster_pct`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub columns: Vec<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unit {
    Rad,
    Deg,
    #[serde(rename = "rad/s")]
    RadPerS,
    #[serde(rename = "deg/s")]
    DegPerS,
    #[serde(rename = "m/s")]
    MPerS,
    #[serde(rename = "cm/s")]
    CmPerS,
    #[serde(rename = "m/s^2")]
    MPerS2,
    G,
    M,
    Cm,
    /// Metres of altitude: depth is its negative.
    UpM,
    /// Gauge pressure, Pa: depth = p / (rho g).
    Pa,
    /// Absolute pressure, Pa or hPa: depth from its rise above the run's first sample.
    PaAbs,
    HpaAbs,
    #[serde(rename = "N")]
    Newton,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    Frd,
    Flu,
    Ned,
    Enu,
}

impl Source {
    pub fn new(topic: &str, fields: &[&str]) -> Source {
        Source {
            topic: topic.into(),
            fields: fields.iter().map(|f| f.to_string()).collect(),
            quaternion: None,
            unit: None,
            frame: None,
            density_kg_m3: None,
            valid: None,
            at: None,
            columns: Vec::new(),
        }
    }

    pub fn unit(mut self, u: Unit) -> Source {
        self.unit = Some(u);
        self
    }

    pub fn frame(mut self, f: Frame) -> Source {
        self.frame = Some(f);
        self
    }

    pub fn quaternion(topic: &str, path: &str, frame: Frame) -> Source {
        Source {
            quaternion: Some(path.into()),
            frame: Some(frame),
            ..Source::new(topic, &[])
        }
    }

    /// The field paths with `name[a..b]` ranges spelled out.
    pub fn expanded(&self) -> Result<Vec<String>, String> {
        let mut out = Vec::new();
        for f in &self.fields {
            match range(f) {
                Some((name, a, b)) => out.extend((a..b).map(|k| format!("{name}[{k}]"))),
                None => out.push(f.clone()),
            }
        }
        if out.len() > 64 {
            return Err(format!(
                "`{}` names {} fields; 64 at most",
                self.topic,
                out.len()
            ));
        }
        Ok(out)
    }
}

impl Source {
    /// The topics the signal is read from: `topic`, or each topic its `{a..b}` stands for.
    pub fn topics(&self) -> Vec<String> {
        let braced = self.topic.split_once('{').and_then(|(head, rest)| {
            let (range, tail) = rest.split_once('}')?;
            let (a, b) = range.split_once("..")?;
            let (a, b): (usize, usize) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
            (a < b && b - a <= 64).then(|| (a..b).map(|k| format!("{head}{k}{tail}")).collect())
        });
        braced.unwrap_or_else(|| vec![self.topic.clone()])
    }
}

/// `name[a..b]` as (name, a, b).
fn range(f: &str) -> Option<(&str, usize, usize)> {
    let (name, rest) = f.split_once('[')?;
    let (a, b) = rest.strip_suffix(']')?.split_once("..")?;
    let (a, b) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
    (a < b).then_some((name, a, b))
}

impl LogSpec {
    /// The signals set here, by name.
    pub fn signals(&self) -> [(&'static str, Option<&Source>); 10] {
        [
            ("command", self.command.as_ref()),
            ("wrench", self.wrench.as_ref()),
            ("velocity", self.velocity.as_ref()),
            ("attitude", self.attitude.as_ref()),
            ("rates", self.rates.as_ref()),
            ("acceleration", self.acceleration.as_ref()),
            ("depth", self.depth.as_ref()),
            ("position", self.position.as_ref()),
            ("sonar", self.sonar.as_ref()),
            ("actuators", self.actuators.as_ref()),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_spell_out() {
        let s = Source::new("/rc", &["channels[0..3]", "x"]);
        assert_eq!(
            s.expanded().unwrap(),
            ["channels[0]", "channels[1]", "channels[2]", "x"]
        );
    }

    #[test]
    fn a_spec_reads_from_yaml() {
        let y = "file: dive.bag\nspan_s: [2, 60]\nstack: mavros\nattitude: {topic: /imu, quaternion: orientation, frame: enu}\ndepth: {topic: /p, fields: [fluid_pressure], unit: pa}\n";
        let s: LogSpec = serde_yaml_ng::from_str(y).unwrap();
        assert_eq!(s.stack, Some(Stack::Mavros));
        assert_eq!(s.depth.unwrap().unit, Some(Unit::Pa));
        assert_eq!(s.attitude.unwrap().frame, Some(Frame::Enu));
    }
}
