//! End-to-end: bad inputs, killed builds and concurrent builds.

use crate::common::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The published reports, with the wall-clock times (the estimator comparison's and the
/// diagnosis's, the one part that legitimately differs between two builds) masked out.
fn reports(dir: &std::path::Path) -> Vec<String> {
    [
        "index.html",
        "parameters.json",
        "validation.json",
        "fusion.json",
        "diagnosis.json",
    ]
    .iter()
    .map(|f| {
        let text = mask_diagnosis_time(&read(dir, &format!("reports/{f}")));
        match (text.find("id=\"comparison\""), text.find("id=\"fusion\"")) {
            (Some(a), Some(b)) if a < b => {
                let table = &text[a..b];
                let masked: String = table
                    .split("<tr>")
                    .map(|row| {
                        // The last two cells of a row are time and evaluations; drop time.
                        let cells: Vec<&str> = row.split("<td>").collect();
                        if cells.len() > 3 {
                            cells[..cells.len() - 2].join("<td>") + "<td>" + cells[cells.len() - 1]
                        } else {
                            row.to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("<tr>");
                format!("{}{masked}{}", &text[..a], &text[b..])
            }
            _ => text,
        }
    })
    .collect()
}

/// Drops the diagnosis's "Took 15.2 s." (HTML) and `"elapsed_s": 15.2` (JSON).
fn mask_diagnosis_time(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = ["Took ", "\"elapsed_s\": "]
        .iter()
        .filter_map(|m| rest.find(m).map(|i| i + m.len()))
        .min()
    {
        out.push_str(&rest[..i]);
        rest = rest[i..]
            .trim_start_matches(|c: char| c.is_ascii_digit() || c == '.' || c == 'e' || c == '-');
    }
    out + rest
}

#[test]
fn a_bad_case_fails_only_what_depends_on_it() {
    let p = project();
    let dir = p.path();
    let bad = dir.join("cases/cfd/starccm/zz_bad.csv");
    std::fs::write(&bad, "\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (m/s)\"\n0.02,10,0.01\n0.04,10,0.o2\n0.06,10,0.03\n").unwrap();
    let o = run(dir, &["build"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("error: stage cfd[zz_bad] failed\n  cases/cfd/starccm/zz_bad.csv:3:9: cannot read \"0.o2\""), "{err}");
    assert!(
        err.contains(
            "not run because they depend on it: compare, fit, diagnose, export, validate, report"
        ),
        "{err}"
    );
    assert!(!dir.join("reports/index.html").exists());
    // The good imports are cached: fixing the file reruns it and the downstream only.
    std::fs::write(
        &bad,
        std::fs::read_to_string(&bad)
            .unwrap()
            .replace("0.o2", "0.02"),
    )
    .unwrap();
    let out = ok(dir, &["build"]);
    assert_eq!(ran(&out), 7, "{out}");
    assert!(
        !dir.join(".hydrofit/tmp").exists()
            || std::fs::read_dir(dir.join(".hydrofit/tmp"))
                .unwrap()
                .count()
                == 0
    );
}

/// A fit of pool runs alone whose every run fails to import says so, naming them, rather
/// than that it received no CFD cases (what it said before).
#[test]
fn a_fit_whose_every_run_failed_names_them() {
    let p = tempfile::tempdir().unwrap();
    let dir = p.path();
    std::fs::write(
        dir.join("pipeline.yaml"),
        "vehicle: {name: x, mass_kg: 30, inertia_kg_m2: {zz: 1}, dofs: [surge, yaw]}\nstages:\n  pool: {kind: pool, inputs: [\"cases/pool/*/\"]}\n  fit: {kind: fit, from: [pool]}\n",
    )
    .unwrap();
    for run in ["a", "b"] {
        let d = dir.join("cases/pool").join(run);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("run.yaml"), "role: train\n").unwrap();
        std::fs::write(
            d.join("thrust.csv"),
            "t,X_N,Y_N,Z_N,N_Nm\n0,1,0,0,0\n0.1,1,0,0,zz\n",
        )
        .unwrap();
    }
    let o = run(dir, &["build"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("error: stage fit failed\n  nothing to fit: every input failed upstream (pool[a], pool[b])"),
        "{err}"
    );
}

#[test]
fn input_error_classes_reach_the_user() {
    let cases: [(&str, &str); 5] = [
        ("", "the file is empty"),
        (
            "\"Physical Time: Physical Time (s)\";\"Body Velocity X Monitor: Velocity (m/s)\"\n0;1\n",
            ":1: the header is separated by ';', not commas",
        ),
        (
            "\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (m/s)\"\n0.02,1,0\n0.04,1,nan\n0.06,1,0\n",
            ":3:8: nan in column",
        ),
        (
            "\"Physical Time: Physical Time (s)\",\"Applied Force X Monitor: Force (N)\",\"Body Velocity X Monitor: Velocity (m/s)\"\n0.02,1,0\n0.06,1,0\n0.04,1,0\n",
            ":4:1: time goes backwards",
        ),
        (
            "\"Physical Time: Physical Time (s)\",\"Thrust: Force (N)\"\n0.02,1\n",
            ":1: no velocity column",
        ),
    ];
    let p = project();
    let dir = p.path();
    let only = "cases/cfd/starccm/one.csv";
    let spec = read(dir, "pipeline.yaml").replace("cases/cfd/starccm/*.csv", only);
    std::fs::write(dir.join("pipeline.yaml"), spec).unwrap();
    for (text, expect) in cases {
        std::fs::write(dir.join(only), text).unwrap();
        let o = run(dir, &["build"]);
        assert_eq!(o.status.code(), Some(1), "{text}");
        let err = stderr(&o);
        assert!(
            err.contains(&format!(
                "{only}{}",
                if expect.starts_with(':') {
                    expect.to_string()
                } else {
                    format!(": {expect}")
                }
            )),
            "expected {expect:?} in\n{err}"
        );
        assert!(err.contains("help: "), "{err}");
    }
}

#[test]
fn pipeline_yaml_errors_are_located() {
    let p = project();
    let dir = p.path();
    let spec = read(dir, "pipeline.yaml");
    std::fs::write(
        dir.join("pipeline.yaml"),
        spec.replace("method: ols", "methd: ols"),
    )
    .unwrap();
    let o = run(dir, &["build"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("pipeline.yaml:")
            && err.contains("unknown field `methd`")
            && err.contains("did you mean `method`?"),
        "{err}"
    );
}

#[test]
fn a_killed_build_followed_by_a_build_gives_the_clean_reports() {
    let clean = project();
    ok(clean.path(), &["build"]);
    let p = project();
    let dir = p.path();
    let mut child = Command::new(BIN)
        .arg("--project")
        .arg(dir)
        .args(["build", "-j", "1"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let objects = dir.join(".hydrofit/objects");
    let start = Instant::now();
    while std::fs::read_dir(&objects).map_or(0, |d| d.count()) < 3
        && start.elapsed() < Duration::from_secs(60)
    {
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !dir.join("reports/index.html").exists(),
        "the build finished before it could be killed"
    );
    // A torn log record, as a kill during the append would leave.
    std::fs::OpenOptions::new()
        .append(true)
        .open(dir.join(".hydrofit/log"))
        .and_then(|mut f| std::io::Write::write_all(&mut f, b"{\"id\":\"cfd[x"))
        .unwrap();
    let out = ok(dir, &["build"]);
    assert!(ran(&out) > 0);
    assert_eq!(reports(dir), reports(clean.path()));
    assert!(stdout(&run(dir, &["status"])).trim() == "up to date");
}

#[test]
fn two_concurrent_builds_do_not_interleave() {
    let clean = project();
    ok(clean.path(), &["build"]);
    let p = project();
    let dir = p.path();
    let spawn = || {
        Command::new(BIN)
            .arg("--project")
            .arg(dir)
            .arg("build")
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    assert!(
        a.status.success() && b.status.success(),
        "{}\n{}",
        stderr(&a),
        stderr(&b)
    );
    // Exactly one of them did the work; the other waited, then found everything built.
    let n = [ran(&stderr(&a)), ran(&stderr(&b))];
    assert!(
        n.contains(&0) && n.iter().sum::<usize>() > 0,
        "{n:?}\n{}\n{}",
        stderr(&a),
        stderr(&b)
    );
    assert!(
        stderr(&a).contains("waiting for another build")
            || stderr(&b).contains("waiting for another build")
    );
    assert_eq!(reports(dir), reports(clean.path()));
}

#[test]
fn ctrl_c_stops_a_long_search_keeps_what_finished_and_the_next_build_resumes() {
    let p = project();
    let dir = p.path();
    let yaml = read(dir, "pipeline.yaml");
    // Only the vehicle fit (the first `method: ols`); the cylinder fit is a two-step OLS.
    let endless = yaml.replacen(
        "      method: ols\n",
        "      method: qpso\n      seed: 1\n      iterations: 100000000\n      restarts: 1\n",
        1,
    );
    assert_ne!(endless, yaml);
    std::fs::write(dir.join("pipeline.yaml"), &endless).unwrap();
    let child = Command::new(BIN)
        .arg("--project")
        .arg(dir)
        .args(["build", "-j", "2"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the fit is searching: every import has finished and been logged.
    let start = Instant::now();
    let imports = count(dir, "cases/cfd/starccm")
        + count(dir, "cases/cfd/openfoam")
        + count(dir, "cases/cfd/sphere")
        + count(dir, "cases/pool");
    while read_opt(dir, ".hydrofit/log").lines().count() < imports
        && start.elapsed() < Duration::from_secs(120)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let t = Instant::now();
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "took {:?} to stop",
        t.elapsed()
    );
    assert!(
        err.contains("interrupted") && !err.contains("failed"),
        "{err}"
    );
    assert!(!dir.join("reports/index.html").exists());
    // The imports are cached: with a finite search the next build runs only what depends on the fit.
    std::fs::write(
        dir.join("pipeline.yaml"),
        yaml.replacen(
            "      method: ols\n",
            "      method: qpso\n      seed: 1\n      iterations: 50\n      restarts: 1\n",
            1,
        ),
    )
    .unwrap();
    let out = ok(dir, &["build"]);
    assert!(ran(&out) > 0 && ran(&out) <= SINGLE_STAGES, "{out}");
    assert!(dir.join("reports/index.html").exists());
}

fn read_opt(dir: &std::path::Path, rel: &str) -> String {
    std::fs::read_to_string(dir.join(rel)).unwrap_or_default()
}
