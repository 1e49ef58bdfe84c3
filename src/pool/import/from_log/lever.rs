//! A velocity measured away from the centre of gravity. A DVL mounted at `at` (body frame,
//! from the centre of gravity) measures the velocity of its own point, `v + omega x at`
//! (Fossen 2011, sect. 2.5: a rigid body's velocity at a point): a BlueROV2's DVL 0.2 m behind
//! the centre reads 0.1 m/s of sway in a 0.5 rad/s turn that the vehicle never had. The
//! body rates logged beside it (`log.rates`, interpolated to the velocity's times) take
//! `omega x at` off, so the fusion and the fit see the centre of gravity's velocity.

use crate::core::diag::InputError;
use crate::pool::import::log_spec::{Frame, Source};

/// Body rates: their times and (p, q, r) samples, rad/s.
type Rates<'a> = (&'a [f64], &'a [[f64; 3]]);

/// Checks `at` before the log is read: only a velocity has it, as a sensor position in metres,
/// and not on a world-frame velocity (an estimator's velocity is of its own reference point).
pub(super) fn check_at(name: &str, src: &Source, shown: &str) -> Result<(), InputError> {
    let Some(at) = src.at else {
        return Ok(());
    };
    let fail = |what: String, fix: &str| Err(InputError::file(shown, what, fix.to_string()));
    if name != "velocity" {
        return fail(
            format!("the {name} on `{}` has `at`", src.topic),
            "`at` places a DVL away from the centre of gravity (`log.velocity.at`); leave it out of this signal",
        );
    }
    let what = |s: &str| format!("the velocity on `{}` has `at`, {s}", src.topic);
    if !at.iter().all(|x| x.is_finite() && x.abs() <= 20.0) {
        return fail(
            what("not a sensor position (metres from the centre of gravity, each within 20 m)"),
            "give `at: [x, y, z]` in metres, x forward, y starboard, z down",
        );
    }
    if matches!(src.frame, Some(Frame::Ned | Frame::Enu)) {
        return fail(
            what(
                "but it is in a world frame: an estimator's velocity is of its own reference point",
            ),
            "leave `at` out, or map the DVL's own body-frame velocity",
        );
    }
    Ok(())
}

/// Moves the velocity samples `rows` (at times `t`) from `src.at` (when it is set, checked by
/// [`check_at`]) to the centre of gravity.
pub(super) fn to_centre(
    t: &[f64],
    rows: &mut [[f64; 3]],
    src: &Source,
    rates: Option<Rates>,
    shown: &str,
) -> Result<(), InputError> {
    let Some(at) = src.at else {
        return Ok(());
    };
    let Some(rates) = rates.filter(|r| r.0.len() >= 2) else {
        return Err(InputError::file(
            shown,
            format!(
                "the velocity on `{}` has `at`, and the log's rates are not mapped: the lever arm's omega x at needs them",
                src.topic
            ),
            "map the body rates in run.yaml's `log.rates` (an IMU's angular_velocity)",
        ));
    };
    for (t, v) in t.iter().zip(rows.iter_mut()) {
        let wxr: [f64; 3] = nalgebra::Vector3::from(at_time(rates, *t))
            .cross(&nalgebra::Vector3::from(at))
            .into();
        for j in 0..3 {
            v[j] -= wxr[j];
        }
    }
    Ok(())
}

/// The rates at time `t`: linear between the samples around it, the nearest outside them.
fn at_time((times, rows): Rates, t: f64) -> [f64; 3] {
    let k = times.partition_point(|&x| x <= t);
    if k == 0 {
        return rows[0];
    }
    if k == times.len() {
        return rows[k - 1];
    }
    let (t0, t1) = (times[k - 1], times[k]);
    let a = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
    std::array::from_fn(|j| rows[k - 1][j] * (1.0 - a) + rows[k][j] * a)
}

#[cfg(test)]
mod tests {
    use super::super::super::log_spec::LogSpec;
    use super::super::read;
    use hydrofit_logs::write::{self, McapCompression, McapWriter};

    /// A vehicle that only turns (r = 0.5 rad/s, no translation) with a DVL 0.3 m behind and
    /// 0.2 m below its centre: the DVL reads v = r x_at = -0.15 m/s of sway; with `at` the
    /// run's velocity is zero again. Without rates mapped, `at` is an error that says so.
    #[test]
    fn a_dvl_away_from_the_centre_is_moved_to_it() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("run.mcap");
        let mut bag = McapWriter::create(&path, McapCompression::None).unwrap();
        let dvl = bag.add_topic("/dvl", "geometry_msgs/TwistStamped").unwrap();
        let imu = bag.add_topic("/imu", "sensor_msgs/Imu").unwrap();
        let (s_dvl, s_imu) = (
            bag.schema(dvl).unwrap().clone(),
            bag.schema(imu).unwrap().clone(),
        );
        let (r, at) = (0.5, [-0.3, 0.0, 0.2]);
        for k in 0..100 {
            let t = 1.7e9 + k as f64 * 0.05;
            let w = [("header.stamp", t), ("angular_velocity.z", r)];
            bag.write(imu, t, &write::message(&s_imu, &w).unwrap())
                .unwrap();
            if k % 4 == 1 {
                // omega x at = (0, 0, r) x (-0.3, 0, 0.2) = (0, -0.3 r, 0).
                let v = [("header.stamp", t), ("twist.linear.y", r * at[0])];
                bag.write(dvl, t, &write::message(&s_dvl, &v).unwrap())
                    .unwrap();
            }
        }
        bag.finish().unwrap();
        let spec = |at: &str, rates: bool| -> LogSpec {
            let mut y = format!(
                "file: run.mcap\nvelocity: {{topic: /dvl, fields: [twist.linear.x, twist.linear.y, twist.linear.z]{at}}}\n"
            );
            if rates {
                y += "rates: {topic: /imu, fields: [angular_velocity.x, angular_velocity.y, angular_velocity.z]}\n";
            }
            serde_yaml_ng::from_str(&y).unwrap()
        };
        let raw = read(d.path(), ".", &spec("", true), None).unwrap();
        let v = &raw.nav.expect("a velocity").cols[1];
        assert!(v.iter().all(|v| (v + 0.15).abs() < 1e-9), "{v:?}");
        let moved = read(d.path(), ".", &spec(", at: [-0.3, 0, 0.2]", true), None).unwrap();
        let nav = moved.nav.expect("a velocity");
        for j in 0..3 {
            assert!(
                nav.cols[j].iter().all(|v| v.abs() < 1e-9),
                "{j}: {:?}",
                nav.cols[j]
            );
        }
        let e = read(d.path(), ".", &spec(", at: [-0.3, 0, 0.2]", false), None).unwrap_err();
        assert!(e.to_string().contains("map the body rates"), "{e}");
        let mut on_rates = spec("", true);
        on_rates.rates.as_mut().unwrap().at = Some([0.1, 0.0, 0.0]);
        let e = read(d.path(), ".", &on_rates, None).unwrap_err();
        assert!(
            e.to_string().contains("the rates on `/imu` has `at`"),
            "{e}"
        );
    }
}
