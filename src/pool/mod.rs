//! Free-running pool and field runs: the run folder and its logs imported, the sensors fused
//! into body-frame velocities with their uncertainty, and the pool stage and report section.

pub mod fusion;
pub mod import;
pub mod report;
pub mod stage;
