//! The CFD inputs under mutation: STAR-CCM+ exports, an OpenFOAM case's tables, log and
//! dictionaries, a run's results read together, the series template and the Slurm settings.

use super::*;

#[test]
fn starccm_exports_under_mutation() {
    use hydrofit::cfd::starccm::{ColumnMap, ImportOptions, parse};
    use hydrofit::core::dof::Dof;
    let columns = ColumnMap::default();
    let dofs = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
    let opts = ImportOptions {
        columns: &columns,
        dofs: &dofs,
        configured_force: Default::default(),
    };
    let dog = Watchdog::new("STAR-CCM+ importer");
    let mut rng = Rng::derive(5, "starccm");
    let (mut failures, mut tried) = (Vec::new(), 0);
    for rel in [
        "cases/cfd/starccm/surge_10N.csv",
        "cases/cfd/starccm/yaw_2Nm.csv",
    ] {
        let Ok(full) = std::fs::read_to_string(manifest_dir().join(rel)) else {
            continue;
        };
        let text = head_seconds_col(&full, 1, 6.0);
        let original = parse(rel, &text, &opts).expect("the seed export parses");
        for _ in 0..cases_per_seed() * 3 {
            // Column 0 is STAR-CCM+'s iteration counter, which no importer reads.
            let m = mutate(
                &text,
                &mut rng,
                &Rows {
                    header: 1,
                    frozen: &[0],
                    time_col: 1,
                    ..TEXT
                },
            );
            let s = String::from_utf8_lossy(&m.bytes).into_owned();
            dog.beat();
            let got = std::panic::catch_unwind(|| parse(rel, &s, &opts));
            check(rel, &m, &original, got, &mut failures);
            tried += 1;
        }
    }
    assert!(tried > 0, "no STAR-CCM+ seed export found");
    report("STAR-CCM+ exports", failures, tried);
}

/// As [`head_seconds`] with the time in column `col`.
fn head_seconds_col(text: &str, col: usize, keep: f64) -> String {
    let mut out = String::new();
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i > 0
            && let Some(t) = l
                .split(',')
                .nth(col)
                .and_then(|t| t.trim().parse::<f64>().ok())
            && t > keep
        {
            break;
        }
        out.push_str(l);
    }
    out
}

#[test]
fn openfoam_results_and_dictionaries_under_mutation() {
    use hydrofit::cfd::openfoam::{dict, results};
    let case = "cases/cfd/openfoam/cylinder_1N";
    let dog = Watchdog::new("OpenFOAM readers");
    let mut rng = Rng::derive(6, "openfoam");
    let (mut failures, mut tried) = (Vec::new(), 0);
    for table in [
        hydrofit::cfd::openfoam::STATE,
        hydrofit::cfd::openfoam::FORCE,
    ] {
        let rel = format!("{case}/{table}");
        let text: String = read(&rel).split_inclusive('\n').take(300).collect();
        let original = results::parse_vector_table(&text).expect("the seed table parses");
        for _ in 0..cases_per_seed() * 2 {
            let m = mutate(
                &text,
                &mut rng,
                &Rows {
                    header: 0,
                    time_col: usize::MAX,
                    ..TEXT
                },
            );
            let s = String::from_utf8_lossy(&m.bytes).into_owned();
            dog.beat();
            let got = std::panic::catch_unwind(|| results::parse_vector_table(&s));
            // One line changed, deleted, repeated or cut takes at most one row with it (the
            // restart rule once dropped every row before a time written over with 0). A cut
            // may end the table anywhere.
            if !m.what.starts_with("cut")
                && let Ok(Ok(v)) = &got
                && v.t.len() + 1 < original.t.len()
            {
                failures.push(format!(
                    "{rel}: {}: {} of {} rows read",
                    m.what,
                    v.t.len(),
                    original.t.len()
                ));
            }
            // The torn-last-line rule may drop the row a cut made: not a silent change.
            let m = Mutated {
                value_change: m.value_change && s.ends_with('\n'),
                ..m
            };
            check(&rel, &m, &original, got, &mut failures);
            tried += 1;
        }
    }
    let log = read(&format!("{case}/log.pimpleFoam"));
    let log: String = log.split_inclusive('\n').take(3000).collect();
    for _ in 0..cases_per_seed() {
        let m = mutate(&log, &mut rng, &TEXT);
        let s = String::from_utf8_lossy(&m.bytes).into_owned();
        dog.beat();
        if std::panic::catch_unwind(|| results::parse_log(&s)).is_err() {
            failures.push(format!("log.pimpleFoam: {}: panicked", m.what));
        }
        tried += 1;
    }
    for rel in ["system/controlDict", "constant/dynamicMeshDict"] {
        let text = read(&format!("{case}/{rel}"));
        for _ in 0..cases_per_seed() {
            let m = mutate(&text, &mut rng, &TEXT);
            let s = String::from_utf8_lossy(&m.bytes).into_owned();
            dog.beat();
            match std::panic::catch_unwind(|| dict::parse(&s).map(|_| ())) {
                Err(_) => failures.push(format!("{rel}: {}: panicked", m.what)),
                Ok(Err(e)) if e.to_string().len() > MAX_MESSAGE => {
                    failures.push(format!("{rel}: {}: long message", m.what))
                }
                _ => {}
            }
            tried += 1;
        }
    }
    report("OpenFOAM readers", failures, tried);
}

