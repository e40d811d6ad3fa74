//! Laws of `Gaussian` and `ManifoldGaussian`: normalisation by quadrature in eigen-coordinates (an
//! independent path from the Cholesky factor the type uses), product = normalised pointwise product,
//! the convolution against its defining integral, sample moments, KL against quadrature, mode, and bad
//! input; and first-order propagation of manifold Gaussians against Monte Carlo.

mod common;

use common::quadrature::gauss_legendre;
use liebayes_densities::{
    Convolve, Density, Entropy, Gaussian, KlDivergence, ManifoldGaussian, Product,
};
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Rn, So3};
use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector1, Vector2};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Symmetric positive definite 2×2 matrices with condition numbers up to 1e8 and scales 1e-6 to 1e6.
fn covariance2() -> impl Strategy<Value = Matrix2<f64>> {
    (-6.0..6.0_f64, 0.0..8.0_f64, 0.0..std::f64::consts::PI).prop_map(
        |(scale, condition, angle)| {
            let (s, c) = angle.sin_cos();
            let rotation = Matrix2::new(c, -s, s, c);
            let eigen = Matrix2::new(1.0, 0.0, 0.0, 10f64.powf(-condition)) * 10f64.powf(scale);
            rotation * eigen * rotation.transpose()
        },
    )
}

fn gaussian2() -> impl Strategy<Value = Gaussian<2>> {
    (proptest::array::uniform2(-1e3..1e3_f64), covariance2())
        .prop_map(|(m, c)| Gaussian::new(Vector2::new(m[0], m[1]), c).unwrap())
}

/// ∫ exp(log_p) over R² in the eigen-coordinates of `covariance` (±12 standard deviations, 30-point
/// Gauss-Legendre on 8 panels per axis).
fn integrate2(g: &Gaussian<2>, f: impl Fn(&Vector2<f64>) -> f64) -> f64 {
    let eigen = SymmetricEigen::new(*g.covariance());
    let sd = eigen.eigenvalues.map(f64::sqrt);
    let rule = gauss_legendre(30);
    let nodes: Vec<(f64, f64)> = (0..8)
        .flat_map(|panel| {
            let (a, b) = (
                -12.0 + 3.0 * f64::from(panel),
                -9.0 + 3.0 * f64::from(panel),
            );
            rule.iter()
                .map(move |(x, w)| (0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w))
        })
        .collect();
    let mut sum = 0.0;
    for (u, wu) in &nodes {
        for (v, wv) in &nodes {
            let y = g.mean() + eigen.eigenvectors * Vector2::new(u * sd[0], v * sd[1]);
            sum += wu * wv * f(&y);
        }
    }
    sum * sd[0] * sd[1]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn integrates_to_one(g in gaussian2()) {
        let total = integrate2(&g, |x| g.log_pdf(x).exp());
        // The nodes μ + offset carry a rounding of |μ| eps, which along the thinnest direction (σ_min)
        // moves ln p by up to 12 |μ| eps / σ_min (at 12 standard deviations).
        let sd_min = SymmetricEigen::new(*g.covariance()).eigenvalues.min().sqrt();
        let tolerance = 1e-12 + 12.0 * f64::EPSILON * g.mean().amax() / sd_min;
        prop_assert!((total - 1.0).abs() <= tolerance, "∫p = {total}, tolerance {tolerance:e}");
    }

    #[test]
    fn product_is_the_normalised_pointwise_product(p in gaussian2(), q in gaussian2(), x in proptest::array::uniform2(-1e3..1e3_f64)) {
        let x = Vector2::new(x[0], x[1]);
        let pq = p.product(&q).unwrap();
        let lhs = p.log_pdf(&x) + q.log_pdf(&x) - p.log_product_integral(&q).unwrap();
        let rhs = pq.log_pdf(&x);
        // Rounding grows with the Mahalanobis terms (each ≤ κ(Σ) |x|²/λ_min in size).
        let scale = 1.0 + p.mahalanobis_squared(&x) + q.mahalanobis_squared(&x) + p.log_normalizer().abs();
        prop_assert!((lhs - rhs).abs() <= 1e-7 * scale, "{lhs} vs {rhs}");
    }

    #[test]
    fn kl_is_nonnegative_and_zero_only_for_equal_arguments(p in gaussian2(), q in gaussian2(), x in proptest::array::uniform2(-1e3..1e3_f64)) {
        prop_assert!(p.kl_divergence(&p).abs() <= 1e-9);
        prop_assert!(p.kl_divergence(&q) >= -1e-9 * (1.0 + p.kl_divergence(&q).abs()));
        let x = Vector2::new(x[0], x[1]);
        prop_assert!(p.log_pdf(&p.mode().unwrap()) >= p.log_pdf(&x));
    }

    #[test]
    fn samples_have_the_analytic_moments(g in gaussian2(), seed in any::<u64>()) {
        let n = 20_000;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let samples: Vec<Vector2<f64>> = (0..n).map(|_| g.sample(&mut rng)).collect();
        let mean = samples.iter().sum::<Vector2<f64>>() / f64::from(n);
        // Whitened error of the sample mean ~ N(0, I/n): 5 standard errors per component.
        let whitened = g.mahalanobis_squared(&mean).sqrt();
        prop_assert!(whitened <= 5.0 * (2.0 / f64::from(n)).sqrt(), "whitened mean error {whitened}");
        let cov = samples.iter().map(|s| (s - g.mean()) * (s - g.mean()).transpose()).sum::<Matrix2<f64>>() / f64::from(n);
        // Whitened sample covariance: L⁻¹ C L⁻ᵀ ≈ I, entries with standard error ≤ √(2/n).
        let l = g.cholesky_factor();
        let li = l.try_inverse().unwrap();
        let white = li * cov * li.transpose() - Matrix2::identity();
        prop_assert!(white.amax() <= 5.0 * (2.0 / f64::from(n)).sqrt(), "whitened covariance error {}", white.amax());
    }
}

