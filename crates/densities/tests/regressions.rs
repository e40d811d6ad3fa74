//! The reproductions a fuzzer (3.3e6 calls) and a new user found, each as it returns now. Every one
//! of these hung, took seconds, or returned a NaN or infinite value from a constructor that said Ok.

use liebayes_densities::manifolds::{LieGroup, S2, So2, So3};
use liebayes_densities::{
    Bingham, Density, Gaussian, GenVonMises2, HeatKernelSo3, Product, VonMises, VonMisesFisher,
    special,
};
use nalgebra::{Matrix3, Matrix4, Vector2, Vector3, Vector4};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

mod common;
use common::fuzz::quick;

#[test]
fn special_functions_refuse_nan_and_negative_arguments_at_once() {
    assert!(quick("log_i0(NaN)", || special::log_i0(f64::NAN)).is_err());
    assert!(quick("a1(NaN)", || special::a1(f64::NAN)).is_err());
    assert!(quick("log_i1(NaN)", || special::log_i1(f64::NAN)).is_err());
    assert!(
        quick("bessel_ratio(3, NaN)", || special::bessel_ratio(
            3,
            f64::NAN
        ))
        .is_err()
    );
    let error = quick("a1(-1e16)", || special::a1(-1e16)).unwrap_err();
    assert!(error.to_string().contains("[0, f64::MAX]"), "{error}");
}

#[test]
fn huge_orders_are_refused_or_fast() {
    let error = quick("bessel_ratio(u32::MAX, 1)", || {
        special::bessel_ratio(u32::MAX, 1.0)
    })
    .unwrap_err();
    assert!(error.to_string().contains("MAX_ORDER"), "{error}");
    let p = VonMises::from_natural(Vector2::new(3.0, 0.0)).unwrap();
    assert!(
        quick("trigonometric_moment(u32::MAX)", || p
            .trigonometric_moment(u32::MAX))
        .is_err()
    );
    let top = quick("trigonometric_moment(MAX_ORDER)", || {
        p.trigonometric_moment(special::MAX_ORDER)
    })
    .unwrap();
    assert_eq!(top, Vector2::zeros());
}

#[test]
fn log_i0_of_1e308_is_finite() {
    let value = special::log_i0(1e308).unwrap();
    assert!(value.is_finite() && value > 9.9e307, "{value}");
}

#[test]
fn inverse_of_a_near_one_is_finite() {
    for r in [1.0 - 1e-8, 1.0 - 1e-12, 1.0 - f64::EPSILON / 2.0] {
        let kappa = special::a1_inverse(r).unwrap();
        assert!(kappa.is_finite(), "A^-1({r}) = {kappa}");
        // 1 − A(κ) = 1/(2κ) + 1/(8κ²) + …, so κ ≈ 1/(2(1 − r)).
        let expected = 0.5 / (1.0 - r);
        assert!(
            (kappa / expected - 1.0).abs() < 1e-6,
            "{kappa:e} vs {expected:e}"
        );
    }
    // A′ at 1e9 was 220x wrong (1 − A/κ − A² cancels): it is 1/(2κ²)(1 + 1/(2κ) + …).
    let derivative = special::a1_derivative(1e9).unwrap();
    assert!(
        (derivative / 5.000_000_002_5e-19 - 1.0).abs() < 1e-15,
        "{derivative:e}"
    );
}

#[test]
fn von_mises_samplers_return_at_every_concentration() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for kappa in [5e-324, 1e-300, 1e-4, 1e16, 1e300] {
        let p = VonMises::from_natural(Vector2::new(kappa, 0.0)).unwrap();
        let x = quick("VonMises::sample", || p.sample(&mut rng));
        assert!((x.cos().hypot(x.sin()) - 1.0).abs() < 1e-15);
        if kappa >= 1e16 {
            assert!(x.angle().abs() < 1e-6, "κ {kappa:e}: {}", x.angle());
        }
    }
    let p = GenVonMises2::from_natural(Vector2::new(1e7, 0.0), Vector2::new(-1e6, 0.0)).unwrap();
    let x = quick("GenVonMises2::sample", || p.sample(&mut rng));
    assert!(x.angle().abs() < 0.01, "{}", x.angle());
}

