//! serde support (feature `serde`) for the azimuth filter's state: the seven numbers of an
//! [`AzimuthDensity`], written as `{"eta": [η₁, η₂], "a": [..], "c": [..], "sigma2": σ²}` and read
//! back through [`AzimuthDensity::from_parts`], so a file outside the valid range is an error; and
//! the plain-data [`VelocityInput`](super::VelocityInput). Values round-trip exactly.

use super::AzimuthDensity;
use nalgebra::Vector2;
use serde::de::Error as _;
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

impl Serialize for AzimuthDensity {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("AzimuthDensity", 4)?;
        state.serialize_field("eta", &self.eta())?;
        state.serialize_field("a", self.a())?;
        state.serialize_field("c", self.c())?;
        state.serialize_field("sigma2", &self.sigma2())?;
        state.end()
    }
}

/// The serialized fields of an [`AzimuthDensity`].
#[derive(Deserialize)]
#[serde(rename = "AzimuthDensity", deny_unknown_fields)]
struct Fields {
    eta: Vector2<f64>,
    a: Vector2<f64>,
    c: Vector2<f64>,
    sigma2: f64,
}

impl<'de> Deserialize<'de> for AzimuthDensity {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let f = Fields::deserialize(deserializer)?;
        AzimuthDensity::from_parts(f.eta, f.a, f.c, f.sigma2).map_err(D::Error::custom)
    }
}
