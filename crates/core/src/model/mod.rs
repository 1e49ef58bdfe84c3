//! The vehicle model: rigid body, hydrodynamic parameters and their dynamics.

pub mod attitude;
pub mod dynamics;
pub mod finned;
pub mod lanes;
pub mod lanes_coupled;
pub mod motion;
pub mod params;
pub mod pool;
pub mod spd;
pub mod stability;
pub mod terms;
pub mod thrusters;
pub mod vehicle;

pub use dynamics::{Plant, Vec6};
pub use params::{Hydro, Mat6, ParamLayout};
pub use pool::Pool;
pub use terms::{CustomTerms, Term};
pub use vehicle::{Structure, Vehicle};

/// Standard gravity, m/s^2.
pub const G: f64 = 9.80665;