#[test]
fn bingham_with_unrepresentable_spreads_is_refused() {
    let diagonal = |z: [f64; 4]| Matrix4::from_diagonal(&Vector4::from(z));
    let error = Bingham::from_natural(diagonal([-1e300, 1e6, f64::MAX, 5e-324])).unwrap_err();
    assert!(
        error.to_string().contains("1e300") || error.to_string().contains("1e6"),
        "{error}"
    );
    assert!(Bingham::from_natural(diagonal([f64::MAX, 0.0, 0.0, -1e4])).is_err());
    // At the edge of the range: finite normaliser, a sample on S³, quickly.
    let p = Bingham::from_natural(diagonal([0.0, -1e6, -1e6, -1e6])).unwrap();
    assert!(p.log_normalizer().is_finite());
    let q = quick("Bingham::sample", || {
        p.sample(&mut ChaCha8Rng::seed_from_u64(2))
    });
    let [w, ..] = q.to_quaternion_wxyz();
    assert!(w.abs() > 0.99);
}

#[test]
fn gen_von_mises_beyond_its_range_is_refused_at_once() {
    let error = quick("GenVonMises2::from_natural(1e17)", || {
        GenVonMises2::from_natural(Vector2::new(1e17, 0.0), Vector2::zeros())
    })
    .unwrap_err();
    assert!(error.to_string().contains("1e16"), "{error}");
    let p = quick("GenVonMises2::from_natural(1e15)", || {
        GenVonMises2::from_natural(Vector2::new(1e15, 0.0), Vector2::zeros())
    })
    .unwrap();
    // ln Z = κ − ½ ln(2πκ) + ln 2π + O(1/κ).
    let expected =
        1e15 - 0.5 * (2.0 * std::f64::consts::PI * 1e15).ln() + (2.0 * std::f64::consts::PI).ln();
    assert!(
        (p.log_normalizer() - expected).abs() <= 1.0,
        "{}",
        p.log_normalizer()
    );
}

#[test]
fn constructors_refuse_parameters_whose_normalisers_overflow() {
    let error = VonMises::from_natural(Vector2::new(f64::MAX, f64::MAX)).unwrap_err();
    assert!(error.to_string().contains("[0, 1e300]"), "{error}");
    // Large values are shown in exponent form, not as 309 digits.
    let error = Bingham::from_natural(Matrix4::from_diagonal(&Vector4::new(
        f64::MAX,
        0.0,
        0.0,
        0.0,
    )))
    .unwrap_err();
    assert!(
        error.to_string().contains("1.7976931348623157e308"),
        "{error}"
    );
    assert!(VonMisesFisher::from_natural(Vector3::new(0.0, f64::MAX, f64::MAX)).is_err());
    for s in [1e-310, 5e-324, 1e-301] {
        assert!(HeatKernelSo3::new(So3::identity(), s).is_err(), "s {s:e}");
    }
    let h = HeatKernelSo3::new(So3::identity(), 1e-300).unwrap();
    let x = So3::exp(&Vector3::new(1.0, 0.0, 0.0));
    assert!(h.log_pdf(&x).is_finite());
    for scale in [1e308, 1e-310, 1e101, 1e-101] {
        let error = Gaussian::new(Vector3::zeros(), Matrix3::identity() * scale).unwrap_err();
        assert!(error.to_string().contains("1e100"), "{scale:e}: {error}");
    }
    // tr Σ⁻¹ = 7.5e99, within the limit.
    let g = Gaussian::new(Vector3::zeros(), Matrix3::identity() * 4e-100).unwrap();
    assert!(g.natural().1.iter().all(|v| v.is_finite()));
}

#[test]
fn von_mises_fisher_keeps_tiny_concentrations_and_equals_the_uniform_at_zero() {
    let x = S2::new(Vector3::x()).unwrap();
    let p = VonMisesFisher::new(x, 1e-300).unwrap();
    let product = p.product(&p).unwrap();
    assert_eq!(product.concentration(), 2e-300);
    assert_eq!(product.mean(), Some(x));
    assert_eq!(
        VonMisesFisher::new(x, 0.0).unwrap(),
        VonMisesFisher::uniform()
    );
    assert_eq!(
        VonMises::new(So2::from_angle(1.0).unwrap(), 0.0).unwrap(),
        VonMises::uniform()
    );
}

