//! proptest strategies for the densities, drawn over the whole parameter range with its edges on
//! purpose.
//!
//! Each family's strategy takes the strategy of its spread parameter, so one function serves the
//! range the law suite can integrate ([`concentration`], [`variance`], [`standard_deviation`]) and
//! the ends of the accepted range ([`extreme_concentration`], [`extreme_variance`]), where only
//! finiteness can be checked.

use crate::{
    Bingham, DensityError, Gaussian, GenVonMises2, HarmonicGaussian, HeatKernelSo3,
    ManifoldGaussian, VonMises, VonMisesFisher,
};
use liebayes_manifolds::Manifold;
use liebayes_manifolds::testing::strategies as manifold;
use nalgebra::{Matrix4, SMatrix, SVector, Vector2, Vector3, Vector4};
use proptest::prelude::*;
use std::fmt::Debug;

/// Concentrations for the laws: exactly 0 and 1e-300, log-uniform over [1e-8, 1e6] in three bands,
/// and 1e6.
pub fn concentration() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => Just(0.0),
        1 => Just(1e-300),
        2 => (-8.0..-1.0_f64).prop_map(|e| 10f64.powf(e)),
        4 => (-1.0..2.0_f64).prop_map(|e| 10f64.powf(e)),
        2 => (2.0..6.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e6),
    ]
}

/// Concentrations at the ends of the accepted range [0, 1e300] of the von Mises and von Mises-Fisher
/// families: 0, the smallest subnormal, 1e-300, log-uniform over [1e6, 1e300], and 1e300.
pub fn extreme_concentration() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => Just(0.0),
        1 => Just(f64::from_bits(1)),
        1 => Just(1e-300),
        3 => (6.0..300.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e300),
    ]
}

/// Heat-kernel variances for the laws: log-uniform over [1e-6, 10], and both ends.
pub fn variance() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        4 => (-6.0..1.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e-6),
        1 => Just(10.0),
    ]
}

/// Heat-kernel variances at the ends of the accepted range [1e-300, f64::MAX]: 1e-300, log-uniform
/// over [1e-300, 1e-6] and [10, 1e300], and f64::MAX.
pub fn extreme_variance() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => Just(1e-300),
        2 => (-300.0..-6.0_f64).prop_map(|e| 10f64.powf(e)),
        2 => (1.0..300.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(f64::MAX),
    ]
}

/// Standard deviations (rad) for Gaussians on the rotation groups: log-uniform over [1e-6, 0.3], and
/// both ends. Up to 0.3 rad the mass beyond the injectivity radius π (more than 10 standard
/// deviations) is below 1e-23, so the laws hold to rounding.
pub fn standard_deviation() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        4 => (-6.0..(0.3_f64).log10()).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e-6),
        1 => Just(0.3),
    ]
}

/// Von Mises distributions: any mean direction (including ±π), concentrations from `kappa`.
///
/// # Panics
/// Never for concentrations in the accepted range [0, 1e300].
pub fn von_mises(kappa: impl Strategy<Value = f64>) -> impl Strategy<Value = VonMises> {
    (manifold::so2::<f64>(), kappa).prop_map(|(mean, kappa)| {
        VonMises::new(mean, kappa).expect("strategy parameters are valid")
    })
}

/// Von Mises-Fisher distributions: any mean direction (including the poles), concentrations from
/// `kappa`.
///
/// # Panics
/// Never for concentrations in the accepted range [0, 1e300].
pub fn von_mises_fisher(
    kappa: impl Strategy<Value = f64>,
) -> impl Strategy<Value = VonMisesFisher> {
    (manifold::s2::<f64>(), kappa).prop_map(|(mean, kappa)| {
        VonMisesFisher::new(mean, kappa).expect("strategy parameters are valid")
    })
}

/// Second-harmonic generalised von Mises distributions: each harmonic with a uniform direction and a
/// concentration from `kappa`, capped at 1e3 (so that the drawn harmonics can disagree strongly and
/// sampling stays fast), and the von Mises case η₂ = 0 and the bimodal case η₁ = 0 on purpose.
///
/// # Panics
/// Never: the concentrations are clamped to [0, 1e3] (a NaN one is read as 0).
pub fn gen_von_mises2(
    kappa: impl Strategy<Value = f64> + Clone,
) -> impl Strategy<Value = GenVonMises2> {
    let capped = |k: f64| if k.is_nan() { 0.0 } else { k.clamp(0.0, 1e3) };
    let harmonic = move || {
        (manifold::so2::<f64>(), kappa.clone()).prop_map(move |(mean, k)| (mean, capped(k)))
    };
    (harmonic(), harmonic(), 0..6_u8).prop_map(|((m1, k1), (m2, k2), case)| {
        let (k1, k2) = match case {
            0 => (k1, 0.0),
            1 => (0.0, k2),
            _ => (k1, k2),
        };
        GenVonMises2::new(m1, k1, m2, k2).expect("capped concentrations are in range")
    })
}

