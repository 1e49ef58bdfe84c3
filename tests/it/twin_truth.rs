//! Numerical truth: the shipped cases are exactly the twin's output, and least squares on them
//! recovers the reference vehicle (seed 001 Table 1) within 2 %.

use crate::common::*;
use hydrofit::cfd::starccm::{ColumnMap, ImportOptions, parse};
use hydrofit::core::model::{Hydro, ParamLayout, Vehicle};
use hydrofit::identify::{Estimator, Regression};

#[test]
fn shipped_cases_are_the_twins_output() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(BIN)
        .args(["--project"])
        .arg(dir.path())
        .args(["twin", "starccm", "--out", "out"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let shipped = manifest_dir().join("cases/cfd/starccm");
    let mut n = 0;
    for e in std::fs::read_dir(dir.path().join("out")).unwrap() {
        let e = e.unwrap();
        let ours = std::fs::read(e.path()).unwrap();
        let theirs = std::fs::read(shipped.join(e.file_name())).unwrap_or_default();
        assert!(
            ours == theirs,
            "{:?} differs from the generator's output: regenerate with `hydrofit twin starccm`",
            e.file_name()
        );
        n += 1;
    }
    assert_eq!(n, std::fs::read_dir(&shipped).unwrap().count());
}

#[test]
fn shipped_pool_runs_and_truth_are_the_twins_output() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(BIN)
        .args(["--project"])
        .arg(dir.path())
        .args(["twin", "pool", "--out", "pool", "--truth", "truth"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (ours, shipped) in [("pool", "cases/pool"), ("truth", "truth/pool")] {
        let mut files = Vec::new();
        let root = dir.path().join(ours);
        for run in std::fs::read_dir(&root).unwrap() {
            let p = run.unwrap().path();
            if p.is_dir() {
                files.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            } else {
                files.push(p);
            }
        }
        assert!(files.len() >= 12);
        for f in files {
            let rel = f.strip_prefix(&root).unwrap();
            let theirs = std::fs::read(manifest_dir().join(shipped).join(rel)).unwrap_or_default();
            assert!(
                std::fs::read(&f).unwrap() == theirs,
                "{shipped}/{} differs: regenerate with `hydrofit twin pool`",
                rel.display()
            );
        }
    }
}

#[test]
fn least_squares_recovers_the_reference_vehicle_within_2_percent() {
    let vehicle = Vehicle::reference();
    let columns = ColumnMap::default();
    let opts = ImportOptions {
        columns: &columns,
        dofs: &vehicle.dofs,
        configured_force: Default::default(),
    };
    let mut responses = Vec::new();
    for e in std::fs::read_dir(manifest_dir().join("cases/cfd/starccm")).unwrap() {
        let path = e.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        responses.push(
            parse(&path.display().to_string(), &text, &opts)
                .unwrap()
                .response,
        );
    }
    let refs: Vec<_> = responses.iter().collect();
    let problem = Regression::build(&vehicle, &refs, 0.0);
    let fit = hydrofit::identify::ols::Ols
        .fit(&problem, &Default::default())
        .unwrap();
    let truth = ParamLayout::new(&vehicle.dofs).from_hydro(&Hydro::reference());
    for (p, t) in fit.parameters.iter().zip(truth) {
        let rel = (p.value - t) / t;
        assert!(
            rel.abs() < 0.02,
            "{} = {} vs truth {t} ({:+.2} %)",
            p.name,
            p.value,
            100.0 * rel
        );
        assert!(p.identifiable, "{p:?}");
        // The stated uncertainty must not be wildly optimistic.
        assert!(
            (p.value - t).abs() < 10.0 * p.stderr + 0.002 * t.abs(),
            "{p:?} vs {t}"
        );
    }
}