/// `HarmonicGaussian::new` accepted features and covariances of 1e210, and then its marginal
/// moments, log density and divergences were NaN. It now takes the limit of every Gaussian,
/// [`MAX_SCALE`] = 1e100, and at that limit every one of them is a number (the log density of a
/// point at ±f64::MAX is −∞, the exact value's overflow).
#[test]
fn harmonic_gaussian_takes_the_gaussian_limit() {
    use liebayes_densities::{Entropy, HarmonicGaussian, KlDivergence, MAX_SCALE};
    use nalgebra::{Matrix2, Matrix2x3};
    let angle =
        GenVonMises2::from_natural(Vector2::new(1.0, 0.5), Vector2::new(0.2, -0.1)).unwrap();
    let make = |b: f64, sigma: f64| {
        HarmonicGaussian::new(
            angle.clone(),
            Matrix2x3::from_element(b),
            Matrix2::new(sigma, 0.3 * sigma, 0.3 * sigma, sigma),
        )
    };
    for (b, sigma) in [(1e210, 1.0), (1.0, 1e210), (1.0, 1e-210), (1e101, 1.0)] {
        let error = make(b, sigma).unwrap_err();
        assert!(
            error.to_string().contains("1e100"),
            "{b:e} {sigma:e}: {error}"
        );
    }
    let far = make(MAX_SCALE, MAX_SCALE).unwrap();
    let near = make(-MAX_SCALE, 1e-99).unwrap();
    for p in [&far, &near] {
        let (mean, cov) = p.marginal_moments();
        assert!(mean.iter().chain(cov.iter()).all(|v| v.is_finite()));
        assert!(p.entropy().is_finite());
        for q in [&far, &near] {
            assert!(p.kl_divergence(q).is_finite());
        }
        let y = So2::from_angle_unchecked(0.3);
        for x in [
            Vector2::new(f64::MAX, -f64::MAX),
            Vector2::new(1e300, 1.0),
            Vector2::zeros(),
        ] {
            let l = p.log_pdf(&(y, x));
            assert!(!l.is_nan() && l != f64::INFINITY, "{x:?}: {l}");
        }
    }
}

/// A covariance whose factor has a diagonal of 1e-10 beside entries of 1: the triangular solve for
/// a point 1e300 away overflowed in its first row and met ∞ − ∞ in the third, so the log density
/// of a Gaussian on Rⁿ (and of the conditional Gaussian of a `HarmonicGaussian`) was NaN where the
/// exact value is −∞, and the KL divergence between means that far apart was `Ok(NaN)`.
#[test]
fn far_points_of_ill_conditioned_gaussians_are_infinitely_unlikely() {
    use liebayes_densities::manifolds::Rn;
    use liebayes_densities::{HarmonicGaussian, ManifoldGaussian};
    let sigma = Matrix3::new(1e-20, 1e-10, 1e-10, 1e-10, 2.0, 2.0, 1e-10, 2.0, 3.0);
    let far = Vector3::new(1e300, 0.0, 0.0);
    let harmonic =
        HarmonicGaussian::<3>::new(GenVonMises2::uniform(), Matrix3::zeros(), sigma).unwrap();
    assert_eq!(harmonic.log_pdf(&(So2::identity(), far)), f64::NEG_INFINITY);
    let gaussian = ManifoldGaussian::new(Rn::new(Vector3::zeros()).unwrap(), sigma).unwrap();
    let at = Rn::new(far).unwrap();
    assert_eq!(gaussian.mahalanobis_squared(&at), f64::INFINITY);
    assert_eq!(gaussian.log_pdf(&at), f64::NEG_INFINITY);
    assert_eq!(
        Gaussian::new(Vector3::zeros(), sigma)
            .unwrap()
            .log_pdf(&far),
        f64::NEG_INFINITY
    );
    let elsewhere = ManifoldGaussian::new(at, Matrix3::identity()).unwrap();
    assert!(elsewhere.kl_divergence(&gaussian).is_err());
    // Near the mean the same densities are ordinary numbers.
    let near = Vector3::new(1e-11, 0.5, -0.25);
    let plain = gaussian.log_pdf(&Rn::new(near).unwrap());
    assert!(plain.is_finite());
    assert!(
        (harmonic.log_pdf(&(So2::identity(), near)) - plain + (2.0 * std::f64::consts::PI).ln())
            .abs()
            < 1e-9
    );
}

/// `VonMises::product` added natural parameters unchecked: chained products passed κ = 1e300
/// (the documented limit) and reached η = (∞, 0), whose log density was NaN. A product beyond
/// the limit is now an error, like every other density's.
#[test]
fn von_mises_products_beyond_the_concentration_limit_are_errors() {
    let p = VonMises::new(So2::identity(), 1e300).unwrap();
    assert!(p.product(&p).is_err());
    let q = VonMises::new(So2::identity(), 4e299).unwrap();
    let pq = q.product(&q).unwrap();
    assert!((pq.concentration() - 8e299).abs() <= 1e-15 * 8e299);
}

