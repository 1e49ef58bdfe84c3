//! One build at a time per project: an exclusive lock on `.hydrofit/lock`, whose text says
//! who holds it so a waiting build can tell the person.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::Path;

pub struct BuildLock {
    _file: File,
}

/// Takes the lock, calling `waiting(holder)` once if another build has it, then blocking.
pub fn acquire(state_dir: &Path, waiting: impl FnOnce(&str)) -> std::io::Result<BuildLock> {
    std::fs::create_dir_all(state_dir)?;
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(state_dir.join("lock"))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            let holder = holder.trim();
            // The holder writes its name just after taking the lock: an empty file is a
            // build that is starting (or a hydrofit that wrote no name).
            waiting(if holder.is_empty() {
                "a build that is starting and has not yet written its process id to .hydrofit/lock"
            } else {
                holder
            });
            file.lock()?;
        }
        Err(TryLockError::Error(e)) => return Err(e),
    }
    file.set_len(0)?;
    file.rewind()?;
    let since = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    write!(
        file,
        "pid {} (hydrofit build, started at unix time {since})",
        std::process::id()
    )?;
    file.flush()?;
    Ok(BuildLock { _file: file })
}
