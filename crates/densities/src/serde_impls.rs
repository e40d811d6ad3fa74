//! serde support (feature `serde`): every density is written as the parameters of its validated
//! constructor and read back through that constructor, so a file can never produce an invalid
//! density (a negative concentration, a covariance that is not positive definite, a NaN): reading
//! it is an error with the constructor's message.
//!
//! | type | written as | read by |
//! |---|---|---|
//! | `VonMises` | `{"natural": [η₁, η₂]}` | [`VonMises::from_natural`] |
//! | `GenVonMises2` | `{"eta1": [..], "eta2": [..]}` | [`GenVonMises2::from_natural`] |
//! | `VonMisesFisher` | `{"mean": [x, y, z], "concentration": κ}` | [`VonMisesFisher::new`] |
//! | `Bingham` | `{"orientation": [16 entries, column-major], "eigenvalues": [..]}` | [`Bingham::new`] |
//! | `HeatKernelSo3` | `{"mean": [w, x, y, z], "variance": s}` | [`HeatKernelSo3::new`] |
//! | `Gaussian<N>` | `{"mean": [..], "covariance": [.., column-major]}` | [`Gaussian::new`] |
//! | `ManifoldGaussian<X, D>` | `{"mean": X, "covariance": [..]}` | [`ManifoldGaussian::new`] |
//! | `HarmonicGaussian<N>` | `{"angle": GenVonMises2, "features": [..], "covariance": [..]}` | [`HarmonicGaussian::new`] |
//!
//! Points are written as in `liebayes_manifolds` (its `serde` feature). Values round-trip exactly
//! with a lossless format (serde_json with `float_roundtrip`, for example): the constructors
//! recompute every derived quantity from the same parameters.

use crate::{
    Bingham, Gaussian, GenVonMises2, HarmonicGaussian, HeatKernelSo3, ManifoldGaussian, VonMises,
    VonMisesFisher,
};
use liebayes_manifolds::{Manifold, S2, So3};
use nalgebra::{Matrix4, SMatrix, SVector, Vector2, Vector3, Vector4};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// `Serialize` through a borrowed representation and `Deserialize` through an owned one checked by
/// a constructor.
macro_rules! through_constructor {
    (
        [$($generics:tt)*] [$($args:tt)*] $ty:ty, [$($bounds:tt)*],
        $repr:ident { $($field:ident : $fty:ty),* $(,)? },
        |$s:ident| $to:expr,
        |$r:ident| $from:expr
    ) => {
        #[derive(Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        #[serde(bound(serialize = "", deserialize = ""))]
        struct $repr<$($generics)*> where $($bounds)* {
            $($field: $fty),*
        }

        impl<$($generics)*> Serialize for $ty where $($bounds)* {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let $s = self;
                let repr: $repr<$($args)*> = $to;
                repr.serialize(serializer)
            }
        }

        impl<'de, $($generics)*> Deserialize<'de> for $ty where $($bounds)* {
            fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
                let $r = $repr::deserialize(deserializer)?;
                $from.map_err(De::Error::custom)
            }
        }
    };
}

through_constructor!(
    [] [] VonMises, [],
    VonMisesRepr { natural: Vector2<f64> },
    |p| VonMisesRepr { natural: p.natural() },
    |r| VonMises::from_natural(r.natural)
);

through_constructor!(
    [] [] GenVonMises2, [],
    GenVonMises2Repr { eta1: Vector2<f64>, eta2: Vector2<f64> },
    |p| {
        let (eta1, eta2) = p.natural();
        GenVonMises2Repr { eta1, eta2 }
    },
    |r| GenVonMises2::from_natural(r.eta1, r.eta2)
);

through_constructor!(
    [] [] VonMisesFisher, [],
    VonMisesFisherRepr { mean: S2<f64>, concentration: f64 },
    |p| VonMisesFisherRepr {
        mean: p.mean().unwrap_or_else(|| S2::new_unchecked(Vector3::z())),
        concentration: p.concentration(),
    },
    |r| VonMisesFisher::new(r.mean, r.concentration)
);

through_constructor!(
    [] [] Bingham, [],
    BinghamRepr { orientation: Matrix4<f64>, eigenvalues: Vector4<f64> },
    |p| BinghamRepr { orientation: *p.orientation(), eigenvalues: p.eigenvalues() },
    |r| Bingham::new(r.orientation, r.eigenvalues)
);

through_constructor!(
    [] [] HeatKernelSo3, [],
    HeatKernelRepr { mean: So3<f64>, variance: f64 },
    |p| HeatKernelRepr { mean: p.mean(), variance: p.variance() },
    |r| HeatKernelSo3::new(r.mean, r.variance)
);

through_constructor!(
    [const N: usize] [N] Gaussian<N>, [],
    GaussianRepr { mean: SVector<f64, N>, covariance: SMatrix<f64, N, N> },
    |p| GaussianRepr { mean: *p.mean(), covariance: *p.covariance() },
    |r| Gaussian::new(r.mean, r.covariance)
);

through_constructor!(
    [X, const D: usize] [X, D] ManifoldGaussian<X, D>,
    [X: Manifold<D, Scalar = f64> + Serialize + for<'a> Deserialize<'a>],
    ManifoldGaussianRepr { mean: X, covariance: SMatrix<f64, D, D> },
    |p| ManifoldGaussianRepr { mean: p.mean().clone(), covariance: *p.covariance() },
    |r| ManifoldGaussian::new(r.mean, r.covariance)
);

through_constructor!(
    [const N: usize] [N] HarmonicGaussian<N>, [],
    HarmonicGaussianRepr {
        angle: GenVonMises2,
        features: SMatrix<f64, N, 3>,
        covariance: SMatrix<f64, N, N>,
    },
    |p| HarmonicGaussianRepr {
        angle: p.angle().clone(),
        features: *p.features(),
        covariance: *p.covariance(),
    },
    |r| HarmonicGaussian::new(r.angle, r.features, r.covariance)
);
