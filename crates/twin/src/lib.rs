//! The digital twin: simulates the seed-001 reference vehicle and writes synthetic inputs in
//! exactly the formats real users have, so every stage can be checked against a known truth.

pub mod auv;
pub mod cfd;
pub mod dsrv;
pub mod effect;
pub mod field;
pub mod pool;
pub mod six;
pub mod tank;
pub mod world;

/// Writes one twin run: its `files` into `cases_dir/<name>/`, its true motion and what it
/// hides into `truth_dir/<name>.csv` and `<name>.json` (outside `cases/`).
pub fn write_run(
    cases_dir: &std::path::Path,
    truth_dir: &std::path::Path,
    name: &str,
    files: &[(&str, String)],
    truth_csv: &str,
    record: &impl serde::Serialize,
) -> anyhow::Result<std::path::PathBuf> {
    let dir = cases_dir.join(name);
    std::fs::create_dir_all(&dir)?;
    std::fs::create_dir_all(truth_dir)?;
    for (file, text) in files {
        hydrofit_core::fsutil::write_atomic(&dir.join(file), text.as_bytes())?;
    }
    hydrofit_core::fsutil::write_atomic(
        &truth_dir.join(format!("{name}.csv")),
        truth_csv.as_bytes(),
    )?;
    hydrofit_core::fsutil::write_atomic(
        &truth_dir.join(format!("{name}.json")),
        &hydrofit_core::fsutil::json_bytes(record)?,
    )?;
    Ok(dir)
}

/// The spread of a log's channel `z` (times `t`) about the truth (`truth_z` at `truth_t`) when
/// the log's own lateness is taken out: the smallest standard deviation, over constant lags
/// from 0 to `max_lag_s` in 5 ms steps, of `z(t) - truth(t - lag)` about its mean. What a
/// perfect model with a lag would leave of the log: its noise, together with whatever of its
/// timing no constant lag explains (a row carrying a sensor sample of varying age).
pub fn noise_about_lateness(
    t: &[f64],
    z: &[f64],
    truth_t: &[f64],
    truth_z: &[f64],
    max_lag_s: f64,
) -> f64 {
    let steps = (max_lag_s / 0.005).round() as usize;
    (0..=steps)
        .map(|k| {
            let lag = k as f64 * 0.005;
            let e: Vec<f64> = t
                .iter()
                .zip(z)
                .filter(|(tk, zk)| zk.is_finite() && *tk - lag >= truth_t[0])
                .map(|(&tk, &zk)| zk - hydrofit_core::interp::interp(truth_t, truth_z, tk - lag))
                .collect();
            let n = e.len() as f64;
            let mean = e.iter().sum::<f64>() / n;
            (e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}
