//! The topics common vehicle software writes, so a run folder needs no mapping for them:
//! a BlueROV2 under ArduSub with mavros (ROS 1 or 2), an ArduSub DataFlash log, an ArduSub
//! MAVLink telemetry log, a PX4 vehicle's ULog or its ROS 2 topics (`/fmu/out/...`). Sources: mavros `rc_io`, `imu`, `local_position` and
//! `global_position` plugins; ArduPilot's log messages (RCOU, ATT, IMU, XKF1, BARO) and MAVLink's
//! common messages; PX4's uORB topics (`msg/*.msg` of PX4-Autopilot, as `px4_msgs` mirrors
//! them). A default whose topic the log lacks is left out (with a note).

use super::log_spec::{Frame, Source, Stack, Unit};

/// The default sources of `stack`, for `n` thrusters commanded in -1..1 (`normalised`) or
/// otherwise (a pulse width), best first per signal (the first whose topic the log has is
/// used).
pub fn defaults(stack: Stack, n: usize, normalised: bool) -> Vec<(&'static str, Source)> {
    match stack {
        Stack::Mavros => mavros(n),
        Stack::Ardusub => ardusub(n),
        Stack::ArdusubTlog => ardusub_tlog(n),
        Stack::Px4 => px4(n, normalised),
        Stack::None => Vec::new(),
    }
}

fn mavros(n: usize) -> Vec<(&'static str, Source)> {
    let imu = "/mavros/imu/data";
    vec![
        (
            "command",
            Source::new("/mavros/rc/out", &[&format!("channels[0..{n}]")]),
        ),
        (
            "attitude",
            Source::quaternion(imu, "orientation", Frame::Enu),
        ),
        ("rates", xyz(imu, "angular_velocity").frame(Frame::Flu)),
        (
            "acceleration",
            xyz(imu, "linear_acceleration").frame(Frame::Flu),
        ),
        (
            "velocity",
            xyz("/mavros/local_position/odom", "twist.twist.linear").frame(Frame::Flu),
        ),
        (
            "depth",
            Source::new("/mavros/global_position/rel_alt", &["data"]).unit(Unit::UpM),
        ),
    ]
}

fn ardusub(n: usize) -> Vec<(&'static str, Source)> {
    let c: Vec<String> = (1..=n).map(|k| format!("C{k}")).collect();
    let c: Vec<&str> = c.iter().map(String::as_str).collect();
    let mut out = vec![
        ("command", Source::new("RCOU", &c)),
        (
            "attitude",
            Source::new("ATT", &["Roll", "Pitch", "Yaw"]).unit(Unit::Deg),
        ),
    ];
    for imu in ["IMU[0]", "IMU"] {
        out.push(("rates", Source::new(imu, &["GyrX", "GyrY", "GyrZ"])));
        out.push(("acceleration", Source::new(imu, &["AccX", "AccY", "AccZ"])));
    }
    // The EKF's velocity (EKF3, else EKF2), north-east-down: a measurement only where a DVL
    // or a position fix aided it, which its status (XKF4 / NKF4) says (`from_log::aiding`).
    for ekf in ["XKF1[0]", "XKF1", "NKF1[0]", "NKF1"] {
        let v = Source::new(ekf, &["VN", "VE", "VD"]).frame(Frame::Ned);
        out.push(("velocity", v));
    }
    // ArduSub's external pressure sensor is the second barometer; its altitude is negative
    // under water.
    for baro in ["BARO[1]", "BARO"] {
        out.push(("depth", Source::new(baro, &["Alt"]).unit(Unit::UpM)));
    }
    out
}

fn ardusub_tlog(n: usize) -> Vec<(&'static str, Source)> {
    let s: Vec<String> = (1..=n).map(|k| format!("servo{k}_raw")).collect();
    let s: Vec<&str> = s.iter().map(String::as_str).collect();
    vec![
        ("command", Source::new("SERVO_OUTPUT_RAW", &s)),
        (
            "attitude",
            Source::new("ATTITUDE", &["roll", "pitch", "yaw"]),
        ),
        (
            "rates",
            Source::new("ATTITUDE", &["rollspeed", "pitchspeed", "yawspeed"]),
        ),
        (
            "velocity",
            Source::new("LOCAL_POSITION_NED", &["vx", "vy", "vz"]).frame(Frame::Ned),
        ),
        (
            "depth",
            Source::new("SCALED_PRESSURE2", &["press_abs"]).unit(Unit::HpaAbs),
        ),
    ]
}

/// PX4: each topic as its ULog names it, then as its ROS 2 bridge publishes it.
fn px4(n: usize, normalised: bool) -> Vec<(&'static str, Source)> {
    // The control allocator's motor commands (-1..1), or the PWM outputs (us).
    let command = match normalised {
        true => ("actuator_motors", format!("control[0..{n}]")),
        false => ("actuator_outputs", format!("output[0..{n}]")),
    };
    let one = |topic: &str, fields: &[&str]| Source::new(topic, fields);
    let signals: Vec<(&'static str, Source)> = vec![
        ("command", one(command.0, &[&command.1])),
        // Hamilton (w, x, y, z), body FRD to NED.
        (
            "attitude",
            one("vehicle_attitude", &["q[1]", "q[2]", "q[3]", "q[0]"]).frame(Frame::Ned),
        ),
        ("rates", one("vehicle_angular_velocity", &["xyz[0..3]"])),
        ("rates", one("sensor_combined", &["gyro_rad[0..3]"])),
        (
            "acceleration",
            one("sensor_combined", &["accelerometer_m_s2[0..3]"]),
        ),
        // The EKF's; `v_xy_valid` says where an aiding sensor measured it (`aiding`).
        (
            "velocity",
            one("vehicle_local_position", &["vx", "vy", "vz"]).frame(Frame::Ned),
        ),
        ("depth", one("vehicle_local_position", &["z"])),
    ];
    let bridged: Vec<_> = (signals.iter())
        .map(|(k, s)| {
            let topic = format!("/fmu/out/{}", s.topic);
            (*k, Source { topic, ..s.clone() })
        })
        .collect();
    signals.into_iter().chain(bridged).collect()
}

fn xyz(topic: &str, base: &str) -> Source {
    let f: Vec<String> = ["x", "y", "z"]
        .iter()
        .map(|c| format!("{base}.{c}"))
        .collect();
    let f: Vec<&str> = f.iter().map(String::as_str).collect();
    Source::new(topic, &f)
}
