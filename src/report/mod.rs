//! The report: `index.html` for people, `parameters.json` and `validation.json` for tools
//! (shapes fixed by docs/formats.md).

pub mod build;
pub mod html;
pub mod json;
pub mod stage;
