//! One door for what a user sets. config.yaml's keys, the command line's flags and the JS input
//! all become a [`SettingsInput`], and [`SettingsInput::apply`] is the only place that maps one
//! onto [`Settings`]. The page shows [`SettingsInput::defaults`] before anything is set.

use std::fmt;
use std::str::FromStr;

use serde::de::{self, Deserializer};
use serde::{Deserialize, Serialize, Serializer};

use super::settings::{InitialSigma, Method, Settings};
use crate::targets::Target;

/// What a user may set, each field optional: unset keeps the default. Keys are camelCase for
/// JS; config.yaml's snake_case names (`initial_sigma`, `target_edge`) are accepted too, and
/// unknown keys are ignored (GMMCalib's configs carry keys of their own).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct SettingsInput {
    /// The methods to run: a name, several comma-separated, or `all` (every one, compared).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub method: Option<Methods>,
    /// The target: `cube:EDGE`, `box:W,D,H`, `sphere:DIAMETER`, `mesh:PATH` or `none` (JS may
    /// also give `{kind, edge | size | diameter}`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<TargetChoice>,
    /// GMMCalib's cube edge (m); `target` wins.
    #[serde(alias = "target_edge", skip_serializing)]
    pub target_edge: Option<f64>,
    /// Mixture components.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<usize>,
    /// The most EM iterations (JRMPC's or `cad`'s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<usize>,
    /// EM's convergence test, for whichever method runs (unset: each method's own).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// Multi-resolution EM, for whichever method runs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multiresolution: Option<bool>,
    /// JRMPC's exact E-step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exact: Option<bool>,
    /// The mixture's initial width: a width (m), `prior` or `bbox`.
    #[serde(alias = "initial_sigma", skip_serializing_if = "Option::is_none")]
    pub initial_sigma: Option<InitialSigma>,
    /// Seeds every random choice.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The global alignment first (unset: for the methods that run it by default).
    #[serde(alias = "alignGlobally", skip_serializing_if = "Option::is_none")]
    pub global: Option<bool>,
    /// Levelling onto the reference's ground (unset: for `gmm` and `cad`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<bool>,
    /// The search from above after levelling.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bev: Option<bool>,
    /// Refine only, from the nominal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine: Option<bool>,
    /// Threads sharing the E-step and the frame pairs (the result does not depend on it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
}

impl SettingsInput {
    /// What every unset field means, as a user would write it (the page's starting settings).
    /// The EM tolerance differs by method, so it stays unset here.
    pub fn defaults() -> Self {
        let s = Settings::default();
        let target = TargetChoice::Shape(s.target.clone());
        SettingsInput {
            method: Some(Methods(vec![Method::default()])),
            target: Some(target),
            target_edge: None,
            components: Some(s.components),
            iterations: Some(s.jrmpc.max_iterations),
            tolerance: None,
            multiresolution: Some(s.gmm_em.multiresolution),
            exact: Some(s.jrmpc.exact),
            initial_sigma: Some(s.initial_sigma),
            seed: Some(s.seed),
            global: s.align_globally,
            level: s.level_ground,
            bev: Some(s.bev.is_some()),
            refine: Some(s.refine_only),
            threads: None,
        }
    }

    /// This input with `lower`'s values where this one sets none (the command line over the
    /// config file).
    pub fn or(self, lower: SettingsInput) -> SettingsInput {
        SettingsInput {
            method: self.method.or(lower.method),
            target: self.target.or(lower.target),
            target_edge: self.target_edge.or(lower.target_edge),
            components: self.components.or(lower.components),
            iterations: self.iterations.or(lower.iterations),
            tolerance: self.tolerance.or(lower.tolerance),
            multiresolution: self.multiresolution.or(lower.multiresolution),
            exact: self.exact.or(lower.exact),
            initial_sigma: self.initial_sigma.or(lower.initial_sigma),
            seed: self.seed.or(lower.seed),
            global: self.global.or(lower.global),
            level: self.level.or(lower.level),
            bev: self.bev.or(lower.bev),
            refine: self.refine.or(lower.refine),
            threads: self.threads.or(lower.threads),
        }
    }

    /// The target chosen: `target`, else a cube of `target_edge`.
    pub fn target_choice(&self) -> Option<TargetChoice> {
        self.target
            .clone()
            .or_else(|| self.target_edge.map(|edge| TargetChoice::Shape(Target::Cube { edge })))
    }