/// Heat kernels on SO(3): any centre (including half turns), variances from `variance`.
///
/// # Panics
/// Never for variances in the accepted range [1e-300, f64::MAX].
pub fn heat_kernel_so3(
    variance: impl Strategy<Value = f64>,
) -> impl Strategy<Value = HeatKernelSo3> {
    (manifold::so3::<f64>(), variance)
        .prop_map(|(mean, s)| HeatKernelSo3::new(mean, s).expect("s in [1e-300, f64::MAX]"))
}

/// Bingham distributions: any orientation in SO(4) (a left times a right quaternion multiplication),
/// eigenvalues 0 ≥ z₁ ≥ z₂ ≥ z₃ ≥ −`spread`, log-uniform gaps from 1e-3 · spread to spread, with
/// repeated eigenvalues (isotropic and uniform cases) and one or two vanishing gaps drawn on purpose.
///
/// # Panics
/// Never: `spread` is clamped to [0, [`Bingham::MAX_SPREAD`]] (a NaN one is read as 0), and the
/// orientation is orthogonal.
pub fn bingham(spread: f64) -> impl Strategy<Value = Bingham> {
    let spread = if spread.is_nan() {
        0.0
    } else {
        spread.clamp(0.0, Bingham::MAX_SPREAD)
    };
    let gap = move || {
        prop_oneof![
            4 => (-3.0..0.0_f64).prop_map(move |e| spread * 10f64.powf(e)),
            1 => (0.0..1.0_f64).prop_map(move |u| spread * u),
            1 => Just(0.0),
        ]
    };
    let eigenvalues = prop_oneof![
        4 => (gap(), gap(), gap()).prop_map(|(a, b, c)| [a, b, c]),
        1 => gap().prop_map(|u| [u, u, u]),
        1 => Just([0.0, 0.0, 0.0]),
    ];
    (manifold::su2::<f64>(), manifold::su2::<f64>(), eigenvalues).prop_map(move |(a, b, gaps)| {
        let [w1, x1, y1, z1] = a.to_quaternion_wxyz();
        let [w2, x2, y2, z2] = b.to_quaternion_wxyz();
        let left = Matrix4::new(
            w1, -x1, -y1, -z1, x1, w1, -z1, y1, y1, z1, w1, -x1, z1, -y1, x1, w1,
        );
        let right = Matrix4::new(
            w2, -x2, -y2, -z2, x2, w2, z2, -y2, y2, -z2, w2, x2, z2, y2, -x2, w2,
        );
        let z = Vector4::new(0.0, -gaps[0], -gaps[1], -gaps[2]);
        Bingham::new(left * right, z).expect("SO(4) orientations are orthogonal")
    })
}

/// Symmetric positive definite D × D matrices `R diag(σ²) Rᵀ` with a random orthogonal R (the Q of a
/// matrix of standard-normal-like entries) and standard deviations σ drawn from `sigma`
/// independently, so the condition number reaches the ratio of the range's ends.
pub fn covariance<const D: usize>(
    sigma: impl Strategy<Value = f64>,
) -> impl Strategy<Value = SMatrix<f64, D, D>> {
    (
        proptest::collection::vec(-1.0..1.0_f64, D * D),
        proptest::collection::vec(sigma, D),
    )
        .prop_map(|(entries, sigmas)| {
            let rotation = orthogonal::<D>(&entries);
            let diagonal =
                SMatrix::<f64, D, D>::from_fn(
                    |i, j| {
                        if i == j { sigmas[i] * sigmas[i] } else { 0.0 }
                    },
                );
            let c = rotation * diagonal * rotation.transpose();
            (c + c.transpose()) * 0.5
        })
}

