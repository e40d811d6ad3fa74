//! `ManifoldGaussian` against independent computations: on Rⁿ it must be the Gaussian itself; on the
//! circle its density, integrated over the circle's own parametrisation (not the tangent one), must
//! give the Gaussian mass inside (−π, π]; on SO(3) its samples must have the tangent moments, and its
//! KL divergence and entropy must match Monte Carlo estimates through `log_pdf` of sampled rotations.
//! Bad covariances are refused with a message. (First-order propagation and composition against Monte
//! Carlo are in `gaussian.rs`.)

mod common;

use common::quadrature::gauss_legendre;
use liebayes_densities::testing::strategies::gaussian;
use liebayes_densities::{Density, Entropy, Gaussian, KlDivergence, ManifoldGaussian};
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{LieGroup, Manifold, Rn, So2, So3};
use nalgebra::{Matrix1, Matrix2, Matrix3, SMatrix, SVector, Vector1, Vector2, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// On Rⁿ, `x ⊟ μ = x − μ`: every quantity is the Gaussian's, the sample the same draw.
    #[test]
    fn on_rn_it_is_the_gaussian(
        p in gaussian::<2>(), q in gaussian::<2>(), x in st::rn_tangent::<f64, 2>(), seed in any::<u64>(),
    ) {
        let mean = Rn::new_unchecked(*p.mean());
        let mp = ManifoldGaussian::new(mean, *p.covariance()).unwrap();
        let mq = ManifoldGaussian::new(mean, *q.covariance()).unwrap();
        let point = Rn::new_unchecked(x);
        prop_assert!(close(mp.log_pdf(&point), p.log_pdf(&x), 1e-12));
        prop_assert!(close(mp.mahalanobis_squared(&point), p.mahalanobis_squared(&x), 1e-12));
        prop_assert!(close(mp.entropy(), p.entropy(), 1e-12));
        prop_assert!(close(mp.log_normalizer(), p.log_normalizer(), 1e-12));
        prop_assert!(close(mp.log_determinant(), p.log_determinant(), 1e-12));
        // KL with a common mean: the Gaussian KL of (μ, P_p) against (μ, P_q).
        let same_mean_q = Gaussian::new(*p.mean(), *q.covariance()).unwrap();
        prop_assert!(close(mp.kl_divergence(&mq).unwrap(), p.kl_divergence(&same_mean_q), 1e-12));
        prop_assert!(mp.kl_divergence(&mp).unwrap().abs() <= 1e-12);
        let (mut r1, mut r2) = (ChaCha8Rng::seed_from_u64(seed), ChaCha8Rng::seed_from_u64(seed));
        let (a, b) = (mp.sample(&mut r1), p.sample(&mut r2));
        prop_assert!((a.coords() - b).amax() <= 1e-12 * (1.0 + b.amax()));
        prop_assert_eq!(*mp.mode().unwrap().coords(), *p.mean());
    }

    /// On SO(3), `μ ⊞ L e` is |e|² from the mean, for any mean, covariance and e within the
    /// injectivity radius.
    #[test]
    fn mahalanobis_distance_of_a_retracted_point(
        mean in st::so3::<f64>(), l in proptest::array::uniform6(0.05..0.5_f64), e in st::point3::<f64>(),
    ) {
        let lower = Matrix3::new(l[0], 0.0, 0.0, l[3] - 0.25, l[1], 0.0, l[4] - 0.25, l[5] - 0.25, l[2]);
        let g = ManifoldGaussian::new(mean, lower * lower.transpose()).unwrap();
        let e = e.normalize() * 2.0;
        let delta = g.cholesky_factor() * e;
        prop_assume!(delta.norm() < 3.0);
        let x = mean.retract(&delta);
        prop_assert!(close(g.mahalanobis_squared(&x), e.norm_squared(), 1e-9));
        prop_assert!(g.log_pdf(&x) <= g.log_pdf(g.mean()));
    }
}

