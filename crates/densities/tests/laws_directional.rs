//! The laws of the von Mises and von Mises-Fisher densities over their whole parameter range
//! (κ = 0, 1e-300, tiny, moderate, large, 1e6): normalisation by independent quadrature, product =
//! normalised pointwise product, sample moments against analytic moments, KL ≥ 0 and = 0 only for equal
//! arguments, the mode maximises the density, rotation invariance, entropy and KL against quadrature.

mod common;

use common::quadrature::{integrate_circle, integrate_peaked, log_integrate_circle};
use liebayes_densities::testing::strategies::{concentration, von_mises, von_mises_fisher};
use liebayes_densities::{
    Density, Entropy, KlDivergence, Product, Rotate, VonMises, VonMisesFisher,
};
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{GroupAction, S2, So2};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Trapezoid points for a von Mises of concentration κ: the aliasing error is 2 A_N(κ) ≈ 2 e^(−N²/2κ),
/// below 1e-16 for N = 16 + 9 √κ.
fn circle_points(kappa: f64) -> usize {
    // κ ≤ 2e6 in these tests, so the count is a small positive integer.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let extra = (9.0 * kappa.sqrt()).ceil() as usize;
    16 + extra
}

/// Rounding of a log density whose terms reach `scale` in magnitude: eps · scale, relative in p.
fn log_rounding(scale: f64) -> f64 {
    8.0 * f64::EPSILON * (1.0 + scale)
}

