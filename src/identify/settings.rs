//! A fit's settings as `pipeline.yaml` writes them: the method with its own settings, and the
//! settings every method shares. Read by the `fit` stage and, one per method, by `compare`.

use crate::identify;
use crate::identify::result::{Expected, Objective};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A fit's settings: the method with its own settings (resolved when parsed), and the
/// settings every method shares. Written flat in `pipeline.yaml` (`method: qpso`,
/// `population: 60`, `skip_start_s: 0.2`); a key neither the method nor the fit reads is an
/// error.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub method: identify::Method,
    pub common: Common,
}

/// The settings of a fit that do not depend on its method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Common {
    pub method: String,
    pub objective: Objective,
    /// Samples before this time in each case are left out: the start-up transient of the
    /// fluid-body coupling (impulsive start, pressure waves) is not vehicle dynamics.
    pub skip_start_s: f64,
    /// The body this fit identifies, when it is not the pipeline's vehicle (a CFD test body
    /// such as the OpenFOAM cylinder). A case that states its own mass overrides `mass_kg`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::core::model::Vehicle>,
    /// Reference values to show beside the identified ones (e.g. potential-flow added mass);
    /// not used by the fit.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub expected: BTreeMap<String, Expected>,
    /// Length for the drag coefficients the report shows for a 2D body per metre of span,
    /// Cd = drag / (1/2 rho u^2 L) (a cylinder: its diameter), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_length_m: Option<f64>,
    /// Two-step identification (method ols): the added mass from the first this-many seconds
    /// of each case after `skip_start_s`, while the body accelerates from rest and its drag is
    /// still negligible, then the drag coefficients from every sample with that added mass
    /// held. For bodies whose drag depends on the history of the motion (a wake that builds
    /// up), which a one-step fit would fold into the added mass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub added_mass_window_s: Option<f64>,
    /// The parameter set this fit identifies, when not the vehicle's (`full_qd`, `diag_qd`,
    /// `diag_mass`, `diag_all`, `full_ld`, `custom`: seed 003 Table I; `diagonal`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure: Option<crate::core::model::Structure>,
    /// The terms of `structure: custom`, when not the vehicle's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub custom_terms: Option<crate::core::model::CustomTerms>,
    /// Seed 003's median outlier filter on the pool runs' velocities (translational) and
    /// accelerations (angular) before the regression: `median_filter: {}` for its values
    /// (length 9, 0.03 m/s, 0.3 deg/s^2). Off when not set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_filter: Option<crate::core::median::MedianFilter>,
    /// `fit`: identify the gain of the pool runs' logged command against the CFD cases' force
    /// scale (needs both in `from`); `fixed` (the default): the command is the force.
    #[serde(skip_serializing_if = "is_fixed")]
    pub thrust_gain: crate::identify::gain::ThrustGain,
    /// Which DOFs of a fit of recordings alone carry a constant force: `chosen` (the default:
    /// those `vehicle.constant_force` lists, and the others where cross-validation across the
    /// runs keeps them), `every_dof` (the listed and the others) or `listed` (only those).
    #[serde(skip_serializing_if = "is_chosen")]
    pub constants: Constants,
    /// Whether a diagonal fit of recordings alone in sway and yaw may add the linear coupling
    /// N_v (a yaw moment from the sway velocity): `chosen` (the default: where
    /// cross-validation across the runs keeps it) or `none`.
    #[serde(skip_serializing_if = "is_chosen_coupling")]
    pub couplings: Couplings,
}

/// The couplings of a diagonal fit of recordings alone (`couplings` in a fit's settings): N_v,
/// and in six DOF K_v and M_u.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Couplings {
    /// Each where it predicts the runs left out of a cross-validation better (see
    /// [`crate::identify::constants`]).
    #[default]
    Chosen,
    /// The diagonal model as it is.
    None,
}

fn is_chosen_coupling(c: &Couplings) -> bool {
    *c == Couplings::Chosen
}

/// The constant forces of a fit of recordings alone (`constants` in a fit's settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Constants {
    /// The listed DOFs, and each other DOF where its constant predicts the runs left out of
    /// a cross-validation better (see [`crate::identify::constants`]).
    #[default]
    Chosen,
    /// Every DOF: a vehicle in the water is never exactly neutral in any of them.
    EveryDof,
    /// Only the DOFs `vehicle.constant_force` lists.
    Listed,
}

