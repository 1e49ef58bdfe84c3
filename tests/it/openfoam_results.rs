//! Reading an OpenFOAM run's results when a file is damaged, cut or replaced: every outcome
//! is a located message or a result whose notes say what was read in place of what.

use hydrofit::cfd::openfoam::{FORCE, STATE, read_track};
use std::path::Path;

fn results() -> (tempfile::TempDir, std::path::PathBuf) {
    crate::common::openfoam_results(200)
}

fn err(dir: &Path) -> String {
    match read_track(dir, "pimpleFoam") {
        Ok(_) => panic!("read without a message"),
        Err(e) => format!("{e:#}"),
    }
}

/// Replaces the first row's value in column `col` (0 = time) of a table with `value`.
fn set_first_row(path: &Path, col: usize, value: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let mut line_no = 0;
    let mut done = false;
    let out: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if done || l.starts_with('#') || l.trim().is_empty() {
                return l.to_string();
            }
            done = true;
            line_no = i + 1;
            // Numbers of a vector are inside parentheses; count them as separate columns.
            let mut k = 0;
            let mut s = String::new();
            for tok in l.split_inclusive(|c: char| c.is_whitespace() || c == '(' || c == ')') {
                let word =
                    tok.trim_end_matches(|c: char| c.is_whitespace() || c == '(' || c == ')');
                if !word.is_empty() && word.parse::<f64>().is_ok() {
                    if k == col {
                        s.push_str(&tok.replacen(word, value, 1));
                    } else {
                        s.push_str(tok);
                    }
                    k += 1;
                } else {
                    s.push_str(tok);
                }
            }
            s
        })
        .collect();
    std::fs::write(path, out.join("\n") + "\n").unwrap();
    line_no
}

#[test]
fn the_intact_copy_reads_with_its_force_and_no_note() {
    let (_d, dir) = results();
    let (track, _, _) = read_track(&dir, "pimpleFoam").unwrap();
    assert!(track.t.len() > 150, "{} rows", track.t.len());
    assert!(track.fluid_force.is_some());
    assert!(track.notes.is_empty(), "{:?}", track.notes);
    assert_eq!(track.source, STATE);
}

#[test]
fn a_state_table_linked_to_itself_is_an_error_not_a_missing_table() {
    let (_d, dir) = results();
    let p = dir.join(STATE);
    std::fs::remove_file(&p).unwrap();
    std::os::unix::fs::symlink(&p, &p).unwrap();
    let e = err(&dir);
    assert!(e.contains("sixDoFRigidBodyState.dat"), "{e}");
    assert!(!e.contains("log.pimpleFoam"), "{e}");
}

#[test]
fn a_table_replaced_by_a_folder_names_its_path() {
    let (_d, dir) = results();
    let p = dir.join(FORCE);
    std::fs::remove_file(&p).unwrap();
    std::fs::create_dir(&p).unwrap();
    let e = err(&dir);
    assert!(e.contains("force.dat"), "{e}");
    assert!(e.contains("folder") || e.contains("directory"), "{e}");
}

#[test]
fn a_huge_force_is_a_located_error() {
    let (_d, dir) = results();
    // Column 1 is the first force component (column 0 is the time).
    let line = set_first_row(&dir.join(FORCE), 1, "1e300");
    let e = err(&dir);
    assert!(e.contains("force.dat"), "{e}");
    assert!(e.contains(&format!("line {line}")), "{e}");
    assert!(e.contains("1e300"), "{e}");
}

#[test]
fn a_huge_velocity_in_the_state_table_is_a_located_error() {
    let (_d, dir) = results();
    let line = set_first_row(&dir.join(STATE), 1, "1e300");
    let e = err(&dir);
    assert!(e.contains("sixDoFRigidBodyState.dat"), "{e}");
    assert!(e.contains(&format!("line {line}")), "{e}");
}

#[test]
fn a_fast_but_bounded_velocity_names_the_file_and_line() {
    let (_d, dir) = results();
    let text = std::fs::read_to_string(dir.join(STATE)).unwrap();
    let header = text
        .lines()
        .rev()
        .find(|l| l.starts_with('#'))
        .unwrap()
        .to_string();
    // The velocity's first component: the column after centreOfMass's three (+ time).
    let names: Vec<&str> = header.trim_start_matches('#').split_whitespace().collect();
    let vel = names.iter().position(|n| *n == "velocity").unwrap();
    // Each name before `velocity` except the time is a vector of 3.
    let col = 1 + 3 * (vel - 1);
    let line = set_first_row(&dir.join(STATE), col, "5e4");
    let e = err(&dir);
    assert!(
        e.contains(&format!("sixDoFRigidBodyState.dat line {line}")),
        "{e}"
    );
    assert!(e.contains("diverged") && e.contains("damaged"), "{e}");
}

#[test]
fn an_empty_force_table_is_noted() {
    let (_d, dir) = results();
    std::fs::write(dir.join(FORCE), "").unwrap();
    let (track, _, _) = read_track(&dir, "pimpleFoam").unwrap();
    assert!(track.fluid_force.is_none());
    assert!(
        track.notes.iter().any(|n| n.contains("force.dat")),
        "{:?}",
        track.notes
    );
}

#[test]
fn a_half_force_table_is_noted() {
    let (_d, dir) = results();
    let text = std::fs::read_to_string(dir.join(FORCE)).unwrap();
    let half: String = text.split_inclusive('\n').take(100).collect();
    std::fs::write(dir.join(FORCE), half).unwrap();
    let (track, _, _) = read_track(&dir, "pimpleFoam").unwrap();
    assert!(track.fluid_force.is_none());
    let note = track.notes.join("\n");
    assert!(note.contains("force.dat covers"), "{note}");
}

#[test]
fn a_motion_table_cut_before_the_logs_end_is_refused() {
    let (_d, dir) = results();
    let text = std::fs::read_to_string(dir.join(STATE)).unwrap();
    let half: String = text.split_inclusive('\n').take(100).collect();
    std::fs::write(dir.join(STATE), half).unwrap();
    let e = err(&dir);
    assert!(e.contains("sixDoFRigidBodyState.dat ends at"), "{e}");
    assert!(e.contains("was cut"), "{e}");
}

#[test]
fn an_empty_motion_table_says_it_has_no_row() {
    let (_d, dir) = results();
    std::fs::write(dir.join(STATE), "").unwrap();
    let e = err(&dir);
    assert!(e.contains("has no row"), "{e}");
    assert!(!e.contains("column"), "{e}");
}

#[test]
fn reading_the_log_instead_of_a_missing_table_is_noted() {
    let (_d, dir) = results();
    std::fs::remove_file(dir.join(STATE)).unwrap();
    let (track, _, _) = read_track(&dir, "pimpleFoam").unwrap();
    assert_eq!(track.source, "log.pimpleFoam");
    assert!(
        track
            .notes
            .iter()
            .any(|n| n.contains("read from log.pimpleFoam")),
        "{:?}",
        track.notes
    );
}
