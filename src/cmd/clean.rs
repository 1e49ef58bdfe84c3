//! `hydrofit clean`: remove the cache and the report files a build published, holding the
//! build lock throughout and leaving the lock file in place.

use crate::pipeline::{Plan, STATE_DIR, lock};
use std::path::Path;
use std::process::ExitCode;

pub fn run(root: &Path) -> anyhow::Result<ExitCode> {
    let state = root.join(STATE_DIR);
    {
        let _lock = lock::acquire(&state, |holder| {
            eprintln!("hydrofit: waiting for a build to finish ({holder})")
        })?;
        // Published files are those of report and design stages; other files in reports/ are
        // the user's.
        let published: Vec<String> = match Plan::load(root, crate::kinds::KINDS) {
            Ok(plan) => plan
                .graph
                .spec
                .stages
                .iter()
                .filter_map(|s| s.kind.publishes_to)
                .map(String::from)
                .collect(),
            Err(_) => vec!["reports".into()],
        };
        for dir in published {
            for name in crate::report::stage::FILES
                .iter()
                .chain(crate::design::files::FILES)
            {
                let p = root.join(&dir).join(name);
                if p.exists() {
                    std::fs::remove_file(&p)?;
                    crate::outln!("removed {dir}/{name}");
                }
            }
        }
        for entry in std::fs::read_dir(&state)? {
            let p = entry?.path();
            if p.file_name().is_some_and(|n| n != "lock") {
                if p.is_dir() {
                    std::fs::remove_dir_all(&p)?
                } else {
                    std::fs::remove_file(&p)?
                }
            }
        }
    }
    // The lock file stays: a build waiting on it holds that very file, and one removed
    // under it would let the next build lock a new file and run beside it.
    crate::outln!("removed the cache in {STATE_DIR}/");
    Ok(ExitCode::SUCCESS)
}
