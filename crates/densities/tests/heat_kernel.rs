//! The SO(3) heat kernel against the reference vectors `heat_kernel_vectors.json` (mpmath, 40 digits), and
//! its laws: normalisation from s = 1e-6 to 10, the Fourier coefficients, the closed convolution
//! (σ² additivity), rotation invariance, and sampling.

mod common;

use common::quadrature::integrate_peaked;
use liebayes_densities::{Convolve, Density, Entropy, HeatKernelSo3, KlDivergence};
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{LieGroup, Manifold, So3};
use nalgebra::Vector3;
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn at_identity(s: f64) -> HeatKernelSo3 {
    HeatKernelSo3::new(So3::identity(), s).unwrap()
}

#[test]
fn matches_the_reference_vectors() {
    let reference = common::reference("heat_kernel_vectors.json");
    let (mut worst_density, mut worst_cdf) = (0.0_f64, 0.0_f64);
    for case in reference["cases"].as_array().expect("cases") {
        let (s, t) = (case["s"].as_f64().unwrap(), case["t"].as_f64().unwrap());
        let h = at_identity(s);
        let log_density = case["log_density_haar"].as_f64().unwrap();
        let density = case["density_haar"].as_f64().unwrap();
        let got_log = h.log_density_of_angle(t).unwrap();
        // Relative 1e-12 on the density is absolute 1e-12 on its logarithm; it also covers the cases
        // whose density underflows (ln f ≈ −49 000 at s = 1e-4, t = π).
        let error = (got_log - log_density).abs();
        assert!(
            error <= 1e-12,
            "ln f(s = {s}, t = {t}) = {got_log}, reference {log_density}, error {error:e}"
        );
        if density > 0.0 && density.is_normal() {
            let relative = common::relative_error(got_log.exp(), density);
            assert!(
                relative <= 1e-12,
                "f(s = {s}, t = {t}) relative error {relative:e}"
            );
            worst_density = worst_density.max(relative);
        }
        let angle_pdf = case["angle_pdf"].as_f64().unwrap();
        let relative = common::relative_error(h.angle_pdf(t).unwrap(), angle_pdf);
        assert!(
            relative <= 1e-12,
            "angle pdf (s = {s}, t = {t}) = {}, reference {angle_pdf}",
            h.angle_pdf(t).unwrap()
        );
        // The reference CDF is itself a double-precision closed form, |err| < 1e-13.
        let cdf_error = (h.angle_cdf(t).unwrap() - case["angle_cdf"].as_f64().unwrap()).abs();
        assert!(
            cdf_error <= 1e-12,
            "angle CDF (s = {s}, t = {t}) error {cdf_error:e}"
        );
        worst_cdf = worst_cdf.max(cdf_error);
    }
    eprintln!(
        "heat kernel: worst density relative error {worst_density:.1e}, worst CDF error {worst_cdf:.1e}"
    );
}

#[test]
fn integrates_to_one_from_tiny_to_large_variance() {
    for s in [
        1e-6, 1e-5, 1e-4, 1e-3, 0.01, 0.1, 0.5, 0.999, 1.0, 2.0, 5.0, 10.0,
    ] {
        let h = at_identity(s);
        // ∫_0^π f(t) (1 − cos t)/π dt, with the quadrature of the tests (not the library's).
        let total = integrate_peaked(|t| h.angle_pdf(t).unwrap(), s.sqrt().min(PI), PI);
        assert!((total - 1.0).abs() <= 1e-12, "s = {s}: ∫ = {total}");
        assert!(
            (h.angle_cdf(PI).unwrap() - 1.0).abs() <= 1e-12,
            "s = {s}: CDF(π) = {}",
            h.angle_cdf(PI).unwrap()
        );
    }
}

#[test]
fn fourier_coefficients_are_the_character_expectations() {
    // E[tr R] = 3 e^(−s): ∫ (1 + 2 cos t) angle_pdf(t) dt.
    for s in [1e-4, 0.05, 0.7, 1.0, 3.0] {
        let h = at_identity(s);
        let trace = integrate_peaked(
            |t| (1.0 + 2.0 * t.cos()) * h.angle_pdf(t).unwrap(),
            s.sqrt().min(PI),
            PI,
        );
        assert!(
            (trace - 3.0 * h.fourier_coefficient(1)).abs() <= 1e-12,
            "s = {s}: E[tr R] = {trace}"
        );
        assert!((h.first_moment().trace() - trace).abs() <= 1e-12);
    }
}

