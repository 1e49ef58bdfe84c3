//! Importers of the input formats in `cases/` and the response table they all produce.

pub mod actuators;
pub mod csvlog;
pub mod openfoam;
pub mod pool;
pub mod response;
pub mod starccm;
pub mod timing;

pub use response::{Response, Series};