    /// Reads a `mesh:PATH` target's file with `read` (the door knows where files are).
    pub fn resolve_mesh(
        &mut self,
        read: impl FnOnce(&str) -> Result<Target, String>,
    ) -> Result<(), String> {
        if let Some(TargetChoice::MeshFile(path)) = &self.target {
            self.target = Some(TargetChoice::Shape(read(path)?));
        }
        Ok(())
    }

    /// Sets what this input sets on `settings`, and returns the methods to run (`gmm` when it
    /// names none). Errors name the key.
    pub fn apply(&self, settings: &mut Settings) -> Result<Vec<Method>, String> {
        let positive = |key: &str, n: Option<usize>| match n {
            Some(0) => Err(format!("{key}: expected a positive integer, got 0")),
            _ => Ok(n),
        };
        let methods = match &self.method {
            Some(Methods(list)) if !list.is_empty() => list.clone(),
            _ => vec![Method::default()],
        };
        match self.target_choice() {
            Some(TargetChoice::Shape(t)) => {
                settings.target = t.checked().map_err(|e| format!("target: {e}"))?;
            }
            Some(TargetChoice::MeshFile(path)) => {
                return Err(format!("target: the model mesh:{path} was not read"));
            }
            None => {}
        }
        if let Some(k) = positive("components", self.components)? {
            settings.components = k;
        }
        if let Some(n) = positive("iterations", self.iterations)? {
            settings.jrmpc.max_iterations = n;
        }
        if let Some(t) = self.tolerance {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("tolerance: expected a non-negative number, got {t}"));
            }
            (settings.jrmpc.tolerance, settings.gmm_em.tolerance) = (t, t);
        }
        if let Some(on) = self.multiresolution {
            (settings.jrmpc.multiresolution, settings.gmm_em.multiresolution) = (on, on);
        }
        if let Some(exact) = self.exact {
            settings.jrmpc.exact = exact;
        }
        if let Some(sigma) = self.initial_sigma {
            settings.initial_sigma = sigma;
        }
        if let Some(seed) = self.seed {
            settings.seed = seed;
        }
        if let Some(on) = self.global {
            settings.align_globally = Some(on);
        }
        if let Some(on) = self.level {
            settings.level_ground = Some(on);
        }
        if self.bev == Some(false) {
            settings.bev = None;
        }
        if let Some(refine) = self.refine {
            settings.refine_only = refine;
        }
        if let Some(t) = positive("threads", self.threads)? {
            settings.jrmpc.threads = t;
        }
        Ok(methods)
    }
}

/// The methods of a run: one, several compared, or `all` ([`Method::ALL`]). Written as a
/// name, names joined by commas, or `all`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Methods(pub Vec<Method>);

impl FromStr for Methods {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Method::parse_list(s).map(Methods).map_err(|e| e.to_string())
    }
}

impl fmt::Display for Methods {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0 == Method::ALL {
            return f.write_str("all");
        }
        let names: Vec<&str> = self.0.iter().map(Method::name).collect();
        f.write_str(&names.join(","))
    }
}

/// A target as a user names it: a shape (or a model already read), or a model file still to
/// read.
#[derive(Clone, Debug, PartialEq)]
pub enum TargetChoice {
    Shape(Target),
    /// `mesh:PATH`: the door reads the file ([`SettingsInput::resolve_mesh`]).
    MeshFile(String),
}

/// The path of a `mesh:PATH` target, if `target` is one.
pub fn mesh_path(target: &str) -> Option<&str> {
    let (kind, path) = target.trim().split_once(':')?;
    (kind.eq_ignore_ascii_case("mesh") && !path.trim().is_empty()).then(|| path.trim())
}

impl FromStr for TargetChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match mesh_path(s) {
            Some(path) => Ok(TargetChoice::MeshFile(path.to_string())),
            None => s.parse().map(TargetChoice::Shape),
        }
    }
}

impl fmt::Display for TargetChoice {
    /// The short form it parses from.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TargetChoice::Shape(Target::Cube { edge }) => write!(f, "cube:{edge}"),
            TargetChoice::Shape(Target::Box { size: [w, d, h] }) => write!(f, "box:{w},{d},{h}"),
            TargetChoice::Shape(Target::Sphere { diameter }) => write!(f, "sphere:{diameter}"),
            TargetChoice::Shape(Target::Mesh(m)) => write!(f, "mesh:{}", m.name),
            TargetChoice::Shape(Target::None) => f.write_str("none"),
            TargetChoice::MeshFile(path) => write!(f, "mesh:{path}"),
        }
    }
}

