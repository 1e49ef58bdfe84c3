//! The integration tests, one binary: each module was once its own test crate. One binary links
//! the library (and polars) once rather than once per file, which keeps a clean build's disk use
//! and link time down. Filter by module as before: `cargo test --release --test it e2e_design`.

mod architecture;
mod artifacts;
mod common;
mod e2e_actuator_logs;
mod e2e_autopilot_logs;
mod e2e_build;
mod e2e_design;
mod e2e_discovery;
mod e2e_export;
mod e2e_field;
mod e2e_field_identifiers;
mod e2e_integrity;
mod e2e_logs;
mod e2e_msg_files;
mod e2e_nav_latency;
mod e2e_openfoam;
mod e2e_pool;
mod e2e_pool_fit;
mod e2e_robust;
mod e2e_rotation;
mod e2e_six_dof;
mod e2e_slurm;
mod e2e_thrust_gain;
mod estimators;
mod fuzz_inputs;
mod log_writer;
mod openfoam_results;
mod readme;
mod report_browser;
mod six_dof;
mod topic_csv_writer;
mod twin_truth;