/// A run's results read as the stage reads them (motion table, force table, solver log): a
/// number changed in a column the product reads changes the motion, the force or the notes,
/// or is refused with the file's name; nothing else is taken in its place without a note.
#[test]
fn openfoam_run_results_under_mutation() {
    use hydrofit::cfd::openfoam::{FORCE, STATE, read_track};
    let dog = Watchdog::new("OpenFOAM run results");
    let mut rng = Rng::derive(9, "openfoam-results");
    let (_d, dir) = crate::common::openfoam_results(120);
    type Read = (
        Vec<f64>,
        Vec<[f64; 3]>,
        Vec<[f64; 3]>,
        Vec<[f64; 3]>,
        Option<Vec<[f64; 3]>>,
        Vec<String>,
    );
    let read_all = |dir: &Path| -> anyhow::Result<Read> {
        let (t, _, _) = read_track(dir, "pimpleFoam")?;
        Ok((t.t, t.position, t.velocity, t.omega, t.fluid_force, t.notes))
    };
    let original = read_all(&dir).expect("the seed results read");
    assert!(original.4.is_some() && original.5.is_empty());
    let (mut failures, mut tried) = (Vec::new(), 0);
    // Numbers of a row: the time, then three per vector. The state table's centreOfRotation
    // and rotation, and the force table's pressure and viscous parts, are not read.
    for (rel, frozen) in [
        (STATE, &[1usize, 2, 3, 7, 8, 9][..]),
        (FORCE, &[4usize, 5, 6, 7, 8, 9][..]),
        ("log.pimpleFoam", &[][..]),
    ] {
        let path = dir.join(rel);
        let text = std::fs::read_to_string(&path).unwrap();
        let rows = if rel.starts_with("log") {
            TEXT
        } else {
            Rows {
                header: 0,
                frozen,
                time_col: usize::MAX,
                span: (f64::NEG_INFINITY, f64::INFINITY),
            }
        };
        for _ in 0..cases_per_seed() / 2 {
            let m = mutate(&text, &mut rng, &rows);
            std::fs::write(&path, &m.bytes).unwrap();
            dog.beat();
            let got = std::panic::catch_unwind(|| read_all(&dir));
            let m = Mutated {
                value_change: m.value_change && m.bytes.ends_with(b"\n"),
                ..m
            };
            if let Ok(Err(e)) = &got {
                let msg = format!("{e:#}");
                let names_a_file = msg.contains(".dat") || msg.contains("log.pimpleFoam");
                if !names_a_file {
                    failures.push(format!("{rel}: {}: message names no file: {msg}", m.what));
                }
            }
            let got = got.map(|r| r.map_err(|e| format!("{e:#}")));
            check(rel, &m, &original, got, &mut failures);
            tried += 1;
        }
        std::fs::write(&path, &text).unwrap();
    }
    report("OpenFOAM run results", failures, tried);
}

