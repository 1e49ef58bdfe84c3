//! Stage kinds: what a stage of `pipeline.yaml` can be. Each kind's adapter lives in its
//! feature's folder; adding a kind is one file there and one line in `KINDS`.

use crate::pipeline::contract::{Kind, Registry};

pub const KINDS: Registry = &[
    &crate::cfd::starccm::stage::KIND,
    &crate::cfd::openfoam::stage::KIND,
    &crate::pool::stage::KIND,
    &crate::identify::stage::KIND,
    &crate::field::arx::stage::KIND,
    &crate::field::adaptive::stage::KIND,
    &crate::field::integrated::stage::KIND,
    &crate::validate::stage::KIND,
    &crate::compare::stage::KIND,
    &crate::diagnose::stage::KIND,
    &crate::report::stage::KIND,
    &crate::export::stage::EXPORT,
    &crate::export::stage::MODEL,
    &crate::design::stage::KIND,
];

pub fn kind(name: &str) -> Option<&'static Kind> {
    crate::pipeline::contract::find(KINDS, name)
}