/// The JS input's object form of a target.
#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum TargetObject {
    Cube {
        edge: f64,
    },
    Box {
        size: [f64; 3],
    },
    Sphere {
        diameter: f64,
    },
    /// A CAD model: its file travels beside the input (bytes cannot travel inside it).
    Mesh,
    None,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum TargetForm {
    Text(String),
    Object(TargetObject),
}

impl<'de> Deserialize<'de> for TargetChoice {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let choice = match TargetForm::deserialize(d)? {
            TargetForm::Text(s) => s.parse().map_err(de::Error::custom)?,
            TargetForm::Object(o) => TargetChoice::Shape(match o {
                TargetObject::Cube { edge } => Target::Cube { edge },
                TargetObject::Box { size } => Target::Box { size },
                TargetObject::Sphere { diameter } => Target::Sphere { diameter },
                TargetObject::None => Target::None,
                TargetObject::Mesh => return Ok(TargetChoice::MeshFile(String::new())),
            }),
        };
        Ok(choice)
    }
}

impl Serialize for TargetChoice {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Methods {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?.parse().map_err(de::Error::custom)
    }
}

impl Serialize for Methods {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A width (m), or a rule's name.
#[derive(Deserialize)]
#[serde(untagged)]
enum SigmaForm {
    Fixed(f64),
    Rule(String),
}

impl<'de> Deserialize<'de> for InitialSigma {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match SigmaForm::deserialize(d) {
            Ok(SigmaForm::Fixed(x)) => InitialSigma::fixed(x),
            Ok(SigmaForm::Rule(r)) => InitialSigma::from_rule(&r),
            Err(_) => Err(InitialSigma::EXPECTED.to_string()),
        }
        .map_err(de::Error::custom)
    }
}

impl Serialize for InitialSigma {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            InitialSigma::Fixed(x) => s.serialize_f64(*x),
            InitialSigma::TargetSize => s.serialize_str("prior"),
            InitialSigma::BoundingBox => s.serialize_str("bbox"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_doors_read_the_same_keys() {
        let yaml: SettingsInput = serde_norway::from_str(
            "method: all\ntarget_edge: 0.4\ninitial_sigma: prior\ncomponents: 50\nrefine: true\nnumber_of_sensors: 2\n",
        )
        .unwrap();
        let json: SettingsInput = serde_json::from_str(
            r#"{"method":"all","target":{"kind":"cube","edge":0.4},"initialSigma":"prior","components":50,"refine":true}"#,
        )
        .unwrap();
        let mut a = Settings::default();
        let mut b = Settings::default();
        assert_eq!(yaml.apply(&mut a).unwrap(), Method::ALL.to_vec());
        assert_eq!(json.apply(&mut b).unwrap(), Method::ALL.to_vec());
        assert_eq!(a, b);
        assert_eq!(a.target, Target::Cube { edge: 0.4 });
        assert_eq!(
            (a.components, a.initial_sigma, a.refine_only),
            (50, InitialSigma::TargetSize, true)
        );
    }

    #[test]
    fn the_command_line_wins_over_the_file() {
        let file = SettingsInput { components: Some(50), exact: Some(true), ..Default::default() };
        let flags = SettingsInput { components: Some(70), ..Default::default() };
        let both = flags.or(file);
        assert_eq!((both.components, both.exact), (Some(70), Some(true)));
    }

    #[test]
    fn defaults_change_nothing_and_read_back() {
        let defaults = SettingsInput::defaults();
        let mut s = Settings::default();
        assert_eq!(defaults.apply(&mut s).unwrap(), vec![Method::Gmm]);
        assert_eq!(s, Settings::default());
        let text = serde_json::to_string(&defaults).unwrap();
        assert!(
            text.contains(r#""target":"cube:0.5""#) && text.contains(r#""method":"gmm""#),
            "{text}"
        );
        let back: SettingsInput = serde_json::from_str(&text).unwrap();
        assert_eq!(back, defaults);
    }

    #[test]
    fn bad_values_name_their_key() {
        let e = serde_json::from_str::<SettingsInput>(r#"{"method":"fast"}"#).unwrap_err();
        assert!(e.to_string().contains("fast"), "{e}");
        let e = serde_json::from_str::<SettingsInput>(r#"{"initialSigma":-1}"#).unwrap_err();
        assert!(e.to_string().contains("positive number"), "{e}");
        let zero = SettingsInput { components: Some(0), ..Default::default() };
        assert!(zero.apply(&mut Settings::default()).unwrap_err().starts_with("components:"));
        let unread = SettingsInput { target: "mesh:chair.obj".parse().ok(), ..Default::default() };
        assert!(unread.apply(&mut Settings::default()).unwrap_err().contains("chair.obj"));
    }
}