#[test]
fn extreme_variances_stay_finite_and_bad_ones_are_refused() {
    for s in [1e-6, 1e-4, 10.0, 100.0] {
        let h = at_identity(s);
        for t in [0.0, 1e-12, 1e-3, 1.0, PI - 1e-12, PI] {
            assert!(
                h.log_density_of_angle(t).unwrap().is_finite(),
                "s {s}, t {t}"
            );
            assert!(h.angle_cdf(t).unwrap().is_finite());
        }
    }
    for s in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(HeatKernelSo3::new(So3::identity(), s).is_err(), "s = {s}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// σ² additivity: the convolution's angle density equals the SO(3) convolution of the two angle
    /// densities, checked through the characters (the Fourier coefficients multiply).
    #[test]
    fn convolution_adds_variances_and_composes_centres(
        a in st::so3::<f64>(), b in st::so3::<f64>(), s1 in 1e-4..3.0_f64, s2 in 1e-4..3.0_f64, l in 0u32..6,
    ) {
        let (p, q) = (HeatKernelSo3::new(a, s1).unwrap(), HeatKernelSo3::new(b, s2).unwrap());
        let pq = p.convolve(&q).unwrap();
        prop_assert!((pq.variance() - (s1 + s2)).abs() <= 1e-15 * (s1 + s2));
        prop_assert!(pq.mean().distance(&a.compose(&b)) < 1e-14);
        let product = p.fourier_coefficient(l) * q.fourier_coefficient(l);
        prop_assert!((pq.fourier_coefficient(l) - product).abs() <= 1e-14);
    }

    /// Invariance: the density of R under LD(c, s) equals that of g R under LD(g c, s), and that of
    /// R g under LD(c g, s) (the kernel is bi-invariant, being isotropic).
    #[test]
    fn density_is_invariant_under_rotations(
        c in st::so3::<f64>(), g in st::so3::<f64>(), x in st::so3::<f64>(), s in 1e-3..4.0_f64,
    ) {
        let p = HeatKernelSo3::new(c, s).unwrap();
        let left = HeatKernelSo3::new(g.compose(&c), s).unwrap();
        let right = HeatKernelSo3::new(c.compose(&g), s).unwrap();
        let tolerance = 1e-9 * (1.0 + p.log_pdf(&x).abs());
        prop_assert!((left.log_pdf(&g.compose(&x)) - p.log_pdf(&x)).abs() <= tolerance);
        prop_assert!((right.log_pdf(&x.compose(&g)) - p.log_pdf(&x)).abs() <= tolerance);
        prop_assert!(p.log_pdf(&c) >= p.log_pdf(&x) - 1e-12, "the centre is the mode");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    /// Samples: E[tr(c⁻¹ R)] = 3 e^(−s) within 5 standard errors (Var[tr] from the degree-2 character:
    /// tr² = 1 + χ₁ + χ₂, so E[tr²] = 1 + 3 e^(−s) + 5 e^(−3s)).
    #[test]
    fn samples_have_the_analytic_trace(c in st::so3::<f64>(), s in 1e-4..4.0_f64, seed in any::<u64>()) {
        let p = HeatKernelSo3::new(c, s).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 4000;
        let mut sum = 0.0;
        let mut axis_sum = Vector3::zeros();
        for _ in 0..n {
            let r = c.inverse().compose(&p.sample(&mut rng));
            sum += r.to_matrix().trace();
            axis_sum += r.log();
        }
        let mean = 3.0 * (-s).exp();
        let variance = 1.0 + 3.0 * (-s).exp() + 5.0 * (-3.0 * s).exp() - mean * mean;
        let tolerance = 5.0 * (variance.max(0.0) / f64::from(n)).sqrt() + 1e-12;
        prop_assert!((sum / f64::from(n) - mean).abs() <= tolerance, "{} vs {} ± {}", sum / f64::from(n), mean, tolerance);
        // The axis is uniform: the mean rotation vector vanishes (|log| ≤ π, so 5 π/√n bounds it).
        prop_assert!((axis_sum / f64::from(n)).amax() <= 5.0 * PI / f64::from(n).sqrt());
    }
}

/// KL by quadrature against Monte Carlo over samples of the first argument (an independent path), and
/// KL(p‖p) = 0; entropy likewise against −E[ln f].
#[test]
fn kl_and_entropy_match_monte_carlo() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let cases = [
        (0.05, 0.08, 0.3),
        (0.5, 0.2, 1.0),
        (2.0, 1.0, 2.5),
        (0.01, 0.01, 0.05),
    ];
    for (s1, s2, delta) in cases {
        let c1 = So3::exp(&Vector3::new(0.2, -0.4, 0.9));
        let c2 = c1.compose(&So3::exp(&(Vector3::new(1.0, 2.0, -2.0) / 3.0 * delta)));
        let p = HeatKernelSo3::new(c1, s1).unwrap();
        let q = HeatKernelSo3::new(c2, s2).unwrap();
        assert!(p.kl_divergence(&p).abs() <= 1e-12);
        let n = 20_000;
        let (mut sum, mut sum2, mut ent, mut ent2) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n {
            let r = p.sample(&mut rng);
            let v = p.log_pdf(&r) - q.log_pdf(&r);
            sum += v;
            sum2 += v * v;
            ent -= p.log_pdf(&r);
            ent2 += p.log_pdf(&r).powi(2);
        }
        let mean = sum / f64::from(n);
        let standard_error = ((sum2 / f64::from(n) - mean * mean).max(0.0) / f64::from(n)).sqrt();
        let kl = p.kl_divergence(&q);
        assert!(kl >= 0.0);
        assert!(
            (kl - mean).abs() <= 5.0 * standard_error + 1e-9,
            "s1 {s1}, s2 {s2}, δ {delta}: {kl} vs MC {mean} ± {standard_error}"
        );
        let entropy_mc = ent / f64::from(n);
        let entropy_se =
            ((ent2 / f64::from(n) - entropy_mc * entropy_mc).max(0.0) / f64::from(n)).sqrt();
        assert!(
            (p.entropy() - entropy_mc).abs() <= 5.0 * entropy_se + 1e-9,
            "entropy {} vs MC {entropy_mc} ± {entropy_se}",
            p.entropy()
        );
    }
}

/// Two very concentrated kernels an angle apart: the divergence is large but finite, about
/// δ²/(2 s₂) (the small-variance limit of the Gaussians' KL, 3/2 (s₁/s₂ − 1 − ln(s₁/s₂)) + δ²/(2 s₂)
/// at s₁ = s₂); the density times the inner integral overflowed to +∞ from s = 1e-250 on.
#[test]
fn the_divergence_of_very_concentrated_kernels_is_finite() {
    let delta = 1.0;
    for s in [1e-100, 1e-250, 1e-300] {
        let p = HeatKernelSo3::new(So3::identity(), s).unwrap();
        let q = HeatKernelSo3::new(So3::exp(&Vector3::new(delta, 0.0, 0.0)), s).unwrap();
        let kl = p.kl_divergence(&q);
        let expected = delta * delta / (2.0 * s);
        assert!(
            (kl / expected - 1.0).abs() < 1e-6,
            "s = {s:e}: {kl:e} vs {expected:e}"
        );
    }
}

/// A nearly uniform p against a very concentrated q: the angle density was multiplied by √s₁
/// (1e10) before the inner integral (2e300) and overflowed, so the divergence was +∞. It is
/// E_p[t²]/(2 s₂) to a relative 1e-297 (the normalisers' terms are of order 1e3), and p is Haar
/// to e^(−s₁/2): E[t²] = π²/3 + 2 under the Haar angle density (1 − cos t)/π.
#[test]
fn the_divergence_from_a_spread_kernel_to_a_concentrated_one_is_finite() {
    let p = at_identity(1e20);
    let q = at_identity(1e-300);
    let kl = p.kl_divergence(&q);
    let expected = (PI * PI / 3.0 + 2.0) / 2e-300;
    assert!((kl / expected - 1.0).abs() < 1e-9, "{kl:e} vs {expected:e}");
}

/// The Haar factor 2 sin²(t/2)/π underflowed below t ≈ 3e-162, so `angle_pdf` was 0 where the
/// density is 7.98e125 (s = 1e-300, t = 1e-162): there it is the Maxwell density
/// √(2/π) t²/s^{3/2} e^{−t²/(2s)} to rounding (t²/(2s) = 5e-25).
#[test]
fn the_angle_density_of_a_tiny_angle_does_not_underflow() {
    for (s, t) in [(1e-300, 1e-162), (1e-300, 1e-160), (1e-200, 1e-162)] {
        let pdf = at_identity(s).angle_pdf(t).unwrap();
        let maxwell = (2.0 / PI).sqrt() * (t / s) * (t / s.sqrt()) * (-t * t / (2.0 * s)).exp();
        assert!(
            (pdf / maxwell - 1.0).abs() < 1e-12,
            "s = {s:e}, t = {t:e}: {pdf:e} vs {maxwell:e}"
        );
    }
}

/// The rejection sampler for s < 1 relies on angle_pdf(t) ≤ 1.5 e^(s/8) m(t), m the Maxwell density of
/// |ξ| for ξ ~ N(0, s I): check the ratio on a fine grid of t over (0, π] for s across (0, 1).
#[test]
fn rejection_bound_of_the_small_variance_sampler_holds() {
    let mut worst: f64 = 0.0;
    for s in [1e-6, 1e-4, 1e-2, 0.1, 0.3, 0.6, 0.9, 0.999] {
        let h = at_identity(s);
        for i in 1..=20_000 {
            let t = PI * f64::from(i) / 20_000.0;
            let log_maxwell =
                0.5 * (2.0 / PI).ln() - 1.5 * f64::ln(s) + 2.0 * t.ln() - t * t / (2.0 * s);
            let log_ratio = h.angle_pdf(t).unwrap().ln() - log_maxwell - s / 8.0;
            if log_ratio.is_finite() {
                worst = worst.max(log_ratio.exp());
            }
        }
    }
    eprintln!("largest angle-density / Maxwell ratio: {worst:.4} (bound 1.5)");
    assert!(worst <= 1.5, "the sampler's bound fails: {worst}");
}