/// ∫ p over the circle, parametrised by the absolute angle t ∈ (−π, π] (points `So2(t)`, not tangent
/// vectors at μ), with panels split at the antipode of μ where `x ⊟ μ` jumps from π to −π. The result
/// must be the mass of N(0, σ²) inside (−π, π], computed separately on the real line.
#[test]
fn integrates_over_the_circle_to_the_unwrapped_mass() {
    let rule = gauss_legendre(40);
    let integrate = |f: &dyn Fn(f64) -> f64, a: f64, b: f64, panels: u32| -> f64 {
        (0..panels)
            .map(|k| {
                let h = (b - a) / f64::from(panels);
                let (lo, hi) = (a + h * f64::from(k), a + h * f64::from(k + 1));
                rule.iter()
                    .map(|(x, w)| 0.5 * (hi - lo) * w * f(0.5 * (lo + hi) + 0.5 * (hi - lo) * x))
                    .sum::<f64>()
            })
            .sum()
    };
    for (mu, sigma) in [(3.0, 0.05), (3.0, 0.3), (-0.4, 1.0), (PI, 1.5)] {
        let g = ManifoldGaussian::new(So2::from_angle_unchecked(mu), Matrix1::new(sigma * sigma))
            .unwrap();
        let density = |t: f64| g.log_pdf(&So2::from_angle_unchecked(t)).exp();
        // The antipode of μ in (−π, π].
        let cut = if mu > 0.0 { mu - PI } else { mu + PI };
        let panels = 200;
        let on_circle =
            integrate(&density, -PI, cut, panels) + integrate(&density, cut, PI, panels);
        let normal = |d: f64| (-0.5 * d * d / (sigma * sigma)).exp() / (sigma * (2.0 * PI).sqrt());
        let inside = integrate(&normal, -PI, PI, 2 * panels);
        assert!(
            (on_circle - inside).abs() < 1e-12,
            "mu {mu}, sigma {sigma}: {on_circle} on the circle, {inside} on the line"
        );
    }
}

/// Mean and standard error of `f` over n samples of `g`.
fn monte_carlo(
    g: &ManifoldGaussian<So3<f64>, 3>,
    n: u32,
    seed: u64,
    f: impl Fn(&So3<f64>) -> f64,
) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut sum, mut sum_sq) = (0.0, 0.0);
    for _ in 0..n {
        let v = f(&g.sample(&mut rng));
        sum += v;
        sum_sq += v * v;
    }
    let mean = sum / f64::from(n);
    let variance = (sum_sq / f64::from(n) - mean * mean).max(0.0);
    (mean, (variance / f64::from(n)).sqrt())
}

#[test]
fn so3_samples_kl_and_entropy_match_monte_carlo() {
    let mean = So3::exp(&Vector3::new(0.4, -2.0, 1.1));
    let lp = Matrix3::new(0.3, 0.0, 0.0, 0.1, 0.2, 0.0, -0.05, 0.08, 0.25);
    let lq = Matrix3::new(0.4, 0.0, 0.0, -0.1, 0.3, 0.0, 0.0, 0.1, 0.2);
    let p = ManifoldGaussian::new(mean, lp * lp.transpose()).unwrap();
    let q = ManifoldGaussian::new(mean, lq * lq.transpose()).unwrap();
    let n = 40_000;
    // Tangent moments: whitened mean and covariance of x ⊟ μ within 5 standard errors (the tangent
    // mass beyond π, where x ⊟ μ would wrap, is below 1e-30 at these spreads).
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut m, mut c) = (Vector3::zeros(), Matrix3::zeros());
    for _ in 0..n {
        let d = mean.local(&p.sample(&mut rng));
        m += d;
        c += d * d.transpose();
    }
    let (m, c) = (m / f64::from(n), c / f64::from(n));
    let li = p.cholesky_factor().try_inverse().unwrap();
    let standard_error = (2.0 / f64::from(n)).sqrt();
    assert!((li * m).amax() <= 5.0 * standard_error);
    assert!((li * c * li.transpose() - Matrix3::identity()).amax() <= 5.0 * standard_error);
    // KL(p ‖ q) = E_p[ln p − ln q] and H(p) = −E_p[ln p], through `log_pdf` of sampled rotations.
    let (kl, kl_se) = monte_carlo(&p, n, 12, |x| p.log_pdf(x) - q.log_pdf(x));
    let exact = p.kl_divergence(&q).unwrap();
    assert!(
        (kl - exact).abs() <= 5.0 * kl_se,
        "KL {kl} ± {kl_se} vs {exact}"
    );
    let (h, h_se) = monte_carlo(&p, n, 13, |x| -p.log_pdf(x));
    assert!(
        (h - p.entropy()).abs() <= 5.0 * h_se,
        "H {h} ± {h_se} vs {}",
        p.entropy()
    );
    // The two sides are different computations that must not both be trivially zero.
    assert!(exact > 0.1);
}

