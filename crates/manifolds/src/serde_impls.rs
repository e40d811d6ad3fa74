//! serde support (feature `serde`): every point of every space, written in the I/O convention of the
//! crate and read back through the validated constructors, so a file can never produce an invalid
//! point (a quaternion that is not unit, a NaN coordinate).
//!
//! | type | written as |
//! |---|---|
//! | `So2` | `[cos θ, sin θ]` |
//! | `So3`, `Su2` | `[w, x, y, z]` (Hamilton, scalar first) |
//! | `S2` | `[x, y, z]` |
//! | `Rn<N>` | `[x₁, …, x_N]` |
//! | `Se2`, `Se3` | `{"rotation": …, "translation": [...]}` |
//! | `Se23` | `{"rotation": [w, x, y, z], "velocity": [...], "position": [...]}` |
//! | `Left<G>` | as `G` |
//! | `ProductManifold` | `{"first": …, "second": …}` |
//! | `MeanSettings` | `{"max_iterations": n, "tolerance": t}` |
//!
//! Reading applies the same tolerances as the constructors (unit norm within
//! [`UNIT_NORM_TOLERANCE`](crate::constants::Thresholds::UNIT_NORM_TOLERANCE)), and reports their
//! message as the format's error. Like the constructors, it stores a quaternion, unit complex
//! number or unit vector as written when it is unit to rounding (`abs(norm² − 1)` at most
//! [`UNIT_ROUNDING_TOLERANCE`](crate::constants::Thresholds::UNIT_ROUNDING_TOLERANCE), 32 eps), and
//! normalised otherwise. So values round-trip exactly (every coordinate is written in full
//! precision by any lossless format) when they are unit to rounding: every value a checked
//! constructor stores (normalising is idempotent), and the products of a few of them; a value
//! further off (a long chain of products without [`renormalized`](crate::So3::renormalized), or one
//! made with an `_unchecked` constructor) is read back normalised.

use crate::{Left, MeanSettings, ProductManifold, Real, Rn, S2, Se2, Se3, Se23, So2, So3, Su2};
use nalgebra::{SVector, Vector2, Vector3};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

impl<T: Real + Serialize> Serialize for So2<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        [self.cos(), self.sin()].serialize(serializer)
    }
}

impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for So2<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let [cos, sin] = <[T; 2]>::deserialize(deserializer)?;
        So2::from_cos_sin(cos, sin).map_err(D::Error::custom)
    }
}

/// `So3` and `Su2`: the quaternion, scalar first.
macro_rules! quaternion_serde {
    ($ty:ident) => {
        impl<T: Real + Serialize> Serialize for $ty<T> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                self.to_quaternion_wxyz().serialize(serializer)
            }
        }

        impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for $ty<T> {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                let [w, x, y, z] = <[T; 4]>::deserialize(deserializer)?;
                $ty::from_quaternion_wxyz(w, x, y, z).map_err(D::Error::custom)
            }
        }
    };
}
quaternion_serde!(So3);
quaternion_serde!(Su2);

impl<T: Real + Serialize> Serialize for S2<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.as_vector().serialize(serializer)
    }
}

impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for S2<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        S2::new(Vector3::deserialize(deserializer)?).map_err(D::Error::custom)
    }
}

impl<T: Real + Serialize, const N: usize> Serialize for Rn<T, N> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.coords().serialize(serializer)
    }
}

impl<'de, T: Real + Deserialize<'de>, const N: usize> Deserialize<'de> for Rn<T, N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        Rn::new(SVector::deserialize(deserializer)?).map_err(D::Error::custom)
    }
}

/// The two parts of a pose, as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Pose<R, V> {
    rotation: R,
    translation: V,
}

/// `Se2` and `Se3`: rotation and translation, read back through `new`.
macro_rules! pose_serde {
    ($ty:ident, $rotation:ident, $translation:ident) => {
        impl<T: Real + Serialize> Serialize for $ty<T> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                Pose {
                    rotation: self.rotation(),
                    translation: self.translation(),
                }
                .serialize(serializer)
            }
        }

        impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for $ty<T> {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                let pose = Pose::<$rotation<T>, $translation<T>>::deserialize(deserializer)?;
                $ty::new(pose.rotation, pose.translation).map_err(D::Error::custom)
            }
        }
    };
}
pose_serde!(Se2, So2, Vector2);
pose_serde!(Se3, So3, Vector3);

/// The three parts of an extended pose, as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExtendedPose<R, V> {
    rotation: R,
    velocity: V,
    position: V,
}

impl<T: Real + Serialize> Serialize for Se23<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        ExtendedPose {
            rotation: self.rotation(),
            velocity: self.velocity(),
            position: self.position(),
        }
        .serialize(serializer)
    }
}

/// Read back through [`Se23::new`].
impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for Se23<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let x = ExtendedPose::<So3<T>, Vector3<T>>::deserialize(deserializer)?;
        Se23::new(x.rotation, x.velocity, x.position).map_err(D::Error::custom)
    }
}

impl<G: Serialize> Serialize for Left<G> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.inner().serialize(serializer)
    }
}

impl<'de, G: Deserialize<'de>> Deserialize<'de> for Left<G> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        G::deserialize(deserializer).map(Left::new)
    }
}

/// The two factors of a product, as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Factors<A, B> {
    first: A,
    second: B,
}

impl<A: Serialize, B: Serialize, const DA: usize, const DB: usize, const D: usize> Serialize
    for ProductManifold<A, B, DA, DB, D>
{
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        Factors {
            first: self.first(),
            second: self.second(),
        }
        .serialize(serializer)
    }
}

impl<'de, A, B, const DA: usize, const DB: usize, const D: usize> Deserialize<'de>
    for ProductManifold<A, B, DA, DB, D>
where
    A: Deserialize<'de>,
    B: Deserialize<'de>,
{
    fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        let factors = Factors::<A, B>::deserialize(deserializer)?;
        Ok(ProductManifold::new(factors.first, factors.second))
    }
}

/// The settings of the weighted mean, as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Settings<T> {
    max_iterations: usize,
    tolerance: T,
}

impl<T: Real + Serialize> Serialize for MeanSettings<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        Settings {
            max_iterations: self.max_iterations(),
            tolerance: self.tolerance(),
        }
        .serialize(serializer)
    }
}

impl<'de, T: Real + Deserialize<'de>> Deserialize<'de> for MeanSettings<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let settings = Settings::<T>::deserialize(deserializer)?;
        MeanSettings::new(settings.max_iterations, settings.tolerance).map_err(D::Error::custom)
    }
}
