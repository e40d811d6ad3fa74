//! proptest strategies for the densities (feature `proptest`), drawn over the whole parameter range
//! with its edges on purpose: κ = 0, 1e-300, tiny, moderate, large and 1e6.

use crate::{Bingham, Gaussian, GenVonMises2, HeatKernelSo3, VonMises, VonMisesFisher};
use liebayes_manifolds::testing::strategies as manifold;
use nalgebra::{Matrix4, SMatrix, SVector, Vector2, Vector4};
use proptest::prelude::*;

/// Concentrations: exactly 0 and 1e-300, log-uniform over [1e-8, 1e6] in three bands, and 1e6.
pub fn concentration() -> impl Strategy<Value = f64> {
    prop_oneof![
        1 => Just(0.0),
        1 => Just(1e-300),
        2 => (-8.0..-1.0_f64).prop_map(|e| 10f64.powf(e)),
        4 => (-1.0..2.0_f64).prop_map(|e| 10f64.powf(e)),
        2 => (2.0..6.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e6),
    ]
}

/// Von Mises distributions: any mean direction (including ±π), any concentration.
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn von_mises() -> impl Strategy<Value = VonMises> {
    (manifold::so2::<f64>(), concentration()).prop_map(|(mean, kappa)| {
        VonMises::from_mean_concentration(mean, kappa).expect("strategy parameters are valid")
    })
}

/// Von Mises-Fisher distributions: any mean direction (including the poles), any concentration.
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn von_mises_fisher() -> impl Strategy<Value = VonMisesFisher> {
    (manifold::s2::<f64>(), concentration()).prop_map(|(mean, kappa)| {
        VonMisesFisher::new(mean, kappa).expect("strategy parameters are valid")
    })
}

/// Second-harmonic generalised von Mises distributions: each harmonic with a uniform direction and a
/// concentration from [`concentration`] (capped at 1e3 so that sampling stays fast).
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn gen_von_mises2() -> impl Strategy<Value = GenVonMises2> {
    let harmonic = || {
        (0.0..std::f64::consts::TAU, concentration())
            .prop_map(|(angle, kappa)| Vector2::new(angle.cos(), angle.sin()) * kappa.min(1e3))
    };
    (harmonic(), harmonic()).prop_map(|(a, b)| GenVonMises2::new(a, b).expect("finite"))
}

/// Heat kernels on SO(3): any centre (including half turns), variance log-uniform over [1e-6, 10].
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn heat_kernel_so3() -> impl Strategy<Value = HeatKernelSo3> {
    (manifold::so3::<f64>(), -6.0..1.0_f64)
        .prop_map(|(centre, e)| HeatKernelSo3::new(centre, 10f64.powf(e)).expect("s > 0"))
}

/// Bingham distributions: any orientation in SO(4) (a left times a right quaternion multiplication),
/// eigenvalues 0 ≥ z₁ ≥ z₂ ≥ z₃ ≥ −`spread`, with repeated eigenvalues (isotropic and uniform cases)
/// drawn on purpose.
///
/// # Panics
/// Never: the orientation is orthogonal.
pub fn bingham(spread: f64) -> impl Strategy<Value = Bingham> {
    let eigenvalues = prop_oneof![
        3 => proptest::array::uniform3(0.0..1.0_f64).prop_map(move |u| [u[0], u[1], u[2]]),
        1 => (0.0..1.0_f64).prop_map(|u| [u, u, u]),
        1 => Just([0.0, 0.0, 0.0]),
    ];
    (manifold::su2::<f64>(), manifold::su2::<f64>(), eigenvalues).prop_map(move |(a, b, u)| {
        let [w1, x1, y1, z1] = a.to_quaternion_wxyz();
        let [w2, x2, y2, z2] = b.to_quaternion_wxyz();
        let left = Matrix4::new(
            w1, -x1, -y1, -z1, x1, w1, -z1, y1, y1, z1, w1, -x1, z1, -y1, x1, w1,
        );
        let right = Matrix4::new(
            w2, -x2, -y2, -z2, x2, w2, z2, -y2, y2, -z2, w2, x2, z2, y2, -x2, w2,
        );
        let z = Vector4::new(0.0, -spread * u[0], -spread * u[1], -spread * u[2]);
        Bingham::from_orientation(&(left * right), &z).expect("SO(4) orientations are orthogonal")
    })
}

/// Gaussians on Rⁿ: means in [−1e3, 1e3]ⁿ, covariances `B Bᵀ + 1e-6 I` with entries of B in [−3, 3].
///
/// # Panics
/// Never: the covariance is positive definite.
pub fn gaussian<const N: usize>() -> impl Strategy<Value = Gaussian<N>> {
    (
        proptest::collection::vec(-1e3..1e3_f64, N),
        proptest::collection::vec(-3.0..3.0_f64, N * N),
    )
        .prop_map(|(mean, b)| {
            let b = SMatrix::<f64, N, N>::from_column_slice(&b);
            let covariance = b * b.transpose() + SMatrix::<f64, N, N>::identity() * 1e-6;
            Gaussian::new(SVector::from_column_slice(&mean), covariance).expect("positive definite")
        })
}