/// The log product integral must fail exactly where the product does (the trait's contract, which
/// the product law checks): two von Mises or von Mises-Fisher densities of concentration 1e300 had
/// a product beyond the accepted 1e300 (an error) but a finite integral; two Gaussians of variance
/// 1.5e-100 a product whose information exceeds 1e100 but an integral; and two of variance 1e100 a
/// product but no integral (Σ₁ + Σ₂ = 2e100 was built as a Gaussian, beyond its range).
#[test]
fn the_product_integral_fails_exactly_where_the_product_does() {
    let vm = VonMises::new(So2::from_angle_unchecked(0.3), 1e300).unwrap();
    assert!(vm.product(&vm).is_err() && vm.log_product_integral(&vm).is_err());
    let mean = S2::new(nalgebra::Vector3::new(0.0, 0.6, 0.8)).unwrap();
    let vmf = VonMisesFisher::new(mean, 1e300).unwrap();
    assert!(vmf.product(&vmf).is_err() && vmf.log_product_integral(&vmf).is_err());
    // tr Σ⁻¹ = 8e99, and 1.6e100 for the product.
    let tight = Gaussian::new(
        nalgebra::Vector2::zeros(),
        nalgebra::Matrix2::identity() * 2.5e-100,
    )
    .unwrap();
    assert!(tight.product(&tight).is_err() && tight.log_product_integral(&tight).is_err());
    let wide = Gaussian::new(
        nalgebra::Vector2::new(1.0, -1.0),
        nalgebra::Matrix2::identity() * 1e100,
    )
    .unwrap();
    assert!(wide.product(&wide).is_ok());
    // ln N(μ; μ, 2e100 I) in two dimensions: −ln(2π) − ln(2e100).
    let value = wide.log_product_integral(&wide).unwrap();
    let expected = -(2.0 * std::f64::consts::PI).ln() - 2e100_f64.ln();
    assert!((value - expected).abs() < 1e-13, "{value} vs {expected}");
}

/// `HarmonicGaussian::new` averaged Σ with its transpose without a check, so
/// `[[1, 1e100], [−1e100, 1]]` became the identity. It now refuses an asymmetry above 1e-12 of the
/// largest entry, as `Gaussian::new` does, and keeps accepting the rounding within it.
#[test]
fn an_asymmetric_harmonic_covariance_is_refused() {
    use liebayes_densities::{DensityError, HarmonicGaussian};
    use nalgebra::{Matrix2, Matrix2x3};
    let angle = GenVonMises2::uniform();
    let skew = Matrix2::new(1.0, 1e100, -1e100, 1.0);
    let error = HarmonicGaussian::new(angle.clone(), Matrix2x3::zeros(), skew).unwrap_err();
    assert!(matches!(error, DensityError::OutOfRange { .. }), "{error}");
    assert!(error.to_string().contains("symmetri"), "{error}");
    for (a, b) in [(1.0, 1.0 + 1e-9), (2.0, 2.0 + 4.1e-12)] {
        let sigma = Matrix2::new(4.0, a, b, 4.0);
        assert!(HarmonicGaussian::new(angle.clone(), Matrix2x3::zeros(), sigma).is_err());
        assert!(Gaussian::new(Vector2::zeros(), sigma).is_err());
    }
    // Within the Gaussian's tolerance: accepted by both, stored symmetric.
    let sigma = Matrix2::new(4.0, 1.0, 1.0 + 2e-12, 4.0);
    let g = HarmonicGaussian::new(angle, Matrix2x3::zeros(), sigma).unwrap();
    assert_eq!(g.covariance()[(0, 1)], g.covariance()[(1, 0)]);
    assert!(Gaussian::new(Vector2::zeros(), sigma).is_ok());
}

