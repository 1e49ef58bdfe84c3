//! The signals read from a vehicle's log laid out as a run folder's CSV logs: each vector in SI
//! units and the body frame, resampled where the fusion needs one time base, and the command
//! turned into the body wrench (per thruster through `vehicle.thrusters`).

use super::super::csvlog::Log;
use super::super::log_spec::{Frame, Source, Unit};
use super::super::{DEPTH, IMU, NAV, SONAR, THRUST, UWB};
use super::{Chosen, FromLog, Samples};
use crate::core::diag::InputError;
use crate::core::model::thrusters::{Command, Thrusters};
use std::collections::BTreeMap;

/// Standard gravity, for pressure to depth and g to m/s^2.
const G: f64 = 9.80665;

/// A vector signal in SI units and the body frame, on its own time base.
struct Series {
    topic: String,
    t: Vec<f64>,
    rows: Vec<[f64; 3]>,
}

/// The run's logs from the signals' samples.
pub(super) fn build(
    out: &mut FromLog,
    sources: &[(&'static str, Chosen)],
    samples: &BTreeMap<&'static str, Samples>,
    thrusters: Option<&Thrusters>,
    shown: &str,
) -> Result<(), InputError> {
    let src = |n: &str| source_of(sources, n);
    say_samples(out, samples, shown)?;
    out.thrust = match (samples.get("command"), samples.get("wrench")) {
        (_, Some(w)) => Some(wrench(w, src("wrench").expect("a source"), shown)?),
        (Some(c), None) => Some(per_thruster(c, thrusters, shown)?),
        (None, None) => None,
    };
    let series = |n: &str, q: Quantity| {
        samples
            .get(n)
            .map(|s| vector(s, src(n).expect("a source"), q))
    };
    let attitude = samples
        .get("attitude")
        .map(|s| attitude(s, src("attitude").expect("a source")));
    let rates = series("rates", Quantity::Rate);
    let accel = series("acceleration", Quantity::Acceleration);
    let mut velocity = series("velocity", Quantity::Velocity);
    if let Some(v) = velocity.as_mut() {
        let r = rates.as_ref().map(|r| (r.t.as_slice(), r.rows.as_slice()));
        super::lever::to_centre(
            &v.t,
            &mut v.rows,
            src("velocity").expect("a source"),
            r,
            shown,
        )?;
    }
    let world = src("velocity")
        .and_then(|s| s.frame)
        .filter(|f| matches!(f, Frame::Ned | Frame::Enu));
    // What the navigation log carries itself (its AHRS's attitude and rates, on its own
    // messages) stays in it, as in nav.csv; the rest is the IMU's.
    let on_nav = |s: &Option<Series>| match (&velocity, s) {
        (Some(v), Some(s)) => world.is_none() && s.topic == v.topic && s.t == v.t,
        _ => false,
    };
    let (att_nav, rates_nav) = (on_nav(&attitude), on_nav(&rates));
    if let Some(v) = velocity {
        let nav_att = attitude.as_ref().filter(|_| att_nav);
        let nav_rates = rates.as_ref().filter(|_| rates_nav);
        out.nav = Some(nav(
            v,
            world,
            attitude.as_ref(),
            [nav_att, nav_rates],
            shown,
        )?);
    }
    let keep = |s: Option<Series>, on: bool| s.filter(|_| !on);
    out.imu = imu(keep(attitude, att_nav), keep(rates, rates_nav), accel);
    out.depth = samples
        .get("depth")
        .map(|s| depth(s, src("depth").expect("a source")));
    out.actuators = (samples.get("actuators"))
        .map(|s| super::actuators::lay_out(s, src("actuators").expect("a source"), shown))
        .transpose()?;
    positions(out, sources, samples, shown)
}

/// The source of signal `name`, if the run reads it.
fn source_of<'a>(sources: &'a [(&'static str, Chosen)], name: &str) -> Option<&'a Source> {
    sources
        .iter()
        .find(|(k, _)| *k == name)
        .map(|(_, c)| &c.source)
}

/// The position fixes (UWB, acoustic positioning, motion capture) and the sonar's track, in
/// the pool frame; a note where the frame is left to its default beside an ENU attitude.
fn positions(
    out: &mut FromLog,
    sources: &[(&'static str, Chosen)],
    samples: &BTreeMap<&'static str, Samples>,
    shown: &str,
) -> Result<(), InputError> {
    let src = |n: &str| source_of(sources, n);
    for (name, width, to) in [
        ("position", UWB.len() - 1, &mut out.uwb),
        ("sonar", SONAR.len() - 1, &mut out.sonar),
    ] {
        if let Some(s) = samples.get(name) {
            let frame = src(name).and_then(|c| c.frame);
            *to = Some(position(s, width, frame, name, shown)?);
            let att = src("attitude");
            let enu_attitude = att.is_some_and(|a| {
                (a.quaternion.is_some() || a.fields.len() == 4)
                    && matches!(a.frame, None | Some(Frame::Enu))
            });
            if frame.is_none() && enu_attitude {
                out.notes.push(format!(
                    "{shown}: the {name} is read in the pool frame (x, y level, z down), the \
                     attitude as an ENU quaternion (ROS's convention): if the {name} is ENU too \
                     (x east, y north, z up, as ROS and most motion-capture systems publish \
                     it), write `frame: enu` in `log.{name}`"
                ));
            }
        }
    }
    Ok(())
}

/// A position log (x, y and, where there are `width` = 3 columns, z) in the pool frame (z
/// down). One in ENU (`frame: enu`: ROS's world frame, REP-103, and most motion-capture
/// systems' as ROS publishes them) is turned into it: x north, y east, z down, as an ENU
/// attitude is.
fn position(
    s: &Samples,
    width: usize,
    frame: Option<Frame>,
    name: &str,
    shown: &str,
) -> Result<Log, InputError> {
    let enu = match frame {
        None | Some(Frame::Ned) => false,
        Some(Frame::Enu) => true,
        Some(f @ (Frame::Frd | Frame::Flu)) => {
            return Err(InputError::file(
                shown,
                format!(
                    "the {name} is given in the body frame `{}`, but a position is in a world frame",
                    format!("{f:?}").to_lowercase()
                ),
                format!(
                    "write `frame: ned` (the pool frame, z down; the default) or `frame: enu` (x east, y north, z up) in run.yaml's `log.{name}`"
                ),
            ));
        }
    };
    let rows: Vec<[f64; 3]> = (s.rows.iter())
        .map(|r| {
            let v = [0, 1, 2].map(|j| r.get(j).copied().unwrap_or(f64::NAN));
            if enu {
                super::super::frames::enu_to_ned(v)
            } else {
                v
            }
        })
        .collect();
    let cols: Vec<Vec<f64>> = (0..width)
        .map(|j| rows.iter().map(|r| r[j]).collect())
        .collect();
    Ok(log_of(&s.t, cols, width))
}

/// A log with the given columns (all-NaN columns marked absent), padded to `width`.
fn log_of(t: &[f64], mut cols: Vec<Vec<f64>>, width: usize) -> Log {
    cols.resize(width, vec![f64::NAN; t.len()]);
    let present = cols.iter().map(|c| c.iter().any(|x| !x.is_nan())).collect();
    Log {
        t: t.to_vec(),
        cols,
        notes: Vec::new(),
        present,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Quantity {
    Rate,
    Acceleration,
    Velocity,
}

/// A vector's three fields in SI units, and in the body frame (FRD) when given in FLU.
fn vector(s: &Samples, src: &Source, q: Quantity) -> Series {
    let k = match (q, src.unit) {
        (Quantity::Rate, Some(Unit::DegPerS)) => std::f64::consts::PI / 180.0,
        (Quantity::Acceleration, Some(Unit::G)) => G,
        (Quantity::Velocity, Some(Unit::CmPerS)) => 0.01,
        _ => 1.0,
    };
    let flu = src.frame == Some(Frame::Flu);
    let rows = s
        .rows
        .iter()
        .map(|r| {
            let v = [0, 1, 2].map(|j| k * r.get(j).copied().unwrap_or(f64::NAN));
            if flu { [v[0], -v[1], -v[2]] } else { v }
        })
        .collect();
    Series {
        topic: s.topic.clone(),
        t: s.t.clone(),
        rows,
    }
}

/// Roll, pitch, yaw (rad, NED / FRD), from three angles or a quaternion (`quaternion: <path>`,
/// or four fields x, y, z, w: a table's flat columns).
fn attitude(s: &Samples, src: &Source) -> Series {
    let k = if src.unit == Some(Unit::Deg) {
        std::f64::consts::PI / 180.0
    } else {
        1.0
    };
    let rows = s
        .rows
        .iter()
        .map(|r| match src.quaternion.is_some() || r.len() == 4 {
            true => {
                super::super::frames::euler_from_quaternion([r[0], r[1], r[2], r[3]], src.frame)
            }
            false => {
                let e = [0, 1, 2].map(|j| k * r.get(j).copied().unwrap_or(f64::NAN));
                super::super::frames::euler_to_ned(e, src.frame)
            }
        })
        .collect();
    Series {
        topic: s.topic.clone(),
        t: s.t.clone(),
        rows,
    }
}

/// `s` at the times `t`: linearly interpolated, yaw (column 2 of an attitude) unwrapped
/// first; NaN outside its span.
fn resample(s: &Series, t: &[f64], unwrap_yaw: bool) -> Vec<[f64; 3]> {
    if s.t == t {
        return s.rows.clone();
    }
    let mut rows = s.rows.clone();
    if unwrap_yaw {
        let tau = 2.0 * std::f64::consts::PI;
        let mut offset = 0.0;
        for (row, w) in rows.iter_mut().skip(1).zip(s.rows.windows(2)) {
            offset -= ((w[1][2] - w[0][2]) / tau).round() * tau;
            row[2] = w[1][2] + offset;
        }
    }
    t.iter()
        .map(|&x| {
            if s.t.is_empty() || x < s.t[0] || x > s.t[s.t.len() - 1] {
                return [f64::NAN; 3];
            }
            let k = s.t.partition_point(|v| *v <= x).clamp(1, s.t.len() - 1);
            let (t0, t1) = (s.t[k - 1], s.t[k]);
            let w = if t1 > t0 { (x - t0) / (t1 - t0) } else { 1.0 };
            std::array::from_fn(|j| rows[k - 1][j] + w * (rows[k][j] - rows[k - 1][j]))
        })
        .collect()
}

/// The IMU log (attitude, rates, specific force) on the time base of the rates, or of the
/// attitude when there are no rates, or of the accelerometer; the others interpolated.
fn imu(attitude: Option<Series>, rates: Option<Series>, accel: Option<Series>) -> Option<Log> {
    let base = rates.as_ref().or(attitude.as_ref()).or(accel.as_ref())?;
    let t = base.t.clone();
    let mut cols = Vec::new();
    for (s, yaw) in [(&attitude, true), (&rates, false), (&accel, false)] {
        let rows = s.as_ref().map(|s| resample(s, &t, yaw));
        for j in 0..3 {
            cols.push(match &rows {
                Some(r) => r.iter().map(|x| x[j]).collect(),
                None => vec![f64::NAN; t.len()],
            });
        }
    }
    Some(log_of(&t, cols, IMU.len() - 1))
}

/// The navigation log: the velocity (turned into the body frame with `attitude` when it was
/// logged in a world frame), with its `own` attitude and rates (those on its messages).
fn nav(
    v: Series,
    world: Option<Frame>,
    attitude: Option<&Series>,
    own: [Option<&Series>; 2],
    shown: &str,
) -> Result<Log, InputError> {
    let t = v.t.clone();
    let mut uvw = v.rows.clone();
    if let Some(frame) = world {
        let a = attitude.ok_or_else(|| {
            InputError::file(
                shown,
                format!("the velocity on `{}` is in a world frame, and the log gives no attitude to turn it into the body frame", v.topic),
                "name the attitude's topic in run.yaml's `log.attitude`, or log the body velocity",
            )
        })?;
        let e = resample(a, &t, true);
        uvw = uvw
            .iter()
            .zip(&e)
            .map(|(x, e)| super::super::frames::world_to_body(*x, *e, frame))
            .collect();
    }
    let mut cols: Vec<Vec<f64>> = (0..3).map(|j| uvw.iter().map(|r| r[j]).collect()).collect();
    for s in own {
        for j in 0..3 {
            cols.push(s.map_or(vec![f64::NAN; t.len()], |s| {
                s.rows.iter().map(|r| r[j]).collect()
            }));
        }
    }
    Ok(log_of(&t, cols, NAV.len() - 1))
}

/// Each signal's topic, sample count and clock, in the run's notes; a signal with no sample
/// in the run is an error.
fn say_samples(
    out: &mut FromLog,
    samples: &BTreeMap<&'static str, Samples>,
    shown: &str,
) -> Result<(), InputError> {
    for (name, s) in samples {
        if s.t.is_empty() {
            // A topic whose file holds a header only, or whose messages all fall outside the
            // run's span: said as such, not as a signal with no fields.
            return Err(InputError::file(
                shown,
                format!("the {name} topic `{}` has no messages in the run", s.topic),
                "check that the topic was recorded (`hydrofit inspect` of the log lists each topic's count and span), or give the run's `span_s` inside it",
            ));
        }
        let clock = match (s.stamped, s.received) {
            (0, _) => "receive times",
            (_, 0) => "header stamps",
            _ => "header stamps where they agree with the receive times, else receive times",
        };
        out.notes.push(format!(
            "{shown}: the {name} from `{}` ({} samples, {clock})",
            s.topic,
            s.t.len()
        ));
    }
    Ok(())
}

/// Depth (m, positive down) from a depth, an altitude or a pressure.
fn depth(s: &Samples, src: &Source) -> Log {
    let rho_g = src.density_kg_m3.unwrap_or(1000.0) * G;
    // Absolute pressure: the standard atmosphere at the surface (the run's own surface
    // pressure is not logged; a constant offset in depth does not change the dynamics).
    const ATM_PA: f64 = 101_325.0;
    let f = |x: f64| match src.unit {
        Some(Unit::Cm) => 0.01 * x,
        Some(Unit::UpM) => -x,
        Some(Unit::Pa) => x / rho_g,
        Some(Unit::PaAbs) => (x - ATM_PA) / rho_g,
        Some(Unit::HpaAbs) => (100.0 * x - ATM_PA) / rho_g,
        _ => x,
    };
    let col = s
        .rows
        .iter()
        .map(|r| f(r.first().copied().unwrap_or(f64::NAN)))
        .collect();
    log_of(&s.t, vec![col], DEPTH.len() - 1)
}

/// The commanded body wrench logged as such: X, Y, Z, K, M, N (or X, Y, Z, N), in the body
/// frame (FLU turned into FRD).
fn wrench(s: &Samples, src: &Source, shown: &str) -> Result<Log, InputError> {
    let n = s.rows.first().map_or(0, Vec::len);
    if n != 6 && n != 4 {
        return Err(InputError::file(
            shown,
            format!(
                "the wrench on `{}` has {n} fields; it needs X, Y, Z, K, M, N or X, Y, Z, N",
                s.topic
            ),
            "name six fields (or four) in run.yaml's `log.wrench.fields`",
        ));
    }
    let flip = if src.frame == Some(Frame::Flu) {
        -1.0
    } else {
        1.0
    };
    // THRUST's column order: X, Y, Z, N, K, M.
    let (x, y, z, nn, k, m) = if n == 6 {
        (0, 1, 2, 5, Some(3), Some(4))
    } else {
        (0, 1, 2, 3, None, None)
    };
    let col = |j: usize, sign: f64| s.rows.iter().map(|r| sign * r[j]).collect::<Vec<f64>>();
    let mut cols = vec![col(x, 1.0), col(y, flip), col(z, flip), col(nn, flip)];
    cols.push(k.map_or(vec![f64::NAN; s.t.len()], |k| col(k, 1.0)));
    cols.push(m.map_or(vec![f64::NAN; s.t.len()], |m| col(m, flip)));
    Ok(log_of(&s.t, cols, THRUST.len() - 1))
}

/// The body wrench of per-thruster commands, through the thrusters' curve and allocation.
fn per_thruster(
    s: &Samples,
    thrusters: Option<&Thrusters>,
    shown: &str,
) -> Result<Log, InputError> {
    let t = thrusters.ok_or_else(|| {
        InputError::file(
            shown,
            format!("`{}` carries per-thruster commands, and pipeline.yaml describes no thrusters", s.topic),
            "add vehicle.thrusters to pipeline.yaml (a layout such as bluerov2, or units with position_m and direction, and a curve), or log the body wrench",
        )
    })?;
    let a = t.allocation();
    let n = s.rows.first().map_or(0, Vec::len);
    if n != a.units.len() {
        return Err(InputError::file(
            shown,
            format!(
                "`{}` gives {n} commands per message and vehicle.thrusters has {} units",
                s.topic,
                a.units.len()
            ),
            "name one field per thruster, in vehicle.thrusters' order, in run.yaml's `log.command.fields`",
        ));
    }
    let (rows, notes) = match t.command {
        Command::Pwm => super::pulse::as_neutral(&s.rows, t.neutral_us, &s.topic, shown),
        _ => (s.rows.clone(), Vec::new()),
    };
    let tau: Vec<[f64; 6]> = rows.iter().map(|r| a.wrench(r)).collect();
    // THRUST's column order: X, Y, Z, N, K, M.
    let cols = [0, 1, 2, 5, 3, 4]
        .iter()
        .map(|&j| tau.iter().map(|w| w[j]).collect())
        .collect();
    let mut log = log_of(&s.t, cols, THRUST.len() - 1);
    log.notes.extend(notes);
    let moves = |j: usize| a.columns.iter().any(|c| c[j].abs() > 1e-12);
    log.present[4] = moves(3);
    log.present[5] = moves(4);
    Ok(log)
}
