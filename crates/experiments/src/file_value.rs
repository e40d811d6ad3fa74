//! A metric value as a summary file holds it. JSON has no NaN or infinity: a value is written as a
//! number, `null` for NaN (no value), and `"inf"` or `"-inf"` for the infinities, so that every
//! value reads back bit for bit (up to the sign of a NaN).

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// One value in its file form (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FileValue(pub(crate) f64);

impl Serialize for FileValue {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let v = self.0;
        if v.is_finite() {
            s.serialize_f64(v)
        } else if v.is_nan() {
            s.serialize_none()
        } else if v > 0.0 {
            s.serialize_str("inf")
        } else {
            s.serialize_str("-inf")
        }
    }
}

/// What a file may hold for a value.
#[derive(Deserialize)]
#[serde(untagged)]
enum Written {
    Number(f64),
    Word(String),
}

impl<'de> Deserialize<'de> for FileValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        Ok(Self(match Option::<Written>::deserialize(d)? {
            None => f64::NAN,
            Some(Written::Number(v)) => v,
            Some(Written::Word(w)) if w == "inf" => f64::INFINITY,
            Some(Written::Word(w)) if w == "-inf" => f64::NEG_INFINITY,
            Some(Written::Word(w)) => {
                return Err(D::Error::custom(format!(
                    "a value must be a number, null, \"inf\" or \"-inf\", not {w:?}"
                )));
            }
        }))
    }
}

/// Values in their file form, for `#[serde(serialize_with = "file_values::serialize")]` (read
/// back through a bounded reader of [`FileValue`]s).
pub(crate) mod file_values {
    use super::FileValue;
    use serde::Serializer;

    pub(crate) fn serialize<S: Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(values.iter().map(|&v| FileValue(v)))
    }
}
