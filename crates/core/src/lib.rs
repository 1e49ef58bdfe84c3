//! What every feature shares: degrees of freedom and units, the vehicle model and its
//! simulation, numerics, seeded random numbers, input errors, atomic files, provenance, plots.

// InputError carries the offending line and its location for the message; it is only built on
// the cold error path, so its size in `Result` is accepted rather than boxed everywhere.
#![allow(clippy::result_large_err)]

pub mod diag;
pub mod dof;
pub mod finite;
pub mod fsutil;
pub mod input;
pub mod interp;
pub mod interrupt;
pub mod lenient;
pub mod median;
pub mod model;
pub mod natural;
pub mod numerics;
pub mod plot;
pub mod progress;
pub mod provenance;
pub mod response;
pub mod rng;
pub mod run;