/// `HarmonicGaussian::marginal_moments` formed `Cov φ = E φφᵀ − E φ E φᵀ`, differences of numbers
/// near 1 that cancel to ±1e-16 where Var cos y ≈ 1/(2κ²) = 5e-25 (κ = 1e12), so `Cov x` of
/// `x = cos y + N(0, 1e-30)` came out negative at about half of the mean angles. It is now summed
/// as squares: positive, and equal to `1e-30 + cos²μ/(2κ²) + sin²μ/κ` to leading order.
#[test]
fn the_marginal_covariance_is_positive_at_any_concentration() {
    use liebayes_densities::HarmonicGaussian;
    use nalgebra::{Matrix1, Matrix1x3};
    let kappa = 1e12;
    for i in 0..400 {
        let mu = -std::f64::consts::PI + f64::from(i) * (std::f64::consts::TAU / 400.0);
        let angle =
            GenVonMises2::new(So2::from_angle_unchecked(mu), kappa, So2::identity(), 0.0).unwrap();
        let p = HarmonicGaussian::new(angle, Matrix1x3::new(0.0, 1.0, 0.0), Matrix1::new(1e-30))
            .unwrap();
        let (_, cov) = p.marginal_moments();
        let (s, c) = mu.sin_cos();
        let expected = 1e-30 + c * c / (2.0 * kappa * kappa) + s * s / kappa;
        assert!(cov[(0, 0)] > 0.0, "mu = {mu}: Cov x = {:e}", cov[(0, 0)]);
        assert!(
            (cov[(0, 0)] / expected - 1.0).abs() < 1e-6,
            "mu = {mu}: Cov x = {:e}, expected {expected:e}",
            cov[(0, 0)]
        );
    }
}

/// In ordinary cases the centred sum over the quadrature nodes gives the covariance of the earlier
/// formula `Σ + B (E φφᵀ − E φ E φᵀ) Bᵀ` and of an independent brute force: the centred second
/// moments of φ on a 4096-point periodic trapezoid grid of the density.
#[test]
fn the_marginal_covariance_matches_a_brute_force_grid() {
    use liebayes_densities::HarmonicGaussian;
    use nalgebra::{Matrix2, Matrix2x3, Matrix3};
    let b = Matrix2x3::new(0.5, -1.5, 2.0, -0.3, 0.7, 1.1);
    let sigma = Matrix2::new(0.4, 0.1, 0.1, 0.2);
    for (k1, k2, mu1, mu2) in [
        (0.0, 0.0, 0.0, 0.0),
        (0.5, 0.0, 1.0, 0.0),
        (3.0, 1.5, -2.0, 0.7),
        (40.0, 0.0, 2.5, 0.0),
        (5.0, 20.0, 0.3, 1.9),
        (1e3, 1e2, -1.2, -1.2),
    ] {
        let angle = GenVonMises2::new(
            So2::from_angle_unchecked(mu1),
            k1,
            So2::from_angle_unchecked(mu2),
            k2,
        )
        .unwrap();
        let p = HarmonicGaussian::new(angle.clone(), b, sigma).unwrap();
        let (mean, cov) = p.marginal_moments();

        let n = 4096;
        let h = std::f64::consts::TAU / f64::from(n);
        let nodes: Vec<(Vector3<f64>, f64)> = (0..n)
            .map(|i| {
                let y = So2::from_angle_unchecked(-std::f64::consts::PI + h * f64::from(i));
                (
                    Vector3::new(1.0, y.cos(), y.sin()),
                    h * angle.log_pdf(&y).exp(),
                )
            })
            .collect();
        let m: Vector3<f64> = nodes.iter().map(|(phi, w)| phi * *w).sum();
        let spread: Matrix3<f64> = nodes
            .iter()
            .map(|(phi, w)| (phi - m) * (phi - m).transpose() * *w)
            .sum();
        let brute = sigma + b * spread * b.transpose();
        let (m1, m2) = angle.trigonometric_moments();
        let phi = Vector3::new(1.0, m1.x, m1.y);
        let second = Matrix3::new(
            1.0,
            m1.x,
            m1.y,
            m1.x,
            0.5 * (1.0 + m2.x),
            0.5 * m2.y,
            m1.y,
            0.5 * m2.y,
            0.5 * (1.0 - m2.x),
        );
        let earlier = sigma + b * (second - phi * phi.transpose()) * b.transpose();
        for (name, reference) in [("grid", brute), ("earlier formula", earlier)] {
            assert!(
                (cov - reference).amax() < 1e-12 * reference.amax(),
                "{name}, kappa ({k1}, {k2}): {cov} against {reference}"
            );
        }
        assert!((mean - b * m).amax() < 1e-12 * (1.0 + mean.amax()));
    }
}

