//! Named scene parameters: a path into the scene's serialized form.
//!
//! A path is a JSON-pointer-like list of segments separated by `/` (RFC 6901
//! without the leading `/` and without `~` escapes, which no scene key needs):
//! object keys, array indices, and `*` for "every element" (all sections get the
//! same value). Examples:
//!
//! - `robot/sections/*/youngs_modulus_pa` (the material is flattened into the section)
//! - `robot/sections/0/guides/holes/radius_m`
//! - `robot/sections/0/shape/solid/diameter_m`
//! - `loads/point/1/force_n/0`
//!
//! Values are set generically: the [`Scene`] is serialized to a
//! [`serde_json::Value`], the numbers are written, and the value is deserialized
//! back, so any numeric field works and the scene's own schema checks apply.

use super::Scene;
use serde_json::Value;
use std::fmt;
use std::str::FromStr;
use thiserror::Error;

/// Why a parameter path could not be parsed, read or written.
#[derive(Debug, Error)]
pub enum ParamError {
    /// The path is malformed.
    #[error("parameter path `{path}`: {why}")]
    BadPath {
        /// The path as given.
        path: String,
        /// What is wrong.
        why: String,
    },
    /// A parameter path does not lead to a number in the scene.
    #[error("parameter path `{path}` does not name a number in the scene: {why}")]
    NoSuchParam {
        /// The path as given.
        path: String,
        /// Where the walk stopped.
        why: String,
    },
    /// The scene no longer deserializes after writing a value (e.g. a float into
    /// an integer field).
    #[error("setting `{path}` = {} breaks the scene: {why}", crate::error::Num(*.value))]
    SetFailed {
        /// The path.
        path: String,
        /// The value written.
        value: f64,
        /// Deserializer message.
        why: String,
    },
    /// The scene could not be serialized to its JSON form.
    #[error("serializing the scene: {0}")]
    Serialize(String),
}

/// One segment of a [`ParamPath`].
#[derive(Clone, Debug, PartialEq, Eq)]
enum Segment {
    /// Object key, or array index when it parses as one.
    Key(String),
    /// Every element of an array (or every value of an object).
    All,
}

/// A parsed parameter path such as `robot/sections/*/youngs_modulus_pa`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamPath {
    text: String,
    segments: Vec<Segment>,
}

impl FromStr for ParamPath {
    type Err = ParamError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let text = s.trim().trim_start_matches('/').to_string();
        if text.is_empty() {
            return Err(ParamError::BadPath {
                path: s.into(),
                why: "empty".into(),
            });
        }
        let segments = text
            .split('/')
            .map(|seg| match seg {
                "" => Err(ParamError::BadPath {
                    path: s.into(),
                    why: "empty segment (`//`)".into(),
                }),
                "*" => Ok(Segment::All),
                k => Ok(Segment::Key(k.to_string())),
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { text, segments })
    }
}

impl fmt::Display for ParamPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl ParamPath {
    /// The path as written (without a leading `/`).
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Every number the path matches in `scene`, in document order. Fails when the
    /// path matches nothing or something that is not a number.
    pub fn get(&self, scene: &Scene) -> Result<Vec<f64>, ParamError> {
        let mut value = to_value(scene)?;
        let mut out = Vec::new();
        self.walk(&mut value, 0, "", &mut |v, at| match v.as_f64() {
            Some(x) => {
                out.push(x);
                Ok(())
            }
            None => Err(format!("`{at}` is {}, not a number", kind(v))),
        })?;
        Ok(out)
    }

    /// The value of the parameter: the first match (all matches of a `*` path are
    /// equal after [`ParamPath::set_in`]; a scene where they differ reports the first).
    pub fn value(&self, scene: &Scene) -> Result<f64, ParamError> {
        Ok(self.get(scene)?[0])
    }

    /// Write `value` into every match of the path in the JSON form of a scene.
    pub fn set_in(&self, root: &mut Value, value: f64) -> Result<(), ParamError> {
        let number = serde_json::Number::from_f64(value).ok_or_else(|| ParamError::SetFailed {
            path: self.text.clone(),
            value,
            why: "not a finite number".into(),
        })?;
        self.walk(root, 0, "", &mut |v, at| {
            if v.is_number() {
                *v = Value::Number(number.clone());
                Ok(())
            } else {
                Err(format!("`{at}` is {}, not a number", kind(v)))
            }
        })
    }

