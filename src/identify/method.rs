//! A method as a `fit` stage names it, resolved once when `pipeline.yaml` is parsed: the
//! estimator from the registry and the settings of its own, checked and with defaults filled
//! in. `fit` and `compare` run methods only through this handle.

use super::{Estimator, Options, OwnSettings, by_name, names};
use serde_json::{Map, Value};

/// An estimator with its own settings.
#[derive(Clone)]
pub struct Method {
    pub estimator: &'static dyn Estimator,
    /// The method's own settings, checked, with defaults.
    pub settings: OwnSettings,
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
        self.settings.apply(&mut base);
        base
    }

    /// `ols`, or `qpso (l1, output error)` for a method with a detail.
    pub fn label(&self, output_error: bool) -> String {
        let obj = if output_error { ", output error" } else { "" };
        match self.settings.detail() {
            Some(d) => format!("{} ({d}{obj})", self.name()).to_lowercase(),
            None => self.name().to_string(),
        }
    }
}

impl std::fmt::Debug for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {:?}", self.name(), self.settings)
    }
}

impl PartialEq for Method {
    fn eq(&self, other: &Method) -> bool {
        self.name() == other.name() && self.settings == other.settings
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::lag::CommandLag;

    fn own(yaml: &str) -> Map<String, Value> {
        serde_yaml_ng::from_str(yaml).unwrap()
    }

    /// A method's settings walk from `pipeline.yaml` to the solver's options as one type; their
    /// JSON (the cache key's and the provenance's) keeps every key with its default.
    #[test]
    fn settings_reach_the_options_typed() {
        let m = Method::parse(
            "pem",
            own("{command_lag: 0.1, added_mass_prior: {heave: 3}}"),
        )
        .unwrap();
        assert!(matches!(m.settings, OwnSettings::Pem(_)), "{m:?}");
        let o = m.options(Options::default());
        assert_eq!(o.command_lag, CommandLag::Seconds(0.1));
        assert_eq!(o.added_mass_prior, [2.0, 2.0, 3.0, 2.0, 2.0, 2.0]);
        assert_eq!(o.iterations, 50);
        let json = serde_json::to_value(&m.settings).unwrap();
        assert_eq!(json["command_lag"], 0.1);
        assert_eq!(json["added_mass_prior"]["heave"], 3.0);
        assert_eq!(json["per_run"], serde_json::json!([]));

        let q = Method::parse("qpso", own("{population: 60, norm: l1}")).unwrap();
        let o = q.options(Options::default());
        assert_eq!((o.population, o.restarts), (60, 5));
        assert_eq!(q.label(false), "qpso (l1)");
        let r = Method::parse("rls", own("{forgetting: 0.99}")).unwrap();
        assert_eq!(r.options(Options::default()).forgetting, 0.99);
        assert_eq!(Method::parse("ols", Map::new()).unwrap().label(true), "ols");
        assert!(Method::parse("ols", own("{population: 3}")).is_err());
    }
}
