//! A method as a `fit` stage names it, resolved once when `pipeline.yaml` is parsed: the
//! estimator from the registry and the settings of its own, checked and with defaults filled
//! in. `fit` and `compare` run methods only through this handle.

use super::{Estimator, Options, by_name, names};
use serde_json::{Map, Value};

/// An estimator with its own settings.
#[derive(Clone)]
pub struct Method {
    pub estimator: &'static dyn Estimator,
    /// The method's own settings with defaults (a JSON object).
    pub settings: Value,
}

impl Method {
    /// The method `name` with its own settings `own`; errors name the method and its keys.
    pub fn parse(name: &str, own: Map<String, Value>) -> Result<Method, String> {
        let estimator = by_name(name).ok_or_else(|| {
            format!(
                "unknown variant `{name}`, expected one of {}",
                names()
                    .iter()
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        let settings = estimator.settings(own)?;
        Ok(Method {
            estimator,
            settings,
        })
    }

    pub fn name(&self) -> &'static str {
        self.estimator.name()
    }

    /// The options a fit runs with: the method's settings over the caller's.
    pub fn options<'a>(&self, mut base: Options<'a>) -> Options<'a> {
        self.estimator.apply(&self.settings, &mut base);
        base
    }

    /// `ols`, or `qpso (l1, output error)` for a method with a detail.
    pub fn label(&self, output_error: bool) -> String {
        let obj = if output_error { ", output error" } else { "" };
        match self.estimator.detail(&self.settings) {
            Some(d) => format!("{} ({d}{obj})", self.name()).to_lowercase(),
            None => self.name().to_string(),
        }
    }
}

impl std::fmt::Debug for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.name(), self.settings)
    }
}

impl PartialEq for Method {
    fn eq(&self, other: &Method) -> bool {
        self.name() == other.name() && self.settings == other.settings
    }
}