/// The positive semi-definite check of a diffusion covariance had an absolute floor,
/// `−1e-12 (1 + max|Σᵢⱼ|)`, and the symmetry check an absolute tolerance `1e-10 (1 + max|Σᵢⱼ|)`:
/// `diag(−1e-13, 1e-20, 1e-20)` was taken for positive semi-definite (its −1e-13 rounded up to 0),
/// and a tiny Σ 1 % asymmetric for symmetric. Both are now relative to Σ's own size.
#[test]
fn diffusion_covariances_are_checked_relative_to_their_size() {
    let refused = [
        Matrix3::from_diagonal(&Vector3::new(-1e-13, 1e-20, 1e-20)),
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1e-12)),
        Matrix3::new(1e-20, 1e-22, 0.0, 0.0, 1e-20, 0.0, 0.0, 0.0, 1e-20),
    ];
    for covariance in refused {
        assert!(
            Bingham::diffusion_second_moment(&covariance).is_err(),
            "{covariance}"
        );
    }
    // Zero eigenvalues that rounding leaves slightly negative are still rounded up to 0.
    let v = Vector3::new(0.3, -0.7, 0.2);
    let rank_one = v * v.transpose();
    let accepted = [
        rank_one,
        rank_one * 1e-30,
        Matrix3::from_diagonal(&Vector3::new(1.0, 1e-3, -1e-17)),
        Matrix3::zeros(),
    ];
    for covariance in accepted {
        let moments = Bingham::diffusion_second_moment(&covariance)
            .unwrap_or_else(|e| panic!("{covariance}: {e}"));
        assert!((moments.trace() - 1.0).abs() < 1e-14);
    }
}

/// `Gaussian::new` limited each entry of Σ⁻¹ to 1e100, the other Gaussians the trace `tr Σ⁻¹`:
/// Σ = 1.5e-100 I₂ (entries of Σ⁻¹ 6.7e99, trace 1.3e100) was a Gaussian but not a
/// `ManifoldGaussian` on R² nor the conditional of a `HarmonicGaussian`. All three now take the
/// trace rule.
#[test]
fn every_gaussian_takes_the_same_inverse_covariance_limit() {
    use liebayes_densities::manifolds::Rn;
    use liebayes_densities::{HarmonicGaussian, ManifoldGaussian};
    use nalgebra::Matrix2;
    let uniform = GenVonMises2::uniform();
    for (variance, valid) in [
        (1.5e-100, false),
        (1.99e-100, false),
        (2.01e-100, true),
        (1.0, true),
    ] {
        let sigma = Matrix2::identity() * variance;
        let gaussian = Gaussian::new(Vector2::zeros(), sigma);
        let on_rn = ManifoldGaussian::new(Rn::new(Vector2::zeros()).unwrap(), sigma);
        assert_eq!(gaussian.is_ok(), valid, "Gaussian, {variance:e}");
        assert_eq!(on_rn.is_ok(), valid, "ManifoldGaussian, {variance:e}");
        if let Ok(g) = gaussian {
            assert!(HarmonicGaussian::independent(uniform.clone(), &g).is_ok());
        } else {
            let features = nalgebra::Matrix2x3::zeros();
            assert!(HarmonicGaussian::new(uniform.clone(), features, sigma).is_err());
        }
    }
    let error = Gaussian::new(Vector2::zeros(), Matrix2::identity() * 1.5e-100).unwrap_err();
    assert!(error.to_string().contains("1e100"), "{error}");
}

/// A rotation or direction accepted 9e-10 off unit norm was stored as given, and the heat kernel's
/// and the von Mises-Fisher's modes and draws (built from it) were that far off their space.
#[test]
fn densities_of_near_unit_locations_have_unit_modes_and_draws() {
    let k = 1.0 + 9e-10;
    let r = So3::from_quaternion_wxyz(0.5 * k, -0.5 * k, 0.5 * k, 0.5 * k).unwrap();
    let heat = HeatKernelSo3::new(r, 0.1).unwrap();
    let vmf = VonMisesFisher::new(S2::new(Vector3::new(0.0, 0.0, k)).unwrap(), 5.0).unwrap();
    let unit = |q: [f64; 4]| (q.iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-14;
    assert!(unit(heat.mode().unwrap().to_quaternion_wxyz()));
    assert!((vmf.mode().unwrap().as_vector().norm_squared() - 1.0).abs() < 1e-14);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..100 {
        assert!(unit(heat.sample(&mut rng).to_quaternion_wxyz()));
        assert!((vmf.sample(&mut rng).as_vector().norm_squared() - 1.0).abs() < 1e-14);
    }
}
