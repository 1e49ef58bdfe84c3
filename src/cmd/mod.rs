//! One file per subcommand.

pub mod bench;
pub mod bench_six;
pub mod build;
pub mod check_diagnosis;
pub mod clean;
pub mod design;
pub mod export;
pub mod graph;
pub mod inspect;
pub mod openfoam;
pub mod provenance;
pub mod scenario;
pub mod status;
pub mod twin;
pub mod verify;