#[test]
fn convolution_matches_its_defining_integral_and_kl_entropy_match_quadrature() {
    let p = Gaussian::new(Vector1::new(0.3), nalgebra::Matrix1::new(0.5)).unwrap();
    let q = Gaussian::new(Vector1::new(-1.2), nalgebra::Matrix1::new(2.0)).unwrap();
    let pq = p.convolve(&q).unwrap();
    let rule = gauss_legendre(30);
    let integrate = |f: &dyn Fn(f64) -> f64| -> f64 {
        (0..40)
            .map(|panel| {
                let (a, b) = (-20.0 + f64::from(panel), -19.0 + f64::from(panel));
                rule.iter()
                    .map(|(x, w)| 0.5 * w * f(0.5 * (a + b) + 0.5 * x))
                    .sum::<f64>()
            })
            .sum()
    };
    for x in [-3.0, -0.9, 0.0, 2.5] {
        let direct =
            integrate(&|y| (p.log_pdf(&Vector1::new(y)) + q.log_pdf(&Vector1::new(x - y))).exp());
        let closed = pq.log_pdf(&Vector1::new(x)).exp();
        assert!(
            (direct - closed).abs() <= 1e-13,
            "x {x}: {direct} vs {closed}"
        );
    }
    let kl = integrate(&|y| {
        let lp = p.log_pdf(&Vector1::new(y));
        lp.exp() * (lp - q.log_pdf(&Vector1::new(y)))
    });
    assert!((kl - p.kl_divergence(&q)).abs() <= 1e-13);
    let entropy = integrate(&|y| {
        let lp = p.log_pdf(&Vector1::new(y));
        -lp.exp() * lp
    });
    assert!((entropy - p.entropy()).abs() <= 1e-13);
}

