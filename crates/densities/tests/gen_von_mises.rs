//! `GenVonMises2`: the trapezoid normaliser against the independent Jacobi-Anger Bessel series, the
//! von Mises special case, product, mode (also of flat-topped densities, against a brute-force
//! maximum), the product integral at concentrations near the limit, and sample moments.

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

/// `f(θ) = η₁ · u(θ) + η₂ · u(2θ)` and `f′(θ)`, directly.
fn exponent_and_slope(eta1: &Vector2<f64>, eta2: &Vector2<f64>, t: f64) -> (f64, f64) {
    let (s, c) = t.sin_cos();
    let (s2, c2) = (2.0 * t).sin_cos();
    (
        eta1.x * c + eta1.y * s + eta2.x * c2 + eta2.y * s2,
        -eta1.x * s + eta1.y * c - 2.0 * eta2.x * s2 + 2.0 * eta2.y * c2,
    )
}

/// Brute force: the largest f on 10⁶ equally spaced angles, refined by 100 bisections of f′ on the
/// two cells about it (f′ changes sign there from + to −: the grid maximum is within a cell of the
/// true one), so to the resolution of f′'s rounding (`eps · (κ₁ + 4κ₂)` divided by |f″|).
fn brute_force_mode(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> f64 {
    const N: u32 = 1_000_000;
    let h = 2.0 * std::f64::consts::PI / f64::from(N);
    let grid = (0..N)
        .map(|i| h * f64::from(i))
        .max_by(|a, b| {
            exponent_and_slope(eta1, eta2, *a)
                .0
                .total_cmp(&exponent_and_slope(eta1, eta2, *b).0)
        })
        .unwrap();
    let (mut low, mut high) = (grid - h, grid + h);
    assert!(
        exponent_and_slope(eta1, eta2, low).1 > 0.0 && exponent_and_slope(eta1, eta2, high).1 < 0.0
    );
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if exponent_and_slope(eta1, eta2, mid).1 > 0.0 {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

/// Flat-topped maxima (κ₁ ≈ 4κ₂ with the second harmonic antipodal, so f″ ≈ 0 at the grid point 0):
/// Newton's step from the grid point was huge and `mode()` returned −2.5664 rad, −2.5664 rad and
/// −2.5088 rad, 6764, 67.6 and 6.5 nats below the maximum (true modes 0.0171, 0.0079, 0.0079). The
/// mode must agree with the brute-force one to 1e-9 rad (f′'s rounding, a few eps (κ₁ + 4κ₂), over
/// |f″| at these maxima, 1.75, 3.8e-3 and 3.8e-4, is below 3e-11; measured against mpmath: 1.4e-13,
/// 6.4e-13, 6.6e-13) and be as probable to 1e-12 in the log (the log density differs by |f″| δ²/2 <
/// 1e-18 there, plus the rounding of g at offsets below 1e-9). The `HarmonicGaussian` built on it
/// has the same mode angle.
#[test]
fn mode_of_flat_topped_densities_is_the_brute_force_maximum() {
    use liebayes_densities::{Gaussian, HarmonicGaussian};
    use liebayes_manifolds::Manifold;
    let cases = [
        (Vector2::new(4000.001, 0.01), Vector2::new(-1000.0, 0.0)),
        (Vector2::new(40.000_001, 1e-5), Vector2::new(-10.0, 0.0)),
        (
            Vector2::new(4.000_000_000_000_001, 1e-6),
            Vector2::new(-1.0, 0.0),
        ),
    ];
    for (eta1, eta2) in cases {
        let p = GenVonMises2::from_natural(eta1, eta2).unwrap();
        let mode = p.mode().unwrap();
        let brute = So2::from_angle_unchecked(brute_force_mode(&eta1, &eta2));
        assert!(
            mode.distance(&brute) <= 1e-9,
            "{eta1:?}, {eta2:?}: mode {} vs brute force {}",
            mode.angle(),
            brute.angle()
        );
        assert!(
            (p.log_pdf(&mode) - p.log_pdf(&brute)).abs() <= 1e-12,
            "{eta1:?}, {eta2:?}: ln p {} at the mode vs {} at the brute-force maximum",
            p.log_pdf(&mode),
            p.log_pdf(&brute)
        );
        let joint = HarmonicGaussian::independent(
            p.clone(),
            &Gaussian::new(nalgebra::Vector1::new(2.0), nalgebra::Matrix1::new(0.5)).unwrap(),
        )
        .unwrap();
        assert_eq!(joint.mode().unwrap().0, mode);
    }
}

/// ln ∫ p q against the von Mises closed form when the second harmonics vanish. It was the difference
/// of normalisers of size κ: at equal means 5e-5 nats off at κ₁ = κ₂ = 1e12, 0.45 at 3e15, 0.81 at
/// 5e15 (exact 16.8086), 0.25 at 5e15 and 4e15; 0.58 nats at 3e15 and 4e15 with means 0.05 apart.
/// Tolerance 1e-13 (1 + |value|): both sides carry the rounding of normalisers less their maxima
/// (about 20, to a few ulp: 1e-14) and, where the means differ by δ, the rounding of the inputs'
/// directions (eps), which moves the value (about κ₁κ₂ δ²/(κ₁ + κ₂)) by a relative 4 eps/δ, below
/// 2e-14 for these δ ≥ 0.05. (Means 1e-7 apart, where that is 1e-8, are no test of either.)
#[test]
fn product_integral_matches_the_von_mises_at_huge_concentrations() {
    let cases = [
        (1e12, 1.0_f64, 1e12, 1.0_f64),
        (1e12, 0.3, 2e12, 0.35),
        (1e12, 0.3, 1e12, 0.3 + std::f64::consts::FRAC_PI_2),
        (3e15, 1.0, 3e15, 1.0),
        (3e15, 0.3, 4e15, 0.35),
        (5e15, 1.0, 5e15, 1.0),
        (5e15, -3.0, 4e15, -3.0),
        (0.0, 0.0, 2.0, 1.0),
        (3.0, 0.4, 5.0, -1.1),
        (200.0, 2.0, 30.0, 2.5),
        (2e5, 3.0, 7e4, -3.1),
    ];
    for (k1, m1, k2, m2) in cases {
        let (eta1, eta2) = (
            Vector2::new(m1.cos(), m1.sin()) * k1,
            Vector2::new(m2.cos(), m2.sin()) * k2,
        );
        let expected = VonMises::from_natural(eta1)
            .unwrap()
            .log_product_integral(&VonMises::from_natural(eta2).unwrap())
            .unwrap();
        let got = GenVonMises2::from_natural(eta1, Vector2::zeros())
            .unwrap()
            .log_product_integral(&GenVonMises2::from_natural(eta2, Vector2::zeros()).unwrap())
            .unwrap();
        assert!(
            (got - expected).abs() <= 1e-13 * (1.0 + expected.abs()),
            "κ {k1:e} at {m1}, {k2:e} at {m2}: {got} vs the von Mises {expected}"
        );
    }
}
