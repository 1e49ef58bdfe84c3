//! End-to-end with the real solver: a short cylinder case built from scratch by `hydrofit
//! build` (blockMesh + pimpleFoam through the openfoam stage), its added mass against
//! potential-flow theory, rerunning only an edited case, and a crashing case. Skipped, with a
//! message, where OpenFOAM is not installed (.ci/run installs it).

use crate::common::*;
use std::path::Path;

const ADDED_MASS: f64 = 1000.0 * std::f64::consts::PI * 0.1 * 0.1;

fn installed() -> bool {
    let on_path = |exe: &str| {
        std::env::var_os("PATH")
            .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(exe).is_file()))
    };
    let etc = std::env::var("WM_PROJECT_DIR")
        .is_ok_and(|d| Path::new(&d).join("etc/controlDict").exists())
        || Path::new("/usr/share/openfoam/etc/controlDict").exists();
    on_path("pimpleFoam") && on_path("blockMesh") && etc
}

const PIPELINE: &str = r#"
vehicle: {name: test, mass_kg: 35.2, dofs: [surge]}
stages:
  openfoam:
    kind: openfoam
    inputs: ["cases/cfd/openfoam/*/"]
  cylinder:
    kind: fit
    from: [openfoam]
    settings:
      method: ols
      skip_start_s: 0.2
      added_mass_window_s: 1.3
      vehicle: {name: cylinder, mass_kg: 62.832, dofs: [surge]}
      reference_length_m: 0.2
      expected: {X_udot: {value: -31.416, source: potential flow}}
  validate:
    kind: validate
    from: [cylinder, openfoam]
  report:
    kind: report
    from: [cylinder, openfoam, validate]
"#;

fn added_mass(dir: &Path) -> f64 {
    let p = json(dir, "reports/parameters.json");
    -p["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "X_udot")
        .unwrap()["value"]
        .as_f64()
        .unwrap()
}

#[test]
fn a_short_cylinder_case_runs_from_scratch_and_gives_the_potential_flow_added_mass() {
    if !installed() {
        eprintln!(
            "skipped: OpenFOAM (pimpleFoam, blockMesh, WM_PROJECT_DIR) is not installed here; `sudo apt-get install openfoam` (or .ci/run) installs it"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    std::fs::write(dir.join("pipeline.yaml"), PIPELINE).unwrap();
    new_cylinder(dir, "cases/cfd/openfoam/short", "2", "2");
    new_cylinder(dir, "cases/cfd/openfoam/other", "3", "2");
    let out = ok(dir, &["build"]);
    assert_eq!(
        ran(&out),
        5,
        "two cases, cylinder, validate, report:\n{out}"
    );
    let ma = added_mass(dir);
    assert!(
        (ma / ADDED_MASS - 1.0).abs() < 0.05,
        "added mass {ma} kg/m against rho pi r^2 = {ADDED_MASS}"
    );
    for f in [
        "log.pimpleFoam",
        "log.blockMesh",
        "hydrofit.run.json",
        "postProcessing/sixDoFRigidBodyState/0/sixDoFRigidBodyState.dat",
    ] {
        assert!(
            dir.join("cases/cfd/openfoam/short").join(f).exists(),
            "{f} kept in the case folder"
        );
    }
    let html = read(dir, "reports/index.html");
    assert!(
        html.contains("run by this build") && html.contains("potential flow"),
        "the report shows the run and the reference"
    );
    // Results written back into the case are not inputs: nothing is stale.
    assert_eq!(ran(&ok(dir, &["build"])), 0);

    // A new force level in one case reruns that case only, and what depends on it.
    let dict = dir.join("cases/cfd/openfoam/short/constant/dynamicMeshDict");
    let text = std::fs::read_to_string(&dict).unwrap();
    std::fs::write(
        &dict,
        text.replace("appliedForce    2;", "appliedForce    4;"),
    )
    .unwrap();
    let stamp_other = read(dir, "cases/cfd/openfoam/other/hydrofit.run.json");
    let out = ok(dir, &["build", "--explain"]);
    assert_eq!(
        ran(&out),
        4,
        "openfoam[short], cylinder, validate, report:\n{out}"
    );
    assert!(
        out.contains("openfoam[short]") && !out.contains("openfoam[other]:"),
        "{out}"
    );
    assert_eq!(
        read(dir, "cases/cfd/openfoam/other/hydrofit.run.json"),
        stamp_other
    );
    let ma2 = added_mass(dir);
    assert!((ma2 / ADDED_MASS - 1.0).abs() < 0.05 && ma2 != ma, "{ma2}");
}

#[test]
fn a_crashing_case_fails_with_the_log_tail_and_leaves_nothing() {
    if !installed() {
        eprintln!(
            "skipped: OpenFOAM is not installed here; `sudo apt-get install openfoam` (or .ci/run) installs it"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    std::fs::write(dir.join("pipeline.yaml"), PIPELINE).unwrap();
    new_cylinder(dir, "cases/cfd/openfoam/broken", "2", "1");
    std::fs::remove_file(dir.join("cases/cfd/openfoam/broken/0/p")).unwrap();
    let o = run(dir, &["build"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("openfoam[broken]")
            && err.contains("FOAM FATAL")
            && err.contains("last lines of log.pimpleFoam"),
        "{err}"
    );
    let case = dir.join("cases/cfd/openfoam/broken");
    assert!(
        !case.join("hydrofit.run.json").exists() && !case.join("log.pimpleFoam").exists(),
        "no partial results"
    );
    // Not cached as a success: the next build tries again and fails the same way.
    let o = run(dir, &["build"]);
    assert!(!o.status.success() && stderr(&o).contains("FOAM FATAL"));
}

#[test]
fn without_openfoam_an_edited_case_says_how_to_install_it() {
    // The shipped cases' results match their inputs: they are read without a solver.
    let p = project();
    let dir = p.path();
    let empty = tempfile::tempdir().unwrap();
    let no_solver = |args: &[&str]| {
        std::process::Command::new(BIN)
            .arg("--project")
            .arg(dir)
            .args(args)
            .env("PATH", empty.path())
            .env_remove("WM_PROJECT_DIR")
            .output()
            .unwrap()
    };
    let o = no_solver(&["build", "report"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(read(dir, "reports/index.html").contains("read from the case folder"));
    let dict = dir.join("cases/cfd/openfoam/cylinder_2N/constant/dynamicMeshDict");
    let text = std::fs::read_to_string(&dict).unwrap();
    std::fs::write(
        &dict,
        text.replace("appliedForce    2;", "appliedForce    3;"),
    )
    .unwrap();
    let o = no_solver(&["build"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("cylinder_2N")
            && err.contains("inputs changed since its results were produced")
            && err.contains("apt-get install openfoam"),
        "{err}"
    );
    assert!(
        err.contains("1 failed"),
        "only that case (and what needs it) fails:\n{err}"
    );
}