/// An orthogonal matrix from D² entries in [−1, 1]: Gram-Schmidt on the columns, with the identity's
/// columns where they are degenerate.
fn orthogonal<const D: usize>(entries: &[f64]) -> SMatrix<f64, D, D> {
    let mut q = SMatrix::<f64, D, D>::from_column_slice(entries);
    for j in 0..D {
        for _ in 0..2 {
            for k in 0..j {
                let projection = q.column(k).dot(&q.column(j));
                let qk = q.column(k).into_owned();
                q.column_mut(j).axpy(-projection, &qk, 1.0);
            }
        }
        let norm = q.column(j).norm();
        if norm > 1e-3 {
            q.column_mut(j).unscale_mut(norm);
        } else {
            // Fall back to the axis with the largest part outside the columns so far (one part
            // is at least √((D − j)/D): the j columns span j dimensions), orthogonalised.
            let residual = |i: usize| {
                let mut e = SVector::<f64, D>::zeros();
                e[i] = 1.0;
                for _ in 0..2 {
                    for k in 0..j {
                        let projection = q.column(k).dot(&e);
                        e -= q.column(k) * projection;
                    }
                }
                e
            };
            let e = (0..D)
                .map(residual)
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .unwrap_or_else(SVector::zeros);
            q.set_column(j, &e.normalize());
        }
    }
    q
}

/// Gaussians on Rⁿ: means in [−1e3, 1e3]ⁿ, covariances from [`covariance`] with standard deviations
/// log-uniform over [1e-3, 1e3] (condition numbers up to 1e12).
///
/// # Panics
/// Never: the covariance is positive definite.
pub fn gaussian<const N: usize>() -> impl Strategy<Value = Gaussian<N>> {
    (
        proptest::collection::vec(-1e3..1e3_f64, N),
        covariance::<N>((-3.0..3.0_f64).prop_map(|e| 10f64.powf(e))),
    )
        .prop_filter_map(
            "a covariance whose inverse is representable (Gaussian::new's range)",
            |(mean, covariance)| Gaussian::new(SVector::from_column_slice(&mean), covariance).ok(),
        )
}

/// Gaussians on any manifold: means from `points` (for instance the manifolds crate's `so3()` or
/// `product(so3(), rn())`), tangent covariances from [`covariance`] with standard deviations from
/// `sigma` ([`standard_deviation`] on the rotation groups). Covariances outside what
/// [`ManifoldGaussian::new`] accepts (entries or `tr P⁻¹` beyond 1e100: standard deviations
/// beyond about 1e-50 to 1e50) are filtered out, as [`gaussian`] does.
pub fn manifold_gaussian<X, const D: usize>(
    points: impl Strategy<Value = X>,
    sigma: impl Strategy<Value = f64>,
) -> impl Strategy<Value = ManifoldGaussian<X, D>>
where
    X: Manifold<D, Scalar = f64> + Clone + Debug,
{
    (points, covariance::<D>(sigma)).prop_filter_map(
        "a covariance ManifoldGaussian::new accepts",
        |(mean, covariance)| ManifoldGaussian::new(mean, covariance).ok(),
    )
}

/// Harmonic Gaussians: the angle from [`gen_von_mises2`] with `kappa`, feature matrices with entries
/// in [−10, 10] (so the conditional mean moves with the angle), and conditional covariances from
/// [`covariance`] with standard deviations log-uniform over [1e-3, 10].
///
/// # Panics
/// Never: the covariance is positive definite.
pub fn harmonic_gaussian<const N: usize>(
    kappa: impl Strategy<Value = f64> + Clone,
) -> impl Strategy<Value = HarmonicGaussian<N>> {
    (
        gen_von_mises2(kappa),
        proptest::collection::vec(-10.0..10.0_f64, 3 * N),
        covariance::<N>((-3.0..1.0_f64).prop_map(|e| 10f64.powf(e))),
    )
        .prop_map(|(angle, b, covariance)| {
            HarmonicGaussian::new(angle, SMatrix::from_column_slice(&b), covariance)
                .expect("positive definite")
        })
}

/// Raw numbers for the bad-input law: every magnitude from the smallest subnormal to f64::MAX of
/// either sign, ±0, NaN and ±∞ (the manifolds crate's
/// [`extreme`](liebayes_manifolds::testing::strategies::extreme)), mixed with ordinary numbers in
/// [−10, 10] so that a constructor of several raw numbers is accepted often enough for its
/// densities to be checked too (a NaN or ±∞ in one component in about one draw of 20).
pub fn extreme() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => manifold::extreme::<f64>(),
        1 => -10.0..10.0_f64,
    ]
}

/// What a constructor makes of raw numbers: a density or the error refusing them.
pub type Built<P> = Result<P, DensityError>;

