//! What every feature shares: degrees of freedom and units, the vehicle model and its
//! simulation, numerics, seeded random numbers, input errors, atomic files, provenance, plots.

pub mod diag;
pub mod dof;
pub mod finite;
pub mod fsutil;
pub mod input;
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
