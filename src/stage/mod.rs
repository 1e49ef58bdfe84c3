//! Stage kinds: what a stage of `pipeline.yaml` can be. Adding a kind is one new file and
//! one line in `KINDS`.

pub mod adaptive;
pub mod arx;
pub mod compare;
pub mod diagnose;
pub mod fit;
pub mod integrated;
pub mod openfoam;
pub mod pool;
pub mod report;
pub mod starccm;
pub mod validate;

pub use crate::pipeline::contract::{
    Artifact, Kind, Registry, RunCtx, StageImpl, Upstream, VehicleUse, parse_as,
};

pub const KINDS: Registry = &[
    &starccm::KIND,
    &openfoam::KIND,
    &pool::KIND,
    &fit::KIND,
    &arx::KIND,
    &adaptive::KIND,
    &integrated::KIND,
    &validate::KIND,
    &compare::KIND,
    &diagnose::KIND,
    &report::KIND,
];

pub fn kind(name: &str) -> Option<&'static Kind> {
    crate::pipeline::contract::find(KINDS, name)
}

pub use crate::fsutil::{read_json, write_json};