#[test]
fn bad_covariances_are_refused_with_a_message() {
    let m = Vector2::zeros();
    let not_pd = Gaussian::new(m, Matrix2::new(1.0, 2.0, 2.0, 1.0))
        .unwrap_err()
        .to_string();
    assert!(not_pd.contains("positive definite"), "{not_pd}");
    assert!(
        Gaussian::new(m, Matrix2::new(1.0, 0.5, 0.0, 1.0))
            .unwrap_err()
            .to_string()
            .contains("symmetric")
    );
    assert!(Gaussian::new(m, Matrix2::new(f64::NAN, 0.0, 0.0, 1.0)).is_err());
    assert!(Gaussian::new(Vector2::new(f64::INFINITY, 0.0), Matrix2::identity()).is_err());
    assert!(Gaussian::new(m, Matrix2::zeros()).is_err());
    // Near-singular but positive definite: accepted, finite everywhere.
    let thin = Gaussian::new(m, Matrix2::new(1.0, 1.0 - 1e-10, 1.0 - 1e-10, 1.0)).unwrap();
    assert!(thin.log_pdf(&Vector2::new(1.0, -1.0)).is_finite());
    assert!(thin.entropy().is_finite());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// First-order propagation of a concentrated manifold Gaussian through the action R ↦ R p and
    /// through composition, against 20 000-sample Monte Carlo: the difference is the statistical error
    /// plus the neglected second order, O(σ²) relative for σ = 1e-2.
    #[test]
    fn manifold_gaussian_propagation_matches_monte_carlo(
        mean in st::so3::<f64>(), other in st::so3::<f64>(), p in st::point3::<f64>(), seed in any::<u64>(),
    ) {
        let sigma = 1e-2;
        let cov = Matrix3::new(1.0, 0.3, 0.0, 0.3, 2.0, -0.2, 0.0, -0.2, 0.5) * sigma * sigma;
        let x = ManifoldGaussian::<So3<f64>, 3>::new(mean, cov).unwrap();
        let y = ManifoldGaussian::<So3<f64>, 3>::new(other, cov * 0.5).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 20_000;
        // Tangent samples come back exactly (local ∘ retract = id inside the injectivity radius).
        let image = x.propagated_covariance(&mean.j_act_self(&p)).unwrap();
        let composed = x.compose(&y).unwrap();
        let (mut c_point, mut c_comp) = (Matrix3::zeros(), Matrix3::zeros());
        for _ in 0..n {
            let r = x.sample(&mut rng);
            let d = r.act(&p) - mean.act(&p);
            c_point += d * d.transpose();
            let e = composed.mean().local(&r.compose(&y.sample(&mut rng)));
            c_comp += e * e.transpose();
        }
        let scale = cov.amax() * (1.0 + p.norm_squared());
        let tolerance = 6.0 * scale * (2.0 / f64::from(n)).sqrt() + 10.0 * sigma * sigma * scale;
        prop_assert!((c_point / f64::from(n) - image).amax() <= tolerance);
        let tolerance = 6.0 * cov.amax() * (2.0 / f64::from(n)).sqrt() + 10.0 * sigma * sigma * cov.amax();
        prop_assert!((c_comp / f64::from(n) - composed.covariance()).amax() <= tolerance);
    }
}

#[test]
fn propagation_into_a_group_keeps_a_full_rank_covariance() {
    // Translation by the rotated point is full rank: a manifold Gaussian on R³ comes out.
    let mean = So3::exp(&nalgebra::Vector3::new(0.2, -0.1, 0.4));
    let x = ManifoldGaussian::<So3<f64>, 3>::new(mean, Matrix3::identity() * 1e-4).unwrap();
    let adjoint = mean.adjoint();
    let world = x.propagate_linearized(mean, &adjoint).unwrap();
    assert!(
        (world.covariance() - Matrix3::identity() * 1e-4).amax() < 1e-18,
        "Ad Σ Adᵀ = Σ for isotropic Σ"
    );
    let degenerate = x.propagate_linearized(
        Rn::<f64, 3>::new_unchecked(nalgebra::Vector3::zeros()),
        &mean.j_act_self(&nalgebra::Vector3::x()),
    );
    assert!(
        degenerate.is_err(),
        "a rank-deficient image is refused, not repaired"
    );
    // A Jacobian whose products overflow (J P Jᵀ with entries near 1e300 · 1e300 · 1e-4) gave NaN
    // and an invalid Gaussian: now an error, as is a non-finite Jacobian.
    let huge = Matrix3::new(1e300, -1e300, 0.0, 1e300, 1e300, 0.0, 0.0, 0.0, 1.0);
    for j in [
        huge,
        Matrix3::identity() * 1e60,
        Matrix3::identity() * f64::NAN,
    ] {
        assert!(x.propagated_covariance(&j).is_err());
        assert!(x.propagate_linearized(mean, &j).is_err());
    }
}
