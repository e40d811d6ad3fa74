//! `GenVonMises2`: the trapezoid normaliser against the independent Jacobi-Anger Bessel series, the
//! von Mises special case, product, mode, and sample moments.

mod common;

use liebayes_densities::{
    Density, Entropy, GenVonMises2, KlDivergence, Product, VonMises, special,
};
use liebayes_manifolds::So2;
use liebayes_manifolds::testing::strategies as st;
use nalgebra::Vector2;
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// `ln Z = ln 2π + ln I₀(κ₁) + ln I₀(κ₂) + ln(1 + 2 Σ_(k≥1) A₂ₖ(κ₁) A_k(κ₂) cos(2k(μ₁ − μ₂)))`, with the
/// bracket's condition number `(1 + 2 Σ |terms|) / bracket` (large when the modes disagree and the
/// terms cancel).
fn bessel_series_log_normalizer(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> (f64, f64) {
    let (k1, k2) = (eta1.norm(), eta2.norm());
    let delta = eta1.y.atan2(eta1.x) - eta2.y.atan2(eta2.x) / 2.0;
    let terms: Vec<f64> = (1..400)
        .map(|k| {
            special::bessel_ratio(2 * k, k1).unwrap()
                * special::bessel_ratio(k, k2).unwrap()
                * (2.0 * f64::from(k) * delta).cos()
        })
        .collect();
    let bracket = 1.0 + 2.0 * terms.iter().sum::<f64>();
    let condition = (1.0 + 2.0 * terms.iter().map(|t| t.abs()).sum::<f64>()) / bracket;
    let value = (2.0 * std::f64::consts::PI).ln()
        + special::log_i0(k1).unwrap()
        + special::log_i0(k2).unwrap()
        + bracket.ln();
    (value, condition)
}

/// Brute force: `ln Z` as a log-sum-exp trapezoid sum over 2¹⁶ equally spaced angles, exact to
/// rounding for these concentrations (the integrand is periodic and entire), and well conditioned where
/// the Bessel series cancels.
fn brute_force_log_normalizer(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> f64 {
    const N: u32 = 1 << 16;
    let h = 2.0 * std::f64::consts::PI / f64::from(N);
    let exponent = |i: u32| {
        let x = h * f64::from(i);
        eta1.x * x.cos() + eta1.y * x.sin() + eta2.x * (2.0 * x).cos() + eta2.y * (2.0 * x).sin()
    };
    let max = (0..N).map(exponent).fold(f64::NEG_INFINITY, f64::max);
    let sum: f64 = (0..N).map(|i| (exponent(i) - max).exp()).sum();
    max + (h * sum).ln()
}

fn harmonic() -> impl Strategy<Value = Vector2<f64>> {
    (
        st::so2::<f64>(),
        prop_oneof![Just(0.0), 0.0..3.0_f64, 3.0..50.0_f64],
    )
        .prop_map(|(d, k)| Vector2::new(d.cos(), d.sin()) * k)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn normaliser_matches_the_bessel_series(eta1 in harmonic(), eta2 in harmonic()) {
        let p = GenVonMises2::from_natural(eta1, eta2).unwrap();
        // Both carry eps · (κ₁ + κ₂) from their ln I₀-sized terms.
        let scale = 1.0 + eta1.norm() + eta2.norm();
        let brute = brute_force_log_normalizer(&eta1, &eta2);
        prop_assert!((p.log_normalizer() - brute).abs() <= 1e-13 * scale, "{} vs brute force {}", p.log_normalizer(), brute);
        // The series also loses its bracket's condition number times eps (its own limit, not the
        // quadrature's); where the modes disagree so much that it cancels to nothing, only the brute
        // force above is a reference.
        let (series, condition) = bessel_series_log_normalizer(&eta1, &eta2);
        if condition.is_finite() && (0.0..1e8).contains(&condition) {
            let tolerance = 1e-13 * scale + 20.0 * f64::EPSILON * condition;
            prop_assert!((p.log_normalizer() - series).abs() <= tolerance, "{} vs {} (condition {condition:e})", p.log_normalizer(), series);
        }
    }

    #[test]
    fn product_mode_and_von_mises_special_case(eta1 in harmonic(), eta2 in harmonic(), x in st::so2::<f64>(), f1 in harmonic(), f2 in harmonic()) {
        let p = GenVonMises2::from_natural(eta1, eta2).unwrap();
        let q = GenVonMises2::from_natural(f1, f2).unwrap();
        let pq = p.product(&q).unwrap();
        let scale = 1.0 + eta1.norm() + eta2.norm() + f1.norm() + f2.norm();
        prop_assert!((p.log_pdf(&x) + q.log_pdf(&x) - p.log_product_integral(&q).unwrap() - pq.log_pdf(&x)).abs() <= 1e-12 * scale);
        if let Some(m) = p.mode() {
            prop_assert!(p.log_pdf(&m) >= p.log_pdf(&x) - 1e-12 * scale);
        }
        let vm = VonMises::from_natural(eta1).unwrap();
        let g = GenVonMises2::from_natural(eta1, Vector2::zeros()).unwrap();
        prop_assert!((vm.log_pdf(&x) - g.log_pdf(&x)).abs() <= 1e-12 * scale);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// First and second trigonometric moments of the samples against quadrature: 20 000 draws, 5
    /// standard errors (every component lies in [−1, 1]).
    #[test]
    fn samples_have_the_quadrature_moments(eta1 in harmonic(), eta2 in harmonic(), seed in any::<u64>()) {
        let p = GenVonMises2::from_natural(eta1, eta2).unwrap();
        let points = 20_000;
        let h = 2.0 * std::f64::consts::PI / f64::from(points);
        let mut m = [0.0; 4];
        for i in 0..points {
            let t = h * f64::from(i);
            let w = p.log_pdf(&So2::from_angle_unchecked(t)).exp() * h;
            m[0] += w * t.cos();
            m[1] += w * t.sin();
            m[2] += w * (2.0 * t).cos();
            m[3] += w * (2.0 * t).sin();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 20_000;
        let mut s = [0.0; 4];
        for _ in 0..n {
            let t = p.sample(&mut rng).angle();
            s[0] += t.cos();
            s[1] += t.sin();
            s[2] += (2.0 * t).cos();
            s[3] += (2.0 * t).sin();
        }
        for k in 0..4 {
            prop_assert!((s[k] / f64::from(n) - m[k]).abs() <= 5.0 / f64::from(n).sqrt(), "moment {k}");
        }
    }
}

/// Strong harmonics whose modes disagree: both von Mises envelopes accept below 1 %, so the grid
/// envelope is used; its draws must still have the quadrature moments.
#[test]
fn grid_fallback_sampler_is_exact() {
    let p = GenVonMises2::from_natural(Vector2::new(40.0, 0.0), Vector2::new(-60.0, 0.0)).unwrap();
    let points = 200_000;
    let h = 2.0 * std::f64::consts::PI / f64::from(points);
    let (mut c1, mut c2) = (0.0, 0.0);
    for i in 0..points {
        let t = h * f64::from(i);
        let w = p.log_pdf(&So2::from_angle_unchecked(t)).exp() * h;
        c1 += w * t.cos();
        c2 += w * (2.0 * t).cos();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 40_000;
    let (mut s1, mut s2) = (0.0, 0.0);
    // The kept sampler (its grid built once); `Density::sample` builds the same one per draw.
    let sampler = p.sampler();
    for _ in 0..n {
        let t = rand::distr::Distribution::sample(&sampler, &mut rng).angle();
        s1 += t.cos();
        s2 += (2.0 * t).cos();
    }
    let tolerance = 5.0 / f64::from(n).sqrt();
    assert!(
        (s1 / f64::from(n) - c1).abs() <= tolerance,
        "E[cos] {} vs {c1}",
        s1 / f64::from(n)
    );
    assert!(
        (s2 / f64::from(n) - c2).abs() <= tolerance,
        "E[cos 2θ] {} vs {c2}",
        s2 / f64::from(n)
    );
}

/// Entropy and KL by quadrature equal the von Mises closed forms when the second harmonics vanish, and
/// KL(p‖p) = 0, KL ≥ 0 otherwise.
#[test]
fn entropy_and_kl_reduce_to_the_von_mises_closed_forms() {
    for (k1, k2) in [(0.0, 0.0), (0.3, 2.0), (5.0, 0.7), (200.0, 30.0)] {
        let (a, b) = (Vector2::new(k1, 0.4 * k1), Vector2::new(-0.5 * k2, k2));
        let (p, q) = (
            VonMises::from_natural(a).unwrap(),
            VonMises::from_natural(b).unwrap(),
        );
        let (gp, gq) = (
            GenVonMises2::from_natural(a, Vector2::zeros()).unwrap(),
            GenVonMises2::from_natural(b, Vector2::zeros()).unwrap(),
        );
        assert!(
            (gp.entropy() - p.entropy()).abs() <= 1e-12 * (1.0 + k1),
            "entropy at {k1}"
        );
        assert!(
            (gp.kl_divergence(&gq) - p.kl_divergence(&q)).abs() <= 1e-11 * (1.0 + k1 + k2),
            "KL at {k1}, {k2}"
        );
        let g = GenVonMises2::from_natural(a, b).unwrap();
        assert!(g.kl_divergence(&g).abs() <= 1e-14);
        assert!(g.kl_divergence(&gp) >= 0.0);
    }
}
