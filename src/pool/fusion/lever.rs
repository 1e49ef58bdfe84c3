//! A navigation log's velocity measured away from the centre of gravity (`fusion: {nav_at_m:
//! [x, y, z]}`). A DVL measures the velocity of the point it is mounted at, `v + omega x at`
//! (Fossen 2011, sect. 2.5): 0.3 m behind the centre, a 0.5 rad/s turn reads 0.15 m/s of sway
//! the vehicle never had, which a fit takes for a sway-yaw coupling. For the runs whose
//! velocity comes from `nav.csv` (or a log without `log.velocity.at`), the fused rates take
//! `omega x at` off the fused velocity, so the fit and the diagnosis see the centre's.

use super::{Fused, rotation};
use crate::pool::import::PoolRun;

/// The largest offset of a sensor from the centre of gravity `nav_at_m` takes, m per axis.
pub const MAX_AT_M: f64 = 20.0;

/// Moves the navigation log's fused velocity channels of `run` from `at` (the sensor's
/// position, body frame, m) to the centre of gravity, with the fused yaw rate and the run's
/// roll and pitch rates where it has them (taken as zero, and said, where it has none). Their
/// standard deviations take in the rates'. Returns the sentence for the run's notes; an error
/// for an `at` that is not a position, for a run whose log places its DVL itself, and for a
/// run with no yaw rate.
pub fn move_to_centre(run: &PoolRun, fused: &mut Fused, at: [f64; 3]) -> anyhow::Result<String> {
    if !at.iter().all(|x| x.is_finite() && x.abs() <= MAX_AT_M) {
        anyhow::bail!(
            "fusion.nav_at_m = {at:?}: not a sensor position\n  help: give [x, y, z] in metres from the centre of gravity (x forward, y starboard, z down), each within {MAX_AT_M} m"
        );
    }
    let in_log = (run.meta.log.as_ref())
        .and_then(|l| l.velocity.as_ref())
        .and_then(|v| v.at);
    if let Some(a) = in_log {
        anyhow::bail!(
            "run {}: its run.yaml places the DVL with `log.velocity.at: {a:?}` and the pool stage with `fusion.nav_at_m: {at:?}`: it would be moved twice\n  help: give the position once, in the pool stage's `fusion` for every run or in each run's `log.velocity`",
            run.name
        );
    }
    let channels: Vec<usize> = (fused.stats.nav.iter())
        .filter_map(|(name, _)| ["u", "v", "w"].iter().position(|c| c == name))
        .collect();
    if channels.is_empty() {
        return Ok(format!(
            "fusion.nav_at_m: run {} has no navigation-log velocity to move",
            run.name
        ));
    }
    let (Some(r), Some(r_std)) = (fused.vel[3].clone(), fused.std[3].clone()) else {
        anyhow::bail!(
            "run {}: fusion.nav_at_m needs the yaw rate to move the navigation log's velocity to the centre of gravity, and the run gives none\n  help: log a heading or a gyro (the navigation log's yaw or r, an IMU)",
            run.name
        );
    };
    let rp = match fused.roll_pitch.rate[0].is_some() {
        true => fused.roll_pitch.clone(),
        false => rotation::fuse(run, &fused.t, &mut Vec::new()),
    };
    let n = fused.t.len();
    let zeros = vec![0.0; n];
    let pick = |k: usize| -> (&[f64], &[f64]) {
        match (&rp.rate[k], &rp.rate_std[k]) {
            (Some(w), Some(s)) if w.len() == n && s.len() == n => (w, s),
            _ => (&zeros, &zeros),
        }
    };
    let (p, q) = (pick(0), pick(1));
    let without_pq = rp.rate[0].is_none() || rp.rate[1].is_none();
    let mut largest = 0.0f64;
    for k in 0..n {
        let w = [p.0[k], q.0[k], r[k]];
        let ws = [p.1[k], q.1[k], r_std[k]];
        let (lever, var) = cross(w, ws, at);
        for &j in &channels {
            for v in [fused.vel[j].as_mut(), fused.tracked.vel[j].as_mut()]
                .into_iter()
                .flatten()
            {
                v[k] -= lever[j];
            }
            for s in [fused.std[j].as_mut(), fused.tracked.std[j].as_mut()]
                .into_iter()
                .flatten()
            {
                s[k] = (s[k] * s[k] + var[j]).sqrt();
            }
            if lever[j].is_finite() {
                largest = largest.max(lever[j].abs());
            }
        }
    }
    let names: Vec<&str> = channels.iter().map(|&j| ["u", "v", "w"][j]).collect();
    Ok(format!(
        "the navigation log's {} moved from its sensor at [{}, {}, {}] m to the centre of gravity (fusion.nav_at_m): omega x at took off up to {largest:.3} m/s, with the fused yaw rate{}",
        names.join(", "),
        at[0],
        at[1],
        at[2],
        match without_pq {
            true => " (the run has no roll and pitch rates: taken as zero)",
            false => " and the roll and pitch rates",
        }
    ))
}

/// `omega x at` and the variance of each component from the rates' standard deviations `ws`.
fn cross(w: [f64; 3], ws: [f64; 3], at: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let lever = nalgebra::Vector3::from(w)
        .cross(&nalgebra::Vector3::from(at))
        .into();
    let sq = |x: f64| x * x;
    let var = [
        sq(ws[1] * at[2]) + sq(ws[2] * at[1]),
        sq(ws[2] * at[0]) + sq(ws[0] * at[2]),
        sq(ws[0] * at[1]) + sq(ws[1] * at[0]),
    ];
    (lever, var)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run whose log places its DVL (`log.velocity.at`) is not moved a second time; an
    /// `at` that is no position is refused.
    #[test]
    fn the_position_is_given_once_and_as_a_position() {
        use crate::twin::field;
        let d = tempfile::tempdir().unwrap();
        let runs = vec![field::default_runs().remove(4)];
        let (cases, truth) = (d.path().join("cases"), d.path().join("truth"));
        field::write_runs(&cases, &truth, &runs, &field::Hidden::default(), 3).unwrap();
        let dir = format!("cases/{}", runs[0].name);
        let files: Vec<String> = ["depth.csv", "nav.csv", "run.yaml", "thrust.csv"]
            .iter()
            .map(|f| format!("{dir}/{f}"))
            .collect();
        let mut run = crate::pool::import::load(d.path(), &dir, &files, None).unwrap();
        let mut fused = super::super::fuse(&run, &Default::default());
        let e = move_to_centre(&run, &mut fused.clone(), [f64::NAN, 0.0, 0.0]).unwrap_err();
        assert!(e.to_string().contains("not a sensor position"), "{e}");
        let before = fused.vel[1].clone();
        let note = move_to_centre(&run, &mut fused, [-0.3, 0.0, 0.0]).unwrap();
        assert!(note.contains("taken as zero"), "{note}");
        assert_ne!(before, fused.vel[1]);
        run.meta.log = Some(
            serde_yaml_ng::from_str(
                "file: dive.mcap\nvelocity: {topic: /dvl, fields: [x, y, z], at: [-0.3, 0, 0]}",
            )
            .unwrap(),
        );
        let e = move_to_centre(&run, &mut fused, [-0.3, 0.0, 0.0]).unwrap_err();
        assert!(e.to_string().contains("moved twice"), "{e}");
    }
}
