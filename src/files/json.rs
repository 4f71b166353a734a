//! JSON rows whose keys are checked for duplicates: `serde_json::Value` keeps the
//! last of two equal keys (`{"q1": 1.0, "q1": 2.0}` reads as `q1 = 2`), so a row
//! parsed into a map would silently drop a value. (Rows parsed into a derived
//! struct need no check: serde's derive already refuses a duplicate field.)

use serde::de::{Deserialize, Deserializer, Error, MapAccess, Visitor};
use serde_json::{Map, Value};

/// A JSON object whose keys are all distinct (its values are not checked).
struct UniqueObject(Map<String, Value>);

impl<'de> Deserialize<'de> for UniqueObject {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Map<String, Value>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<Self::Value, A::Error> {
                let mut out = Map::new();
                while let Some(key) = m.next_key::<String>()? {
                    if out.contains_key(&key) {
                        return Err(A::Error::custom(format!(
                            "duplicate key `{key}` (each key once per row)"
                        )));
                    }
                    let value: Value = m.next_value()?;
                    out.insert(key, value);
                }
                Ok(out)
            }
        }
        d.deserialize_map(V).map(UniqueObject)
    }
}

/// Parse `text` as one JSON object; a key given twice is an error naming the key
/// (and, through `serde_json`, the line and column where it repeats).
pub fn unique_object(text: &str) -> Result<Map<String, Value>, serde_json::Error> {
    serde_json::from_str::<UniqueObject>(text).map(|o| o.0)
}

#[cfg(test)]
mod tests {
    use super::unique_object;

    #[test]
    fn a_repeated_key_is_refused_naming_it() {
        let e = unique_object(r#"{"q1": 1.0, "q1": 2.0}"#).unwrap_err();
        assert!(e.to_string().contains("duplicate key `q1`"), "{e}");
    }

    #[test]
    fn distinct_keys_and_nested_values_are_kept() {
        let m = unique_object(r#"{"a": 1, "b": {"c": [1, 2]}, "d": null}"#).unwrap();
        assert_eq!(m.len(), 3);
        assert_eq!(m["b"]["c"][1], 2);
    }

    #[test]
    fn a_non_object_is_refused() {
        assert!(unique_object("[1, 2]").is_err());
        assert!(unique_object("3").is_err());
    }
}