#[test]
fn kl_needs_a_common_mean() {
    let mean = So3::exp(&Vector3::new(0.1, 0.2, 0.3));
    let p = ManifoldGaussian::new(mean, Matrix3::identity() * 0.01).unwrap();
    let nearby = ManifoldGaussian::new(
        mean.retract(&Vector3::new(1e-9, 0.0, 0.0)),
        Matrix3::identity() * 0.02,
    )
    .unwrap();
    // 1e-9 rad is 1e-8 standard deviations: the same point; the offset's term is included.
    assert!(p.kl_divergence(&nearby).is_ok());
    let moved = ManifoldGaussian::new(
        mean.retract(&Vector3::new(1e-3, 0.0, 0.0)),
        Matrix3::identity() * 0.02,
    )
    .unwrap();
    let message = p.kl_divergence(&moved).unwrap_err().to_string();
    assert!(message.contains("common mean"), "{message}");
}

/// A mean with a NaN or infinite coordinate (built with an unchecked constructor) is refused before
/// the covariance is looked at.
#[test]
fn a_non_finite_mean_is_refused() {
    for bad in [f64::NAN, f64::INFINITY] {
        let mean = Rn::new_unchecked(Vector2::new(1.0, bad));
        let error = ManifoldGaussian::new(mean, Matrix2::identity()).unwrap_err();
        assert!(error.to_string().contains("mean"), "{error}");
        let angle = So2::from_angle_unchecked(bad);
        assert!(ManifoldGaussian::new(angle, Matrix1::new(1.0)).is_err());
    }
}

#[test]
fn bad_covariances_are_refused_with_a_message() {
    let x = So2::from_angle_unchecked(1.0);
    let not_pd = ManifoldGaussian::new(x, Matrix1::new(-1.0)).unwrap_err();
    assert!(not_pd.to_string().contains("positive definite"), "{not_pd}");
    assert!(ManifoldGaussian::new(x, Matrix1::new(f64::NAN)).is_err());
    assert!(ManifoldGaussian::new(x, Matrix1::new(0.0)).is_err());
    let y = Rn::new_unchecked(Vector2::new(1.0, 2.0));
    let asymmetric = ManifoldGaussian::new(y, Matrix2::new(1.0, 0.5, 0.0, 1.0)).unwrap_err();
    assert!(asymmetric.to_string().contains("symmetric"), "{asymmetric}");
    // Positive definite, but tr P⁻¹ above MAX_SCALE = 1e100 (the limit of every Gaussian):
    // refused; at 1e-99 accepted.
    for eigenvalue in [1e-310, 1e-300, 1e-101] {
        let tiny = ManifoldGaussian::new(y, Matrix2::new(eigenvalue, 0.0, 0.0, 1.0)).unwrap_err();
        assert!(tiny.to_string().contains("inverse"), "{tiny}");
    }
    let small = ManifoldGaussian::new(y, Matrix2::new(1e-99, 0.0, 0.0, 1.0)).unwrap();
    assert!(small.log_pdf(&y).is_finite() && small.entropy().is_finite());
    let far = Rn::new_unchecked(Vector2::new(1.0 + 1e-40, 2.0));
    assert!(small.mahalanobis_squared(&far).is_finite());
    // ln det P where the product of the Cholesky diagonal under- or overflows (1e-445, 1e450 in
    // nine dimensions): the sum of logarithms instead of the logarithm of the product.
    for scale in [1e-99, 1e-50, 1e50, 1e100] {
        let g = ManifoldGaussian::new(
            Rn::<f64, 9>::new_unchecked(SVector::zeros()),
            SMatrix::<f64, 9, 9>::identity() * scale,
        )
        .unwrap();
        let expected = 9.0 * f64::ln(scale);
        assert!(
            (g.log_determinant() / expected - 1.0).abs() < 1e-15,
            "{scale}: {}",
            g.log_determinant()
        );
        assert!(g.entropy().is_finite());
    }
    // A covariance of 1e100 is fine; above it (1.6e308 was accepted, its samples NaN and its
    // entropy infinite) it is refused, as by Gaussian::new.
    let wide = ManifoldGaussian::new(x, Matrix1::new(1e100)).unwrap();
    assert!(wide.log_pdf(&So2::from_angle_unchecked(-2.0)).is_finite());
    assert!(wide.entropy().is_finite());
    for huge in [1e101, 1.6e308] {
        let error = ManifoldGaussian::new(x, Matrix1::new(huge)).unwrap_err();
        assert!(error.to_string().contains("1e100"), "{error}");
        assert!(Gaussian::new(Vector1::zeros(), Matrix1::new(huge)).is_err());
    }
}