/// [`VonMises::from_natural`] of two raw numbers.
pub fn von_mises_raw() -> impl Strategy<Value = Built<VonMises>> {
    (extreme(), extreme()).prop_map(|(a, b)| VonMises::from_natural(Vector2::new(a, b)))
}

/// [`GenVonMises2::from_natural`] of four raw numbers.
pub fn gen_von_mises2_raw() -> impl Strategy<Value = Built<GenVonMises2>> {
    proptest::array::uniform4(extreme())
        .prop_map(|[a, b, c, d]| GenVonMises2::from_natural(Vector2::new(a, b), Vector2::new(c, d)))
}

/// [`VonMisesFisher::from_natural`] of three raw numbers.
pub fn von_mises_fisher_raw() -> impl Strategy<Value = Built<VonMisesFisher>> {
    proptest::array::uniform3(extreme())
        .prop_map(|[a, b, c]| VonMisesFisher::from_natural(Vector3::new(a, b, c)))
}

/// [`Bingham::from_natural`] of a symmetric matrix of ten raw numbers.
pub fn bingham_raw() -> impl Strategy<Value = Built<Bingham>> {
    proptest::collection::vec(extreme(), 10).prop_map(|upper| {
        let mut m = Matrix4::zeros();
        let mut k = 0;
        for i in 0..4 {
            for j in i..4 {
                m[(i, j)] = upper[k];
                m[(j, i)] = upper[k];
                k += 1;
            }
        }
        Bingham::from_natural(m)
    })
}

/// [`HeatKernelSo3::new`] at any mean with a raw variance.
pub fn heat_kernel_so3_raw() -> impl Strategy<Value = Built<HeatKernelSo3>> {
    (manifold::so3::<f64>(), extreme()).prop_map(|(mean, s)| HeatKernelSo3::new(mean, s))
}

/// Raw covariances: half of them N × N matrices of raw entries (symmetric or not, mostly refused),
/// half positive definite with raw standard deviations (accepted within the Gaussians' limits).
pub fn raw_covariance<const N: usize>() -> impl Strategy<Value = SMatrix<f64, N, N>> {
    prop_oneof![
        proptest::collection::vec(extreme(), N * N)
            .prop_map(|entries| SMatrix::<f64, N, N>::from_column_slice(&entries)),
        covariance::<N>(prop_oneof![
            1 => manifold::extreme_finite::<f64>().prop_map(f64::abs),
            2 => (-3.0..3.0_f64).prop_map(|e| 10f64.powf(e)),
        ]),
    ]
}

/// [`Gaussian::new`] with a raw mean and a [`raw_covariance`].
pub fn gaussian_raw<const N: usize>() -> impl Strategy<Value = Built<Gaussian<N>>> {
    (
        proptest::collection::vec(extreme(), N),
        raw_covariance::<N>(),
    )
        .prop_map(|(mean, covariance)| Gaussian::new(SVector::from_column_slice(&mean), covariance))
}

/// [`ManifoldGaussian::new`] at means from `points` with a [`raw_covariance`].
pub fn manifold_gaussian_raw<X, const D: usize>(
    points: impl Strategy<Value = X>,
) -> impl Strategy<Value = Built<ManifoldGaussian<X, D>>>
where
    X: Manifold<D, Scalar = f64> + Clone + Debug,
{
    (points, raw_covariance::<D>())
        .prop_map(|(mean, covariance)| ManifoldGaussian::new(mean, covariance))
}

/// [`HarmonicGaussian::new`] with an angle from [`gen_von_mises2`], raw features and a
/// [`raw_covariance`].
pub fn harmonic_gaussian_raw<const N: usize>() -> impl Strategy<Value = Built<HarmonicGaussian<N>>>
{
    (
        gen_von_mises2(concentration()),
        proptest::collection::vec(extreme(), 3 * N),
        raw_covariance::<N>(),
    )
        .prop_map(|(angle, b, covariance)| {
            HarmonicGaussian::new(angle, SMatrix::from_column_slice(&b), covariance)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A column that falls inside the span of the ones before and whose own axis is spanned too
    /// normalised a zero vector (NaN) in the fallback; it now takes the axis with the largest part
    /// outside the span.
    #[test]
    fn degenerate_columns_give_an_orthogonal_matrix() {
        for entries in [[0.0, 0.5, 0.0, 0.3], [0.0; 4], [1.0, 0.0, 1.0, 0.0]] {
            let q = orthogonal::<2>(&entries);
            let error = (q.transpose() * q - SMatrix::<f64, 2, 2>::identity()).amax();
            assert!(error < 1e-12, "{entries:?}: {q}");
        }
    }
}
