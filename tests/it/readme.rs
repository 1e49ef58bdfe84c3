//! The README stays short and true: its commands table lists exactly the subcommands
//! `hydrofit --help` has, every document it links exists, and it reads in minutes.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

fn readme() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap()
}

#[test]
fn the_commands_table_is_the_cli() {
    let out = Command::new(env!("CARGO_BIN_EXE_hydrofit"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&out.stdout).to_string();
    let cli: BTreeSet<String> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(String::from)
        .collect();
    let table: BTreeSet<String> = readme()
        .lines()
        .filter_map(|l| l.strip_prefix("| `hydrofit "))
        .filter_map(|l| l.split([' ', '`']).next())
        .map(String::from)
        .collect();
    assert!(
        cli.len() >= 10,
        "read too few commands from --help:\n{help}"
    );
    assert_eq!(
        table, cli,
        "README's commands table against `hydrofit --help`"
    );
}

#[test]
fn every_linked_document_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = readme();
    for (i, _) in text.match_indices("](") {
        let target = text[i + 2..].split(')').next().unwrap();
        if target.starts_with("http") {
            continue;
        }
        let file = target.split('#').next().unwrap();
        assert!(
            root.join(file).exists(),
            "README links to {target}, which is not there"
        );
    }
}

#[test]
fn the_readme_reads_in_five_minutes() {
    let lines = readme().lines().count();
    assert!(
        lines <= 220,
        "README.md has {lines} lines; move detail to docs/"
    );
}
