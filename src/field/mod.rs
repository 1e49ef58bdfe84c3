//! Field-trial identifiers of the source papers that need no acceleration signal and work on
//! what a free-running vehicle logs (seed 000, seed 002, seed 004): ARX transfer functions
//! with order selection ([`arx`]), least squares on an integrated regressor and recursive
//! least squares with forgetting ([`integrated`]), over the named signals of a fused pool run
//! ([`signals`]).

pub mod arx;
pub mod signals;
