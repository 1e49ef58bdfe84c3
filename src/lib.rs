//! hydrofit: identifies an underwater vehicle's hydrodynamic model from CFD runs and pool tests
//! as a reproducible, cached build. See README.md for the user's view.
//!
//! The code is laid out by feature: each folder owns its importers, its algorithms, its stage
//! adapter, its artifact and its report section, on a shared `core` (docs/architecture.md).
// InputError carries the offending line and its location for the message; it is only built on
// the cold error path, so its size in `Result` is accepted rather than boxed everywhere.
#![allow(clippy::result_large_err)]

pub mod cfd;
pub mod cli;
pub mod cmd;
pub mod compare;
/// The shared layer below every feature, a crate of its own (crates/core) so that the twin
/// builds on it without the product.
pub use hydrofit_core as core;
pub mod design;
pub mod diagnose;
pub mod export;
pub mod field;
pub mod identify;
pub mod kinds;
pub mod pipeline;
pub mod pool;
pub mod report;
/// The digital twins (crates/twin): synthetic inputs with a known truth, for the `twin`
/// commands, the benchmarks and the tests.
pub use hydrofit_twin as twin;
pub mod validate;

/// `println!` for command output that may go to a closed pipe (`hydrofit status | head`):
/// a reader that has gone away ends the program quietly instead of panicking.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        if let Err(e) = writeln!(out, $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            panic!("writing to stdout: {e}");
        }
    }};
}