    fn walk(
        &self,
        v: &mut Value,
        depth: usize,
        at: &str,
        leaf: &mut dyn FnMut(&mut Value, &str) -> Result<(), String>,
    ) -> Result<(), ParamError> {
        let fail = |why: String| ParamError::NoSuchParam {
            path: self.text.clone(),
            why,
        };
        let Some(seg) = self.segments.get(depth) else {
            return leaf(v, at).map_err(fail);
        };
        match (seg, v) {
            (Segment::All, Value::Array(items)) => {
                if items.is_empty() {
                    return Err(fail(format!("`{at}` is an empty array")));
                }
                for (i, item) in items.iter_mut().enumerate() {
                    self.walk(item, depth + 1, &format!("{at}/{i}"), leaf)?;
                }
                Ok(())
            }
            (Segment::All, Value::Object(map)) => {
                if map.is_empty() {
                    return Err(fail(format!("`{at}` is an empty table")));
                }
                for (k, item) in map.iter_mut() {
                    self.walk(item, depth + 1, &format!("{at}/{k}"), leaf)?;
                }
                Ok(())
            }
            (Segment::Key(k), Value::Object(map)) => match map.get_mut(k) {
                Some(item) => self.walk(item, depth + 1, &format!("{at}/{k}"), leaf),
                None => {
                    let keys: Vec<&str> = map.keys().map(String::as_str).collect();
                    Err(fail(format!(
                        "no key `{k}` under `{}` (keys: {})",
                        if at.is_empty() { "/" } else { at },
                        keys.join(", ")
                    )))
                }
            },
            (Segment::Key(k), Value::Array(items)) => {
                let i: usize = k
                    .parse()
                    .map_err(|_| fail(format!("`{at}` is an array: `{k}` is not an index")))?;
                let n = items.len();
                match items.get_mut(i) {
                    Some(item) => self.walk(item, depth + 1, &format!("{at}/{i}"), leaf),
                    None => Err(fail(format!("`{at}` has {n} elements, no index {i}"))),
                }
            }
            (_, v) => Err(fail(format!(
                "`{at}` is {}, cannot descend into it",
                kind(v)
            ))),
        }
    }
}

/// A copy of `scene` with each `(path, value)` written, in order (a later path
/// overrides an earlier one where both match). One serialize/deserialize round trip.
pub fn set_params(scene: &Scene, params: &[(ParamPath, f64)]) -> Result<Scene, ParamError> {
    if params.is_empty() {
        return Ok(scene.clone());
    }
    let mut root = to_value(scene)?;
    for (p, v) in params {
        p.set_in(&mut root, *v)?;
    }
    serde_json::from_value(root).map_err(|e| ParamError::SetFailed {
        path: params
            .iter()
            .map(|(p, _)| p.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        value: params[params.len() - 1].1,
        why: e.to_string(),
    })
}

/// [`set_params`] with the paths and their values side by side (extra values or
/// paths are ignored).
pub fn set_values(
    scene: &Scene,
    params: &[ParamPath],
    values: &[f64],
) -> Result<Scene, ParamError> {
    let pairs: Vec<(ParamPath, f64)> = params.iter().cloned().zip(values.iter().copied()).collect();
    set_params(scene, &pairs)
}

fn to_value(scene: &Scene) -> Result<Value, ParamError> {
    serde_json::to_value(scene).map_err(|e| ParamError::Serialize(e.to_string()))
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null (an absent optional table?)",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "a table",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/thesis/table_4_3.toml"
        ))
        .unwrap();
        Scene::from_toml_str(&text).unwrap()
    }

    fn p(s: &str) -> ParamPath {
        s.parse().unwrap()
    }

    #[test]
    fn wildcard_sets_every_section_and_round_trips() {
        let two = Scene::from_toml_str(
            &std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/data/thesis/table_4_1.toml"
            ))
            .unwrap(),
        )
        .unwrap();
        let e = p("robot/sections/*/youngs_modulus_pa");
        let s = set_params(&two, &[(e.clone(), 61.5e9)]).unwrap();
        assert_eq!(e.get(&s).unwrap(), vec![61.5e9, 61.5e9]);
        assert_eq!(s.robot.sections[1].material.youngs_modulus_pa, 61.5e9);
        // a later, more specific path overrides
        let s = set_params(
            &two,
            &[
                (e.clone(), 61.5e9),
                (p("/robot/sections/1/youngs_modulus_pa"), 60e9),
            ],
        )
        .unwrap();
        assert_eq!(e.get(&s).unwrap(), vec![61.5e9, 60e9]);
    }

    #[test]
    fn nested_fields_and_array_components() {
        let s = scene();
        let r = p("robot/sections/0/guides/holes/radius_m");
        assert_eq!(r.value(&s).unwrap(), 0.01);
        let s2 = set_params(
            &s,
            &[(r.clone(), 9.6e-3), (p("loads/point/0/force_n/0"), 0.5)],
        )
        .unwrap();
        assert_eq!(
            s2.robot.sections[0].guides.as_ref().unwrap().holes.radius_m,
            9.6e-3
        );
        assert_eq!(s2.loads.point[0].force_n, [0.5, 0.0, 0.0]);
        assert_eq!(
            p("robot/sections/0/shape/solid/diameter_m")
                .value(&s)
                .unwrap(),
            1.56e-3
        );
    }

    #[test]
    fn bad_paths_are_errors_with_context() {
        let s = scene();
        let e = p("robot/sections/0/youngs_modulus")
            .get(&s)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no key `youngs_modulus`") && e.contains("youngs_modulus_pa"),
            "{e}"
        );
        let e = p("robot/sections/3/length_m")
            .get(&s)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no index 3"), "{e}");
        let e = p("robot/sections/0").get(&s).unwrap_err().to_string();
        assert!(e.contains("not a number"), "{e}");
        let e = p("numerics/guide_mass").get(&s).unwrap_err().to_string();
        assert!(e.contains("a string"), "{e}");
        assert!("a//b".parse::<ParamPath>().is_err());
        assert!("".parse::<ParamPath>().is_err());
        // a float into an integer field fails at deserialization, naming the path
        let e = set_params(&s, &[(p("robot/sections/0/guides/count"), 5.5)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("guides/count"), "{e}");
        let e = set_params(&s, &[(p("robot/sections/0/length_m"), f64::NAN)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("finite"), "{e}");
    }
}