/// The fit recovers the distribution its samples came from (20 000 draws on SO(3): the mean within
/// 5 standard errors, every covariance entry within 5 standard errors of its sample estimate), equals
/// the fit to duplicated samples when the weights are integers, and is told apart from a wrong model
/// (the covariance of a distribution twice as wide is far outside those errors). On Rⁿ it is the
/// sample mean and the (biased) sample covariance, computed directly.
#[test]
fn the_fit_recovers_the_sampled_distribution() {
    let mean = So3::exp(&Vector3::new(0.4, -1.2, 2.0));
    let cov = Matrix3::new(
        0.02, 0.004, -0.003, 0.004, 0.01, 0.002, -0.003, 0.002, 0.015,
    );
    let truth = ManifoldGaussian::<So3<f64>, 3>::new(mean, cov).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 20_000;
    let samples: Vec<So3<f64>> = (0..n).map(|_| truth.sample(&mut rng)).collect();
    let fit = ManifoldGaussian::fit(&samples, &vec![1.0; n]).unwrap();
    let se_mean = (cov.trace() / n as f64).sqrt();
    assert!(fit.mean().local(&mean).norm() < 5.0 * se_mean);
    for i in 0..3 {
        for j in 0..3 {
            // Var of a product of two zero-mean normals: P_ii P_jj + P_ij².
            let se = ((cov[(i, i)] * cov[(j, j)] + cov[(i, j)].powi(2)) / n as f64).sqrt();
            assert!(
                (fit.covariance()[(i, j)] - cov[(i, j)]).abs() < 5.0 * se,
                "{i}{j}"
            );
            assert!((fit.covariance()[(i, j)] - 4.0 * cov[(i, j)]).abs() > 5.0 * se || i != j);
        }
    }
    let copies: Vec<usize> = (0..200).map(|k| k % 3).collect();
    let weights: Vec<f64> = copies.iter().map(|&c| c as f64).collect();
    let repeated: Vec<So3<f64>> = samples[..200]
        .iter()
        .zip(&copies)
        .flat_map(|(x, &c)| std::iter::repeat_n(*x, c))
        .collect();
    let a = ManifoldGaussian::fit(&samples[..200], &weights).unwrap();
    let b = ManifoldGaussian::fit(&repeated, &vec![1.0; repeated.len()]).unwrap();
    assert!(a.mean().local(b.mean()).norm() < 1e-12);
    assert!((a.covariance() - b.covariance()).norm() < 1e-12);

    let vectors = [[1.0, 2.0], [3.0, -1.0], [0.5, 0.5], [2.0, 4.0]].map(Vector2::from);
    let points: Vec<Rn<f64, 2>> = vectors.iter().map(|v| Rn::new(*v).unwrap()).collect();
    let fit = ManifoldGaussian::fit(&points, &[1.0; 4]).unwrap();
    let m = Vector2::new(6.5 / 4.0, 5.5 / 4.0);
    assert!((SVector::from(*fit.mean()) - m).norm() < 1e-12);
    let direct = vectors.iter().fold(Matrix2::zeros(), |p, x| {
        let r = x - m;
        p + r * r.transpose() / 4.0
    });
    assert!((fit.covariance() - direct).norm() < 1e-12);
}

#[test]
fn the_fit_refuses_what_it_cannot_fit() {
    let x = So3::exp(&Vector3::new(0.1, 0.2, 0.3));
    let fit = ManifoldGaussian::<So3<f64>, 3>::fit;
    assert!(fit(&[], &[]).is_err());
    assert!(fit(&[x, x], &[1.0]).is_err());
    assert!(
        fit(&[x, x], &[1.0, -1.0])
            .to_string_err()
            .contains("weight")
    );
    assert!(fit(&[x, x], &[1.0, f64::NAN]).is_err());
    assert!(fit(&[x, x], &[0.0, 0.0]).is_err());
    // Two distinct rotations span one direction: P is singular, refused.
    assert!(fit(&[x, So3::identity()], &[1.0, 1.0]).is_err());
}

/// An error's message, for the assertions above.
trait ToStringErr {
    fn to_string_err(&self) -> String;
}

impl<T> ToStringErr for Result<T, liebayes_densities::DensityError> {
    fn to_string_err(&self) -> String {
        self.as_ref()
            .err()
            .map(ToString::to_string)
            .unwrap_or_default()
    }
}