/// ∫ over S² of f(x) dS, in the frame of `axis`: x(t, φ) at the point with cosine 1 − t to the axis.
fn integrate_sphere_about(axis: &S2<f64>, width: f64, f: impl Fn(&S2<f64>) -> f64) -> f64 {
    let basis = axis.tangent_basis();
    integrate_peaked(
        |t| {
            let radius = (t * (2.0 - t)).max(0.0).sqrt();
            integrate_circle(
                |phi| {
                    let x = axis.as_vector() * (1.0 - t)
                        + (basis.column(0) * phi.cos() + basis.column(1) * phi.sin()) * radius;
                    f(&S2::new_unchecked(x.normalize()))
                },
                64,
            )
        },
        width,
        2.0,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn von_mises_integrates_to_one(p in von_mises(concentration())) {
        let kappa = p.concentration();
        let total = integrate_circle(|t| p.log_pdf(&So2::from_angle_unchecked(t)).exp(), circle_points(kappa));
        let tolerance = log_rounding(kappa + p.log_normalizer().abs());
        prop_assert!((total - 1.0).abs() <= tolerance, "∫p = {total} for κ = {kappa}");
    }

    #[test]
    fn von_mises_product_is_the_normalised_pointwise_product(p in von_mises(concentration()), q in von_mises(concentration()), x in st::so2::<f64>()) {
        let pq = p.product(&q).unwrap();
        let log_integral = p.log_product_integral(&q).unwrap();
        // ln p(x) + ln q(x) − ln ∫pq = ln (pq)(x)
        let lhs = p.log_pdf(&x) + q.log_pdf(&x) - log_integral;
        let scale = p.concentration() + q.concentration() + p.log_normalizer().abs() + q.log_normalizer().abs();
        prop_assert!((lhs - pq.log_pdf(&x)).abs() <= log_rounding(scale));
        // ∫ pq by quadrature, independently of the closed form.
        let kappa = pq.concentration();
        let quad = log_integrate_circle(|t| {
            let y = So2::from_angle_unchecked(t);
            p.log_pdf(&y) + q.log_pdf(&y)
        }, circle_points(kappa));
        prop_assert!((quad - log_integral).abs() <= log_rounding(scale), "{} vs {}", quad, log_integral);
    }

    #[test]
    fn von_mises_kl_is_nonnegative_and_zero_only_for_equal_arguments(p in von_mises(concentration()), q in von_mises(concentration())) {
        prop_assert_eq!(p.kl_divergence(&p), 0.0);
        let kl = p.kl_divergence(&q);
        let scale = p.concentration() + q.concentration() + p.log_normalizer().abs() + q.log_normalizer().abs();
        prop_assert!(kl >= -log_rounding(scale), "KL = {kl}");
        if (p.natural() - q.natural()).norm() > 1e-6 * (1.0 + p.concentration()) {
            prop_assert!(kl > 0.0, "KL = {kl} for different arguments");
        }
    }

    #[test]
    fn von_mises_mode_maximises_the_density(p in von_mises(concentration()), x in st::so2::<f64>()) {
        if let Some(m) = p.mode() {
            prop_assert!(p.log_pdf(&m) >= p.log_pdf(&x) - log_rounding(p.concentration()));
        } else {
            prop_assert_eq!(p.concentration(), 0.0);
        }
    }

    #[test]
    fn von_mises_fisher_integrates_to_one(p in von_mises_fisher(concentration()), axis in st::s2::<f64>()) {
        let kappa = p.concentration();
        // About the mean direction (the density is peaked there) for the concentrated, about an
        // arbitrary axis for the diffuse ones.
        let about = if kappa > 5.0 { p.mean().unwrap() } else { axis };
        let total = integrate_sphere_about(&about, 1.0 / (kappa + 1.0), |x| p.log_pdf(x).exp());
        let tolerance = log_rounding(kappa + p.log_normalizer().abs()) + 1e-13;
        prop_assert!((total - 1.0).abs() <= tolerance, "∫p = {total} for κ = {kappa}");
    }

    #[test]
    fn von_mises_fisher_product_kl_mode_and_rotation(
        p in von_mises_fisher(concentration()), q in von_mises_fisher(concentration()), x in st::s2::<f64>(), r in st::so3::<f64>(),
    ) {
        let scale = p.concentration() + q.concentration() + p.log_normalizer().abs() + q.log_normalizer().abs();
        let pq = p.product(&q).unwrap();
        let lhs = p.log_pdf(&x) + q.log_pdf(&x) - p.log_product_integral(&q).unwrap();
        prop_assert!((lhs - pq.log_pdf(&x)).abs() <= log_rounding(scale));
        prop_assert_eq!(p.kl_divergence(&p), 0.0);
        prop_assert!(p.kl_divergence(&q) >= -log_rounding(scale));
        if let Some(m) = p.mode() {
            prop_assert!(p.log_pdf(&m) >= p.log_pdf(&x) - log_rounding(p.concentration()));
        }
        // Invariance: the density of R x under the rotated distribution equals that of x.
        let rx = S2::new_unchecked(r.act(x.as_vector()));
        prop_assert!((p.rotated(&r).unwrap().log_pdf(&rx) - p.log_pdf(&x)).abs() <= log_rounding(scale));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Sample moments against analytic moments: 20 000 draws, 5 standard errors.
    #[test]
    fn von_mises_samples_have_the_analytic_moments(p in von_mises(concentration()), seed in any::<u64>()) {
        let n = 20_000;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut sum = Vector2::zeros();
        let mut sum2 = Vector2::zeros();
        for _ in 0..n {
            let x = p.sample(&mut rng);
            sum += Vector2::new(x.cos(), x.sin());
            sum2 += Vector2::new((2.0 * x.angle()).cos(), (2.0 * x.angle()).sin());
        }
        let m1 = p.trigonometric_moment(1).unwrap();
        let m2 = p.trigonometric_moment(2).unwrap();
        // Cov[u(θ)] has eigenvalues (1 + A2)/2 − A1² (along μ) and (1 − A2)/2 (across): the variance of
        // any component is at most the larger.
        let (a1, a2) = (m1.norm(), m2.norm());
        let variance = (f64::midpoint(1.0, a2) - a1 * a1).max((1.0 - a2) / 2.0).max(0.0) + 1e-300;
        let tolerance = 5.0 * (variance / f64::from(n)).sqrt() + 1e-12;
        prop_assert!((sum / f64::from(n) - m1).amax() <= tolerance, "{:?} vs {:?} ± {}", sum / f64::from(n), m1, tolerance);
        prop_assert!((sum2 / f64::from(n) - m2).amax() <= 5.0 / f64::from(n).sqrt());
    }

    #[test]
    fn von_mises_fisher_samples_have_the_analytic_moments(p in von_mises_fisher(concentration()), seed in any::<u64>()) {
        let n = 20_000;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut sum = Vector3::zeros();
        for _ in 0..n {
            let x = p.sample(&mut rng);
            prop_assert!((x.as_vector().norm() - 1.0).abs() < 1e-15);
            sum += x.as_vector();
        }
        let mean = p.first_moment();
        // tr Cov[x] = 1 − |E x|²; 5 standard errors of the largest component.
        let tolerance = 5.0 * ((1.0 - mean.norm_squared()).max(0.0) / f64::from(n)).sqrt() + 1e-12;
        prop_assert!((sum / f64::from(n) - mean).amax() <= tolerance, "{:?} vs {:?}", sum / f64::from(n), mean);
    }
}

#[test]
fn entropy_and_kl_match_quadrature() {
    for kappa in [0.0, 1e-300, 1e-6, 0.3, 2.0, 40.0, 3000.0, 1e6] {
        let p = VonMises::new(So2::from_angle_unchecked(0.7), kappa).unwrap();
        let q = VonMises::new(So2::from_angle_unchecked(-2.0), 1.5).unwrap();
        let n = circle_points(kappa);
        let entropy = integrate_circle(
            |t| {
                let l = p.log_pdf(&So2::from_angle_unchecked(t));
                -l.exp() * l
            },
            n,
        );
        let kl = integrate_circle(
            |t| {
                let x = So2::from_angle_unchecked(t);
                let l = p.log_pdf(&x);
                l.exp() * (l - q.log_pdf(&x))
            },
            n,
        );
        let tolerance = log_rounding(kappa) * (1.0 + kappa.ln().abs());
        assert!(
            (entropy - p.entropy()).abs() <= tolerance.max(1e-12),
            "κ {kappa}: entropy {entropy} vs {}",
            p.entropy()
        );
        assert!(
            (kl - p.kl_divergence(&q)).abs() <= (tolerance * (1.0 + kl.abs())).max(1e-12),
            "κ {kappa}: KL {kl} vs {}",
            p.kl_divergence(&q)
        );

        let mean = S2::new(Vector3::new(0.0, 0.6, 0.8)).unwrap();
        let v = VonMisesFisher::new(mean, kappa).unwrap();
        let entropy = integrate_sphere_about(&mean, 1.0 / (kappa + 1.0), |x| {
            let l = v.log_pdf(x);
            -l.exp() * l
        });
        let tolerance = log_rounding(kappa) * (1.0 + v.entropy().abs()) + 1e-12;
        assert!(
            (entropy - v.entropy()).abs() <= tolerance,
            "vMF κ {kappa}: {entropy} vs {}",
            v.entropy()
        );
    }
}

#[test]
fn extreme_concentrations_give_finite_numbers() {
    for kappa in [0.0, 1e-300, 1e6] {
        let p = VonMises::new(So2::from_angle_unchecked(3.0), kappa).unwrap();
        let x = So2::from_angle_unchecked(-3.0);
        for v in [
            p.log_pdf(&x),
            p.log_normalizer(),
            p.entropy(),
            p.mean_resultant_length(),
        ] {
            assert!(v.is_finite(), "κ {kappa}: {v}");
        }
        let s = VonMisesFisher::new(S2::new(Vector3::x()).unwrap(), kappa).unwrap();
        let y = S2::new(-Vector3::x()).unwrap();
        for v in [s.log_pdf(&y), s.log_normalizer(), s.entropy()] {
            assert!(v.is_finite(), "vMF κ {kappa}: {v}");
        }
    }
    assert!(VonMises::new(So2::from_angle_unchecked(0.0), -1.0).is_err());
    assert!(VonMises::from_natural(Vector2::new(f64::NAN, 0.0)).is_err());
    assert!(VonMisesFisher::new(S2::new(Vector3::z()).unwrap(), f64::INFINITY).is_err());
    assert!(VonMisesFisher::from_natural(Vector3::new(0.0, f64::NAN, 1.0)).is_err());
}

/// |η| = 1e-300: the concentration does not underflow to 0 (hypot, not a squared norm), and the mode,
/// the mean direction and the moments agree that the distribution is (barely) not uniform.
#[test]
fn von_mises_with_the_tiniest_concentration_is_consistent() {
    let p =
        liebayes_densities::VonMises::from_natural(nalgebra::Vector2::new(1e-300, 0.0)).unwrap();
    assert_eq!(p.concentration(), 1e-300);
    assert_eq!(p.mode().map(|m| m.angle()), Some(0.0));
    assert_eq!(p.mean().map(|m| m.angle()), Some(0.0));
    let m = p.trigonometric_moment(1).unwrap();
    assert!(m.iter().all(|v| v.is_finite()) && m.x > 0.0);
}