/// A series' template case, mutated, written into a case with a swept entry set and read
/// as the stage reads it: no panic, and every message bounded and naming the file.
#[test]
fn series_template_under_mutation() {
    use hydrofit::cfd::openfoam::{read_setup, series};
    use hydrofit::core::provenance::InputFile;
    let dog = Watchdog::new("series template");
    let mut rng = Rng::derive(10, "series");
    let src = manifest_dir().join("cases/cfd/templates/sphere");
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let mut rels = Vec::new();
    for sub in ["0", "constant", "system"] {
        for e in std::fs::read_dir(src.join(sub)).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            let rel = format!("tpl/{sub}/{name}");
            std::fs::create_dir_all(root.join("tpl").join(sub)).unwrap();
            std::fs::copy(src.join(sub).join(&name), root.join(&rel)).unwrap();
            rels.push(rel);
        }
    }
    rels.sort();
    let inputs = || -> Vec<InputFile> {
        rels.iter()
            .map(|r| InputFile::new(r.clone(), "0".repeat(64)))
            .collect()
    };
    let params = vec![("appliedForce".to_string(), "2".to_string())];
    let run = || -> anyhow::Result<()> {
        let ins = inputs();
        let tpl = series::template_folder("sphere", &ins)?;
        series::write_case(root, &ins, &tpl, "runs/f2", &params)?;
        read_setup(&root.join("runs/f2"), "runs/f2").map(|_| ())
    };
    run().expect("the seed template writes a case that reads");
    let (mut failures, mut tried) = (Vec::new(), 0);
    for rel in ["tpl/constant/dynamicMeshDict", "tpl/system/controlDict"] {
        let text = std::fs::read_to_string(root.join(rel)).unwrap();
        for _ in 0..cases_per_seed() / 2 {
            let m = mutate(&text, &mut rng, &TEXT);
            std::fs::write(root.join(rel), &m.bytes).unwrap();
            dog.beat();
            match std::panic::catch_unwind(run) {
                Err(_) => failures.push(format!("{rel}: {}: panicked", m.what)),
                Ok(Err(e)) => {
                    let msg = format!("{e:#}");
                    if msg.len() > MAX_MESSAGE {
                        failures.push(format!("{rel}: {}: message of {} bytes", m.what, msg.len()));
                    }
                    if !msg.contains("Dict") && !msg.contains("tpl") && !msg.contains("runs/f2") {
                        failures.push(format!("{rel}: {}: names no file: {msg}", m.what));
                    }
                }
                Ok(Ok(())) => {}
            }
            tried += 1;
        }
        std::fs::write(root.join(rel), &text).unwrap();
    }
    report("series template", failures, tried);
}

/// The `slurm:` settings of the shipped cluster stage, mutated inside pipeline.yaml: read
/// at parse time (no panic, bounded messages), and the values sbatch would refuse are
/// refused there with their line.
#[test]
fn slurm_settings_under_mutation() {
    let spec = read("pipeline.yaml");
    let line = spec
        .lines()
        .find(|l| l.trim_start().starts_with("slurm: {"))
        .expect("the shipped pipeline has a slurm stage")
        .to_string();
    let indent = &line[..line.len() - line.trim_start().len()];
    let parse = |s: &str| {
        hydrofit::pipeline::spec::parse("pipeline.yaml", s, hydrofit::kinds::KINDS).map(|_| ())
    };
    let line_no = spec.lines().position(|l| l == line).unwrap() + 1;
    for bad in [
        "{max_running: 0}",
        "{mem: 2GG}",
        "{time: '1:2:3:4'}",
        "{time: soon}",
        "{cpus: 0}",
        "{partition: 'a b'}",
        "{sbatch: ['--array=0-3']}",
        "{sbatch: ['--output=x']}",
    ] {
        let s = spec.replace(&line, &format!("{indent}slurm: {bad}"));
        let e = parse(&s).expect_err(bad).to_string();
        assert!(
            e.contains(&format!("pipeline.yaml:{line_no}")),
            "{bad}: not located at line {line_no}: {e}"
        );
    }
    let dog = Watchdog::new("slurm settings");
    let mut rng = Rng::derive(11, "slurm");
    let body = line.trim_start().to_string();
    let (mut failures, mut tried) = (Vec::new(), 0);
    for _ in 0..cases_per_seed() {
        let m = mutate(&body, &mut rng, &TEXT);
        let mutated = String::from_utf8_lossy(&m.bytes).replace('\n', " ");
        let s = spec.replace(&line, &format!("{indent}{mutated}"));
        dog.beat();
        match std::panic::catch_unwind(|| parse(&s)) {
            Err(_) => failures.push(format!("slurm: {}: panicked", m.what)),
            Ok(Err(e)) if e.to_string().len() > MAX_MESSAGE => {
                failures.push(format!("slurm: {}: long message", m.what))
            }
            _ => {}
        }
        tried += 1;
    }
    report("slurm settings", failures, tried);
}