/// A sample of weight zero adds nothing to a fit, however far: its outer product overflowed
/// (1e200² = ∞) and ∞ · 0 made the covariance NaN, so the fit failed with the wrong error.
#[test]
fn a_far_sample_of_weight_zero_does_not_spoil_a_fit() {
    let at = |x: f64| Rn::<f64, 1>::new(Vector1::new(x)).unwrap();
    let fit = ManifoldGaussian::fit(&[at(0.0), at(1.0), at(1e200)], &[1.0, 1.0, 0.0]).unwrap();
    assert_eq!(fit.mean().coords()[0], 0.5);
    assert!((fit.covariance()[0] - 0.25).abs() < 1e-15);
}

/// The public quadrature helpers of `testing`: a rule of more than 200 points per axis indexed
/// past the 200-node Hermite rule (a panic), and `usize::MAX` points stepped down one at a time (a
/// hang). Both now give a bounded rule that integrates the Gaussian's mass.
#[test]
fn testing_quadrature_bounds_its_points() {
    use liebayes_densities::testing::quadrature;
    let (mean, covariance) = (Vector1::new(0.5), Matrix1::new(2.0));
    for points in [201, 10_000, usize::MAX] {
        let nodes = quadrature::rn::<1>(&mean, &covariance, points);
        assert!(nodes.len() <= quadrature::MAX_HERMITE_NODES, "{points}");
        // Against the Lebesgue measure: the Gaussian's own density integrates to 1.
        let gaussian = Gaussian::new(mean, covariance).unwrap();
        let mass: f64 = nodes
            .iter()
            .map(|(x, w)| w * gaussian.log_pdf(x).exp())
            .sum();
        assert!((mass - 1.0).abs() < 1e-12, "{points}: {mass}");
    }
}

/// `check_sampler` with no draws divided 0 by 0 and failed with "sample mean NaN"; it now fails
/// naming n.
#[test]
fn the_sampler_law_needs_a_draw() {
    use liebayes_densities::VonMises;
    use liebayes_densities::testing::laws::check_sampler;
    let p = VonMises::new(So2::identity(), 2.0).unwrap();
    let error = check_sampler(&p, &mut ChaCha8Rng::seed_from_u64(1), 0).unwrap_err();
    assert!(error.to_string().contains("n = 0"), "{error}");
}

/// The strategies clamp what their docs now say they clamp: a negative or NaN concentration, and
/// a negative or huge Bingham spread, made `gen_von_mises2` and `bingham` panic.
#[test]
fn strategies_clamp_their_parameters() {
    use liebayes_densities::testing::strategies::{bingham, gen_von_mises2};
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    for kappa in [-1.0, f64::NAN, f64::INFINITY] {
        for _ in 0..16 {
            let tree = gen_von_mises2(Just(kappa)).new_tree(&mut runner).unwrap();
            assert!(tree.current().log_normalizer().is_finite(), "{kappa}");
        }
    }
    for spread in [-2e12, f64::NEG_INFINITY, f64::NAN, 1e300] {
        for _ in 0..16 {
            let tree = bingham(spread).new_tree(&mut runner).unwrap();
            assert!(tree.current().log_normalizer().is_finite(), "{spread}");
        }
    }
}