fn is_chosen(c: &Constants) -> bool {
    *c == Constants::Chosen
}

fn is_fixed(g: &crate::identify::gain::ThrustGain) -> bool {
    *g == crate::identify::gain::ThrustGain::Fixed
}

/// The keys [`Common`] reads, as its derived `Deserialize` names them: the split between the
/// common settings and the method's own follows the struct, with no list kept by hand.
fn common_keys() -> &'static [&'static str] {
    static KEYS: std::sync::OnceLock<&'static [&'static str]> = std::sync::OnceLock::new();
    KEYS.get_or_init(|| {
        let mut fields: &'static [&'static str] = &[];
        let _ = Common::deserialize(FieldNames(&mut fields));
        assert!(!fields.is_empty(), "Common deserializes as a struct");
        fields
    })
}

/// A deserializer that only records the field names a derived struct asks for, then stops.
struct FieldNames<'a>(&'a mut &'static [&'static str]);

impl<'de> serde::Deserializer<'de> for FieldNames<'_> {
    type Error = serde::de::value::Error;

    fn deserialize_any<V: serde::de::Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
        Err(serde::de::Error::custom("field names only"))
    }

    fn deserialize_struct<V: serde::de::Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Self::Error> {
        *self.0 = fields;
        Err(serde::de::Error::custom("field names only"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

/// A method's "unknown field" error, with every key the fit reads as the expected ones (so
/// a misspelled common key is suggested too) and what the method itself reads.
fn unknown_key(e: &str, method: &str) -> String {
    let Some(rest) = e.strip_prefix("unknown field `") else {
        return format!("{e} (settings of method {method})");
    };
    let key = rest.split('`').next().unwrap_or_default();
    let own: Vec<&str> = e
        .split("expected")
        .nth(1)
        .map_or(vec![], |s| s.split('`').skip(1).step_by(2).collect());
    let all: Vec<String> = own
        .iter()
        .chain(common_keys().iter())
        .map(|k| format!("`{k}`"))
        .collect();
    let reads = if own.is_empty() {
        "no settings of its own".to_string()
    } else {
        own.join(", ")
    };
    format!(
        "unknown field `{key}`, expected one of {} (method {method} reads {reads})",
        all.join(", ")
    )
}

impl Default for Common {
    fn default() -> Self {
        Common {
            // The prediction-error method: least squares where there are only CFD cases, the
            // simulation error of the pool runs where there are any (see identify::pem).
            method: "pem".into(),
            objective: Objective::EquationError,
            skip_start_s: 0.0,
            vehicle: None,
            expected: BTreeMap::new(),
            reference_length_m: None,
            added_mass_window_s: None,
            structure: None,
            custom_terms: None,
            median_filter: None,
            thrust_gain: Default::default(),
            constants: Default::default(),
            couplings: Default::default(),
        }
    }
}

impl Settings {
    /// Method `name` with its default settings and the default common ones.
    pub fn of_method(name: &str) -> Settings {
        Settings {
            method: identify::Method::parse(name, Default::default()).expect("a registered method"),
            common: Common {
                method: name.into(),
                ..Common::default()
            },
        }
    }

    /// `ols`, `qpso (l1, output error)`: how tables name this configuration.
    pub fn label(&self) -> String {
        self.method
            .label(self.common.objective == Objective::OutputError)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings::of_method("ols")
    }
}

impl<'de> Deserialize<'de> for Settings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Settings, D::Error> {
        use serde::de::Error;
        let mut all = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let mut common = serde_json::Map::new();
        for k in common_keys() {
            if let Some(v) = all.remove(*k) {
                common.insert(k.to_string(), v);
            }
        }
        let common: Common =
            serde_json::from_value(serde_json::Value::Object(common)).map_err(D::Error::custom)?;
        let known = identify::by_name(&common.method).is_some();
        let method = identify::Method::parse(&common.method, all).map_err(|e| {
            if known {
                D::Error::custom(unknown_key(&e, &common.method))
            } else {
                D::Error::custom(e)
            }
        })?;
        Ok(Settings { method, common })
    }
}

impl Serialize for Settings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = serde_json::to_value(&self.common).map_err(serde::ser::Error::custom)?;
        let obj = v.as_object_mut().expect("settings are a map");
        if let Ok(serde_json::Value::Object(own)) = serde_json::to_value(&self.method.settings) {
            obj.extend(own);
        }
        v.serialize(s)
    }
}
