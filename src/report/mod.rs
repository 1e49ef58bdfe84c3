//! The report: `index.html` for people, `parameters.json` and `validation.json` for tools
//! (shapes fixed by docs/formats.md).

pub mod build;
pub mod compare;
pub mod diagnose;
pub mod field;
pub mod field_adaptive;
pub mod field_integrated;
pub mod html;
pub mod json;
pub mod openfoam;
pub mod pool;
pub mod sets;