/// A world-frame Gaussian on SE(3) moved by a translation of 1e30: `Ad(g) P Ad(g)ᵀ` has exact
/// eigenvalues 1e-60 beside 1e60, and the rounded matrix was stored (singular or indefinite,
/// refused by `new` and by the serde reader) beside a factor of its own that it disagreed with. A
/// moved Gaussian's covariance is now one that `new` accepts, giving the same density (its factor's
/// determinant), or the move is an error.
#[test]
fn a_translated_gaussian_passes_the_checks_of_new() {
    use liebayes_densities::Rotate;
    use liebayes_manifolds::{Left, Se3};
    use nalgebra::Matrix6;
    let p = ManifoldGaussian::new(Left::new(Se3::identity()), Matrix6::identity()).unwrap();
    let (mut accepted, mut refused) = (0, 0);
    for exponent in [0, 3, 8, 12, 20, 25, 30, 35, 40] {
        for k in 0..24 {
            let angle = f64::from(k) * 0.27;
            let rotation = So3::exp(&Vector3::new(0.3 * angle.cos(), -0.2, angle.sin()));
            let direction = Vector3::new(angle.cos(), angle.sin(), 0.3 * angle.sin() * angle.cos());
            let translation = if k == 0 { Vector3::x() } else { direction } * 10f64.powi(exponent);
            let g = Left::new(Se3::new(rotation, translation).unwrap());
            let Ok(moved) = p.rotated(&g) else {
                refused += 1;
                continue;
            };
            accepted += 1;
            let again = ManifoldGaussian::new(*moved.mean(), *moved.covariance())
                .unwrap_or_else(|e| panic!("translation {translation:?}: {e}"));
            assert!((again.log_determinant() - moved.log_determinant()).abs() <= 1e-3);
            let l = moved.cholesky_factor();
            let scale = moved.covariance().amax();
            assert!((l * l.transpose() - moved.covariance()).amax() <= 1e-14 * scale);
            if exponent <= 3 {
                // Ad(g) P Ad(g)ᵀ itself, to rounding.
                let j = g.j_compose_other(p.mean());
                let exact = j * j.transpose();
                assert!((moved.covariance() - exact).amax() <= 1e-14 * exact.amax());
            }
        }
    }
    assert!(accepted >= 24 * 2 && refused > 0, "{accepted} {refused}");
}

/// `quadrature::s3` made 16.9 M nodes (674 MB) for the widths (0.1000001, 0.1000001, 0), four times
/// `MAX_NODES`; every width, NaN, zero, subnormal or infinite, now gives at most `MAX_NODES`.
#[test]
fn s3_bounds_its_nodes_for_every_width() {
    use liebayes_densities::testing::quadrature;
    use nalgebra::Matrix4;
    let frame = Matrix4::identity();
    let wide = 0.100_000_1;
    let mut widths = vec![
        [wide, wide, 0.0],
        [wide, wide, 1e-300],
        [wide, wide, 5e-324],
        [wide, 0.2, 1e-12],
        [10.0, 10.0, 0.0],
        [1e-300, 1e-300, 1e-300],
        [0.0, 0.0, 0.0],
        [f64::NAN, f64::NAN, f64::NAN],
        [f64::NAN, wide, 0.0],
        [wide, f64::NAN, 0.0],
        [f64::INFINITY, wide, 0.0],
        [-1.0, wide, wide],
        [wide, -f64::NAN, 1e-300],
    ];
    for e in [-300, -100, -20, -12, -8, -5, -4, -3, -1] {
        widths.push([wide, wide, 10f64.powi(e)]);
        widths.push([1.0, 0.5, 10f64.powi(e)]);
    }
    for w in widths {
        let count = quadrature::s3(&frame, &w).len();
        assert!(count <= quadrature::MAX_NODES, "{w:?}: {count} nodes");
    }
}

/// `quadrature::rn` and `tangent` ran nalgebra's unbounded eigensolver on the caller's matrix and
/// returned nodes of NaN for a non-finite one; they now use the bounded one and return no nodes
/// where it fails.
#[test]
fn gaussian_rules_have_no_nodes_where_the_eigendecomposition_fails() {
    use liebayes_densities::testing::quadrature;
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let covariance = Matrix2::new(bad, 0.1, 0.1, 1.0);
        assert!(quadrature::rn(&Vector2::zeros(), &covariance, 4).is_empty());
        let spread = Matrix3::new(1.0, 0.0, 0.0, 0.0, bad, 0.0, 0.0, 0.0, 1.0);
        assert!(quadrature::tangent(&So3::identity(), &spread, 4).is_empty());
    }
    let nodes = quadrature::rn(&Vector2::zeros(), &Matrix2::new(2.0, 0.1, 0.1, 1.0), 4);
    assert_eq!(nodes.len(), 16);
}

/// `check_sampler(p, rng, n)` drew n samples for any n, up to u32::MAX (4.3e9 draws, hours); beyond
/// 2²⁴ it now fails at once, naming n, without a draw.
#[test]
fn the_sampler_law_refuses_more_draws_than_its_limit() {
    use liebayes_densities::VonMises;
    use liebayes_densities::testing::laws::check_sampler;
    let p = VonMises::new(So2::identity(), 2.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for n in [(1 << 24) + 1, u32::MAX] {
        let error = check_sampler(&p, &mut rng, n).unwrap_err();
        assert!(error.to_string().contains(&format!("n = {n}")), "{error}");
    }
    assert_eq!(rng, ChaCha8Rng::seed_from_u64(1), "a refused call drew");
}
