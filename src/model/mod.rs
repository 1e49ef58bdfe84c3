//! The vehicle model: rigid body, hydrodynamic parameters and their dynamics.

pub mod dynamics;
pub mod lanes;
pub mod motion;
pub mod params;
pub mod pool;
pub mod stability;
pub mod vehicle;

pub use dynamics::{Plant, Vec6};
pub use params::{Hydro, ParamLayout};
pub use pool::Pool;
pub use vehicle::{Structure, Vehicle};
